// The learned cluster samplers: `bayes` (Vévoda et al. 2018, docs/method.md §3–§4) and `donikian`
// (Donikian et al. 2006, docs/method.md §8), and the recording of their observations.
// Mirror of src/learning/mod.rs (`slot_weight`, `donikian_weights`); tests/learning/ checks
// GPU against CPU. The including kernel declares the region buffers, `slot_stat_texels`
// (SlotStats[] as texels, parallel to `cuts`), `slot_delta` (SlotDelta[], same), `learn`
// (LearnParams[1]) and the specialization constant LEARN_FLAGS (= learn[0].flags, fixed for
// the pipeline: on lavapipe a branch costs its body even where no lane takes it, so a switch
// that is off must be compiled out, not tested per slot; `lightlearn profile` measured the
// --brdf-select and --control-variates tests alone at 22 % of a bayes pass with both off).
#ifndef LEARNING_GLSL
#define LEARNING_GLSL

#include "regions.glsl"
#include "posterior.glsl"

#define NO_SLOT 0xffffffffu


// The switches as specialization-constant expressions without && or ||: glslang 11 emits
// `A && B` of specialization constants as a branch whose result does not dominate its uses
// (spirv-val rejects the module). BAYES_FLAGS: LEARN_FLAGS for bayes, 0 for the others.
const uint BAYES_FLAGS = SAMPLER == SAMPLER_BAYES ? LEARN_FLAGS : 0u;
const bool REGRESSION_ON = (LEARN_FLAGS & LEARN_REGRESSION) != 0u;
const bool CV_ON = (BAYES_FLAGS & LEARN_CONTROL_VARIATES) != 0u;
// --regression importance (the default): the regressor is the cluster's unoccluded
// importance Ĩ_C(x) (wang's weight) instead of 1/d², so y = Î_C / Ĩ_C, the share of the
// unoccluded estimate that arrives: Ĩ's cosine bounds vary across a region as its distance
// does (docs/method.md §3).
const bool REGRESS_IMPORTANCE = (BAYES_FLAGS & LEARN_REGRESS_IMPORTANCE) != 0u;
const bool DEFENSIVE_ON = (BAYES_FLAGS & LEARN_DEFENSIVE) != 0u;
// --refine-cuts (bayes and donikian): observations are also counted by the side of the
// chosen slot's node they came through (render.comp `side_counts`).
const bool REFINE_ON = (LEARN_FLAGS & LEARN_REFINE) != 0u;

// --brdf-select: a factor > 0 on slot weights for the BRDF at the shading point towards the
// node's cluster; every including kernel defines it (render.comp: the BRDF; the test kernel
// light_sample.comp: 1). It must depend only on the shading point, never on the light drawn,
// so that light_pmf repeats it exactly.
float brdf_toward(GpuLightNode nd, vec3 p, vec3 n);

// Fixed point of the window sums: y / scale with 24 fraction bits, y / scale clamped to 4096
// so that one observation adds at most 2^36 to Σ and 2^48 to Σ² (the 64-bit sums then hold
// ≥ 2^15 clamped observations per slot and window). The clamp only touches the model, never
// the image: the estimator stays unbiased whatever the statistics say.
#define FIX_ONE 16777216.0
#define FIX_CLAMP 4096.0
#define TWO_POW_32 4294967296.0

// The posterior's sampling weight of one slot at x (docs/method.md §4) before the 1/d² factor
// (by importance: before the factor Ĩ_C(x)), from the coefficients fold.comp stored (posterior.glsl); mu0 is the prior mean of y at x.
float bayes_weight(SlotStats s, float mu0) {
    // t is clamped so that t² stays a normal float: only absurd prior/scale ratios are
    // touched, and the weight stays positive and finite (the estimator unbiased).
    float t = clamp(mu0 / s.scale, 1e-15, 1e15);
    if ((LEARN_FLAGS & LEARN_TARGET_MEAN) != 0u) return s.scale * max(s.coef_a * t + s.coef_b, 0.0);
    float v = (s.coef_a * t + s.coef_b) * t + s.coef_c;
    // v underflows only without data (b = c = 0), where the weight is t · sqrt(a).
    return s.scale * (v > 0.0 ? sqrt(v) : t * sqrt(s.coef_a));
}

