#version 460
#extension GL_GOOGLE_include_directive : require
// One progressive pass: for every pixel one jittered camera ray and one path. At every surface
// vertex one next-event sample (light chosen by SAMPLER, point on it, shadow ray, the glTF
// metallic-roughness BRDF of bsdf.glsl). --max-depth 1 is direct light by light sampling
// alone (the paper's DI estimator, no BSDF ray). --max-depth D ≥ 2 is a path tracer with up
// to D surface vertices: the path goes on by BSDF sampling (cosine / GGX visible normals),
// and an emitter that a BSDF ray hits counts with the power-heuristic MIS weight against the
// light sampler's exact pmf (light_pmf.glsl), after the next-event sample of the vertex
// before it carried the complementary weight. Russian roulette from the third vertex on
// (pbrt-v4's rule: q = 1 − max throughput).
// Sums of the sample and of its square go to `accum` (.xyz); accum.sum.w counts the light
// samples that came out zero (occluded, facing away, a dead end) and accum.sum_sq.w all
// light samples: the zero-sample rate learning is meant to cut.
#include "types.glsl"
#include "rng.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// Descriptor sets by lifetime (src/render/session/mod.rs binds each when it changes): set 0 the
// scene (uploaded once), set 1 the learned state (rebound when cuts are added), set 2 the
// film (rebound on resize).

// The light sampler, a closed set (src/render/mod.rs LightSampler): 0 uniform, 1 power,
// 2 lightbvh, 3 wang, 4 donikian, 5 bayes. build.rs compiles one kernel per sampler and
// per DIRECT_ONLY (FIXED_SAMPLER, FIXED_DIRECT_ONLY; src/gpu/mod.rs kernels::render) and
// strips what the others need with spirv-opt: lavapipe then builds the default render's
// kernel in 0.3–0.4 s instead of 0.8–1.1 s, as the other samplers' functions no longer reach
// its inliner, with the same images (docs/results.md, twenty-second session). Without the
// defines (glslangValidator by hand) they are specialization constants as before.
#ifdef FIXED_SAMPLER
const uint SAMPLER = FIXED_SAMPLER;
#else
layout(constant_id = 0) const uint SAMPLER = 0u;
#endif
// How a cut's cluster picks its light: 0 by power, 1 by importance (RegionSettings).
layout(constant_id = 1) const uint IN_CLUSTER = 0u;
// Stages knocked out for the stage profile (`lightlearn profile`, src/bench/stages.rs); 0 in
// every render. The images are then wrong: only the time of a pass means something.
layout(constant_id = 2) const uint KNOCK_OUT = 0u;
#define KNOCK_SELECT 1u   // lights picked uniformly instead of by SAMPLER
#define KNOCK_SHADOW 2u   // shadow rays not traced (every light sample taken as visible)
#define KNOCK_MIS_PMF 4u  // light_pmf of an emitter a BSDF ray hits not evaluated
#define KNOCK_OBSERVE 8u  // observations not recorded (no statistics atomics)
#define KNOCK_SHADING 16u // the path ends at its first hit, whose distance is its sample: the
                          // camera rays alone (everything after them left out)
#define KNOCK_IMPORTANCE 32u // the unoccluded importance is Φ/d² (light_tree.glsl): its cone
                             // and cosine bounds' arithmetic left out
