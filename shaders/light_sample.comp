#version 460
#extension GL_GOOGLE_include_directive : require
// Runs a light-tree sampler (SAMPLER: 2 lightbvh, 3 wang) for a batch of (p, n, u) queries:
// the GPU side of the tests that GPU and CPU pick the same light with the same pmf
// (tests/light_tree.rs, tests/regions.rs).
#include "types.glsl"

layout(local_size_x = 64) in;

layout(constant_id = 0) const uint SAMPLER = 2u;

layout(std430, set = 0, binding = 0) readonly buffer Nodes { LightNode light_nodes[]; };
layout(std430, set = 0, binding = 1) readonly buffer Order { uint light_order[]; };
layout(std430, set = 0, binding = 2) readonly buffer Queries { LightQuery queries[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Choices { LightChoice choices[]; };
layout(std430, set = 0, binding = 4) readonly buffer Grid { GridParams grid[]; };
layout(std430, set = 0, binding = 5) readonly buffer RegionIndex { uint region_index[]; };
layout(std430, set = 0, binding = 6) readonly buffer Cuts { uint cuts[]; };

layout(push_constant) uniform Push { uint query_count; };

#include "regions.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= query_count) return;
    LightQuery q = queries[i];
    LightChoice c;
    c.light = SAMPLER == SAMPLER_WANG ? sample_wang(q.p, q.n, q.u, c.pmf)
                                      : sample_light_tree(q.p, q.n, q.u, c.pmf);
    if (c.light == NO_LIGHT) c.pmf = 0.0;
    choices[i] = c;
}
