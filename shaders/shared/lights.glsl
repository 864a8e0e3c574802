// Light selection (uniform, power) and light evaluation. The including kernel declares
// `alias_table` (AliasEntry[]) and the SAMPLER constant.
#ifndef LIGHTS_GLSL
#define LIGHTS_GLSL

#include "types.glsl"

// Below this width in cos θ a spot's ramp is a step (scene::SPOT_HARD_EDGE).
const float SPOT_HARD_EDGE = 1e-12;

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

// glTF KHR_lights_punctual spot falloff (squared linear ramp in cos θ) over the file's
// cones, a step where they meet; see scene::spot_falloff (why not the extension's 1e-3).
float spot_falloff(float cos_theta, float cos_inner, float cos_outer) {
    float d = cos_inner - cos_outer;
    if (d <= SPOT_HARD_EDGE) return cos_theta > cos_outer ? 1.0 : 0.0;
    float scale = 1.0 / d;
    float a = clamp((cos_theta - cos_outer) * scale, 0.0, 1.0);
    return a * a;
}

// Triangle lights sampled by solid angle (--light-point solid-angle; the including kernel
// defines the constant LIGHT_POINT_SOLID_ANGLE): where the triangle's solid angle Ω at x is
// within these bounds the direction is uniform over the spherical triangle (Arvo 1995), so
// 1/r² and cosθ_y no longer vary over the samples; elsewhere the point is uniform by area.
// Below 3e-4 sr (pbrt-v4 draws the same line) the construction works with nearly parallel
// f32 unit vectors (q and z near 1, their complements' square roots) and loses precision,
// while area sampling is as good there (r and cosθ_y hardly vary over a small triangle);
// near 2π the triangle is a hemisphere and the sampling degenerates. The choice depends on
// (x, light) alone, so the MIS weight of a BSDF ray that hits the light finds the same
// density (solid_angle_pdf).
const float SOLID_ANGLE_MIN = 3e-4;
const float SOLID_ANGLE_MAX = 6.0;

// Ω of triangle (p0, p1, p2) at x (Van Oosterom & Strackee 1983). The triple product is taken
// with the edges, a·((b−a)×(c−a)) = a·(b×c), which stays exact for a small far triangle.
float triangle_solid_angle(vec3 x, vec3 p0, vec3 p1, vec3 p2) {
    vec3 a = p0 - x, b = p1 - x, c = p2 - x;
    float la = length(a), lb = length(b), lc = length(c);
    float num = abs(dot(a, cross(p1 - p0, p2 - p0)));
    float den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    return 2.0 * atan(num, den);
}

bool solid_angle_sampled(float omega) {
    return omega > SOLID_ANGLE_MIN && omega < SOLID_ANGLE_MAX;
}

// The density per steradian with which sample_light_point draws a point of triangle light l
// from x, where it samples by solid angle; 0 where it samples by area (the caller then takes
// r² / (A cosθ_y)).
float solid_angle_pdf(GpuLight l, vec3 x) {
    if (!LIGHT_POINT_SOLID_ANGLE || (l.kind & 0xffu) != LIGHT_TRIANGLE) return 0.0;
    float omega = triangle_solid_angle(x, l.p0, l.p1, l.p2);
    return solid_angle_sampled(omega) ? 1.0 / omega : 0.0;
}

// The component of v orthogonal to the unit vector w, normalised.
vec3 orthonormal_to(vec3 v, vec3 w) {
    return normalize(v - dot(v, w) * w);
}

// A direction uniform over the spherical triangle of unit vectors A, B, C of solid angle
// omega (Arvo, "Stratified sampling of spherical triangles", 1995): u.x chooses the area of
// the sub-triangle A B C' (C' on the arc from A to C), u.y the point on the arc from B to C'.
// Arvo's sin/cos of (area − α) are expanded, with α's cosine and sine taken from the great
// circles' normals and the area from omega: no arc cosines (the three interior angles cost
// three acos, and acos near 1 is ill-conditioned for a thin triangle) and one cross product
// fewer.
vec3 sample_spherical_triangle(vec3 A, vec3 B, vec3 C, float omega, vec2 u) {
    vec3 nab = normalize(cross(A, B));
    vec3 nac = normalize(cross(A, C));
    // The interior angle α at A, between the great circles through A and B and through A and C.
    float cos_a = dot(nab, nac);
    float sin_a = length(cross(nab, nac));
    float area = u.x * omega;
    float sin_area = sin(area);
    float cos_area = cos(area);
    float s = sin_area * cos_a - cos_area * sin_a;
    float t = cos_area * cos_a + sin_area * sin_a;
    float uu = t - cos_a;
    float vv = s + sin_a * dot(A, B);
    float q = clamp(((vv * t - uu * s) * cos_a - vv) / ((vv * s + uu * t) * sin_a), -1.0, 1.0);
    vec3 c2 = q * A + sqrt(max(1.0 - q * q, 0.0)) * orthonormal_to(C, A);
    float z = 1.0 - u.y * (1.0 - dot(c2, B));
    return z * B + sqrt(max(1.0 - z * z, 0.0)) * orthonormal_to(c2, B);
}

// A point y on light l seen from x: the unoccluded irradiance-like term
// L_e · cosθ_y / (r² p(y)) (radiance × geometry, no BRDF, no cosθ_x), the unit direction
// wi from x to y and the distance. Triangles are sampled uniformly by area, or by solid
// angle (see SOLID_ANGLE_MIN): then sa_pdf is the density per steradian (else 0).
vec3 sample_light_point(GpuLight l, vec3 x, vec2 u, out vec3 wi, out float dist, out float sa_pdf) {
    uint kind = l.kind & 0xffu;
    sa_pdf = 0.0;
    if (LIGHT_POINT_SOLID_ANGLE && kind == LIGHT_TRIANGLE) {
        float omega = triangle_solid_angle(x, l.p0, l.p1, l.p2);
        if (solid_angle_sampled(omega)) {
            vec3 ny = normalize(cross(l.p1 - l.p0, l.p2 - l.p0));
            wi = sample_spherical_triangle(normalize(l.p0 - x), normalize(l.p1 - x), normalize(l.p2 - x), omega, u);
            // Where the direction meets the light's plane.
            float cos_w = dot(ny, wi);
            dist = dot(l.p0 - x, ny) / cos_w;
            float cos_y = -cos_w;
            if ((l.kind & LIGHT_TWO_SIDED) != 0u) cos_y = abs(cos_y);
            if (!(dist > 0.0) || cos_y <= 0.0) return vec3(0.0);
            sa_pdf = 1.0 / omega;
            return l.radiance * omega;
        }
    }
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
