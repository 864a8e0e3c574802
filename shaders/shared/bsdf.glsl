// The glTF 2.0 metallic-roughness BRDF (the specification's Appendix B, with the
// KHR_materials_specular factors), reflection only:
//   f = mix(dielectric, metal, metallic)
//   metal      = F_schlick(F0 = base colour, v·h) · S
//   dielectric = specular · F_d(v·h) · S + base / π · (1 − w(n·v)) (1 − w(n·l)) / (1 − w_avg),
//                F_d = F_schlick(F0 = min(0.04 · specular colour, 1)), w = specular · max(F_d),
//                w_avg = ∫ w(n·l) cos / π dl = specular · (f0 + (1 − f0) / 21), f0 = max(F0_d)
//   S = D_GGX(h) · G2(v, l) / (4 |n·v| |n·l|), α = roughness²
// ONE DEVIATION from the specification: its dielectric weights the diffuse base by
// 1 − w(v·h). That is not energy conserving: a white, smooth dielectric seen at cos θ = 0.1
// reflects 1.55× what arrives (tests/bsdf.rs measured 1.55 at roughness 0.05, 1.43 at 0.2,
// 1.11 at 0.5). We couple the diffuse base to the layer by the Fresnel of both directions
// instead (Ashikhmin & Shirley 2000's form, normalised as Kulla & Conty 2017): reciprocal,
// and under a perfectly smooth layer exactly the energy the layer transmits, so a white
// dielectric reflects at most all of it. Under a rough layer a little less (single scattering).
// At normal view both give the base 0.96 × base / π (to 0.3 %: F(v·h) < 0.003 there).
// G2 is the height-correlated Smith form 1 / (1 + Λ(v) + Λ(l)) (as glTF's sample viewer
// and pbrt-v4; Mitsuba 3 uses the separable G1(v) · G1(l), which differs by Λ(v)Λ(l) in
// the denominator, see tests/mitsuba.rs). Single scattering: rough metals lose the energy of
// multiple bounces between microfacets, as in both references (a white metal of roughness 1
// reflects 31 % at normal view, tests/bsdf.rs).
//
// Sampling picks the specular lobe with probability p_spec (its Fresnel-weighted share at
// n·v), then the GGX distribution of visible normals (Heitz 2018, "Sampling the GGX
// Distribution of Visible Normals"), else a cosine-weighted direction; bsdf_pdf is the
// mixture's pdf, which the MIS weights need. A material with metallic = specular = 0 is
// exactly Lambertian: p_spec = 0, f = base / π, pdf = cos / π, and the random numbers are
// used as the Lambert-only path tracer used them.
//
// Needs PI, luminance() and GpuMaterial (types.glsl).

// Below this α the GGX peak 1/(π α²) grows past what float MIS weights handle well; roughness
// under sqrt(1e-3) ≈ 0.03 renders as 0.03 (no perfect mirrors yet).
const float MIN_ALPHA = 1.0e-3;

// Whether any material of the scene is glossy; an including kernel that knows may define it
// false (render.comp, from SCENE_FLAGS), compiling the GGX code out.
#ifndef SCENE_GLOSSY
#define SCENE_GLOSSY true
#endif

struct Bsdf {
    vec3 base;      // base colour (factor × texture)
    float metallic;
    vec3 f0_d;      // the dielectric layer's F0
    float specular; // the dielectric layer's weight
    float alpha;
    float p_spec;   // probability of sampling the specular lobe (depends on v only)
    float albedo;   // a scalar estimate of the directional albedo (luminance), for priors
    bool lambert;   // metallic = specular = 0
};

float max3(vec3 v) { return max(v.x, max(v.y, v.z)); }

float schlick_weight(float c) {
    float m = clamp(1.0 - c, 0.0, 1.0);
    float m2 = m * m;
    return m2 * m2 * m;
}

// The BRDF at a shading point of material m with base colour `base`, seen from v (unit, on
// the side of n).
Bsdf make_bsdf(GpuMaterial m, vec3 base, vec3 n, vec3 v) {
    Bsdf b;
    b.base = base;
    b.metallic = m.metallic;
    b.specular = m.specular;
    b.f0_d = min(0.04 * m.specular_color, vec3(1.0));
    b.alpha = max(m.roughness * m.roughness, MIN_ALPHA);
    // SCENE_GLOSSY false: no material of the scene is glossy, so the GGX code compiles out.
    b.lambert = !SCENE_GLOSSY || (m.metallic == 0.0 && m.specular == 0.0);
    float w = schlick_weight(dot(n, v));
    float fd = max3(b.f0_d) + (1.0 - max3(b.f0_d)) * w;
    float ws = b.metallic * luminance(base + (1.0 - base) * w) + (1.0 - b.metallic) * b.specular * fd;
    float wd = (1.0 - b.metallic) * (1.0 - b.specular * fd) * luminance(base);
    b.albedo = ws + wd;
    if (ws <= 0.0) b.p_spec = 0.0;
    else if (wd <= 0.0) b.p_spec = 1.0;
    // Clamped so that neither lobe is starved where the Fresnel estimate at n·v is poor.
    else b.p_spec = clamp(ws / (ws + wd), 0.1, 0.9);
    return b;
}

