// The learned cluster samplers: `bayes` (Vévoda et al. 2018, method.md §3–§4) and `donikian`
// (Donikian et al. 2006, method.md §8), and the recording of their observations.
// Mirror of src/learning/mod.rs (`slot_weight`, `donikian_weights`); tests/learning.rs checks
// GPU against CPU. The including kernel declares the region buffers, `slot_stats`
// (SlotStats[], parallel to `cuts`), `slot_delta` (SlotDelta[], same) and `learn`
// (LearnParams[1]).
#ifndef LEARNING_GLSL
#define LEARNING_GLSL

#include "regions.glsl"

#define NO_SLOT 0xffffffffu

// Fixed point of the window sums: y / scale with 24 fraction bits, y / scale clamped to 4096
// so that one observation adds at most 2^36 to Σ and 2^48 to Σ² (the 64-bit sums then hold
// ≥ 2^15 clamped observations per slot and window). The clamp only touches the model, never
// the image: the estimator stays unbiased whatever the statistics say.
#define FIX_ONE 16777216.0
#define FIX_CLAMP 4096.0
#define TWO_POW_32 4294967296.0

// The posterior's sampling weight of one slot at x (method.md §4), before the 1/d² factor:
// sqrt((1 − p̂0)(k̂² + ĥ)) or, with target = mean, (1 − p̂0) k̂. mu0 is the prior mean of
// y at x: the unoccluded estimate in the units of k.
float bayes_weight(SlotStats s, float mu0) {
    LearnParams L = learn[0];
    bool priors = (L.flags & LEARN_PRIORS) != 0u;
    float nz = s.n_zero;
    float nv = s.n_nonzero;
    float n_all = nz + nv;
    float a0 = priors ? L.prior_zero : 0.0;
    float b0 = priors ? L.prior_nonzero : 0.0;
    float nbar = priors ? L.prior_n : 0.0;
    float abar = priors ? L.prior_alpha : 0.0;
    float beta0 = priors ? abar * (L.prior_cv * mu0) * (L.prior_cv * mu0) : 0.0;
    // 1 − p̂0, the posterior mean of the non-zero chance; without priors the frequency, kept
    // ≥ 1/(n + 1) so that a slot never seen lit keeps a chance (guarded division).
    float q = priors ? (b0 + nv) / (a0 + b0 + n_all)
                     : (n_all > 0.0 ? max(nv / n_all, 1.0 / (n_all + 1.0)) : 1.0);
    float kappa = nbar + nv;
    float mu = kappa > 0.0 ? (nbar * mu0 + s.sum) / kappa : mu0;
    // Without priors a slot whose observations all rounded to 0 would starve (biased):
    // it falls back to the unoccluded estimate.
    if (!priors && !(mu > 0.0)) mu = mu0;
    float alpha = abar + 0.5 * nv;
    float ybar = nv > 0.0 ? s.sum / nv : 0.0;
    float ss = max(s.sum_sq - s.sum * ybar, 0.0);
    float dm = ybar - mu0;
    float beta = beta0 + 0.5 * ss + (kappa > 0.0 ? nbar * nv * dm * dm / (2.0 * kappa) : 0.0);
    float h = alpha > 0.5 ? beta / (alpha - 0.5) : 0.0;
    if ((L.flags & LEARN_TARGET_MEAN) != 0u) return q * mu;
    // sqrt(mu² + h) without squaring tiny or huge values.
    float sh = sqrt(h);
    float m = max(abs(mu), sh);
    if (m <= 0.0) return 0.0;
    float a = mu / m;
    float b = sh / m;
    return sqrt(q) * m * sqrt(a * a + b * b);
}

