// The light-selection pmf of the active SAMPLER for a given light: what multiple importance
// sampling needs when a BSDF-sampled ray hits an emitter (docs/method.md §5: the pmfs are exact
// because the statistics are frozen within a pass). Each case repeats its sampler's own
// choice, so light_pmf(p, n, l) equals the pmf that sampler reports when it picks l
// (tests/learning.rs). The including kernel declares `light_position` (uint[]: a light's
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
    uint o = region_index[region_of(p, n)];
    float total;
    if (SAMPLER == SAMPLER_WANG) {
        total = wang_weights(o, p, n);
    } else {
        float cv_total;
        total = learned_weights(o, p, n, brdf, cv_total);
    }
    return pmf_in_cut(o, total, pos, p, n);
}

#endif