// The posterior's predicted mean of the observation Î_C at x (docs/method.md §6): (1 − p̂0) μ / d²
// (d² = 1/Ĩ_C(x) by importance) with μ the regression constant's posterior mean at prior mean mu0, divided by the
// observation's BRDF factor (brdf; 1 unless --brdf-aware) so that it predicts Î_C itself.
float predicted_mean(SlotStats s, float mu0, float di, float brdf) {
    if (!(brdf > 0.0)) return 0.0;
    vec2 c = mean_coefficients(s, learn[0]);
    return max(c.x * mu0 + c.y * s.scale, 0.0) / (di * brdf);
}

// The bayes weight of slot i of the cut at offset o at (p, n) (0: the slot cannot light x);
// under --control-variates its predicted mean is added to cv_total. One function for the
// sum over the cut and for the one slot that light_pmf_of_cut needs, so both are the same
// float.
// learn[0].prior_scale, read once per cut (by learned_weights, light_pmf_of_cut) rather than
// once per slot: a buffer read in the slot loop is a per-lane gather on lavapipe that its
// compiler did not hoist, and hoisting this one made a bayes pass 10 % faster (`lightlearn profile`, default scene,
// depth 8: 2.30 s -> 2.02-2.10 s).
float sel_prior_scale = 0.0;

// --defensive ε (DEFENSIVE_ON, bayes): the cluster pmf is the mixture
// (1 − ε) w_C / W + ε Ĩ_C / I of the learned weights and wang's (Ĩ; their totals W, I),
// i.e. weights w_C + λ Ĩ_C of total W + λ I with λ = ε / (1 − ε) · W / I, so no cluster is
// drawn with less than ε times wang's chance. cut_imp: the cut's Ĩ_C for the mixing;
// sel_lambda: the λ of the last choice, which light_pmf_of_cut needs to repeat its pmf
// (render.comp keeps it with the path).
float cut_imp[MAX_CUT];
float sel_lambda = 0.0;

float mixed_weight(float w, float imp, float lambda) { return w + lambda * imp; }

// imp: the slot's unoccluded importance Ĩ_C at (p, n), wang's weight (--defensive mixes it in).
float bayes_slot_weight(uint o, uint i, vec3 p, vec3 n, float brdf, inout float cv_total, out float imp) {
    GpuLightNode nd = light_node(cut_word(o + 1u + i));
    float dn;
    imp = light_importance_d2(nd, p, n, dn);
    float w = 0.0;
    if (imp > 0.0) {
        float di = REGRESSION_ON ? dn : 1.0;
        // The prior mean of y = Î · d²: Ĩ · d² (Ĩ without its distance) in the
        // observation's units (prior_scale: 1/π maps a one-sided emitter's power
        // Φ = π A L to A L); by importance (y = Î / Ĩ) the same without Ĩ. Before any data
        // w ∝ Ĩ: bayes starts as wang.
        float mu0 = REGRESS_IMPORTANCE ? brdf * sel_prior_scale : imp * di * brdf * sel_prior_scale;
        SlotStats st = slot_stats_at(o + 1u + i);
        // By importance: Ĩ × the weight of y, a product where 1/d² takes a division.
        w = REGRESS_IMPORTANCE ? bayes_weight(st, mu0) * imp : bayes_weight(st, mu0) / di;
        if ((LEARN_FLAGS & LEARN_BRDF_SELECT) != 0u) w *= brdf_toward(nd, p, n);
        if (CV_ON && w > 0.0) cv_total += predicted_mean(st, mu0, REGRESS_IMPORTANCE ? 1.0 / imp : di, brdf);
    }
    return w;
}