#define IMPORTANCE_KNOCKED_OUT ((KNOCK_OUT & KNOCK_IMPORTANCE) != 0u)
// The learned samplers' switches (LearnParams.flags), fixed for the pipeline (learning.glsl).
layout(constant_id = 3) const uint LEARN_FLAGS = 0u;
// What the scene's materials need (src/render/gpu_scene.rs kernel_flags): 1 a glossy material, 2 a
// textured one, 4 an emissive texture, 8 smooth triangles, bits 8–15 the directional lights. Code no material needs is compiled out: on lavapipe a branch costs its body
// even where no lane takes it (`lightlearn profile`).
layout(constant_id = 4) const uint SCENE_FLAGS = 0x10fu;
#define SCENE_GLOSSY ((SCENE_FLAGS & 1u) != 0u)
const bool SCENE_TEXTURED = (SCENE_FLAGS & 2u) != 0u;
// 4: an emissive texture (emission = factor × texture at the light sample's point and at an
// emitter a ray hits).
const bool SCENE_EMISSIVE_TEXTURED = (SCENE_FLAGS & 4u) != 0u;
// Bits 8–15: the directional lights (after params.light_count in the light texels), each
// sampled at every vertex by sun_light; 0 compiles that out.
const uint DIRECTIONAL_COUNT = (SCENE_FLAGS >> 8u) & 0xffu;
// 8: smooth triangles, whose corners' normals (in tri_uv after the texture coordinates) are
// interpolated into the shading normal (texture.glsl shading_normal).
const bool SCENE_SMOOTH = (SCENE_FLAGS & 8u) != 0u;
// Normal textures: tangent frames after the normals (texture.glsl mapped_normal); always with
// SCENE_SMOOTH.
const bool SCENE_NORMAL_MAPPED = (SCENE_FLAGS & 16u) != 0u;
// 32: a material of alphaMode MASK: the alpha test at every triangle a ray meets
// (alpha.glsl).
const bool SCENE_ALPHA_MASK = (SCENE_FLAGS & 32u) != 0u;
#define TRI_ATTR_STRIDE (SCENE_NORMAL_MAPPED ? 13u : SCENE_SMOOTH ? 9u : 6u)
// --max-depth 1 (RenderSettings::max_depth is fixed for a session): direct light alone, the
// BSDF sampling and MIS code compiled out (lavapipe runs the code after a uniform `break`
// too). The push constant max_depth stays the loop's bound.
#ifdef FIXED_DIRECT_ONLY
const bool DIRECT_ONLY = FIXED_DIRECT_ONLY;
#else
layout(constant_id = 5) const bool DIRECT_ONLY = false;
#endif
// Paths traced one bounce per dispatch through queues (main() says why): whenever a path
// has more than one vertex (src/render/passes.rs `wavefront`); direct light takes its one
// vertex in one invocation.
const bool WAVEFRONT = !DIRECT_ONLY;
// --light-point solid-angle (RenderSettings::light_point): triangle lights sampled by solid
// angle where that is well conditioned (lights.glsl); false: uniformly by area.
layout(constant_id = 6) const bool LIGHT_POINT_SOLID_ANGLE = false;
// --indirect-light-samples N (RenderSettings::indirect_light_samples, 1 to 16): next-event
// samples at every vertex after the first, averaged, each with the power heuristic against
// the BSDF ray at N times its pdf (the multi-sample MIS of N light samples and one BSDF
// sample). 1 (the default) compiles to the one sample the loop always took.
layout(constant_id = 7) const uint INDIRECT_LIGHT_SAMPLES = 1u;
// --first-light-samples N (RenderSettings::first_light_samples, 1 to 16): next-event samples
// at the first vertex, averaged, each from independent numbers (above 1 the first vertex's
// stratified light numbers are not used), so the variance of their light sampling falls as
// 1/N and what stays as N grows is the camera ray's: the floor under any light choice
// (ci/bench_floor.py). 1 (the default) compiles to the one stratified sample.
layout(constant_id = 8) const uint FIRST_LIGHT_SAMPLES = 1u;
// --stratify (RenderSettings::stratify, fixed for a session): STRATIFY_SOBOL, STRATIFY_R2 or
// STRATIFY_OFF (types.glsl). A push constant before: every sample then computed the numbers
// of all three modes (lavapipe runs both sides of a choice).
layout(constant_id = 9) const uint STRATIFY = STRATIFY_SOBOL;
// Whether any vertex takes more than one light sample (sums of specialization constants:
// glslang 11 mistranslates || between them, learning.glsl says so).
const bool MULTI_LIGHT_SAMPLES = INDIRECT_LIGHT_SAMPLES + FIRST_LIGHT_SAMPLES > 2u;
const bool FIRST_INDEPENDENT = FIRST_LIGHT_SAMPLES > 1u;