float ggx_d(float alpha, float cos_h) {
    float a2 = alpha * alpha;
    float c2 = cos_h * cos_h;
    float t = c2 * (a2 - 1.0) + 1.0;
    return a2 / (PI * t * t);
}

float ggx_lambda(float alpha, float c) {
    float c2 = max(c * c, 1.0e-12);
    float tan2 = max(1.0 - c2, 0.0) / c2;
    return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

// f(v, l), without the cosine. Zero unless both directions are above the surface.
vec3 bsdf_eval(Bsdf b, vec3 n, vec3 v, vec3 l) {
    float cv = dot(n, v);
    float cl = dot(n, l);
    if (cv <= 0.0 || cl <= 0.0) return vec3(0.0);
    if (b.lambert) return b.base * (1.0 / PI);
    vec3 h = normalize(v + l);
    float w = schlick_weight(dot(v, h));
    float s = ggx_d(b.alpha, dot(n, h))
            / ((1.0 + ggx_lambda(b.alpha, cv) + ggx_lambda(b.alpha, cl)) * 4.0 * cv * cl);
    vec3 fm = b.base + (1.0 - b.base) * w;
    vec3 fd = b.f0_d + (1.0 - b.f0_d) * w;
    float f0 = max3(b.f0_d);
    float wv = b.specular * (f0 + (1.0 - f0) * schlick_weight(cv));
    float wl = b.specular * (f0 + (1.0 - f0) * schlick_weight(cl));
    float w_avg = b.specular * (f0 + (1.0 - f0) / 21.0);
    // A full-strength layer of F0 = 1 (specular 1, specularColorFactor ≥ 25) leaves the
    // base no light: w_avg = 1, and 0/0 made every sample NaN, a black image (an audit,
    // 2026-12-06). The limit f0 → 1 of the quotient is 0.
    vec3 diffuse = w_avg < 1.0 ? b.base * ((1.0 - wv) * (1.0 - wl) / (PI * (1.0 - w_avg))) : vec3(0.0);
    return mix(diffuse + b.specular * fd * s, fm * s, b.metallic);
}

// The solid-angle pdf of bsdf_sample choosing l.
float bsdf_pdf(Bsdf b, vec3 n, vec3 v, vec3 l) {
    float cv = dot(n, v);
    float cl = dot(n, l);
    if (cv <= 0.0 || cl <= 0.0) return 0.0;
    float p = (1.0 - b.p_spec) * cl / PI;
    if (b.p_spec > 0.0) {
        vec3 h = normalize(v + l);
        // Visible normals: D_v(h) = G1(v) max(v·h, 0) D(h) / (n·v); reflection's Jacobian
        // 1 / (4 v·h) cancels v·h.
        float g1 = 1.0 / (1.0 + ggx_lambda(b.alpha, cv));
        p += b.p_spec * g1 * ggx_d(b.alpha, dot(n, h)) / (4.0 * cv);
    }
    return p;
}

// An orthonormal frame (t, bt) around n.
void bsdf_frame(vec3 n, out vec3 t, out vec3 bt) {
    t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0.0, 1.0, 0.0)) : cross(n, vec3(1.0, 0.0, 0.0)));
    bt = cross(n, t);
}

// A cosine-distributed direction about n (pdf cos θ / π).
vec3 sample_cosine(vec3 n, vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    vec3 t, bt;
    bsdf_frame(n, t, bt);
    return normalize(r * cos(phi) * t + r * sin(phi) * bt + sqrt(max(1.0 - u.x, 0.0)) * n);
}

// A GGX visible normal for v, in the local frame (z = n) (Heitz 2018, listing 1).
vec3 sample_ggx_vndf(vec3 v, float alpha, vec2 u) {
    vec3 vh = normalize(vec3(alpha * v.x, alpha * v.y, v.z));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)));
}

// A direction l from the BRDF's sampling distribution; pdf = bsdf_pdf(l), 0 where the sample
// left the hemisphere (then the path ends).
vec3 bsdf_sample(Bsdf b, vec3 n, vec3 v, vec2 u, out float pdf) {
    vec3 l;
    if (u.x < b.p_spec) {
        u.x = min(u.x / b.p_spec, 0.99999994);
        vec3 t, bt;
        bsdf_frame(n, t, bt);
        vec3 hl = sample_ggx_vndf(vec3(dot(v, t), dot(v, bt), dot(v, n)), b.alpha, u);
        vec3 h = normalize(hl.x * t + hl.y * bt + hl.z * n);
        l = reflect(-v, h);
    } else {
        if (b.p_spec > 0.0) u.x = min((u.x - b.p_spec) / (1.0 - b.p_spec), 0.99999994);
        l = sample_cosine(n, u);
    }
    pdf = bsdf_pdf(b, n, v, l);
    return l;
}
