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

#endif
