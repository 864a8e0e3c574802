// Host/shader shared structs. Mirror of src/gpu/layout.rs, field for field and by name;
// tests/layout.rs checks offsets and sizes in the compiled SPIR-V.
#ifndef TYPES_GLSL
#define TYPES_GLSL

#define BVH_LEAF_BIT 0x80000000u

// The light samplers (src/render/mod.rs LightSampler::shader_id).
#define SAMPLER_UNIFORM 0u
#define SAMPLER_POWER 1u
#define SAMPLER_LIGHTBVH 2u
#define SAMPLER_WANG 3u

struct BvhNode {
    vec3 a_min; uint a_ref;
    vec3 a_max; uint a_count;
    vec3 b_min; uint b_ref;
    vec3 b_max; uint b_count;
};

struct BvhTri {
    vec3 v0; uint prim;
    vec3 e1; uint pad0;
    vec3 e2; uint pad1;
};

#define LIGHT_POINT 0u
#define LIGHT_SPOT 1u
#define LIGHT_TRIANGLE 2u
#define LIGHT_TWO_SIDED 0x100u

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

struct LightNode {
    vec3 bmin; float phi;
    vec3 bmax; float cos_o;
    vec3 axis; float cos_e;
    uint right;
    uint begin;
    uint count;
    uint flags;
};

struct LightQuery {
    vec3 p; float u;
    vec3 n; uint pad;
};

struct LightChoice {
    uint light;
    float pmf;
};

struct GridParams {
    vec3 lo; float cell;
    uvec3 dims; uint bins;
};

#define MATERIAL_TWO_SIDED 1u

struct GpuMaterial {
    vec3 base_color; uint flags;
    vec3 emission; uint pad;
};

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
    uint pad0;
    uint pad1;
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
