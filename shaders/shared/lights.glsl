// Light selection (uniform, power) and light evaluation. The including kernel declares
// `alias_table` (AliasEntry[]) and the SAMPLER constant.
#ifndef LIGHTS_GLSL
#define LIGHTS_GLSL

#include "types.glsl"


// Picks a light with one uniform number u; returns its index and selection pmf.
uint pick_light(float u, uint count, out float pmf) {
    float x = u * float(count);
    uint i = min(uint(x), count - 1u);
    if (SAMPLER == SAMPLER_POWER) {
        AliasEntry e = alias_table[i];
        if (x - float(i) >= e.q) i = e.alias;
        pmf = alias_table[i].pmf;
    } else {
        pmf = 1.0 / float(count);
    }
    return i;
}

// glTF KHR_lights_punctual spot falloff (squared linear ramp in cos θ); see scene::spot_falloff.
float spot_falloff(float cos_theta, float cos_inner, float cos_outer) {
    float scale = 1.0 / max(cos_inner - cos_outer, 1e-3);
    float a = clamp((cos_theta - cos_outer) * scale, 0.0, 1.0);
    return a * a;
}

// A point y on light l seen from x: the unoccluded irradiance-like term
// L_e · cosθ_y / (r² p(y)) (radiance × geometry, no BRDF, no cosθ_x), the unit direction
// wi from x to y and the distance. Triangles are sampled uniformly by area.
vec3 sample_light_point(GpuLight l, vec3 x, vec2 u, out vec3 wi, out float dist) {
    uint kind = l.kind & 0xffu;
    vec3 y;
    if (kind == LIGHT_TRIANGLE) {
        float su = sqrt(u.x);
        float b0 = 1.0 - su;
        float b1 = u.y * su;
        y = b0 * l.p0 + b1 * l.p1 + (1.0 - b0 - b1) * l.p2;
    } else {
        y = l.p0;
    }
    vec3 to = y - x;
    float d2 = dot(to, to);
    dist = sqrt(d2);
    wi = to / dist;
    if (d2 <= 0.0) return vec3(0.0);
    if (kind == LIGHT_POINT) return l.radiance / d2;
    if (kind == LIGHT_SPOT) return l.radiance * (spot_falloff(dot(l.p1, -wi), l.cos_inner, l.cos_outer) / d2);
    vec3 ny = normalize(cross(l.p1 - l.p0, l.p2 - l.p0));
    float cos_y = dot(ny, -wi);
    if ((l.kind & LIGHT_TWO_SIDED) != 0u) cos_y = abs(cos_y);
    if (cos_y <= 0.0) return vec3(0.0);
    return l.radiance * (cos_y * l.area / d2);
}

#endif
