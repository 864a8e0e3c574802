// The light tree's importance and the `lightbvh` sampler's stochastic descent. Mirror of
// src/lights/bounds.rs (`importance`) and src/lights/tree.rs (`LightTree::sample`), checked against it by
// tests/light_tree.rs. The including kernel declares `light_node_texels` (usamplerBuffer:
// GpuLightNode[] as RGBA32UI texels, src/gpu/buffer.rs Buffer::texels) and `light_order`
// (uint[]).
#ifndef LIGHT_TREE_GLSL
#define LIGHT_TREE_GLSL

#include "types.glsl"

// Node i of the light tree: four texels, in the order of GpuLightNode's members (the round
// trip against the host's bytes: tests/layout.rs). Only the members a caller uses are
// fetched (the compiler drops the other texel fetches).
GpuLightNode light_node(uint i) {
    int t = int(4u * i);
    uvec4 a = texelFetch(light_node_texels, t);
    uvec4 b = texelFetch(light_node_texels, t + 1);
    uvec4 c = texelFetch(light_node_texels, t + 2);
    uvec4 d = texelFetch(light_node_texels, t + 3);
    GpuLightNode nd;
    nd.centre = uintBitsToFloat(a.xyz);
    nd.phi = uintBitsToFloat(a.w);
    nd.axis = uintBitsToFloat(b.xyz);
    nd.cos_o = uintBitsToFloat(b.w);
    nd.radius = uintBitsToFloat(c.x);
    nd.sin_o = uintBitsToFloat(c.y);
    nd.cos_e = uintBitsToFloat(c.z);
    nd.flags = c.w;
    nd.right = d.x;
    nd.begin = d.y;
    nd.count = d.z;
    nd.pad = d.w;
    return nd;
}

// render.comp's stage profile (`lightlearn profile`) can leave the importance's bounds out;
// every other kernel and every render keep them.
#ifndef IMPORTANCE_KNOCKED_OUT
#define IMPORTANCE_KNOCKED_OUT false
#endif

#define NO_LIGHT 0xffffffffu
#define ONE_MINUS_EPSILON 0.99999994

// cos(max(0, a - b)) and sin(max(0, a - b)) from sines and cosines.
float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 1.0 : cos_a * cos_b + sin_a * sin_b;
}
float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 0.0 : sin_a * cos_b - cos_a * sin_b;
}

// The least squared distance of the importance (src/lights/bounds.rs d2_floor says why):
// (radius / 2)² for a node of point lights alone, pbrt-v4's radius (half the box diagonal)
// where an area light is inside; so points inside a node do not blow up.
float d2_floor(GpuLightNode nd) {
    return (nd.flags & LIGHT_NODE_AREA) != 0u ? nd.radius : 0.25 * nd.radius * nd.radius;
}

// The squared distance of the importance and of the learned regression.
float node_d2(GpuLightNode nd, vec3 p) {
    vec3 to = p - nd.centre;
    return max(dot(to, to), d2_floor(nd));
}