// A cluster of the region's cut by the learned weights, then a light inside by power.
// slot: the index of the chosen slot in `cuts` (and in the statistics), NO_SLOT where the
// region has no cut of its own (the shared fallback cut does not learn: it samples as
// `wang`). p_slot: P(C | x); d2: the regression distance² to C (1 without regression);
// brdf: the observation's BRDF factor (1 unless --brdf-aware).
uint sample_learned(vec3 p, vec3 n, float u, float brdf, out float pmf, out uint slot,
                    out float p_slot, out float d2) {
    uint o = region_index[region_of(p, n)];
    uint count = cuts[o];
    bool regression = (learn[0].flags & LEARN_REGRESSION) != 0u;
    float total = 0.0;
    pmf = 0.0;
    slot = NO_SLOT;
    p_slot = 0.0;
    d2 = 1.0;
    if (SAMPLER == SAMPLER_DONIKIAN && o != 0u) {
        // Running mean of the observations (zeros included), mixed with the unoccluded
        // estimate: P = (1 − λ) mean / Σ mean + λ Ĩ / Σ Ĩ; Ĩ alone until the region has
        // seen as many samples as it has slots.
        float seen = 0.0;
        float sum_mean = 0.0;
        float sum_imp = 0.0;
        for (uint i = 0u; i < count; ++i) {
            SlotStats s = slot_stats[o + 1u + i];
            seen += s.n_zero + s.n_nonzero;
            sum_mean += s.n_zero + s.n_nonzero > 0.0 ? s.sum / (s.n_zero + s.n_nonzero) : 0.0;
            cut_w[i] = light_importance(light_nodes[cuts[o + 1u + i]], p, n);
            sum_imp += cut_w[i];
        }
        if (sum_imp <= 0.0) return NO_LIGHT;
        if (seen >= float(count) && sum_mean > 0.0) {
            float lambda = learn[0].lambda;
            for (uint i = 0u; i < count; ++i) {
                SlotStats s = slot_stats[o + 1u + i];
                float mean = s.n_zero + s.n_nonzero > 0.0 ? s.sum / (s.n_zero + s.n_nonzero) : 0.0;
                // Ĩ = 0 proves the slot gives nothing here: never spend a sample on it.
                cut_w[i] = cut_w[i] > 0.0 ? (1.0 - lambda) * mean / sum_mean + lambda * cut_w[i] / sum_imp : 0.0;
            }
            total = 0.0;
            for (uint i = 0u; i < count; ++i) total += cut_w[i];
        } else {
            total = sum_imp;
        }
    } else {
        for (uint i = 0u; i < count; ++i) {
            LightNode nd = light_nodes[cuts[o + 1u + i]];
            float imp = light_importance(nd, p, n);
            float w = 0.0;
            if (imp > 0.0) {
                float di = regression ? node_d2(nd, p) : 1.0;
                // The prior mean of y = Î · d²: Ĩ · d² (Ĩ without its distance), ÷ π
                // because a node's power is Φ = π A L for a one-sided emitter while
                // Î · d² ≈ A L cosθ_x cosθ_y. Before any data w ∝ Ĩ: bayes starts as wang.
                float mu0 = imp * di * brdf * (1.0 / 3.14159265358979);
                w = bayes_weight(slot_stats[o + 1u + i], mu0) / di;
            }
            cut_w[i] = w;
            total += w;
        }
    }
    if (total <= 0.0) return NO_LIGHT;
    uint k;
    uint li = pick_in_cut(o, count, total, u, pmf, k, p_slot);
    if (o != 0u) {
        slot = o + 1u + k;
        if (regression && SAMPLER == SAMPLER_BAYES) d2 = node_d2(light_nodes[cuts[slot]], p);
    }
    return li;
}

// Adds one observation y (≥ 0) of a slot to the window's sums (64-bit fixed point as two
// 32-bit words: the carry of the low word goes into the high word, so the sum is exact).
void record_observation(uint slot, float y) {
    if (!(y > 0.0)) {
        atomicAdd(slot_delta[slot].n_zero, 1u);
        return;
    }
    atomicAdd(slot_delta[slot].n_nonzero, 1u);
    float q = min(y / slot_stats[slot].scale, FIX_CLAMP);
    // q · 2^24 is an integer-valued float after rounding; splitting it at 2^32 is exact.
    float v = floor(q * FIX_ONE + 0.5);
    float hi = floor(v / TWO_POW_32);
    uint lo = uint(v - hi * TWO_POW_32);
    uint old = atomicAdd(slot_delta[slot].sum_lo, lo);
    uint carry = old + lo < old ? 1u : 0u;
    if (uint(hi) + carry > 0u) atomicAdd(slot_delta[slot].sum_hi, uint(hi) + carry);
    v = floor(q * q * FIX_ONE + 0.5);
    hi = floor(v / TWO_POW_32);
    lo = uint(v - hi * TWO_POW_32);
    old = atomicAdd(slot_delta[slot].sq_lo, lo);
    carry = old + lo < old ? 1u : 0u;
    if (uint(hi) + carry > 0u) atomicAdd(slot_delta[slot].sq_hi, uint(hi) + carry);
}

#endif
