#version 460
#extension GL_GOOGLE_include_directive : require
// One progressive pass of direct illumination: for every pixel one jittered camera ray, the
// emission seen directly, and one next-event sample (light chosen by SAMPLER, point on it,
// shadow ray, Lambertian BRDF). Sums of the sample and of its square go to `accum` (.xyz);
// accum.sum.w counts the light samples that came out zero (occluded, facing away, a dead
// end) and accum.sum_sq.w all light samples: the zero-sample rate learning is meant to cut.
#include "types.glsl"
#include "rng.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// The light sampler, a closed set (src/render/mod.rs LightSampler): 0 uniform, 1 power,
// 2 lightbvh, 3 wang, 4 donikian, 5 bayes.
layout(constant_id = 0) const uint SAMPLER = 0u;
// How a cut's cluster picks its light: 0 by power, 1 by importance (RegionSettings).
layout(constant_id = 1) const uint IN_CLUSTER = 0u;

layout(std430, set = 0, binding = 0) readonly buffer Nodes { BvhNode bvh_nodes[]; };
layout(std430, set = 0, binding = 1) readonly buffer Tris { BvhTri bvh_tris[]; };
layout(std430, set = 0, binding = 2) readonly buffer TriMaterial { uint tri_material[]; };
layout(std430, set = 0, binding = 3) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, set = 0, binding = 4) readonly buffer Lights { GpuLight lights[]; };
layout(std430, set = 0, binding = 5) readonly buffer Alias { AliasEntry alias_table[]; };
layout(std430, set = 0, binding = 6) buffer Accum { PixelAccum accum[]; };
// [0]: samples dropped because they were NaN or Inf (reported, never averaged in).
// [1]: learned-sampler samples taken in a region without its own cut (the shared fallback).
layout(std430, set = 0, binding = 7) buffer Counters { uint counters[]; };
layout(std430, set = 0, binding = 8) readonly buffer LightNodes { LightNode light_nodes[]; };
layout(std430, set = 0, binding = 9) readonly buffer LightOrder { uint light_order[]; };
layout(std430, set = 0, binding = 10) readonly buffer Grid { GridParams grid[]; };
layout(std430, set = 0, binding = 11) readonly buffer RegionIndex { uint region_index[]; };
layout(std430, set = 0, binding = 12) readonly buffer Cuts { uint cuts[]; };
layout(std430, set = 0, binding = 13) readonly buffer Stats { SlotStats slot_stats[]; };
layout(std430, set = 0, binding = 14) buffer Delta { SlotDelta slot_delta[]; };
layout(std430, set = 0, binding = 15) readonly buffer Learn { LearnParams learn[]; };

layout(push_constant) uniform Push { RenderParams params; };

#include "bvh.glsl"
#include "lights.glsl"
#include "light_tree.glsl"
#include "regions.glsl"
#include "learning.glsl"

// Random-number dimensions of one pixel sample.
#define DIM_JITTER_X 0u
#define DIM_JITTER_Y 1u
#define DIM_LIGHT 2u
#define DIM_LIGHT_U 3u
#define DIM_LIGHT_V 4u

