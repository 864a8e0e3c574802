// Region lookup and the `wang` sampler (cluster of the region's cut ∝ Ĩ_C(x), light inside
// by power). Mirror of src/lights/grid.rs and src/lights/regions.rs. The including kernel declares the learned
// state's texel buffers (learned_texels.glsl) and the light tree buffers.
#ifndef REGIONS_GLSL
#define REGIONS_GLSL

#include "light_tree.glsl"
#include "learned_texels.glsl"

uint region_of(vec3 p, vec3 n) {
    GridParams g = grid_params();
    vec3 c = floor((p - g.lo) / g.cell);
    uvec3 cell = min(uvec3(max(c, vec3(0.0))), g.dims - 1u);
    uint flat_cell = (cell.z * g.dims.y + cell.y) * g.dims.x + cell.x;
    uint bin = 0u;
    if (g.bins == 6u) {
        vec3 a = abs(n);
        uint axis = (a.x >= a.y && a.x >= a.z) ? 0u : (a.y >= a.z ? 1u : 2u);
        bin = 2u * axis + (n[axis] < 0.0 ? 1u : 0u);
    }
    return flat_cell * g.bins + bin;
}

// The offset in `cuts` of the cut of the region of (p, n) (0: the shared fallback). A kernel
// that defines FLAG_MISSING_REGIONS (render.comp) also reports a region that has no cut yet,
// so the host builds one between frames (src/render/session/growth.rs).
uint region_cut(vec3 p, vec3 n) {
    uint r = region_of(p, n);
    uint o = region_index_at(r);
#ifdef FLAG_MISSING_REGIONS
    if (o == 0u) flag_missing_region(r);
#endif
    return o;
}

#define MAX_CUT 64  // RegionSettings::k_max is checked against it

// The weights of the current cut's slots (filled by the sampler that calls pick_in_cut).
float cut_w[MAX_CUT];
// The cut (offset) and weight total of the last choice by sample_wang / sample_learned: what
// light_pmf_of_cut needs to repeat that choice's pmf at the same point without summing the
// cut again (with learning.glsl's sel_lambda under --defensive).
uint sel_cut = 0u;
float sel_total = 0.0;
// Which child of the chosen slot's node the last pick_in_cut descended into first: 0 the
// left, 1 the right, 2 none (the slot is one light). --refine-cuts counts each slot's
// observations by this side (render.comp `side_counts`), so a split is made where the two
// children differ (src/render/refine.rs). Set only under --refine-cuts (LEARN_FLAGS, which
// every kernel that includes this file declares): nothing else reads it.
uint sel_side = 2u;

// Picks slot k of the cut at offset o ∝ cut_w (total > 0: their sum), then a light inside the
// slot's node: by power (IN_CLUSTER 0, Wang & Åkerlund), or by descending the node's subtree
// by importance at (p, n) like lightbvh (IN_CLUSTER 1; NO_LIGHT at a dead end, where no
// light of the node can reach p). Returns the light; pmf = P(k) · P(l | k), p_slot = P(k).
uint pick_in_cut(uint o, uint count, float total, float u, vec3 p, vec3 n, out float pmf, out uint k, out float p_slot) {
    float target = u * total;
    float acc = 0.0;
    k = 0u;
    float acc_k = 0.0;
    bool chosen = false;
    uint i = 0u;
    if (count > 0u) do {
        if (cut_w[i] > 0.0) {
            k = i;
            acc_k = acc;
            if (target < acc + cut_w[i]) chosen = true;
            else acc += cut_w[i];
        }
        ++i;
    } while (i < count && !chosen);
    float v = clamp((target - acc_k) / cut_w[k], 0.0, ONE_MINUS_EPSILON);
    uint node = cut_word(o + 1u + k);
    p_slot = cut_w[k] / total;
    pmf = p_slot;
    sel_side = 2u;
    if (light_node(node).count > 1u) do {
        uint l = node + 1u;
        uint r = light_node(node).right;
        float pl;
        if (IN_CLUSTER == 1u) {
            float il = light_importance(light_node(l), p, n);
            float ir = light_importance(light_node(r), p, n);
            if (il + ir <= 0.0) {
                pmf = 0.0;
                return NO_LIGHT;
            }
            pl = il / (il + ir);
        } else {
            pl = light_node(l).phi / (light_node(l).phi + light_node(r).phi);
        }
        if ((LEARN_FLAGS & LEARN_REFINE) != 0u && sel_side == 2u) sel_side = v < pl ? 0u : 1u;
        if (v < pl) {
            v = min(v / pl, ONE_MINUS_EPSILON);
            pmf *= pl;
            node = l;
        } else {
            v = min((v - pl) / (1.0 - pl), ONE_MINUS_EPSILON);
            pmf *= 1.0 - pl;
            node = r;
        }
    } while (light_node(node).count > 1u);
    return light_order[light_node(node).begin];
}