// Fills cut_w with the learned weights of the cut at offset o at (p, n) and returns their
// sum (0: no cluster can light x); cv_total as in sample_learned. Under --defensive the
// weights and the sum are the mixture's and sel_lambda its λ (0 otherwise).
float learned_weights(uint o, vec3 p, vec3 n, float brdf, out float cv_total) {
    uint count = cut_word(o);
    const bool regression = REGRESSION_ON;
    const bool cv = CV_ON;
    float total = 0.0;
    cv_total = 0.0;
    if (SAMPLER == SAMPLER_DONIKIAN && o != 0u) {
        // Running mean of the observations (zeros included), mixed with the unoccluded
        // estimate: P = (1 − λ) mean / Σ mean + λ Ĩ / Σ Ĩ; Ĩ alone until the region has
        // seen as many samples as it has slots.
        float seen = 0.0;
        float sum_mean = 0.0;
        float sum_imp = 0.0;
        for (uint i = 0u; i < count; ++i) {
            SlotStats s = slot_stats_at(o + 1u + i);
            seen += s.n_zero + s.n_nonzero;
            sum_mean += s.n_zero + s.n_nonzero > 0.0 ? s.sum / (s.n_zero + s.n_nonzero) : 0.0;
            cut_w[i] = light_importance(light_node(cut_word(o + 1u + i)), p, n);
            sum_imp += cut_w[i];
        }
        if (sum_imp <= 0.0) return 0.0;
        if (seen >= float(count) && sum_mean > 0.0) {
            float lambda = learn[0].lambda;
            for (uint i = 0u; i < count; ++i) {
                SlotStats s = slot_stats_at(o + 1u + i);
                float mean = s.n_zero + s.n_nonzero > 0.0 ? s.sum / (s.n_zero + s.n_nonzero) : 0.0;
                // Ĩ = 0 proves the slot gives nothing here: never spend a sample on it.
                cut_w[i] = cut_w[i] > 0.0 ? (1.0 - lambda) * mean / sum_mean + lambda * cut_w[i] / sum_imp : 0.0;
            }
            for (uint i = 0u; i < count; ++i) total += cut_w[i];
            return total;
        }
        return sum_imp;
    }
    sel_prior_scale = learn[0].prior_scale;
    float imp_total = 0.0;
    uint i = 0u;
    if (count > 0u) do {
        float imp;
        cut_w[i] = bayes_slot_weight(o, i, p, n, brdf, cv_total, imp);
        total += cut_w[i];
        if (DEFENSIVE_ON) {
            cut_imp[i] = imp;
            imp_total += imp;
        }
        ++i;
    } while (i < count);
    sel_lambda = 0.0;
    if (DEFENSIVE_ON) {
        if (total > 0.0 && imp_total > 0.0) {
            float eps = learn[0].defensive;
            sel_lambda = eps / (1.0 - eps) * (total / imp_total);
            i = 0u;
            do {
                cut_w[i] = mixed_weight(cut_w[i], cut_imp[i], sel_lambda);
                ++i;
            } while (i < count);
            total = mixed_weight(total, imp_total, sel_lambda);
        }
    }
    return total;
}

