#version 460
#extension GL_GOOGLE_include_directive : require
// Evaluates and samples the material BRDF (bsdf.glsl) for a batch of queries: the GPU side of
// tests/bsdf.rs (sampling density = bsdf_pdf, energy conservation, reciprocity, the glTF
// formula). Not used for rendering.
#include "types.glsl"

layout(local_size_x = 64) in;

struct BsdfQuery {
    vec3 n; float u0;
    vec3 v; float u1;
    vec3 l; float pad;
    GpuMaterial material;
};

struct BsdfResult {
    vec3 f; float pdf;            // f(v, l) and bsdf_pdf(v, l)
    vec3 sampled; float sampled_pdf;  // bsdf_sample(v, (u0, u1)) and the pdf it returned
    vec3 weight; float p_spec;    // f(v, sampled) cos / pdf (0 where the sample failed)
};

layout(std430, set = 0, binding = 0) readonly buffer Queries { BsdfQuery queries[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Results { BsdfResult results[]; };
#ifndef LAYOUT_ONLY
layout(set = 0, binding = 2) uniform usamplerBuffer layer_albedo_texels;
#endif

layout(push_constant) uniform Push { uint query_count; };

const float PI = 3.14159265358979;
float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

#include "bsdf.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= query_count) return;
    BsdfQuery q = queries[i];
    Bsdf b = make_bsdf(q.material, q.material.base_color, q.n, q.v);
    BsdfResult r;
    r.f = bsdf_eval(b, q.n, q.v, q.l);
    r.pdf = bsdf_pdf(b, q.n, q.v, q.l);
    float pdf;
    vec3 l = bsdf_sample(b, q.n, q.v, vec2(q.u0, q.u1), pdf);
    r.sampled = l;
    r.sampled_pdf = pdf;
    float c = dot(q.n, l);
    r.weight = pdf > 0.0 && c > 0.0 ? bsdf_eval(b, q.n, q.v, l) * (c / pdf) : vec3(0.0);
    r.p_spec = b.p_spec;
    results[i] = r;
}