const float PI = 3.14159265358979;

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= params.width || px.y >= params.height) return;
    uint pixel = px.y * params.width + px.x;
    uint s = params.sample_index;
    uint seed = params.seed;

    // Box filter: a uniform point in the pixel (stratified over passes, or independent).
    vec2 jitter = params.stratified != 0u
        ? pixel_jitter_r2(seed, pixel, s)
        : vec2(sample_rand(seed, pixel, s, DIM_JITTER_X), sample_rand(seed, pixel, s, DIM_JITTER_Y));
    vec2 ndc = vec2((float(px.x) + jitter.x) / float(params.width) * 2.0 - 1.0,
                    1.0 - (float(px.y) + jitter.y) / float(params.height) * 2.0);
    vec3 dir = normalize(params.cam_w.xyz + ndc.x * params.cam_u.xyz + ndc.y * params.cam_v.xyz);
    vec3 origin = params.cam_pos.xyz;

    vec3 L = vec3(0.0);
    float zero_samples = 0.0;
    float light_samples = 0.0;
    float t;
    uint slot = trace_ray(origin, dir, 0.0, 3.0e38, false, t);
    if (slot != NO_HIT) {
        BvhTri tri = bvh_tris[slot];
        vec3 ng = normalize(cross(tri.e1, tri.e2));
        bool front = dot(ng, dir) < 0.0;
        GpuMaterial m = materials[tri_material[tri.prim]];
        if (front || (m.flags & MATERIAL_TWO_SIDED) != 0u) L += m.emission;

        // Reflection is two-sided: shade the side the camera sees.
        vec3 n = front ? ng : -ng;
        vec3 x = origin + t * dir;
        float pmf;
        float u_light = sample_rand(seed, pixel, s, DIM_LIGHT);
        uint li;
        const bool learned = SAMPLER == SAMPLER_BAYES || SAMPLER == SAMPLER_DONIKIAN;
        uint slot = NO_SLOT;
        float p_slot = 1.0;
        float d2_slot = 1.0;
        float cv_total = 0.0;
        float cv_chosen = 0.0;
        // --brdf-aware: the observation includes the (Lambertian) BRDF as luminance.
        float brdf = (SAMPLER == SAMPLER_BAYES && (learn[0].flags & LEARN_BRDF) != 0u)
                         ? dot(m.base_color, vec3(0.2126, 0.7152, 0.0722)) / PI : 1.0;
        if (SAMPLER == SAMPLER_LIGHTBVH) li = sample_light_tree(x, n, u_light, pmf);
        else if (SAMPLER == SAMPLER_WANG) li = sample_wang(x, n, u_light, pmf);
        else if (learned) li = sample_learned(x, n, u_light, brdf, pmf, slot, p_slot, d2_slot, cv_total, cv_chosen);
        else li = pick_light(u_light, params.light_count, pmf);
        if (learned && li != NO_LIGHT && slot == NO_SLOT) atomicAdd(counters[1], 1u);
        // The observation of the chosen cluster: Î_C = L_e G V / (P(l|C) p(y|l)) as
        // luminance (not divided by P(C|x)); zero when occluded or facing away.
        float observed = 0.0;
        vec3 Ic = vec3(0.0);  // Î_C in RGB, for the control variate
        vec3 wi;
        float dist;
        vec2 u = vec2(sample_rand(seed, pixel, s, DIM_LIGHT_U), sample_rand(seed, pixel, s, DIM_LIGHT_V));
        // NO_LIGHT: no light can reach the front of n here (zero contribution, exactly).
        GpuLight light = lights[li == NO_LIGHT ? 0u : li];
        vec3 Li = li == NO_LIGHT ? vec3(0.0) : sample_light_point(light, x, u, wi, dist);
        float cos_x = dot(n, wi);
        if (li != NO_LIGHT && cos_x > 0.0 && any(greaterThan(Li, vec3(0.0)))) {
            // The shadow ray starts just off the surface and aims at the light point itself:
            // keeping wi and dist from x made a surface parallel to an area light (a floor under
            // a ceiling panel) meet the light's own plane before tmax, i.e. shadow itself
            // (found by the Mitsuba cross-check, tests/mitsuba.rs: floor 48 % too dark).
            float eps = params.ray_eps;
            vec3 so = x + n * eps;
            vec3 to_light = wi * dist - n * eps;
            float sdist = length(to_light);
            // Stop short of an area light's own surface; a point light has none.
            float tmax = (light.kind & 0xffu) == LIGHT_TRIANGLE ? sdist - eps : sdist;
            float ts;
            if (trace_ray(so, to_light / sdist, 0.0, tmax, true, ts) == NO_HIT) {
                L += m.base_color * (1.0 / PI) * Li * (cos_x / pmf);
                Ic = Li * (cos_x * p_slot / pmf);
                observed = dot(Li, vec3(0.2126, 0.7152, 0.0722)) * cos_x * (p_slot / pmf) * brdf;
            }
        }
        if (learned && slot != NO_SLOT) record_observation(slot, observed * d2_slot);
        light_samples = 1.0;
        zero_samples = any(greaterThan(Ic, vec3(0.0))) ? 0.0 : 1.0;
        // --control-variates (method.md §6): Σ_C g_C + (Î_C − g_C) / P(C) instead of
        // Î_C / P(C), with g_C the model's predicted mean of Î_C (gray: the model learns
        // luminance). Unbiased for any g fixed within the pass; also where the sample was
        // occluded or a dead end (Î_C = 0), which is why it is added here, outside the
        // shadow-ray branch. p_slot = 0 only where no cluster can light x (g's all 0).
        if (cv_total > 0.0 && p_slot > 0.0) {
            L += m.base_color * (1.0 / PI) * (vec3(cv_total) - vec3(cv_chosen) / p_slot);
        }
    }

    if (any(isnan(L)) || any(isinf(L))) {
        atomicAdd(counters[0], 1u);
        L = vec3(0.0);
    }
    PixelAccum a = accum[pixel];
    a.sum += vec4(L, zero_samples);
    a.sum_sq += vec4(L * L, light_samples);
    accum[pixel] = a;
}