// The BVH as texels (bvh.glsl).
layout(set = 0, binding = 0) uniform usamplerBuffer bvh_node_texels;
layout(set = 0, binding = 1) uniform usamplerBuffer bvh_tri_texels;
layout(std430, set = 0, binding = 2) readonly buffer TriMaterial { uint tri_material[]; };
// The materials and the lights as texels (scene_texels.glsl).
layout(set = 0, binding = 3) uniform usamplerBuffer material_texels;
layout(set = 0, binding = 4) uniform usamplerBuffer light_texels;
layout(std430, set = 0, binding = 5) readonly buffer Alias { AliasEntry alias_table[]; };
// The film: each pixel's PixelAccum as two RGBA32UI texels (sum, sum_sq), read as a uniform
// texel buffer (film_read) and written as a storage texel buffer through the same view
// (film_write). lavapipe loads a storage buffer's words lane by lane but a texel with one
// vector gather: a lone direct-light dispatch, which reads and writes its pixels once, took
// 2.48 against 2.62 ms on city at 128×96 this way (`bayes --update-every 1`, 256 dispatches:
// 0.94× the time; the same bits; docs/results.md, sixteenth session).
layout(set = 2, binding = 0) uniform usamplerBuffer accum_texels;
layout(set = 2, binding = 6, rgba32ui) uniform writeonly uimageBuffer accum_image;
// [0]: samples dropped because they were NaN or Inf (reported, never averaged in).
// [1]: learned-sampler samples taken in a region without its own cut (the shared fallback).
layout(std430, set = 2, binding = 1) buffer Counters { uint counters[]; };
// Direct light: the rows of 8 pixels that can see the scene (x / 8 in the low 16 bits, y in
// the high 16), one per SIMD group of a workgroup (main(); src/render/coverage.rs says why).
layout(std430, set = 2, binding = 5) readonly buffer LiveRows { uint live_count; uint live_row[]; };
// The light tree as texels (light_tree.glsl light_node).
layout(set = 0, binding = 6) uniform usamplerBuffer light_node_texels;
layout(std430, set = 0, binding = 7) readonly buffer LightOrder { uint light_order[]; };
layout(set = 1, binding = 0) uniform usamplerBuffer grid_texels;
// The region index and the cuts as R32UI texels (regions.glsl).
layout(set = 1, binding = 1) uniform usamplerBuffer region_index_texels;
layout(set = 1, binding = 2) uniform usamplerBuffer cut_texels;
// The statistics as texels (learning.glsl slot_stats_at).
layout(set = 1, binding = 3) uniform usamplerBuffer slot_stat_texels;
layout(std430, set = 1, binding = 4) buffer Delta { SlotDelta slot_delta[]; };
layout(std430, set = 1, binding = 5) readonly buffer Learn { LearnParams learn[]; };
// A light's position in the tree order (the inverse of light_order), for light_pmf.
layout(std430, set = 0, binding = 8) readonly buffer LightPosition { uint light_position[]; };
// The light of an emissive triangle (by `prim`), NO_LIGHT for the others.
layout(std430, set = 0, binding = 9) readonly buffer TriLight { uint tri_light[]; };
// Base-colour textures (texture.glsl).
layout(std430, set = 0, binding = 10) readonly buffer Textures { GpuTexture textures[]; };
layout(std430, set = 0, binding = 11) readonly buffer Texels { uint texels[]; };
// Each triangle's texture coordinates (as float bits) and, in smooth scenes, its corners'
// normals (texture.glsl, src/render/gpu_scene.rs triangle_attributes).
layout(std430, set = 0, binding = 12) readonly buffer TriUv { uint tri_uv[]; };
// The dielectric layer's albedo table (bsdf.glsl, src/layer_albedo.rs).
layout(set = 0, binding = 13) uniform usamplerBuffer layer_albedo_texels;

// Regions without a cut of their own that samples reached, for the host to build cuts for
// between frames: [0] counts newly set bits, then one bit per region.
layout(std430, set = 1, binding = 6) buffer MissingRegions { uint missing_regions[]; };

layout(push_constant) uniform Push { RenderParams params; };

void flag_missing_region(uint r) {
    uint word = 1u + (r >> 5u);
    uint bit = 1u << (r & 31u);
    if ((missing_regions[word] & bit) != 0u) return;
    if ((atomicOr(missing_regions[word], bit) & bit) == 0u) atomicAdd(missing_regions[0], 1u);
}
#define FLAG_MISSING_REGIONS

// The slots this learning window touched, for the fold (fold.comp), which then visits those
// alone: [0] its workgroup count (an indirect dispatch, one group per 64 entries), [1] and
// [2] 1, [3] the count, then the slots (NO_SLOT after the last). lavapipe runs a kernel's
// body for every invocation, even one that returns at once, so a fold over all 47652 slots
// of city cost as much as it did although a 128×96 direct pass touches at most 12288 of
// them: the list made bayes on city 14-20 % faster (docs/results.md, 2026-12-02).
layout(std430, set = 1, binding = 7) buffer Touched { uint touched_slots[]; };

void mark_touched(uint slot) {
    if (atomicExchange(slot_delta[slot].touched, 1u) != 0u) return;
    uint k = atomicAdd(touched_slots[3], 1u);
    touched_slots[4u + k] = slot;
    if ((k & 63u) == 0u) atomicAdd(touched_slots[0], 1u);
}
#define TRACK_TOUCHED

// --refine-cuts: each slot's observations by the child of its node that the light came
// from (regions.glsl sel_side): [6 slot + side] counts them, [6 slot + 2 + 2 side] (low,
// high word) sums their y² in the fixed point of the window sums (learning.glsl
// record_observation). Summed over the whole render, never cleared: a slot that splits
// gives way to new slots, whose sums start at 0. src/render/refine.rs splits a cluster
// where its two children's second moments differ, which the slot's own totals cannot tell
// from a spread that a split would not sort out.
layout(std430, set = 1, binding = 8) buffer SideCounts { uint side_counts[]; };

