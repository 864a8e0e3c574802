// The learned state as the render kernels read it: the region grid, the region index, the
// cuts and the statistics, each a uniform texel buffer (src/gpu/buffer.rs Buffer::texels and
// Buffer::words say why). The including kernel declares `grid_texels` (RGBA32UI),
// `region_index_texels`, `cut_texels` (R32UI) and `slot_stat_texels` (RGBA32UI).
#ifndef LEARNED_TEXELS_GLSL
#define LEARNED_TEXELS_GLSL

#include "types.glsl"

// The region grid: two texels, as GridParams.
GridParams grid_params() {
    uvec4 a = texelFetch(grid_texels, 0);
    uvec4 b = texelFetch(grid_texels, 1);
    GridParams g;
    g.lo = uintBitsToFloat(a.xyz);
    g.cell = uintBitsToFloat(a.w);
    g.dims = b.xyz;
    g.bins = b.w;
    return g;
}

// Word i of the cuts (a cut: its length, then its nodes) and of the region index.
uint cut_word(uint i) { return texelFetch(cut_texels, int(i)).x; }
uint region_index_at(uint r) { return texelFetch(region_index_texels, int(r)).x; }

// Slot i's totals and coefficients: two texels, in the order of
// SlotStats's members (round trip: tests/layout.rs). fold.comp writes the same buffer as a
// storage buffer between passes.
SlotStats slot_stats_at(uint i) {
    uvec4 a = texelFetch(slot_stat_texels, int(2u * i));
    uvec4 b = texelFetch(slot_stat_texels, int(2u * i + 1u));
    SlotStats s;
    s.n_zero = uintBitsToFloat(a.x);
    s.n_nonzero = uintBitsToFloat(a.y);
    s.sum = uintBitsToFloat(a.z);
    s.sum_sq = uintBitsToFloat(a.w);
    s.scale = uintBitsToFloat(b.x);
    s.coef_a = uintBitsToFloat(b.y);
    s.coef_b = uintBitsToFloat(b.z);
    s.coef_c = uintBitsToFloat(b.w);
    return s;
}

#endif
