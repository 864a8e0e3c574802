// Host/shader shared structs. Mirror of src/abi.rs, field for field and by name;
// tests/layout.rs checks offsets and sizes in the compiled SPIR-V.
#ifndef TYPES_GLSL
#define TYPES_GLSL

#define BVH_LEAF_BIT 0x80000000u
#define BVH_LEAF_COUNT_SHIFT 23u
#define BVH_LEAF_FIRST_MASK 0x7fffffu
// Entries of the traversal's stack of siblings to visit (bvh.glsl); the builder caps the
// depth so it cannot overflow (src/accel/bvh.rs STACK_SIZE says why 32 is enough).
#define BVH_STACK_SIZE 32u

// The light samplers (src/render/mod.rs LightSampler::shader_id).
#define SAMPLER_UNIFORM 0u
#define SAMPLER_POWER 1u
#define SAMPLER_LIGHTBVH 2u
#define SAMPLER_WANG 3u
#define SAMPLER_DONIKIAN 4u
#define SAMPLER_BAYES 5u

// The children's boxes plane by plane, then their references (src/abi.rs BvhNode).
struct BvhNode {
    vec4 lo_x;
    vec4 lo_y;
    vec4 lo_z;
    vec4 hi_x;
    vec4 hi_y;
    vec4 hi_z;
    uvec4 refs;
};

struct BvhTri {
    vec3 v0; uint prim;
    vec3 e1; uint pad0;
    vec3 e2; uint pad1;
};

#define LIGHT_POINT 0u
#define LIGHT_SPOT 1u
#define LIGHT_TRIANGLE 2u
// A directional light, after the sampled lights (next_event.glsl sun_light).
#define LIGHT_DIRECTIONAL 3u
#define LIGHT_TWO_SIDED 0x100u
// A triangle light with an emissive texture: its cos_outer and cos_inner words hold the
// triangle's and the texture's index (scene_texels.glsl light_texture_words).
#define LIGHT_TEXTURED 0x200u

struct GpuLight {
    vec3 p0; uint kind;
    vec3 p1; float cos_outer;
    vec3 p2; float cos_inner;
    vec3 radiance; float area;
};

struct AliasEntry {
    float q; uint alias; float pmf; uint pad;
};

#define LIGHT_NODE_TWO_SIDED 1u
#define LIGHT_NODE_AREA 2u

// A light-tree node with its box as centre and bounding-sphere radius and its cone's sine
// precomputed (GpuLightNode in src/abi.rs, made by bounds.rs `gpu_node`).
struct GpuLightNode {
    vec3 centre; float phi;
    vec3 axis; float cos_o;
    float radius; float sin_o; float cos_e; uint flags;
    uint right;
    uint begin;
    uint count;
    uint pad;
};

struct LightQuery {
    vec3 p; float u;
    vec3 n; uint light;
};

struct LightChoice {
    uint light;
    float pmf;
    float cv_total;
    float cv_chosen;
    float pmf_again;
    float pmf_query;
};

struct GridParams {
    vec3 lo; float cell;
    uvec3 dims; uint bins;
};

// Learned statistics of one (region, cut slot), parallel to the `cuts` array: totals of the
// observations y (counts of zero and non-zero ones, Σy, Σy²) folded in so far, frozen during a
// pass, the scale of the window's fixed-point sums, and the bayes weight's coefficients
// (weight² = scale² (a t² + b t + c), t = prior mean / scale; see fold.comp).
struct SlotStats {
    float n_zero; float n_nonzero; float sum; float sum_sq;
    float scale; float coef_a; float coef_b; float coef_c;
};

// Observations of the current window, summed by atomics in 64-bit fixed point (lo, hi words):
// integer sums do not depend on the order of the adds, so renders are bit-identical.
struct SlotDelta {
    uint n_zero; uint n_nonzero;
    uint sum_lo; uint sum_hi;
    uint sq_lo; uint sq_hi;
    // 1 once the slot is in the window's list of touched slots (render.comp mark_touched),
    // until the fold that clears the window.
    uint touched; uint pad1;
};

#define LEARN_REGRESSION 1u
#define LEARN_TARGET_MEAN 2u
#define LEARN_PRIORS 4u
#define LEARN_BRDF 8u
#define LEARN_CONTROL_VARIATES 16u
#define LEARN_BRDF_SELECT 32u
#define LEARN_REGRESS_IMPORTANCE 64u
#define LEARN_DEFENSIVE 128u
#define LEARN_REFINE 256u

// Hyperparameters and switches of the learned samplers (src/learning/mod.rs LearnSettings).
struct LearnParams {
    float prior_zero; float prior_nonzero; float prior_n; float prior_alpha;
    float prior_cv; float lambda; uint flags; float prior_scale;
    float defensive;
};

#define MATERIAL_TWO_SIDED 1u
#define MATERIAL_ALPHA_MASK 2u

#define NO_TEXTURE 0xffffffffu

struct GpuMaterial {
    vec3 base_color; uint flags;
    vec3 emission; uint texture;
    vec3 specular_color; float specular;
    float metallic; float roughness; uint emissive_texture; uint metallic_roughness_texture;
    uint normal_texture; float normal_scale; float alpha_cutoff; float alpha;
};

struct GpuTexture {
    uint offset; uint width; uint height; uint wrap;
};
// GpuTexture.wrap flags above wrapS (bits 0-7) and wrapT (bits 8-15).
#define TEXTURE_NEAREST 65536u
#define TEXTURE_16_BIT 131072u
#define TEXTURE_LINEAR 262144u

// RenderParams.stratified: independent numbers, R2/R5 (rng.glsl) or Owen-scrambled Sobol'.
#define STRATIFY_OFF 0u
#define STRATIFY_R2 1u
#define STRATIFY_SOBOL 2u

struct RenderParams {
    vec4 cam_pos;
    vec4 cam_u;
    vec4 cam_v;
    vec4 cam_w;
    uint width;
    uint height;
    uint sample_index;
    uint seed;
    uint light_count;
    float ray_eps;
    uint max_depth;
    uint bounce;     // the wavefront's bounce (render.comp WAVEFRONT), 0 otherwise
    uint row0;       // the first film row of a dispatch that starts paths
    uint queue_cap;  // paths per queue (render.comp set 3)
    uint passes;     // direct light, samplers that do not learn: samples per pixel of this dispatch
};

struct GpuRay {
    vec3 origin; float tmin;
    vec3 dir; float tmax;
};

struct GpuHit {
    float t; uint prim;
};

struct TraceParams {
    uint ray_count;
    uint any_hit;
    uint pad0;
    uint pad1;
};

struct PixelAccum {
    vec4 sum;
    vec4 sum_sq;
};

#endif
