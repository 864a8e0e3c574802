#version 460
#extension GL_GOOGLE_include_directive : require
// Runs a light-tree sampler (SAMPLER: 2 lightbvh, 3 wang, 4 donikian, 5 bayes) for a batch of
// (p, n, u) queries: the GPU side of the tests that GPU and CPU pick the same light with the
// same pmf (tests/light_tree.rs, tests/regions.rs, tests/learning/), and that light_pmf
// gives every light the pmf its sampler picks it with (tests/learning/).
#include "types.glsl"

layout(local_size_x = 64) in;

layout(constant_id = 0) const uint SAMPLER = 2u;
// How a cut's cluster picks its light: 0 by power, 1 by importance (RegionSettings).
layout(constant_id = 1) const uint IN_CLUSTER = 0u;
// The learned samplers' switches: learn[0].flags, fixed for the pipeline (learning.glsl).
layout(constant_id = 3) const uint LEARN_FLAGS = 0u;

// The light tree as texels (light_tree.glsl light_node).
layout(set = 0, binding = 0) uniform usamplerBuffer light_node_texels;
layout(std430, set = 0, binding = 1) readonly buffer Order { uint light_order[]; };
layout(std430, set = 0, binding = 2) readonly buffer Queries { LightQuery queries[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Choices { LightChoice choices[]; };
layout(set = 0, binding = 4) uniform usamplerBuffer grid_texels;
layout(set = 0, binding = 5) uniform usamplerBuffer region_index_texels;
layout(set = 0, binding = 6) uniform usamplerBuffer cut_texels;
layout(set = 0, binding = 7) uniform usamplerBuffer slot_stat_texels;
layout(std430, set = 0, binding = 8) buffer Delta { SlotDelta slot_delta[]; };
layout(std430, set = 0, binding = 9) readonly buffer Learn { LearnParams learn[]; };
layout(std430, set = 0, binding = 10) readonly buffer Position { uint light_position[]; };

layout(push_constant) uniform Push { uint query_count; };

#include "light_pmf.glsl"

// The CPU mirrors know no BRDF: the selection factor of --brdf-select is 1 here.
float brdf_toward(GpuLightNode nd, vec3 p, vec3 n) { return 1.0; }

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= query_count) return;
    LightQuery q = queries[i];
    LightChoice c;
    c.cv_total = 0.0;
    c.cv_chosen = 0.0;
    uint slot;
    float p_slot, d2;
    if (SAMPLER == SAMPLER_WANG) c.light = sample_wang(q.p, q.n, q.u, c.pmf);
    else if (SAMPLER == SAMPLER_LIGHTBVH) c.light = sample_light_tree(q.p, q.n, q.u, c.pmf);
    else c.light = sample_learned(q.p, q.n, q.u, 1.0, c.pmf, slot, p_slot, d2, c.cv_total, c.cv_chosen);
    if (c.light == NO_LIGHT) c.pmf = 0.0;
    // The pmf of the chosen light again, as render.comp's MIS weight takes it (from the
    // choice's cut and total: light_pmf_of_cut), and light_pmf of the query's own light
    // (q.light; none: 0) summed afresh.
    c.pmf_again = c.light == NO_LIGHT ? 0.0 : light_pmf_of_cut(sel_cut, sel_total, sel_lambda, q.p, q.n, c.light, 0u, 1.0);
    c.pmf_query = q.light == NO_LIGHT ? 0.0 : light_pmf(q.p, q.n, q.light, 0u, 1.0);
    choices[i] = c;
}