#include "scene_texels.glsl"
#include "texture.glsl"
#include "alpha.glsl"
#include "bvh.glsl"
#include "lights.glsl"
#include "light_tree.glsl"
#include "regions.glsl"
#define HAS_ALIAS_TABLE
#include "light_pmf.glsl"

// Random-number dimensions of one pixel sample: the jitter, then DIMS_PER_VERTEX per vertex
// (the first vertex keeps the dimensions the direct-light kernel always used).
#define DIM_JITTER_X 0u
#define DIM_JITTER_Y 1u
#define DIM_LIGHT 2u
#define DIM_LIGHT_U 3u
#define DIM_LIGHT_V 4u
#define DIM_BSDF_U 5u
#define DIM_BSDF_V 6u
#define DIM_RR 7u
#define DIMS_PER_VERTEX 6u
// The extra next-event samples of --indirect-light-samples draw their three numbers from
// dimensions DIM_EXTRA_LIGHT + 64 · depth + 3 · (sample − 1) + 0…2 (at most 15 extra: 45 a
// vertex), and those of --first-light-samples N > 1 from DIM_EXTRA_LIGHT + 3 · sample + 0…2
// (all N: 48), apart from the others (100 vertices, the most --max-depth allows, use dimensions
// up to 100 · DIMS_PER_VERTEX + DIM_RR < 1024).
#define DIM_EXTRA_LIGHT 1024u

// Random number `dim` (DIM_LIGHT … DIM_BSDF_V) of vertex `depth`: stratified over the passes
// at the first vertex (rng.glsl first_vertex_sobol or first_vertex_r5) when the jitter is,
// independent elsewhere.
float vertex_rand(uint seed, uint pixel, uint s, uint depth, uint dim) {
    if (STRATIFY != STRATIFY_OFF && depth == 0u) {
        return STRATIFY == STRATIFY_SOBOL ? first_vertex_sobol(dim - DIM_LIGHT)
                                          : first_vertex_r5(s, dim - DIM_LIGHT);
    }
    return sample_rand(seed, pixel, s, depth * DIMS_PER_VERTEX + dim);
}

const float PI = 3.14159265358979;

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

#include "bsdf.glsl"

// --brdf-select: the BRDF of the shading point whose light is being chosen (or whose light
// pmf light_pmf repeats), seen from sel_v; sel_on only for glossy materials under the flag.
Bsdf sel_bsdf;
vec3 sel_v;
vec3 sel_r;  // the mirror direction of sel_v, once per vertex rather than once per slot
bool sel_on = false;

void select_brdf(Bsdf b, vec3 v, vec3 n, bool on) {
    sel_bsdf = b;
    sel_v = v;
    sel_r = reflect(-v, n);
    sel_on = on && !b.lambert;
}

// The luminance of f(v, l) for the direction l to the node's bounding sphere that is nearest
// the mirror direction (all of it from inside the sphere), plus a floor of 0.1 × albedo/π:
// a factor > 0, so every cluster that can light x keeps a chance (unbiased), that favours
// the clusters a glossy lobe points at. Depends on the shading point only.
float brdf_toward(GpuLightNode nd, vec3 p, vec3 n) {
    if (!sel_on) return 1.0;
    vec3 r = sel_r;
    vec3 to = nd.centre - p;
    float d2 = dot(to, to);
    float r2 = nd.radius * nd.radius;
    vec3 l = r;
    if (d2 > r2) {
        vec3 wc = to * inversesqrt(d2);
        float cos_b = sqrt(1.0 - r2 / d2);
        float c = dot(r, wc);
        if (c < cos_b) {
            vec3 perp = r - c * wc;
            float lp = length(perp);
            l = lp > 0.0 ? cos_b * wc + sqrt(r2 / d2) * (perp / lp) : wc;
        }
    }
    // Just above the surface if the nearest direction is below it.
    float ln = dot(l, n);
    if (ln < 0.01) l = normalize(l + (0.01 - ln) * n);
    return luminance(bsdf_eval(sel_bsdf, n, sel_v, l)) + 0.1 * sel_bsdf.albedo / PI;
}

// The power heuristic (β = 2) weight of a strategy with pdf a against one with pdf b.
float power_heuristic(float a, float b) {
    float a2 = a * a;
    float b2 = b * b;
    return a2 + b2 > 0.0 ? a2 / (a2 + b2) : 0.0;
}

