// The light-selection pmf of the active SAMPLER for a given light: what multiple importance
// sampling needs when a BSDF-sampled ray hits an emitter (docs/method.md §5: the pmfs are exact
// because the statistics are frozen within a pass). Each case repeats its sampler's own
// choice, so light_pmf(p, n, l) equals the pmf that sampler reports when it picks l
// (tests/learning/). The including kernel declares `light_position` (uint[]: a light's
// position in the tree order, the inverse of `light_order`) besides the sampler's buffers.
#ifndef LIGHT_PMF_GLSL
#define LIGHT_PMF_GLSL

#include "learning.glsl"

// count: the number of lights; brdf: as for sample_learned.
float light_pmf(vec3 p, vec3 n, uint li, uint count, float brdf) {
    if (SAMPLER == SAMPLER_UNIFORM) return 1.0 / float(count);
#ifdef HAS_ALIAS_TABLE
    if (SAMPLER == SAMPLER_POWER) return alias_table[li].pmf;
#endif
    uint pos = light_position[li];
    if (SAMPLER == SAMPLER_LIGHTBVH) return light_tree_pmf(pos, p, n);
    uint o = region_index_at(region_of(p, n));
    float total;
    if (SAMPLER == SAMPLER_WANG) {
        total = wang_weights(o, p, n);
    } else {
        float cv_total;
        total = learned_weights(o, p, n, brdf, cv_total);
    }
    return pmf_in_cut(o, total, pos, p, n);
}

// light_pmf at the point of a choice by sample_wang or sample_learned (bayes) whose cut and
// weight total the caller kept (sel_cut, sel_total): one slot's weight instead of the cut's
// sum (the same float as light_pmf gives: the same functions on the same inputs, golden
// pixels unchanged). The MIS weight of every emitter a BSDF ray hits needs it; summing the
// cut again there cost 12 % of a bayes pass (`lightlearn profile`). Other samplers:
// light_pmf.
// lambda: the choice's sel_lambda (bayes under --defensive; else unused).
float light_pmf_of_cut(uint o, float total, float lambda, vec3 p, vec3 n, uint li, uint count, float brdf) {
    if (SAMPLER != SAMPLER_WANG && SAMPLER != SAMPLER_BAYES) return light_pmf(p, n, li, count, brdf);
    uint pos = light_position[li];
    uint k = slot_holding(o, pos);
    if (k == NO_SLOT_IN_CUT) return 0.0;
    float w;
    if (SAMPLER == SAMPLER_WANG) {
        w = light_importance(light_node(cut_word(o + 1u + k)), p, n);
    } else {
        float cv = 0.0;
        float imp;
        sel_prior_scale = learn[0].prior_scale;
        w = bayes_slot_weight(o, k, p, n, brdf, cv, imp);
        if (DEFENSIVE_ON) w = mixed_weight(w, imp, lambda);
    }
    return pmf_in_slot(o, k, w, total, pos, p, n);
}

#endif
