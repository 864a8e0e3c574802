#version 460
#extension GL_GOOGLE_include_directive : require
// Runs the `lightbvh` descent for a batch of (p, n, u) queries: the GPU side of the test that
// GPU and CPU light trees pick the same light with the same pmf (tests/light_tree.rs).
#include "types.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Nodes { LightNode light_nodes[]; };
layout(std430, set = 0, binding = 1) readonly buffer Order { uint light_order[]; };
layout(std430, set = 0, binding = 2) readonly buffer Queries { LightQuery queries[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Choices { LightChoice choices[]; };

layout(push_constant) uniform Push { uint query_count; };

#include "light_tree.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= query_count) return;
    LightQuery q = queries[i];
    LightChoice c;
    c.light = sample_light_tree(q.p, q.n, q.u, c.pmf);
    if (c.light == NO_LIGHT) c.pmf = 0.0;
    choices[i] = c;
}