// One path between vertices: what the next vertex needs of the ones before it. In the
// wavefront (WAVEFRONT) it waits in a queue between the dispatches of two bounces.
struct Path {
    uint pixel;
    vec3 origin;
    vec3 dir;
    vec3 beta;  // the path throughput
    vec3 L;
    float zero_samples;
    float light_samples;
    // The previous vertex, for the MIS weight of an emitter the BSDF ray from it hits.
    vec3 prev_x;
    vec3 prev_n;
    float prev_brdf;
    vec3 prev_wo;
    float prev_bsdf_pdf;
    // The cut and weight total of the previous vertex's light choice (light_pmf_of_cut).
    uint prev_cut;
    float prev_cut_total;
    float prev_cut_lambda;  // sel_lambda (--defensive)
    Bsdf prev_bsdf;  // only with --brdf-select (select_brdf at an emitter hit)
};

// --brdf-select changes a choice only at a glossy material (select_brdf): on a scene without
// one its BSDF need not wait in the queues (3 texels a path fewer each way).
const uint GLOSSY_BAYES_FLAGS = (SCENE_FLAGS & 1u) != 0u ? BAYES_FLAGS : 0u;
const bool BRDF_SELECT = (GLOSSY_BAYES_FLAGS & LEARN_BRDF_SELECT) != 0u;

// The sample index of the path being traced: params.sample_index + j for the j-th of the
// params.passes samples a direct-light invocation takes (main()).
uint sample_s;

// A path's first ray: the camera ray through a uniform point in the pixel (box filter;
// stratified over passes, or independent).
Path camera_path(uvec2 px) {
    Path st;
    st.pixel = px.y * params.width + px.x;
    uint s = sample_s;
    uint seed = params.seed;
    // The sample's Sobol' point, once for its jitter and its first vertex (rng.glsl).
    if (STRATIFY == STRATIFY_SOBOL) sobol_point(s, sobol_lo, sobol_hi);
    vec2 jitter = STRATIFY == STRATIFY_SOBOL ? pixel_jitter_sobol()
        : STRATIFY == STRATIFY_R2 ? pixel_jitter_r2(s)
        : vec2(sample_rand(seed, st.pixel, s, DIM_JITTER_X), sample_rand(seed, st.pixel, s, DIM_JITTER_Y));
    vec2 ndc = vec2((float(px.x) + jitter.x) / float(params.width) * 2.0 - 1.0,
                    1.0 - (float(px.y) + jitter.y) / float(params.height) * 2.0);
    st.dir = normalize(params.cam_w.xyz + ndc.x * params.cam_u.xyz + ndc.y * params.cam_v.xyz);
    st.origin = params.cam_pos.xyz;
    st.beta = vec3(1.0);
    st.L = vec3(0.0);
    st.zero_samples = 0.0;
    st.light_samples = 0.0;
    st.prev_x = vec3(0.0);
    st.prev_n = vec3(0.0);
    st.prev_brdf = 1.0;
    st.prev_wo = vec3(0.0);
    st.prev_bsdf_pdf = 0.0;
    st.prev_cut = 0u;
    st.prev_cut_total = 0.0;
    st.prev_cut_lambda = 0.0;
    st.prev_bsdf = Bsdf(vec3(0.0), 0.0, vec3(0.0), 0.0, 0.0, 0.0, 0.0, true);
    return st;
}

float max_abs(vec3 v) { return max3(abs(v)); }

// How far a ray starts off a surface at x (and stops short of an area light), as src/render/
// gpu_scene.rs `surface_epsilon` (the CPU tracers' copy): 1e-4 of x's own coordinates, and
// at least 1e-5 of the other magnitudes its rounding comes from (`far`: the ray's origin and
// length, which x = origin + t·dir rounds at ~1e-7 of, and the triangle's corners, which its
// intersection test does). One offset for the whole scene (1e-4 of its size) let a far-away
// object widen every offset: a dark wall 1e5 units beside a 1-unit box made the box's image
// +3.5 % (direct) and its indirect light vanish, with exit 0 (an audit, 2026-12-06).
float surface_eps(float local, float far) { return max(1e-4 * local, max(1e-5 * far, 1e-30)); }

#include "next_event.glsl"

