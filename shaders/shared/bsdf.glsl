// The glTF 2.0 metallic-roughness BRDF (the specification's Appendix B, with the
// KHR_materials_specular factors), reflection only:
//   f = mix(dielectric, metal, metallic)
//   metal      = F_schlick(F0 = base colour, v·h) · S
//   dielectric = specular · F_d(v·h) · S + base / π · (1 − K(n·v)) (1 − K(n·l)) / (1 − K_avg),
//                F_d = F_schlick(F0 = min(0.04 · specular colour, 1)),
//                E(μ) = specular · (f0 M(μ, α) + (1 − f0) S(μ, α)), f0 = max(F0_d): the layer's
//                directional albedo (M, S tabulated by src/layer_albedo.rs), K = E + its
//                multiple scattering (1 − M) F_ms, K_avg its average
//   S = D_GGX(h) · G2(v, l) / (4 |n·v| |n·l|), α = roughness²
// ONE DEVIATION from the specification: its dielectric weights the diffuse base by
// 1 − F(v·h). That is not energy conserving: a white, smooth dielectric seen at cos θ = 0.1
// reflects 1.55× what arrives (tests/bsdf.rs measured 1.55 at roughness 0.05, 1.43 at 0.2,
// 1.11 at 0.5). We couple the diffuse base to the layer by the layer's albedo in both
// directions instead (Kulla & Conty 2017's energy compensation; what the layer keeps
// includes its multiple scattering, layer_kept): reciprocal, and the base's albedo is
// exactly 1 − kept(n·v), so a white dielectric reflects nearly all that arrives
// (tests/bsdf.rs: 0.997–1.001 at roughness 0.05–1, cos θ 0.1–1; the layer's own multiple
// scattering is not rendered). Under a rough layer this is close to the specification
// (roughness 1: 0.99–1.033×, 0.8: 0.96–1.023×; at 0.5 0.84–1.02×, lower
// where the specification's form gains energy). Until 2026-12-07 E was the macro normal's
// Fresnel, exact for a smooth layer only: rough dielectrics rendered at 0.30–0.44× the
// specification under grazing light and 1.05× under normal light.
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
// Needs PI, luminance() and GpuMaterial (types.glsl), and the layer albedo table bound as
// the texel buffer `layer_albedo_texels` (below).

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

// (M, S) of the dielectric's GGX layer at view cosine mu and roughness r = sqrt(α),
// bilinear in the table (src/layer_albedo.rs; LayerAlbedo::lookup mirrors it). The
// including kernel binds the table as the texel buffer `layer_albedo_texels` (RGBA32UI, two
// float pairs a texel): 32 × 32 pairs, row-major in r, then the 32 rows' averages. A texel
// buffer rather than a storage buffer: render.comp already uses 16 of the latter, and a
// device need take no more than 4 a stage (desktop drivers take far more; a review,
// 2026-12-07, not checked on any device).
const int LAYER_N_MU = 32;
const int LAYER_N_ROUGH = 32;

#ifdef LAYOUT_ONLY
// tests/layout.rs compiles bsdf.comp for naga, which takes no texel buffers: the structs'
// layout is what it checks.
vec2 layer_pair(int k) { return vec2(0.0); }
#else
vec2 layer_pair(int k) {
    uvec4 t = texelFetch(layer_albedo_texels, k >> 1);
    return uintBitsToFloat((k & 1) == 0 ? t.xy : t.zw);
}
#endif

vec2 layer_albedo(float mu, float r) {
    float x = clamp(mu, 0.0, 1.0) * float(LAYER_N_MU - 1);
    float y = clamp(r, 0.0, 1.0) * float(LAYER_N_ROUGH - 1);
    int i = clamp(int(x), 0, LAYER_N_MU - 2);
    int j = clamp(int(y), 0, LAYER_N_ROUGH - 2);
    float fx = x - float(i);
    float fy = y - float(j);
    int k = j * LAYER_N_MU + i;
    vec2 lo = mix(layer_pair(k), layer_pair(k + 1), fx);
    vec2 hi = mix(layer_pair(k + LAYER_N_MU), layer_pair(k + LAYER_N_MU + 1), fx);
    return mix(lo, hi, fy);
}

