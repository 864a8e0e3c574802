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

// Entries of siblings waiting to be visited; the builder caps the depth so this cannot
// overflow (src/accel/bvh.rs STACK_SIZE says why 24 is enough).
#define STACK_SIZE 24
#define NO_HIT 0xffffffffu

// Node i of the BVH: eight texels, in the order of BvhNode's members (tests/layout.rs checks
// the round trip against the host's bytes).
BvhNode bvh_node(uint i) {
    int t = int(8u * i);
    uvec4 a = texelFetch(bvh_node_texels, t);
    uvec4 b = texelFetch(bvh_node_texels, t + 1);
    uvec4 c = texelFetch(bvh_node_texels, t + 2);
    uvec4 d = texelFetch(bvh_node_texels, t + 3);
    uvec4 e = texelFetch(bvh_node_texels, t + 4);
    uvec4 f = texelFetch(bvh_node_texels, t + 5);
    uvec4 g = texelFetch(bvh_node_texels, t + 6);
    uvec4 h = texelFetch(bvh_node_texels, t + 7);
    BvhNode n;
    n.a_min = uintBitsToFloat(a.xyz);
    n.a_ref = a.w;
    n.a_max = uintBitsToFloat(b.xyz);
    n.a_count = b.w;
    n.b_min = uintBitsToFloat(c.xyz);
    n.b_ref = c.w;
    n.b_max = uintBitsToFloat(d.xyz);
    n.b_count = d.w;
    n.c_min = uintBitsToFloat(e.xyz);
    n.c_ref = e.w;
    n.c_max = uintBitsToFloat(f.xyz);
    n.c_count = f.w;
    n.d_min = uintBitsToFloat(g.xyz);
    n.d_ref = g.w;
    n.d_max = uintBitsToFloat(h.xyz);
    n.d_count = h.w;
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
    uint stack[STACK_SIZE];
    float stack_t[STACK_SIZE];
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
                float key[4];
                uint rf[4];
                key[0] = slab(n.a_min, n.a_max, oi, inv, tmin, best_t);
                key[1] = slab(n.b_min, n.b_max, oi, inv, tmin, best_t);
                key[2] = slab(n.c_min, n.c_max, oi, inv, tmin, best_t);
                key[3] = slab(n.d_min, n.d_max, oi, inv, tmin, best_t);
                rf[0] = n.a_ref;
                rf[1] = n.b_ref;
                rf[2] = n.c_ref;
                rf[3] = n.d_ref;
                na = key[0] >= 0.0 && (n.a_ref & BVH_LEAF_BIT) != 0u ? n.a_count : 0u;
                uint nb = key[1] >= 0.0 && (n.b_ref & BVH_LEAF_BIT) != 0u ? n.b_count : 0u;
                uint nc = key[2] >= 0.0 && (n.c_ref & BVH_LEAF_BIT) != 0u ? n.c_count : 0u;
                uint nd = key[3] >= 0.0 && (n.d_ref & BVH_LEAF_BIT) != 0u ? n.d_count : 0u;
                nab = na + nb;
                nabc = nab + nc;
                nall = nabc + nd;
                // (Tested once the next node is chosen, so that choice culls by the distance
                // known before them: the same hits, a few more steps.)
                fa = n.a_ref & ~BVH_LEAF_BIT;
                fb = n.b_ref & ~BVH_LEAF_BIT;
                fc = n.c_ref & ~BVH_LEAF_BIT;
                fd = n.d_ref & ~BVH_LEAF_BIT;
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