// Vertex `depth` of a path: the surface its ray hits (the emitter there, with its MIS
// weight), then for depth < max_depth one next-event sample and the BSDF ray on. False when
// the path ends here. Vertices 0 … max_depth − 1 sample a light and the BSDF; the ray after
// the last one only looks for the emitter it hits (its MIS weight completes that vertex's
// light sample).
bool path_vertex(inout Path st, uint depth) {
    uint pixel = st.pixel;
    uint s = sample_s;
    uint seed = params.seed;
    const bool mis = params.max_depth > (DIRECT_ONLY ? 0xffffffffu : 1u);
    const bool brdf_select = BRDF_SELECT;
    float t;
    uint hit = trace_ray(st.origin, st.dir, 0.0, 3.0e38, false, t);
    if (hit == NO_HIT) return false;
    if ((KNOCK_OUT & KNOCK_SHADING) != 0u) {
        // The hit is used, so the compiler keeps the traversal.
        st.L += vec3(t);
        return false;
    }
    BvhTri tri = bvh_tri(hit);
    vec3 ng = normalize(cross(tri.e1, tri.e2));
    bool front = dot(ng, st.dir) < 0.0;
    GpuMaterial m = material_at(tri_material[tri.prim]);
    if ((front || (m.flags & MATERIAL_TWO_SIDED) != 0u) && any(greaterThan(m.emission, vec3(0.0)))) {
        float w = 1.0;
        uint li = tri_light[tri.prim];
        // Compiled out for direct light (depth is always 0 there): lavapipe runs an if's
        // body even where no lane takes it, and this one repeats the light choice's pmf.
        if (!DIRECT_ONLY && depth > 0u && li != NO_LIGHT) {
            // The light sampler's pdf of this point, in solid angle at prev_x.
            select_brdf(st.prev_bsdf, st.prev_wo, st.prev_n, brdf_select);
            float p_sel = (KNOCK_OUT & KNOCK_MIS_PMF) != 0u
                ? 1.0 / float(params.light_count)
                : light_pmf_of_cut(st.prev_cut, st.prev_cut_total, st.prev_cut_lambda, st.prev_x, st.prev_n, li, params.light_count, st.prev_brdf);
            vec3 to = st.origin + t * st.dir - st.prev_x;
            float cos_l = abs(dot(ng, st.dir));
            GpuLight hit_light = light_at(li);
            // The same point sampling as the light sample at prev_x took (lights.glsl).
            float sa_pdf = solid_angle_pdf(hit_light, st.prev_x);
            float p_light = sa_pdf > 0.0 ? p_sel * sa_pdf
                : cos_l > 0.0 ? p_sel * dot(to, to) / (hit_light.area * cos_l) : 0.0;
            // The vertex before took INDIRECT_LIGHT_SAMPLES light samples, the first
            // FIRST_LIGHT_SAMPLES.
            float n_light = float(depth >= 2u ? INDIRECT_LIGHT_SAMPLES : FIRST_LIGHT_SAMPLES);
            w = power_heuristic(st.prev_bsdf_pdf, n_light * p_light);
        }
        vec3 emitted = m.emission;
        if (SCENE_EMISSIVE_TEXTURED && m.emissive_texture != NO_TEXTURE) {
            emitted *= sample_texture(m.emissive_texture, triangle_uv(tri.prim, st.origin + t * st.dir, tri.v0, tri.e1, tri.e2));
        }
        st.L += st.beta * emitted * w;
    }
    if (depth == params.max_depth) return false;

    // Reflection is two-sided: shade the side the ray came from.
    vec3 n = front ? ng : -ng;
    vec3 x = st.origin + t * st.dir;
    // The surface's own side (rays leave by it); n becomes the shading normal of a smooth
    // triangle, turned to that side, unless it faces away from the ray (a grazing view of a
    // strongly bent normal: then the triangle's own shades, as a flat one would).
    vec3 n_geo = n;
    if (SCENE_SMOOTH) {
        vec3 ns = shading_normal(tri.prim, x, tri.v0, tri.e1, tri.e2);
        if (SCENE_NORMAL_MAPPED && m.normal_texture != NO_TEXTURE) {
            // The texture's normal in the frame of the front (the vertex normals', else the
            // winding's), turned whole to the side shaded: glTF reverses the normal of a
            // back face after the map, not the frame before it.
            vec3 base = ns == vec3(0.0) ? ng : ns;
            vec2 uv = triangle_uv(tri.prim, x, tri.v0, tri.e1, tri.e2);
            ns = mapped_normal(tri.prim, x, tri.v0, tri.e1, tri.e2, base, uv, m.normal_texture, m.normal_scale);
            ns = dot(base, n_geo) < 0.0 ? -ns : ns;
        } else {
            ns = dot(ns, n_geo) < 0.0 ? -ns : ns;
        }
        if (dot(ns, st.dir) < 0.0) n = ns;
    }
    // How far rays leave x: by x's scale and the rounding of x = origin + t·dir and of the
    // triangle's own intersection test (surface_eps).
    float eps = surface_eps(max_abs(x), max(max(max_abs(st.origin), t), max(max_abs(tri.v0), max(max_abs(tri.v0 + tri.e1), max_abs(tri.v0 + tri.e2)))));
    uint dim0 = depth * DIMS_PER_VERTEX;
    // glTF: base colour = factor × texture; roughness and metallic = factors × the
    // metallic-roughness texture's green and blue.
    if (SCENE_TEXTURED && (m.texture != NO_TEXTURE || m.metallic_roughness_texture != NO_TEXTURE)) {
        vec2 uv = triangle_uv(tri.prim, x, tri.v0, tri.e1, tri.e2);
        if (m.texture != NO_TEXTURE) m.base_color *= sample_texture(m.texture, uv);
        if (m.metallic_roughness_texture != NO_TEXTURE) {
            vec3 mr = sample_texture(m.metallic_roughness_texture, uv);
            m.roughness *= mr.g;
            m.metallic *= mr.b;
        }
    }
    vec3 wo = -st.dir;
    Bsdf bsdf = make_bsdf(m, m.base_color, n, wo);
    select_brdf(bsdf, wo, n, brdf_select);
    // --brdf-aware: the observation includes the BRDF towards the light as luminance; its
    // prior (and light_pmf) take the BRDF's albedo / π, the Lambertian f of equal albedo.
    const bool brdf_aware = (BAYES_FLAGS & LEARN_BRDF) != 0u;
    float brdf = brdf_aware ? bsdf.albedo / PI : 1.0;
    // Next-event samples at this vertex.
    uint n_light = depth >= 1u ? INDIRECT_LIGHT_SAMPLES : FIRST_LIGHT_SAMPLES;
    next_event(st, x, n, n_geo, eps, wo, bsdf, brdf, depth, 0u, n_light);
    if (DIRECTIONAL_COUNT > 0u) sun_light(st, x, n, n_geo, eps, wo, bsdf);
    // Compiled out at 1 (the default): a loop around the one sample cost paths 5-10 %.
    if (MULTI_LIGHT_SAMPLES) {
        uint rep = 1u;
        while (rep < n_light) {
            next_event(st, x, n, n_geo, eps, wo, bsdf, brdf, depth, rep, n_light);
            ++rep;
        }
    }

    if (!mis) return false;
    // The BSDF ray: also taken after the last vertex, to find the emitter it hits.
    vec2 ub = vec2(vertex_rand(seed, pixel, s, depth, DIM_BSDF_U), vertex_rand(seed, pixel, s, depth, DIM_BSDF_V));
    float bsdf_pdf_o;
    vec3 wn = bsdf_sample(bsdf, n, wo, ub, bsdf_pdf_o);
    float cos_o = dot(n, wn);
    if (cos_o <= 0.0 || !(bsdf_pdf_o > 0.0)) return false;
    // Under the surface itself (a shading normal's hemisphere reaches below it): the path
    // ends, as the light sample above refuses such directions.
    if (SCENE_SMOOTH && dot(n_geo, wn) <= 0.0) return false;
    // f cos / pdf (the albedo exactly for a Lambertian BRDF sampled by cos θ / π).
    st.beta *= bsdf.lambert ? bsdf.base : bsdf_eval(bsdf, n, wo, wn) * (cos_o / bsdf_pdf_o);
    // The light sample above was drawn at x itself: light_pmf must see the same point.
    st.prev_x = x;
    st.prev_n = n;
    st.prev_brdf = brdf;
    st.prev_bsdf = bsdf;
    st.prev_wo = wo;
    st.prev_bsdf_pdf = bsdf_pdf_o;
    st.prev_cut = sel_cut;
    st.prev_cut_total = sel_total;
    st.prev_cut_lambda = sel_lambda;
    st.origin = x + n_geo * eps;
    st.dir = wn;
    if (depth + 1u >= 3u) {
        float q = max(0.0, 1.0 - max(st.beta.x, max(st.beta.y, st.beta.z)));
        if (sample_rand(seed, pixel, s, dim0 + DIM_RR) < q) return false;
        st.beta /= 1.0 - q;
    }
    return any(greaterThan(st.beta, vec3(0.0)));
}

