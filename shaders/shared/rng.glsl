// Random numbers as a pure function of (seed, pixel, sample, dimension); mirror of src/rng.rs.
#ifndef RNG_GLSL
#define RNG_GLSL

uint hash32(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

float sample_rand(uint seed, uint pixel, uint sample_index, uint dim) {
    uint h = hash32(seed ^ hash32(pixel ^ hash32((sample_index * 0x9e3779b9u) ^ hash32(dim))));
    return float(h >> 8) * (1.0 / 16777216.0);
}

// A pixel's keys for its jitter (x, then y from x's) and for number k of its first vertex:
// the rotations of R2 and R5 and the scrambles of Sobol' (src/rng.rs has the same).
uvec2 jitter_keys(uint seed, uint pixel) {
    uint kx = hash32(seed ^ hash32(pixel ^ 0x68bc21ebu));
    return uvec2(kx, hash32(kx ^ 0x02e5be93u));
}

uint vertex_key(uint seed, uint pixel, uint k) {
    return hash32(seed ^ hash32(pixel ^ hash32(k ^ 0xa511e9b3u)));
}

// The keys of the pixel being traced (set_pixel_keys): a pixel's samples share them, so an
// invocation hashes them once, not once a sample (a direct-light dispatch takes many).
uvec2 px_jitter_key = uvec2(0u);
uint px_vertex_key[5] = uint[5](0u, 0u, 0u, 0u, 0u);

void set_pixel_keys(uint seed, uint pixel) {
    px_jitter_key = jitter_keys(seed, pixel);
    for (uint k = 0u; k < 5u; ++k) px_vertex_key[k] = vertex_key(seed, pixel, k);
}

// The point in the pixel of sample s, stratified over the passes: the R2 sequence (Roberts
// 2018, the plastic-number Kronecker lattice) in 32-bit fixed point, so it stays exact for
// any sample count, shifted per pixel by a random offset (Cranley–Patterson rotation: each
// sample is still uniform over the pixel, so the estimate stays unbiased). Edge pixels of
// visible emitters converge far faster than with independent jitter; measured on rooms16,
// 128×96, 256 spp: pixels with ref > 1 held 50–70 % of every sampler's squared error.
vec2 pixel_jitter_r2(uint s) {
    uvec2 o = px_jitter_key;
    uint x = s * 3242174889u + o.x;  // round(0.7548776662 · 2^32)
    uint y = s * 2447445414u + o.y;  // round(0.5698402910 · 2^32)
    return vec2(float(x >> 8), float(y >> 8)) * (1.0 / 16777216.0);
}

// Number k (0 … 4: light choice, point on the light u and v, BSDF direction u and v) of the
// first vertex of sample s, stratified over the passes like the jitter: the R5 sequence
// (Roberts 2018: steps 1/φ^1 … 1/φ^5 with φ the root of x^6 = x + 1, a Kronecker lattice
// that stays low-discrepancy in all five dimensions) in 32-bit fixed point, rotated per pixel
// and dimension (Cranley–Patterson: each number is still uniform, so each sample stays
// unbiased). A pixel's samples then split between the lights (and points on them) close to
// their probabilities instead of by chance: rooms16, direct light, 256 spp, `wang` 6.7×
// and `bayes` 2.0× less variance (docs/results.md, 2026-12-04). Later vertices keep
// independent numbers: the R10 sequence over the first two vertices gained ≤ 5 % with
// paths and cost direct light 26 % (`wang`).
const uint R5_STEP[5] = uint[5](3785032107u, 3335640777u, 2939605023u, 2590590015u, 2283013049u);

float first_vertex_r5(uint s, uint k) {
    uint o = px_vertex_key[k];
    return float((s * R5_STEP[k] + o) >> 8) * (1.0 / 16777216.0);
}

// --stratify sobol (the default): the pixel jitter and the first vertex's five numbers as
// dimensions 0–1 and 2–6 of the Sobol' sequence (Joe & Kuo 2008 direction numbers), each
// Owen-scrambled per pixel and dimension by Burley's hash (2020, "Practical hash-based Owen
// scrambling"; the kind of sampler pbrt-v4 and Cycles default to). Every number stays uniform
// (unbiased), and the first 2^m samples of a pixel are a (0, m, 2)-net in the jitter and
// (3, m, 2)-nets in the point on the light and in the BSDF direction (t ≤ 2 up to 256 samples;
// src/rng.rs tests): edge pixels of visible emitters converge faster than with R2 (rooms16,
// direct light, 256 spp: `wang` 1.8×, `bayes` 1.6× less variance in the same time within the
// noise; docs/results.md, eighth session). Mirror of src/rng.rs.

// The next direction number of a Sobol' dimension of degree deg and coefficients a from the
// window r of its last four (v[b-1], v[b-2], v[b-3], v[b-4]), which it shifts (Joe & Kuo
// 2008's recurrence).
uint sobol_next(inout uvec4 r, uint deg, uint a) {
    uint vs = r[deg - 1u];
    uint v = vs ^ (vs >> deg);
    for (uint k = 1u; k < deg; ++k) {
        if (((a >> (deg - 1u - k)) & 1u) != 0u) v ^= r[k - 1u];
    }
    r = uvec4(v, r.xyz);
    return v;
}

// Dimensions 0–6 of the unscrambled Sobol' point i (lo: 0–3, hi: 4–6): the XOR of the
// direction numbers of its set bits (Joe & Kuo 2008, new-joe-kuo-6.21201). Bits 0–15 with the
// numbers as constants, bits 16–31 (a pixel's 65537th sample on) by the recurrence from the
// numbers of bits 12–15; src/rng.rs checks both against its `sobol_dim`, and that against
// scipy's Sobol' points. i is the pass index, the same in every lane. A table indexed per lane
// made a pass 5× slower on lavapipe, and the recurrence for every bit 15 % slower (city,
// `wang`, direct light); with these constants a direct pass costs about what R2's did
// (docs/results.md, eighth session).
void sobol_point(uint i, out uvec4 lo, out uvec4 hi) {
    lo = uvec4(bitfieldReverse(i), 0u, 0u, 0u);
    hi = uvec4(0u);
    uint bit;
    bit = (i >> 0u) & 1u;
    lo.yzw ^= bit * uvec3(0x80000000u, 0x80000000u, 0x80000000u);
    hi.xyz ^= bit * uvec3(0x80000000u, 0x80000000u, 0x80000000u);
    bit = (i >> 1u) & 1u;
    lo.yzw ^= bit * uvec3(0xc0000000u, 0xc0000000u, 0xc0000000u);
    hi.xyz ^= bit * uvec3(0x40000000u, 0x40000000u, 0xc0000000u);
    bit = (i >> 2u) & 1u;
    lo.yzw ^= bit * uvec3(0xa0000000u, 0x60000000u, 0x20000000u);
    hi.xyz ^= bit * uvec3(0x20000000u, 0x60000000u, 0xa0000000u);
    bit = (i >> 3u) & 1u;
    lo.yzw ^= bit * uvec3(0xf0000000u, 0x90000000u, 0x50000000u);
    hi.xyz ^= bit * uvec3(0xb0000000u, 0x30000000u, 0xd0000000u);
    bit = (i >> 4u) & 1u;
    lo.yzw ^= bit * uvec3(0x88000000u, 0xe8000000u, 0xf8000000u);
    hi.xyz ^= bit * uvec3(0xf8000000u, 0xc8000000u, 0x58000000u);
    bit = (i >> 5u) & 1u;
    lo.yzw ^= bit * uvec3(0xcc000000u, 0x5c000000u, 0x74000000u);
    hi.xyz ^= bit * uvec3(0xdc000000u, 0x24000000u, 0x94000000u);
    bit = (i >> 6u) & 1u;
    lo.yzw ^= bit * uvec3(0xaa000000u, 0x8e000000u, 0xa2000000u);
    hi.xyz ^= bit * uvec3(0x7a000000u, 0x56000000u, 0x3e000000u);
    bit = (i >> 7u) & 1u;
    lo.yzw ^= bit * uvec3(0xff000000u, 0xc5000000u, 0x93000000u);
    hi.xyz ^= bit * uvec3(0x9d000000u, 0xfb000000u, 0xe3000000u);
    bit = (i >> 8u) & 1u;
    lo.yzw ^= bit * uvec3(0x80800000u, 0x68800000u, 0xd8800000u);
    hi.xyz ^= bit * uvec3(0x5a800000u, 0xe0800000u, 0xbe800000u);
    bit = (i >> 9u) & 1u;
    lo.yzw ^= bit * uvec3(0xc0c00000u, 0x9cc00000u, 0x25400000u);
    hi.xyz ^= bit * uvec3(0x2fc00000u, 0x70400000u, 0x23c00000u);
    bit = (i >> 10u) & 1u;
    lo.yzw ^= bit * uvec3(0xa0a00000u, 0xee600000u, 0x59e00000u);
    hi.xyz ^= bit * uvec3(0xa1600000u, 0xa8600000u, 0x1e200000u);
    bit = (i >> 11u) & 1u;
    lo.yzw ^= bit * uvec3(0xf0f00000u, 0x55900000u, 0xe6d00000u);
    hi.xyz ^= bit * uvec3(0xf0b00000u, 0x14300000u, 0xf3100000u);
    bit = (i >> 12u) & 1u;
    lo.yzw ^= bit * uvec3(0x88880000u, 0x80680000u, 0x78080000u);
    hi.xyz ^= bit * uvec3(0xda880000u, 0x9ec80000u, 0x46780000u);
    bit = (i >> 13u) & 1u;
    lo.yzw ^= bit * uvec3(0xcccc0000u, 0xc09c0000u, 0xb40c0000u);
    hi.xyz ^= bit * uvec3(0x6fc40000u, 0xdf240000u, 0x67840000u);
    bit = (i >> 14u) & 1u;
    lo.yzw ^= bit * uvec3(0xaaaa0000u, 0x60ee0000u, 0x82020000u);
    hi.xyz ^= bit * uvec3(0x81620000u, 0xb6d60000u, 0x78460000u);
    bit = (i >> 15u) & 1u;
    lo.yzw ^= bit * uvec3(0xffff0000u, 0x90550000u, 0xc3050000u);
    hi.xyz ^= bit * uvec3(0x40bb0000u, 0x8bbb0000u, 0x84670000u);
    if (i >= 65536u) {
        uvec4 r1 = uvec4(0xffff0000u, 0xaaaa0000u, 0xcccc0000u, 0x88880000u);
        uvec4 r2 = uvec4(0x90550000u, 0x60ee0000u, 0xc09c0000u, 0x80680000u);
        uvec4 r3 = uvec4(0xc3050000u, 0x82020000u, 0xb40c0000u, 0x78080000u);
        uvec4 r4 = uvec4(0x40bb0000u, 0x81620000u, 0x6fc40000u, 0xda880000u);
        uvec4 r5 = uvec4(0x8bbb0000u, 0xb6d60000u, 0xdf240000u, 0x9ec80000u);
        uvec4 r6 = uvec4(0x84670000u, 0x78460000u, 0x67840000u, 0x46780000u);
        uint b = 16u;
        do {
            uvec3 v = uvec3(sobol_next(r1, 1u, 0u), sobol_next(r2, 2u, 1u), sobol_next(r3, 3u, 1u));
            uvec3 w = uvec3(sobol_next(r4, 3u, 2u), sobol_next(r5, 4u, 1u), sobol_next(r6, 4u, 4u));
            bit = (i >> b) & 1u;
            lo.yzw ^= bit * v;
            hi.xyz ^= bit * w;
            ++b;
        } while (b < 32u && (i >> b) != 0u);
    }
}

// A nested uniform (Owen) scramble of the bits of x, most significant first, keyed by seed:
// Laine–Karras's permutation on the reversed bits (Burley 2020).
uint owen_scramble(uint x, uint seed) {
    x = bitfieldReverse(x);
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return bitfieldReverse(x);
}

float owen_float(uint x, uint seed) {
    return float(owen_scramble(x, seed) >> 8) * (1.0 / 16777216.0);
}

// The unscrambled point of the sample being traced (render.comp sets it with sample_s, once
// per sample: every lane of a pass shares it).
uvec4 sobol_lo;
uvec4 sobol_hi;

// The point in the pixel of the current sample (dimensions 0 and 1).
vec2 pixel_jitter_sobol() {
    uvec2 k = px_jitter_key;
    return vec2(owen_float(sobol_lo.x, k.x), owen_float(sobol_lo.y, k.y));
}

// Number k (0 … 4, as first_vertex_r5) of the first vertex of the current sample: dimension
// 2 + k (the point on the light 3, 4 and the BSDF direction 5, 6: up to 256 samples no pair of
// dimensions 2–6 has t < 2).
float first_vertex_sobol(uint k) {
    uint x = k == 0u ? sobol_lo.z : (k == 1u ? sobol_lo.w : (k == 2u ? sobol_hi.x : (k == 3u ? sobol_hi.y : sobol_hi.z)));
    return owen_float(x, px_vertex_key[k]);
}

#endif