// Their averages 2 ∫ (M, S) μ dμ at roughness r, linear in r (LayerAlbedo::lookup_avg).
vec2 layer_albedo_avg(float r) {
    float y = clamp(r, 0.0, 1.0) * float(LAYER_N_ROUGH - 1);
    int j = clamp(int(y), 0, LAYER_N_ROUGH - 2);
    int k = LAYER_N_MU * LAYER_N_ROUGH + j;
    return mix(layer_pair(k), layer_pair(k + 1), y - float(j));
}

// What the layer keeps of light arriving at a cosine whose table terms are ms (E: its single
// scattering plus the multiple scattering between its microfacets, Kulla & Conty 2017's
// F_ms; the base gets the rest), given f0 = max(F0_d), the weight `specular` and the layer's
// average (M̄, S̄).
// F_ms makes a layer of F0 = 1 keep everything (nothing reaches the base, as a smooth one);
// at F0 = 0.04 it is below 0.7 % of 1 − M.
float layer_kept(vec2 ms, float f0, float specular, vec2 avg) {
    float f_avg = specular * (f0 + (1.0 - f0) / 21.0);
    float f_ms = f_avg * f_avg * avg.x / max(1.0 - f_avg * (1.0 - avg.x), 1.0e-6);
    return specular * (f0 * ms.x + (1.0 - f0) * ms.y) + (1.0 - ms.x) * f_ms;
}

// Its average 2 ∫ layer_kept μ dμ: the same at the averages (it is linear in M and S).
float layer_kept_avg(float f0, float specular, vec2 avg) {
    return layer_kept(avg, f0, specular, avg);
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
    // The lobes' shares as bsdf_eval weighs them: the layer's directional albedo E and the
    // base's 1 − what the layer keeps, where a dielectric layer reads the table. With the
    // macro normal's Fresnel for both, a layer of F0 = 1 left p_spec = 1, so the base,
    // which light reaches under a rough layer, was never sampled, and a rough layer's share
    // was overstated (0.62 against E = 0.05 at roughness 1, n·v 0.1) (two reviews,
    // 2026-12-07). A Lambertian material or a metal reads no table.
    float e_layer = b.specular * fd;
    float kept = 0.0;
    if (SCENE_GLOSSY && !b.lambert && b.metallic < 1.0 && b.specular > 0.0) {
        float r = sqrt(b.alpha);
        float f0 = max3(b.f0_d);
        vec2 ms = layer_albedo(max(dot(n, v), 0.0), r);
        vec2 avg = layer_albedo_avg(r);
        e_layer = b.specular * (f0 * ms.x + (1.0 - f0) * ms.y);
        kept = layer_kept_avg(f0, b.specular, avg) < 1.0 - 1.0e-6 ? layer_kept(ms, f0, b.specular, avg) : 1.0;
    }
    float ws = b.metallic * luminance(base + (1.0 - base) * w) + (1.0 - b.metallic) * e_layer;
    float wd = (1.0 - b.metallic) * (1.0 - kept) * luminance(base);
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
    // What the layer keeps at both directions and on average (layer_kept: its directional
    // albedo E = specular · (F0 M + (1 − F0) S) and its multiple scattering; the tables
    // from src/layer_albedo.rs).
    // A metal's diffuse part is weighed away and a layer of weight 0 keeps nothing: no
    // table read (10 texel fetches an evaluation on the committed scenes' metals otherwise;
    // a review, 2026-12-07).
    float wv = 0.0;
    float wl = 0.0;
    float w_avg = 0.0;
    if (b.metallic < 1.0 && b.specular > 0.0) {
        float f0 = max3(b.f0_d);
        float r = sqrt(b.alpha);
        vec2 avg = layer_albedo_avg(r);
        wv = layer_kept(layer_albedo(cv, r), f0, b.specular, avg);
        wl = layer_kept(layer_albedo(cl, r), f0, b.specular, avg);
        w_avg = layer_kept_avg(f0, b.specular, avg);
    }
    // A full-strength layer of F0 = 1 (specular 1, specularColorFactor ≥ 25) leaves the base
    // no light: w_avg = 1, and 0/0 made every sample NaN, a black image (an audit,
    // 2026-12-06). The quotient's limit there is 0.
    vec3 diffuse = w_avg < 1.0 - 1.0e-6 ? b.base * ((1.0 - wv) * (1.0 - wl) / (PI * (1.0 - w_avg))) : vec3(0.0);
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
