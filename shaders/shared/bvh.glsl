// BVH traversal. The including kernel declares `bvh_node_texels` and `bvh_tri_texels`
// (usamplerBuffer: BvhNode[] and BvhTri[] as RGBA32UI texels, src/gpu/buffer.rs
// Buffer::texels, which says why texels and not storage buffers). Same loop as Bvh::traverse in src/accel/bvh.rs (here both children's leaves
// in one inner loop, tested in the same order: the same hits).
#ifndef BVH_GLSL
#define BVH_GLSL

#include "types.glsl"

// Far children waiting to be visited; the builder caps the depth so this cannot overflow
// (src/accel/bvh.rs MAX_DEPTH).
#define STACK_SIZE 48
#define NO_HIT 0xffffffffu

// Node i of the BVH: four texels, in the order of BvhNode's members (tests/layout.rs checks
// the round trip against the host's bytes).
BvhNode bvh_node(uint i) {
    int t = int(4u * i);
    uvec4 a = texelFetch(bvh_node_texels, t);
    uvec4 b = texelFetch(bvh_node_texels, t + 1);
    uvec4 c = texelFetch(bvh_node_texels, t + 2);
    uvec4 d = texelFetch(bvh_node_texels, t + 3);
    BvhNode n;
    n.a_min = uintBitsToFloat(a.xyz);
    n.a_ref = a.w;
    n.a_max = uintBitsToFloat(b.xyz);
    n.a_count = b.w;
    n.b_min = uintBitsToFloat(c.xyz);
    n.b_ref = c.w;
    n.b_max = uintBitsToFloat(d.xyz);
    n.b_count = d.w;
    return n;
}

// Triangle i of the BVH's order: three texels, as BvhTri.
BvhTri bvh_tri(uint i) {
    int t = int(3u * i);
    uvec4 a = texelFetch(bvh_tri_texels, t);
    uvec4 b = texelFetch(bvh_tri_texels, t + 1);
    uvec4 c = texelFetch(bvh_tri_texels, t + 2);
    BvhTri tri;
    tri.v0 = uintBitsToFloat(a.xyz);
    tri.prim = a.w;
    tri.e1 = uintBitsToFloat(b.xyz);
    tri.pad0 = b.w;
    tri.e2 = uintBitsToFloat(c.xyz);
    tri.pad1 = c.w;
    return tri;
}

// Entry distance of the box if hit within [tmin, tmax], else -1 (callers keep tmin >= 0).
// `oi` = o * inv, so each plane distance is one fused multiply-add.
float slab(vec3 lo, vec3 hi, vec3 oi, vec3 inv, float tmin, float tmax) {
    vec3 t0 = lo * inv - oi;
    vec3 t1 = hi * inv - oi;
    vec3 tn = min(t0, t1);
    vec3 tf = max(t0, t1);
    float near = max(max(max(tn.x, tn.y), tn.z), tmin);
    float far = min(min(min(tf.x, tf.y), tf.z), tmax);
    return near <= far ? near : -1.0;
}

// Möller–Trumbore, both faces: t of the hit, or -1.
float intersect_tri(BvhTri tri, vec3 o, vec3 d, float tmin, float tmax) {
    vec3 p = cross(d, tri.e2);
    float det = dot(tri.e1, p);
    if (det == 0.0) return -1.0;
    float inv_det = 1.0 / det;
    vec3 s = o - tri.v0;
    float u = dot(s, p) * inv_det;
    if (u < 0.0 || u > 1.0) return -1.0;
    vec3 q = cross(s, tri.e1);
    float v = dot(d, q) * inv_det;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    float t = dot(tri.e2, q) * inv_det;
    return (t > tmin && t < tmax) ? t : -1.0;
}

// Closest hit (any_hit = false) or the first hit found (shadow rays) with t in (tmin, tmax).
// Returns the index into the BVH's triangles of the hit triangle or NO_HIT; its distance in t_hit.
uint trace_ray(vec3 o, vec3 d, float tmin, float tmax, bool any_hit, out float t_hit) {
    // A zero direction component would make o * inv = 0 * inf = NaN: nudge it to ±1e-20.
    vec3 dd = mix(d, mix(vec3(1e-20), vec3(-1e-20), lessThan(d, vec3(0.0))), lessThan(abs(d), vec3(1e-20)));
    vec3 inv = 1.0 / dd;
    vec3 oi = o * inv;
    float best_t = tmax;
    uint best = NO_HIT;
    uint stack[STACK_SIZE];
    // Entry distance of each stacked child: skipped on pop once a closer hit is known.
    float stack_t[STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;
    for (;;) {
        BvhNode n = bvh_node(node);
        float ta = slab(n.a_min, n.a_max, oi, inv, tmin, best_t);
        float tb = slab(n.b_min, n.b_max, oi, inv, tmin, best_t);
        bool hit_a = ta >= 0.0;
        bool hit_b = tb >= 0.0;
        // The triangles of both children that are hit leaves, in one loop (a's first): one
        // copy of the intersection code, so SIMD lanes with a leaf in a and lanes with one
        // in b run it together.
        uint na = hit_a && (n.a_ref & BVH_LEAF_BIT) != 0u ? n.a_count : 0u;
        uint nb = hit_b && (n.b_ref & BVH_LEAF_BIT) != 0u ? n.b_count : 0u;
        if (na + nb > 0u) {
            uint fa = n.a_ref & ~BVH_LEAF_BIT;
            uint fb = n.b_ref & ~BVH_LEAF_BIT;
            for (uint k = 0u; k < na + nb; ++k) {
                uint i = k < na ? fa + k : fb + (k - na);
                float t = intersect_tri(bvh_tri(i), o, d, tmin, best_t);
                if (t >= 0.0) { best_t = t; best = i; }
                if (any_hit && best != NO_HIT) break;
            }
            if (any_hit && best != NO_HIT) break;
            hit_a = hit_a && na == 0u;
            hit_b = hit_b && nb == 0u;
        }
        if (hit_a && hit_b) {
            bool a_first = ta <= tb;
            stack[sp] = a_first ? n.b_ref : n.a_ref;
            stack_t[sp] = a_first ? tb : ta;
            sp++;
            node = a_first ? n.a_ref : n.b_ref;
        } else if (hit_a) {
            node = n.a_ref;
        } else if (hit_b) {
            node = n.b_ref;
        } else {
            // Pop the next child that can still hold a closer hit.
            bool found = false;
            while (sp > 0u && !found) {
                sp--;
                found = stack_t[sp] <= best_t;
                node = stack[sp];
            }
            if (!found) break;
        }
    }
    t_hit = best_t;
    return best;
}

#endif
