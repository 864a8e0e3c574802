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

// The point in the pixel of sample s, stratified over the passes: the R2 sequence (Roberts
// 2018, the plastic-number Kronecker lattice) in 32-bit fixed point, so it stays exact for
// any sample count, shifted per pixel by a random offset (Cranley–Patterson rotation: each
// sample is still uniform over the pixel, so the estimate stays unbiased). Edge pixels of
// visible emitters converge far faster than with independent jitter; measured on rooms16,
// 128×96, 256 spp: pixels with ref > 1 held 50–70 % of every sampler's squared error.
vec2 pixel_jitter_r2(uint seed, uint pixel, uint s) {
    uint ox = hash32(seed ^ hash32(pixel ^ 0x68bc21ebu));
    uint oy = hash32(ox ^ 0x02e5be93u);
    uint x = s * 3242174889u + ox;  // round(0.7548776662 · 2^32)
    uint y = s * 2447445414u + oy;  // round(0.5698402910 · 2^32)
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

float first_vertex_r5(uint seed, uint pixel, uint s, uint k) {
    uint o = hash32(seed ^ hash32(pixel ^ hash32(k ^ 0xa511e9b3u)));
    return float((s * R5_STEP[k] + o) >> 8) * (1.0 / 16777216.0);
}

#endif