// A cluster of the region's cut by the learned weights, then a light inside (pick_in_cut).
// slot: the index of the chosen slot in `cuts` (and in the statistics), NO_SLOT where the
// region has no cut of its own (the shared fallback cut does not learn: it samples as
// `wang`). p_slot: P(C | x); d2: what the observation is multiplied by, the regression
// distance² to C (1/Ĩ_C(x) by importance, 1 without regression);
// brdf: the observation's BRDF factor (1 unless --brdf-aware). With --control-variates
// (bayes only) cv_total = Σ_C g_C(x) over the cut and cv_chosen = g of the chosen slot, the
// predicted means of Î_C (predicted_mean; 0 for a slot of weight 0, which lights nothing
// here); both 0 otherwise.
uint sample_learned(vec3 p, vec3 n, float u, float brdf, out float pmf, out uint slot,
                    out float p_slot, out float d2, out float cv_total, out float cv_chosen) {
    uint o = region_cut(p, n);
    uint count = cut_word(o);
    const bool regression = REGRESSION_ON;
    const bool cv = CV_ON;
    pmf = 0.0;
    slot = NO_SLOT;
    p_slot = 0.0;
    d2 = 1.0;
    cv_chosen = 0.0;
    float total = learned_weights(o, p, n, brdf, cv_total);
    sel_cut = o;
    sel_total = total;
    if (total <= 0.0) return NO_LIGHT;
    uint k;
    uint li = pick_in_cut(o, count, total, u, p, n, pmf, k, p_slot);
    if (o != 0u) {
        slot = o + 1u + k;
        if (REGRESS_IMPORTANCE) d2 = 1.0 / light_importance(light_node(cut_word(slot)), p, n);
        else if (regression && SAMPLER == SAMPLER_BAYES) d2 = node_d2(light_node(cut_word(slot)), p);
    }
    if (cv) {
        // The chosen slot's g again, by the same arithmetic as in the sum above (the
        // estimator is unbiased only if this g is the one that Σ counted).
        float dn;
        float imp = light_importance_d2(light_node(cut_word(o + 1u + k)), p, n, dn);
        float di = REGRESS_IMPORTANCE ? 1.0 / imp : (regression ? dn : 1.0);
        float mu0 = REGRESS_IMPORTANCE ? brdf * learn[0].prior_scale : imp * di * brdf * learn[0].prior_scale;
        cv_chosen = predicted_mean(slot_stats_at(o + 1u + k), mu0, di, brdf);
    }
    return li;
}

// x (≥ 0, at most FIX_CLAMP²) in the window sums' fixed point, as (low, high) words:
// x · 2^24 is an integer-valued float after rounding, so splitting it at 2^32 is exact
// (src/learning/mod.rs fixed_sum reads it back).
uvec2 fixed_words(float x) {
    float v = floor(x * FIX_ONE + 0.5);
    float hi = floor(v / TWO_POW_32);
    return uvec2(uint(v - hi * TWO_POW_32), uint(hi));
}

// Adds one observation y (≥ 0) of a slot to the window's sums (64-bit fixed point as two
// 32-bit words: the carry of the low word goes into the high word, so the sum is exact).
// A kernel that defines TRACK_TOUCHED (render.comp) lists the slot for the fold the first
// time the window sees it: only the first observation of each count can find it 0, so the
// list's atomics run at most twice per slot and window.
void record_observation(uint slot, float y) {
    if (!(y > 0.0)) {
        uint first = atomicAdd(slot_delta[slot].n_zero, 1u);
#ifdef TRACK_TOUCHED
        if (first == 0u) mark_touched(slot);
#endif
        return;
    }
    uint first = atomicAdd(slot_delta[slot].n_nonzero, 1u);
#ifdef TRACK_TOUCHED
    if (first == 0u) mark_touched(slot);
#endif
    float q = min(y / slot_stats_at(slot).scale, FIX_CLAMP);
    uvec2 w = fixed_words(q);
    uint old = atomicAdd(slot_delta[slot].sum_lo, w.x);
    uint carry = old + w.x < old ? 1u : 0u;
    if (w.y + carry > 0u) atomicAdd(slot_delta[slot].sum_hi, w.y + carry);
    w = fixed_words(q * q);
    old = atomicAdd(slot_delta[slot].sq_lo, w.x);
    carry = old + w.x < old ? 1u : 0u;
    if (w.y + carry > 0u) atomicAdd(slot_delta[slot].sq_hi, w.y + carry);
}

#endif