#include "path_queue.glsl"

// A finished path added to a pixel's sums: its sample, its square, and the light-sample
// counts. Returns 1 where the sample was NaN or infinite (then dropped, for counters[0]),
// else 0.
uint add_path(Path st, inout PixelAccum a) {
    bool bad = any(isnan(st.L)) || any(isinf(st.L));
    vec3 L = bad ? vec3(0.0) : st.L;
    a.sum += vec4(L, st.zero_samples);
    a.sum_sq += vec4(L * L, st.light_samples);
    return bad ? 1u : 0u;
}

// A pixel's sums in the film.
PixelAccum film_read(uint pixel) {
    return PixelAccum(uintBitsToFloat(texelFetch(accum_texels, int(2u * pixel))),
                      uintBitsToFloat(texelFetch(accum_texels, int(2u * pixel + 1u))));
}

void film_write(uint pixel, PixelAccum a) {
    imageStore(accum_image, int(2u * pixel), floatBitsToUint(a.sum));
    imageStore(accum_image, int(2u * pixel + 1u), floatBitsToUint(a.sum_sq));
}

// A finished path into the film.
void finish_path(Path st) {
    PixelAccum a = film_read(st.pixel);
    if (add_path(st, a) != 0u) atomicAdd(counters[0], 1u);
    film_write(st.pixel, a);
}

