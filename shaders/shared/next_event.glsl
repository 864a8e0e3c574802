// Next-event estimation at a path vertex (render.comp includes it after what it uses: Path,
// sample_s, vertex_rand, the samplers, bsdf.glsl, surface_eps): the light sample a sampler
// chooses (`next_event`, with its MIS weight and the learned samplers' observation) and each
// directional light's own shadow ray (`sun_light`). Split from render.comp by concept.
#ifndef NEXT_EVENT_GLSL
#define NEXT_EVENT_GLSL

// --refine-cuts: one observation y of `slot` through child `side` (render.comp's SideCounts).
void record_side(uint slot, uint side, float y) {
    uint b = 6u * slot;
    atomicAdd(side_counts[b + side], 1u);
    if (!(y > 0.0)) return;
    float q = min(y / slot_stats_at(slot).scale, FIX_CLAMP);
    uvec2 w = fixed_words(q * q);
    uint old = atomicAdd(side_counts[b + 2u + 2u * side], w.x);
    uint carry = old + w.x < old ? 1u : 0u;
    if (w.y + carry > 0u) atomicAdd(side_counts[b + 3u + 2u * side], w.y + carry);
}

// Next-event sample `rep` of `n_light` at vertex `depth` (x, its normal n, the direction
// wo back along the path, its BSDF): a light chosen by SAMPLER, a point on it, the shadow
// ray, the contribution weighted against the BSDF ray (MIS) and divided by n_light, and
// the learned samplers' observation. Sample 0 takes the vertex's own (stratified) numbers.
void next_event(inout Path st, vec3 x, vec3 n, vec3 ng, float eps, vec3 wo, Bsdf bsdf, float brdf, uint depth, uint rep, uint n_light) {
    uint pixel = st.pixel;
    uint s = sample_s;
    uint seed = params.seed;
    const bool learned = SAMPLER == SAMPLER_BAYES || SAMPLER == SAMPLER_DONIKIAN;
    const bool mis = params.max_depth > (DIRECT_ONLY ? 0xffffffffu : 1u);
    const bool brdf_aware = (BAYES_FLAGS & LEARN_BRDF) != 0u;
    // Sample 0 takes the vertex's own numbers, except at a first vertex of several samples.
    bool own = rep == 0u && !(FIRST_INDEPENDENT && depth == 0u);
    uint dim_extra = DIM_EXTRA_LIGHT + 64u * depth + 3u * (depth == 0u ? rep : rep - 1u);
    float pmf;
    float u_light = own ? vertex_rand(seed, pixel, s, depth, DIM_LIGHT) : sample_rand(seed, pixel, s, dim_extra);
    uint li;
    uint slot = NO_SLOT;
    float p_slot = 1.0;
    float d2_slot = 1.0;
    float cv_total = 0.0;
    float cv_chosen = 0.0;
    if ((KNOCK_OUT & KNOCK_SELECT) != 0u) li = pick_light(u_light, params.light_count, pmf);
    else if (SAMPLER == SAMPLER_LIGHTBVH) li = sample_light_tree(x, n, u_light, pmf);
    else if (SAMPLER == SAMPLER_WANG) li = sample_wang(x, n, u_light, pmf);
    else if (learned) li = sample_learned(x, n, u_light, brdf, pmf, slot, p_slot, d2_slot, cv_total, cv_chosen);
    else li = pick_light(u_light, params.light_count, pmf);
    if (learned && li != NO_LIGHT && slot == NO_SLOT && (KNOCK_OUT & KNOCK_SELECT) == 0u) atomicAdd(counters[1], 1u);
    // The observation of the chosen cluster: Î_C = L_e G V / (P(l|C) p(y|l)) as
    // luminance (not divided by P(C|x)); zero when occluded or facing away. Learning
    // models the light-sampling estimator, so it takes no MIS weight (docs/method.md §5).
    float observed = 0.0;
    vec3 Ic = vec3(0.0);  // Î_C in RGB, for the control variate
    vec3 wi;
    float dist;
    vec2 u = own
        ? vec2(vertex_rand(seed, pixel, s, depth, DIM_LIGHT_U), vertex_rand(seed, pixel, s, depth, DIM_LIGHT_V))
        : vec2(sample_rand(seed, pixel, s, dim_extra + 1u), sample_rand(seed, pixel, s, dim_extra + 2u));
    // NO_LIGHT: no light can reach the front of n here (zero contribution, exactly).
    GpuLight light = light_at(li == NO_LIGHT ? 0u : li);
    float sa_pdf = 0.0;
    vec3 Li = li == NO_LIGHT ? vec3(0.0) : sample_light_point(light, x, u, wi, dist, sa_pdf);
    // glTF: emission = factor × emissive texture, at the point drawn (before the shadow ray,
    // so a black texel costs none).
    if (SCENE_EMISSIVE_TEXTURED && li != NO_LIGHT && (light.kind & LIGHT_TEXTURED) != 0u) {
        uvec2 tw = light_texture_words(li);
        Li *= sample_texture(tw.y, triangle_uv(tw.x, x + wi * dist, light.p0, light.p1 - light.p0, light.p2 - light.p0));
    }
    float cos_x = dot(n, wi);
    // With a shading normal n, a direction must also leave the surface itself (ng).
    if (SCENE_SMOOTH && dot(ng, wi) <= 0.0) cos_x = 0.0;
    if (li != NO_LIGHT && cos_x > 0.0 && any(greaterThan(Li, vec3(0.0)))) {
        // The shadow ray starts just off the surface and aims at the light point itself:
        // keeping wi and dist from x made a surface parallel to an area light (a floor under
        // a ceiling panel) meet the light's own plane before tmax, i.e. shadow itself
        // (found by the Mitsuba cross-check, tests/mitsuba.rs: floor 48 % too dark).
        vec3 so = x + ng * eps;
        vec3 to_light = wi * dist - ng * eps;
        float sdist = length(to_light);
        bool area = (light.kind & 0xffu) == LIGHT_TRIANGLE;
        // Stop short of an area light's own surface (by the offset its coordinates need);
        // a point light has none.
        float tmax = area ? sdist - max(eps, surface_eps(max_abs(x + wi * dist), max(max_abs(light.p0), max(max_abs(light.p1), max_abs(light.p2))))) : sdist;
        float ts;
        if ((KNOCK_OUT & KNOCK_SHADOW) != 0u || trace_ray(so, to_light / sdist, 0.0, tmax, true, ts) == NO_HIT) {
            // Evaluated only for visible samples (GGX costs tens of operations).
            vec3 f = bsdf_eval(bsdf, n, wo, wi);
            float w = 1.0;
            if (mis && area) {
                // The light sample's pdf in solid angle: pmf · d² / (cos_y A) by area, pmf / Ω
                // by solid angle.
                float cos_y = abs(dot(normalize(cross(light.p1 - light.p0, light.p2 - light.p0)), wi));
                float p_light = sa_pdf > 0.0 ? pmf * sa_pdf : pmf * dist * dist / (cos_y * light.area);
                w = power_heuristic(float(n_light) * p_light, bsdf_pdf(bsdf, n, wo, wi));
            }
            st.L += st.beta * f * Li * (cos_x / pmf * w / float(n_light));
            Ic = Li * (cos_x * p_slot / pmf);
            observed = luminance(Li) * cos_x * (p_slot / pmf) * (brdf_aware ? luminance(f) : 1.0);
        }
    }
    if (learned && slot != NO_SLOT && (KNOCK_OUT & KNOCK_OBSERVE) == 0u) record_observation(slot, observed * d2_slot);
    if (REFINE_ON && learned && slot != NO_SLOT && sel_side < 2u && (KNOCK_OUT & KNOCK_OBSERVE) == 0u)
        record_side(slot, sel_side, observed * d2_slot);
    st.light_samples += 1.0;
    st.zero_samples += any(greaterThan(Ic, vec3(0.0))) ? 0.0 : 1.0;
    // --control-variates (docs/method.md §6): Σ_C g_C + (Î_C − g_C) / P(C) instead of
    // Î_C / P(C), with g_C the model's predicted mean of Î_C (gray: the model learns
    // luminance). Unbiased for any g fixed within the pass (with MIS too: g need not
    // predict the weighted term); also where the sample was occluded or a dead end
    // (Î_C = 0), which is why it is added here, outside the shadow-ray branch.
    // p_slot = 0 only where no cluster can light x (g's all 0). The factor that turns g
    // into radiance must not depend on the light drawn: the diffuse lobe at normal
    // incidence (the BRDF itself for a Lambertian material; 0 for a metal, where the
    // control variate is then off).
    if (cv_total > 0.0 && p_slot > 0.0) {
        vec3 f_cv = (1.0 - bsdf.metallic) * (1.0 - bsdf.specular * max3(bsdf.f0_d)) * bsdf.base / PI;
        st.L += st.beta * f_cv * (vec3(cv_total) - vec3(cv_chosen) / p_slot) / float(n_light);
    }
}

// The directional lights at x (glTF's sun): each one's parallel light, a shadow ray towards
// it, the BSDF. Delta lights: no other strategy finds them, so no MIS weight, and no light
// sampler chooses them (they add to its estimate, one shadow ray each a vertex).
void sun_light(inout Path st, vec3 x, vec3 n, vec3 ng, float eps, vec3 wo, Bsdf bsdf) {
    for (uint k = 0u; k < DIRECTIONAL_COUNT; ++k) {
        GpuLight sun = light_at(params.light_count + k);
        vec3 wi = -sun.p1;
        float cos_x = dot(n, wi);
        if (SCENE_SMOOTH && dot(ng, wi) <= 0.0) cos_x = 0.0;
        float ts;
        // `profile`'s shadow-ray knock-out leaves these out too.
        if (cos_x > 0.0 && ((KNOCK_OUT & KNOCK_SHADOW) != 0u || trace_ray(x + ng * eps, wi, 0.0, 3.0e38, true, ts) == NO_HIT)) {
            st.L += st.beta * bsdf_eval(bsdf, n, wo, wi) * sun.radiance * cos_x;
        }
    }
}

#endif
