#version 460
#extension GL_GOOGLE_include_directive : require
// Traces a batch of rays through the BVH: the kernel behind the GPU-vs-CPU BVH test and the
// ray-throughput benchmark. Closest hit, or any hit for shadow-ray timing.
#include "types.glsl"

layout(local_size_x = 64) in;

// The BVH as texels (bvh.glsl).
layout(set = 0, binding = 0) uniform usamplerBuffer bvh_node_texels;
layout(set = 0, binding = 1) uniform usamplerBuffer bvh_tri_texels;
layout(std430, set = 0, binding = 2) readonly buffer Rays { GpuRay rays[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Hits { GpuHit hits[]; };

layout(push_constant) uniform Push { TraceParams params; };

#include "bvh.glsl"

void main() {
    // Rows of workgroups (src/accel/gpu_trace.rs: at most 8192 a row).
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u + gl_GlobalInvocationID.x;
    if (i >= params.ray_count) return;
    GpuRay r = rays[i];
    float t;
    uint slot = trace_ray(r.origin, r.dir, r.tmin, r.tmax, params.any_hit != 0u, t);
    GpuHit h;
    h.t = t;
    h.prim = slot == NO_HIT ? NO_HIT : bvh_tri(slot).prim;
    hits[i] = h;
}