// Fills cut_w with the `wang` weights (Ĩ_C(x)) of the cut at offset o; returns their sum.
float wang_weights(uint o, vec3 p, vec3 n) {
    uint count = cut_word(o);
    float total = 0.0;
    // Bottom-tested loops here and in pick_in_cut, learned_weights and the descents of
    // light_tree.glsl: lavapipe runs a failed top test's body once more, masked
    // (render.comp main).
    uint i = 0u;
    if (count > 0u) do {
        cut_w[i] = light_importance(light_node(cut_word(o + 1u + i)), p, n);
        total += cut_w[i];
        ++i;
    } while (i < count);
    return total;
}

uint sample_wang(vec3 p, vec3 n, float u, out float pmf) {
    uint o = region_cut(p, n);
    uint count = cut_word(o);
    float total = wang_weights(o, p, n);
    sel_cut = o;
    sel_total = total;
    pmf = 0.0;
    if (total <= 0.0) return NO_LIGHT;
    uint k;
    float p_slot;
    return pick_in_cut(o, count, total, u, p, n, pmf, k, p_slot);
}

#define NO_SLOT_IN_CUT 0xffffffffu

// The slot k of the cut at offset o whose node holds order position pos, found by binary
// search over the slots' range starts (a cut covers the order with disjoint ranges in order);
// NO_SLOT_IN_CUT if none does.
uint slot_holding(uint o, uint pos) {
    uint lo = 0u;
    uint hi = cut_word(o);
    // The first slot whose range starts after pos; the one before it is the candidate.
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (light_node(cut_word(o + 1u + mid)).begin <= pos) lo = mid + 1u;
        else hi = mid;
    }
    if (lo == 0u) return NO_SLOT_IN_CUT;
    uint node = cut_word(o + lo);
    return pos < light_node(node).begin + light_node(node).count ? lo - 1u : NO_SLOT_IN_CUT;
}

// The probability that pick_in_cut returns the light at position pos given that slot k (of
// weight w out of total) holds it: P(k) times the descent inside.
float pmf_in_slot(uint o, uint k, float w, float total, uint pos, vec3 p, vec3 n) {
    if (!(total > 0.0) || !(w > 0.0)) return 0.0;
    uint leaf;
    return w / total * descent_pmf(cut_word(o + 1u + k), pos, p, n, IN_CLUSTER == 1u, leaf);
}

// The probability that pick_in_cut (cut at offset o, weights cut_w summing to total) returns
// the light at position pos of the tree order: the slot holding it, found by binary search
// over the slots' range starts (a cut covers the order with disjoint ranges in order), times
// the descent inside. Mirror of src/lights/regions.rs `pmf_in_cut`.
float pmf_in_cut(uint o, float total, uint pos, vec3 p, vec3 n) {
    uint k = slot_holding(o, pos);
    return k == NO_SLOT_IN_CUT ? 0.0 : pmf_in_slot(o, k, cut_w[k], total, pos, p, n);
}

#endif
