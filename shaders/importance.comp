#version 460
#extension GL_GOOGLE_include_directive : require
// Evaluates the light-tree importance for node i at query i: the GPU side of the test that
// the GLSL and Rust importance functions agree on random inputs (tests/importance.rs).
#include "types.glsl"

layout(local_size_x = 64) in;

// The light tree as texels (light_tree.glsl light_node).
layout(set = 0, binding = 0) uniform usamplerBuffer light_node_texels;
layout(std430, set = 0, binding = 1) readonly buffer Order { uint light_order[]; };
layout(std430, set = 0, binding = 2) readonly buffer Queries { LightQuery queries[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Values { float values[]; };

layout(push_constant) uniform Push { uint query_count; };

#include "light_tree.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= query_count) return;
    values[i] = light_importance(light_node(i), queries[i].p, queries[i].n);
}
