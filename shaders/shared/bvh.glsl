// BVH traversal over 4-wide nodes. The including kernel declares `bvh_node_texels` and
// `bvh_tri_texels` (usamplerBuffer: BvhNode[] and BvhTri[] as RGBA32UI texels,
// src/gpu/buffer.rs Buffer::texels, which says why texels and not storage buffers). The same
// steps as Bvh::traverse in src/accel/traverse.rs (a node's hit leaves tested after the next node
// is chosen, here all four children's in one loop, in the same order; the same sibling
// entries: the same nodes and hits), but for the alpha test a kernel may define as
// BVH_ALPHA_TEST (render.comp: alpha.glsl's glTF cutouts).
#ifndef BVH_GLSL
#define BVH_GLSL

#include "types.glsl"

#define NO_HIT 0xffffffffu

// Node i of the BVH: seven texels, BvhNode's members in order (tests/layout.rs checks the
// round trip against the host's bytes).
BvhNode bvh_node(uint i) {
    int t = int(7u * i);
    BvhNode n;
    n.lo_x = uintBitsToFloat(texelFetch(bvh_node_texels, t));
    n.lo_y = uintBitsToFloat(texelFetch(bvh_node_texels, t + 1));
    n.lo_z = uintBitsToFloat(texelFetch(bvh_node_texels, t + 2));
    n.hi_x = uintBitsToFloat(texelFetch(bvh_node_texels, t + 3));
    n.hi_y = uintBitsToFloat(texelFetch(bvh_node_texels, t + 4));
    n.hi_z = uintBitsToFloat(texelFetch(bvh_node_texels, t + 5));
    n.refs = texelFetch(bvh_node_texels, t + 6);
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

// a < b ? a : b and a > b ? a : b, lane by lane: one x86 min/max instruction each, where
// lavapipe compiles GLSL's min and max to return the number beside a NaN, three instructions
// (a compare for NaN and a blend besides; docs/results.md, thirty-eighth session). They are
// also what the CPU traversal's min and max do on x86 (SSE minps / maxps; src/accel/traverse.rs
// slab4).
vec4 min_x86(vec4 a, vec4 b) { return mix(b, a, lessThan(a, b)); }
vec4 max_x86(vec4 a, vec4 b) { return mix(b, a, greaterThan(a, b)); }

// Each child's entry distance if its box is hit within [tmin, tmax], else -1 (callers keep
// tmin >= 0). `oi` = o * inv, so each plane distance is one multiply-add.
vec4 slab4(BvhNode n, vec3 oi, vec3 inv, float tmin, float tmax) {
    vec4 x0 = n.lo_x * inv.x - oi.x, x1 = n.hi_x * inv.x - oi.x;
    vec4 y0 = n.lo_y * inv.y - oi.y, y1 = n.hi_y * inv.y - oi.y;
    vec4 z0 = n.lo_z * inv.z - oi.z, z1 = n.hi_z * inv.z - oi.z;
    vec4 near = max_x86(max_x86(max_x86(min_x86(x0, x1), min_x86(y0, y1)), min_x86(z0, z1)), vec4(tmin));
    vec4 far = min_x86(min_x86(min_x86(max_x86(x0, x1), max_x86(y0, y1)), max_x86(z0, z1)), vec4(tmax));
    return mix(vec4(-1.0), near, lessThanEqual(near, far));
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

// Sorts (key, ref) pairs i < j by key: one compare-exchange of the network in trace_ray.
#define COMPARE_EXCHANGE(i, j) \
    if (key[j] < key[i]) { \
        float tk = key[i]; key[i] = key[j]; key[j] = tk; \
        uint tr = rf[i]; rf[i] = rf[j]; rf[j] = tr; \
    }

// Closest hit (any_hit = false) or the first hit found (shadow rays) with t in (tmin, tmax).
// Returns the index into the BVH's triangles of the hit triangle or NO_HIT; its distance in t_hit.
uint trace_ray(vec3 o, vec3 d, float tmin, float tmax, bool any_hit, out float t_hit) {
    // A zero direction component would make o * inv = 0 * inf = NaN: nudge it to ±1e-20.
    vec3 dd = mix(d, mix(vec3(1e-20), vec3(-1e-20), lessThan(d, vec3(0.0))), lessThan(abs(d), vec3(1e-20)));
    vec3 inv = 1.0 / dd;
    vec3 oi = o * inv;
    // At most the largest float, as Bvh::traverse: with tmax = ∞ (trace.comp's callers may
    // pass it) a box entered at t = ∞ would count as an interior child to visit.
    float best_t = min(tmax, uintBitsToFloat(0x7f7fffffu));
    uint best = NO_HIT;
    // The interior children still to visit of the last node that had two or more, in
    // registers: their block's first slot (src/accel/bvh.rs flatten gives a node's interior
    // children consecutive slots), each one's offset in it in two bits of s_ofs (the next in
    // the low bits), how many, and the next one's entry distance (a lower bound for the
    // others). The next node with two or more spills the entry to the stack as one word and
    // that distance: one store site a step instead of a store per child (lavapipe stores to a
    // run-time-indexed array lane by lane; three child pushes a step cost rooms' pass 0.30 s
    // against 0.28 s, bench-rays 4.3–4.5 against 5.6–5.7 Mrays/s: docs/results.md, thirty-seventh
    // session). Shadow rays keep the distances too: the variant without them ran 2.4× slower
    // on lavapipe (thirty-sixth session).
    uint stack[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;
    uint s_base = 0u, s_ofs = 0u, s_cnt = 0u;
    float s_k0 = 0.0;
    bool more_nodes = true;
    // The hit leaves of the last node visited: four triangle ranges (first, count), a's first.
    uint fa = 0u, fb = 0u, fc = 0u, fd = 0u;
    uint na = 0u, nab = 0u, nabc = 0u, nall = 0u;
    // Node steps until this lane holds leaves to test or has no node left, the group stepping
    // on while any lane does; then the leaves' triangles (Aila and Laine's "while-while").
    // lavapipe runs the body of every `if` for the whole SIMD group of 8 and a loop body at
    // least once, so the leaf loop inside each node step ran a masked triangle test (three
    // texel fetches) at every step, for rooms' shadow rays five wasted rounds in six steps:
    // this loop took rooms' direct-light pass 0.28-0.29 -> 0.24 s and city's 0.09 -> 0.08 s
    // (docs/results.md, thirty-seventh session).
    do {
        do {
            if (nall == 0u && more_nodes) {
                BvhNode n = bvh_node(node);
                vec4 keys = slab4(n, oi, inv, tmin, best_t);
                float key[4] = float[4](keys.x, keys.y, keys.z, keys.w);
                uint rf[4] = uint[4](n.refs.x, n.refs.y, n.refs.z, n.refs.w);
                // Hit leaves' triangle counts (a leaf ref: BVH_LEAF_BIT, the count, the first
                // triangle; src/abi.rs).
                uvec4 count = (n.refs >> BVH_LEAF_COUNT_SHIFT) & 255u;
                na = key[0] >= 0.0 && (rf[0] & BVH_LEAF_BIT) != 0u ? count.x : 0u;
                uint nb = key[1] >= 0.0 && (rf[1] & BVH_LEAF_BIT) != 0u ? count.y : 0u;
                uint nc = key[2] >= 0.0 && (rf[2] & BVH_LEAF_BIT) != 0u ? count.z : 0u;
                uint nd = key[3] >= 0.0 && (rf[3] & BVH_LEAF_BIT) != 0u ? count.w : 0u;
                nab = na + nb;
                nabc = nab + nc;
                nall = nabc + nd;
                // (Tested once the next node is chosen, so that choice culls by the distance
                // known before them: the same hits, a few more steps.)
                fa = n.refs.x & BVH_LEAF_FIRST_MASK;
                fb = n.refs.y & BVH_LEAF_FIRST_MASK;
                fc = n.refs.z & BVH_LEAF_FIRST_MASK;
                fd = n.refs.w & BVH_LEAF_FIRST_MASK;
                // Interior children that can still hold a closer hit, nearest first; the others
                // sort last with key ∞ (a five-exchange sorting network).
                uint m = 0u;
                for (int i = 0; i < 4; ++i) {
                    bool inner = key[i] >= 0.0 && (rf[i] & BVH_LEAF_BIT) == 0u && key[i] <= best_t;
                    key[i] = inner ? key[i] : uintBitsToFloat(0x7f800000u);  // +inf
                    m += inner ? 1u : 0u;
                }
                COMPARE_EXCHANGE(0, 1)
                COMPARE_EXCHANGE(2, 3)
                COMPARE_EXCHANGE(0, 2)
                COMPARE_EXCHANGE(1, 3)
                COMPARE_EXCHANGE(1, 2)
                if (m > 0u) {
                    if (m > 1u) {
                        if (s_cnt > 0u) {
                            stack[sp] = (s_base << 8u) | (s_ofs << 2u) | s_cnt;
                            stack_t[sp] = s_k0;
                            sp++;
                        }
                        // Leaf refs carry BVH_LEAF_BIT: the least ref is the block's first slot.
                        uint base = min(min(rf[0], rf[1]), min(rf[2], rf[3]));
                        s_base = base;
                        s_ofs = ((rf[1] - base) & 3u) | (((rf[2] - base) & 3u) << 2u) | (((rf[3] - base) & 3u) << 4u);
                        s_cnt = m - 1u;
                        s_k0 = key[1];
                    }
                    node = rf[0];
                } else {
                    // The nearest sibling left that can still hold a closer hit: from the
                    // registers, else from the stack (the distance stacked with an entry, its
                    // first's, stands for its later siblings').
                    bool found = false;
                    while (!found && (s_cnt > 0u || sp > 0u)) {
                        if (s_cnt == 0u) {
                            sp--;
                            uint e = stack[sp];
                            s_base = e >> 8u;
                            s_ofs = (e >> 2u) & 63u;
                            s_cnt = e & 3u;
                            s_k0 = stack_t[sp];
                        }
                        if (s_k0 <= best_t) {
                            found = true;
                            node = s_base + (s_ofs & 3u);
                            s_ofs >>= 2u;
                            s_cnt--;
                        } else {
                            s_cnt = 0u;  // sorted: the rest are farther still
                        }
                    }
                    more_nodes = found;
                }
            }
        } while (nall == 0u && more_nodes);
        // One copy of the intersection code for the four ranges, so lanes with leaves in
        // different children run it together.
        uint k = 0u;
        do {
            if (k < nall) {
                uint i = k < na ? fa + k : (k < nab ? fb + (k - na) : (k < nabc ? fc + (k - nab) : fd + (k - nabc)));
#ifdef BVH_ALPHA_TEST
                // A cut-out point is no hit (alpha.glsl).
                BvhTri tri = bvh_tri(i);
                float t = intersect_tri(tri, o, d, tmin, best_t);
                if (t >= 0.0 && BVH_ALPHA_TEST(tri, o + t * d)) { best_t = t; best = i; }
#else
                float t = intersect_tri(bvh_tri(i), o, d, tmin, best_t);
                if (t >= 0.0) { best_t = t; best = i; }
#endif
                if (any_hit && best != NO_HIT) break;
                ++k;
            }
        } while (k < nall);
        if (any_hit && best != NO_HIT) break;
        nall = 0u;
    } while (more_nodes);
    t_hit = best_t;
    return best;
}

#endif