// WAVEFRONT (paths, max_depth ≥ 2): one dispatch per bounce. Bounce 0 starts the paths of
// rows row0 … of the film and takes their first vertex; bounce d ≥ 1 takes vertex d of the
// paths queued by bounce d − 1 (an indirect dispatch over the queue). A path that ends goes
// into the film at once. Lanes of a SIMD group then work on live paths only: in one loop
// over the vertices (direct light, and the preview's reduced film) a lane whose path ended
// waits for the longest of its group.
void main() {
    Path st;
    uint depth = 0u;
    sample_s = params.sample_index;
    if (WAVEFRONT) {
        if (params.bounce > 0u) {
            uint q = params.bounce & 1u;
            uint i = gl_WorkGroupID.x * 64u + gl_LocalInvocationIndex;
            if (i >= queue_head[4u * q + 3u]) return;
            st = load_path(q, i);
            depth = params.bounce;
        } else {
            uvec2 px = uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y + params.row0);
            if (px.x >= params.width || px.y >= params.height) return;
            set_pixel_keys(params.seed, px.y * params.width + px.x);
            st = camera_path(px);
        }
        if (path_vertex(st, depth)) {
            push_path(st);
            return;
        }
        finish_path(st);
        return;
    }
    // Direct light (and the preview's reduced film): params.passes samples of the pixel, one
    // after the other, each added to the film as its own pass would add it (the same sums in
    // the same order: the image is bit for bit that of one dispatch per pass). A dispatch
    // costs lavapipe ~0.4 ms whatever its size (docs/results.md). The learned samplers take
    // the passes of one learning window (their statistics frozen within it; --update-every):
    // against the loop compiled out for them, bayes on rooms16 and city (128×96, 256 spp,
    // four interleaved pairs) took 1.03× the time with windows of 1 (within the noise) and
    // 0.75–0.8× with windows of 4 (docs/results.md, 2026-12-03).
    // Row gl_LocalInvocationID.y of the workgroup takes one row of 8 pixels of the list the
    // host made: only rows that can see the scene (the rest would add exact zeros) in an
    // order that shares them evenly among lavapipe's threads (src/render/coverage.rs).
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint row = group * 8u + gl_LocalInvocationID.y;
    if (row >= live_count) return;
    uint code = live_row[row];
    uvec2 px = uvec2((code & 0xffffu) * 8u + gl_LocalInvocationID.x, code >> 16u);
    if (px.x >= params.width || px.y >= params.height) return;
    // Bottom-tested: llvmpipe (lavapipe) runs every loop body once more, with all lanes
    // masked off, when a top test fails (its loops only branch back at the end, and its ifs
    // never branch around a body), so a `for` over the passes cost a whole masked pass per
    // dispatch: a lone pass took 1.44× a batched one (`uniform`, cornell40 from
    // ci/bench_outside.py, 128×96, 256 spp: 0.49 against 0.34 s), 1.15× with this loop
    // (0.386 against 0.335 s). The same reason shapes the loops of bvh.glsl, light_tree.glsl,
    // regions.glsl and learning.glsl (docs/results.md, 2026-12-04, fifth session).
    // The pixel's sums stay in registers over the passes and go back to the film once, with
    // the dropped samples' count: the same additions in the same order as a read and a write
    // a pass (the same bits). lavapipe reads and writes a storage buffer word by word and
    // lane by lane: without those 32 bytes a sample `uniform` direct light takes 1.32× (rooms)
    // and 1.41× (city) the samples a second (ci/bench_mitsuba.py; docs/results.md, fourteenth
    // session).
    uint passes = max(params.passes, 1u);
    uint j = 0u;
    uint pixel = px.y * params.width + px.x;
    PixelAccum a = film_read(pixel);
    uint dropped = 0u;
    set_pixel_keys(params.seed, pixel);
    do {
        sample_s = params.sample_index + j;
        st = camera_path(px);
        for (depth = 0u; depth <= params.max_depth; ++depth) {
            if (!path_vertex(st, depth)) break;
        }
        dropped += add_path(st, a);
        ++j;
    } while (j < passes);
    film_write(pixel, a);
    if (dropped > 0u) atomicAdd(counters[0], dropped);
}
