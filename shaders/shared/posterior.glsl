// The bayes sampling weight of one slot in closed form (docs/method.md §3–§4), as coefficients
// the fold kernel stores once per slot and the render kernel evaluates per shading point.
// Mirror of src/learning/mod.rs `coefficients`.
//
// With t = μ0 / scale (μ0: the prior mean of y at the shading point; scale: the slot's
// fixed-point scale, which keeps every number near 1):
//   μ = P μ0 + Q,  ĥ = H2 μ0² + H0 + H1 (ȳ − μ0)²,  1 − p̂0 = R,
//   w² = R (μ² + ĥ) = scale² (a t² + b t + c)     (target sqrt(mean² + variance))
//   w  = R μ       = scale (a t + b)               (target mean)
#ifndef POSTERIOR_GLSL
#define POSTERIOR_GLSL

#include "types.glsl"

// R = 1 − p̂0 and the posterior mean of the regression constant as μ = P μ0 + Q·scale:
// the part of the posterior that the sampling weight and the predicted mean share.
vec3 posterior_rpq(SlotStats s, LearnParams L) {
    bool priors = (L.flags & LEARN_PRIORS) != 0u;
    float nz = s.n_zero;
    float nv = s.n_nonzero;
    float n_all = nz + nv;
    float a0 = priors ? L.prior_zero : 0.0;
    float b0 = priors ? L.prior_nonzero : 0.0;
    float nbar = priors ? L.prior_n : 0.0;
    // 1 − p̂0; without priors the frequency, kept ≥ 1/(n + 1) so that a slot never seen
    // lit keeps a chance (a guarded division).
    float R = priors ? (b0 + nv) / (a0 + b0 + n_all)
                     : (n_all > 0.0 ? max(nv / n_all, 1.0 / (n_all + 1.0)) : 1.0);
    float s1 = s.sum / s.scale;
    float kappa = nbar + nv;
    float P = kappa > 0.0 ? nbar / kappa : 1.0;
    float Q = kappa > 0.0 ? s1 / kappa : 0.0;
    // Without priors a slot whose observations all rounded to 0 would starve (biased): it
    // falls back to the unoccluded estimate.
    if (!priors && !(Q > 0.0)) {
        P = 1.0;
        Q = 0.0;
    }
    return vec3(R, P, Q);
}

// The posterior's predicted mean of y, E[y] = (1 − p̂0) μ = scale (a t + b): the control
// variate of docs/method.md §6 (and the weight of --target mean).
vec2 mean_coefficients(SlotStats s, LearnParams L) {
    vec3 rpq = posterior_rpq(s, L);
    return vec2(rpq.x * rpq.y, rpq.x * rpq.z);
}

vec3 weight_coefficients(SlotStats s, LearnParams L) {
    bool priors = (L.flags & LEARN_PRIORS) != 0u;
    float sc = s.scale;
    float nv = s.n_nonzero;
    float nbar = priors ? L.prior_n : 0.0;
    float abar = priors ? L.prior_alpha : 0.0;
    vec3 rpq = posterior_rpq(s, L);
    float R = rpq.x;
    float P = rpq.y;
    float Q = rpq.z;
    float s1 = s.sum / sc;
    float s2 = s.sum_sq / (sc * sc);
    float ybar = nv > 0.0 ? s1 / nv : 0.0;
    float kappa = nbar + nv;
    float den = abar + 0.5 * nv - 0.5;  // α' − ½
    float H2 = 0.0;
    float H0 = 0.0;
    float H1 = 0.0;
    if (den > 0.0) {
        H2 = abar * L.prior_cv * L.prior_cv / den;
        H0 = 0.5 * max(s2 - s1 * ybar, 0.0) / den;
        H1 = kappa > 0.0 ? nbar * nv / (2.0 * kappa * den) : 0.0;
    }
    if ((L.flags & LEARN_TARGET_MEAN) != 0u) return vec3(R * P, R * Q, 0.0);
    return vec3(R * (P * P + H2 + H1), R * (2.0 * P * Q - 2.0 * H1 * ybar),
                R * (Q * Q + H0 + H1 * ybar * ybar));
}

#endif
