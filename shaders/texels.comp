#version 460
#extension GL_GOOGLE_include_directive : require
// Reads every struct that kernels fetch as texels (bvh.glsl, light_tree.glsl,
// learned_texels.glsl, scene_texels.glsl) through its fetch function and writes it to a storage buffer of that
// struct: the GPU side of the test that the fetch functions rebuild the host's bytes exactly
// (tests/layout.rs), and the module whose storage blocks give these structs' explicit layout.
#include "types.glsl"

layout(local_size_x = 64) in;

#ifndef LAYOUT_ONLY
layout(set = 0, binding = 0) uniform usamplerBuffer bvh_node_texels;
layout(set = 0, binding = 1) uniform usamplerBuffer bvh_tri_texels;
layout(set = 0, binding = 2) uniform usamplerBuffer light_node_texels;
layout(set = 0, binding = 3) uniform usamplerBuffer slot_stat_texels;
layout(set = 0, binding = 4) uniform usamplerBuffer cut_texels;
layout(set = 0, binding = 5) uniform usamplerBuffer region_index_texels;
layout(set = 0, binding = 12) uniform usamplerBuffer light_texels;
layout(set = 0, binding = 13) uniform usamplerBuffer material_texels;
layout(set = 0, binding = 14) uniform usamplerBuffer grid_texels;
#define OUT writeonly
#else
// naga 30 (tests/layout.rs naga_agrees_with_our_reader) reads no texel buffers: for it the
// module is compiled with LAYOUT_ONLY, the output blocks alone.
#define OUT
#endif
layout(std430, set = 0, binding = 6) OUT buffer NodesOut { BvhNode nodes_out[]; };
layout(std430, set = 0, binding = 7) OUT buffer TrisOut { BvhTri tris_out[]; };
layout(std430, set = 0, binding = 8) OUT buffer LightNodesOut { GpuLightNode light_nodes_out[]; };
layout(std430, set = 0, binding = 9) OUT buffer StatsOut { SlotStats stats_out[]; };
layout(std430, set = 0, binding = 10) OUT buffer WordsOut { uvec2 words_out[]; };
// How many of each to copy: nodes, triangles, light nodes, slots, words (cut and index),
// lights, materials (and the one grid).
layout(push_constant) uniform Push { uint counts[7]; };
// light_tree.glsl needs it declared; nothing here reads it.
layout(std430, set = 0, binding = 11) readonly buffer LightOrder { uint light_order[]; };
layout(std430, set = 0, binding = 15) OUT buffer LightsOut { GpuLight lights_out[]; };
layout(std430, set = 0, binding = 16) OUT buffer MaterialsOut { GpuMaterial materials_out[]; };
layout(std430, set = 0, binding = 17) OUT buffer GridOut { GridParams grid_out[]; };
#ifndef LAYOUT_ONLY


#include "bvh.glsl"
#include "light_tree.glsl"
#include "learned_texels.glsl"
#include "scene_texels.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < counts[0]) nodes_out[i] = bvh_node(i);
    if (i < counts[1]) tris_out[i] = bvh_tri(i);
    if (i < counts[2]) light_nodes_out[i] = light_node(i);
    if (i < counts[3]) stats_out[i] = slot_stats_at(i);
    if (i < counts[4]) words_out[i] = uvec2(cut_word(i), region_index_at(i));
    if (i < counts[5]) lights_out[i] = light_at(i);
    if (i < counts[6]) materials_out[i] = material_at(i);
    if (i == 0u) grid_out[0] = grid_params();
}
#else
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counts[0]) return;
    nodes_out[i] = nodes_out[i + 1u];
    tris_out[i] = tris_out[i + 1u];
    light_nodes_out[i] = light_nodes_out[i + 1u];
    stats_out[i] = stats_out[i + 1u];
    words_out[i] = words_out[i + 1u];
    lights_out[i] = lights_out[i + 1u];
    materials_out[i] = materials_out[i + 1u];
    grid_out[i] = grid_out[i + 1u];
}
#endif