// Unoccluded importance of a node at p for a receiver with normal n (see bounds.rs
// `node_importance`, operation for operation); also returns its clamped distance² (node_d2),
// which the learned samplers need. The node's centre, radius and sin θ_o come precomputed
// (GpuLightNode): one inverse square root gives the direction and the sphere's sine.
float light_importance_d2(GpuLightNode nd, vec3 p, vec3 n, out float d2) {
    vec3 to = p - nd.centre;
    float dist2 = dot(to, to);
    d2 = max(dist2, d2_floor(nd));
    if (IMPORTANCE_KNOCKED_OUT) return nd.phi / d2;
    float inv_dist = dist2 > 0.0 ? 1.0 / sqrt(dist2) : 0.0;
    vec3 wi = to * inv_dist;
    float cos_w = dot(nd.axis, wi);
    if ((nd.flags & LIGHT_NODE_TWO_SIDED) != 0u) cos_w = abs(cos_w);
    float sin_w = sqrt(max(1.0 - cos_w * cos_w, 0.0));
    float cos_b = -1.0;
    float sin_b = 0.0;
    if (dist2 > nd.radius * nd.radius) {
        sin_b = nd.radius * inv_dist;
        cos_b = sqrt(max(1.0 - sin_b * sin_b, 0.0));
    }
    float cos_wo = cos_sub_clamped(sin_w, cos_w, nd.sin_o, nd.cos_o);
    float sin_wo = sin_sub_clamped(sin_w, cos_w, nd.sin_o, nd.cos_o);
    float cos_p = cos_sub_clamped(sin_wo, cos_wo, sin_b, cos_b);
    if (cos_p < nd.cos_e) return 0.0;  // strict: see bounds.rs (a hard-edged spot)
    float imp = nd.phi * cos_p / d2;
    if (n != vec3(0.0)) {
        float cos_i = dot(n, -wi);
        float sin_i = sqrt(max(1.0 - cos_i * cos_i, 0.0));
        imp *= max(cos_sub_clamped(sin_i, cos_i, sin_b, cos_b), 0.0);
    }
    return max(imp, 0.0);
}

float light_importance(GpuLightNode nd, vec3 p, vec3 n) {
    float d2;
    return light_importance_d2(nd, p, n, d2);
}

// The probability that a descent from `node` ends at the leaf holding order position pos:
// by importance at (p, n) (lightbvh, and --in-cluster importance) or by power. A node's left
// child holds the positions before its right child's `begin`.
// leaf: the node where the descent ends.
float descent_pmf(uint node, uint pos, vec3 p, vec3 n, bool by_importance, out uint leaf) {
    float pmf = 1.0;
    leaf = node;
    if (light_node(node).count > 1u && pmf > 0.0) do {
        uint l = node + 1u;
        uint r = light_node(node).right;
        float pl;
        if (by_importance) {
            float il = light_importance(light_node(l), p, n);
            float ir = light_importance(light_node(r), p, n);
            if (il + ir <= 0.0) return 0.0;
            pl = il / (il + ir);
        } else {
            pl = light_node(l).phi / (light_node(l).phi + light_node(r).phi);
        }
        bool left = pos < light_node(r).begin;
        pmf *= left ? pl : 1.0 - pl;
        node = left ? l : r;
        leaf = node;
    } while (light_node(node).count > 1u && pmf > 0.0);
    return pmf;
}

// The pmf with which sample_light_tree picks the light at order position pos (0 where it
// never does, including a leaf it would refuse).
float light_tree_pmf(uint pos, vec3 p, vec3 n) {
    uint leaf;
    float pmf = descent_pmf(0u, pos, p, n, true, leaf);
    return pmf > 0.0 && light_importance(light_node(leaf), p, n) > 0.0 ? pmf : 0.0;
}

// One descent by importance: the light index (or NO_LIGHT) and its pmf.
uint sample_light_tree(vec3 p, vec3 n, float u, out float pmf) {
    uint node = 0u;
    pmf = 1.0;
    if (light_node(node).count > 1u) do {
        uint l = node + 1u;
        uint r = light_node(node).right;
        float il = light_importance(light_node(l), p, n);
        float ir = light_importance(light_node(r), p, n);
        if (il == 0.0 && ir == 0.0) return NO_LIGHT;
        float pl = il / (il + ir);
        if (u < pl) {
            u = min(u / pl, ONE_MINUS_EPSILON);
            pmf *= pl;
            node = l;
        } else {
            u = min((u - pl) / (1.0 - pl), ONE_MINUS_EPSILON);
            pmf *= 1.0 - pl;
            node = r;
        }
    } while (light_node(node).count > 1u);
    GpuLightNode leaf = light_node(node);
    if (light_importance(leaf, p, n) <= 0.0) return NO_LIGHT;
    return light_order[leaf.begin];
}

#endif
