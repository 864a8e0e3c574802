// The wavefront's path queues (render.comp, WAVEFRONT): a path's state between the
// dispatches of its bounces. The including kernel defines `Path`, `params` (RenderParams)
// and the specialization constants BRDF_SELECT and INDIRECT_LIGHT_SAMPLES.
#ifndef PATH_QUEUE_GLSL
#define PATH_QUEUE_GLSL

// The wavefront's path queues (set 2, with the film they belong to): two queues of
// params.queue_cap paths each, PATH_TEXELS RGBA32UI texels a path, in one buffer read as
// texels (path_texels) and written as a storage texel buffer (path_image: the same view); queue_head[4q…4q+3] is queue q's
// indirect dispatch (its workgroups, 1, 1) and its length. Bounce d ≥ 1 reads queue d & 1
// and appends the paths that go on to queue (d + 1) & 1, whose head the host reset before.
#define PATH_TEXELS 10u
layout(std430, set = 2, binding = 2) buffer QueueHeads { uint queue_head[8]; };
layout(set = 2, binding = 3) uniform usamplerBuffer path_texels;
layout(set = 2, binding = 4, rgba32ui) uniform writeonly uimageBuffer path_image;

Path load_path(uint q, uint i) {
    int t = int((q * params.queue_cap + i) * PATH_TEXELS);
    uvec4 a = texelFetch(path_texels, t);
    uvec4 b = texelFetch(path_texels, t + 1);
    uvec4 c = texelFetch(path_texels, t + 2);
    uvec4 d = texelFetch(path_texels, t + 3);
    uvec4 e = texelFetch(path_texels, t + 4);
    uvec4 f = texelFetch(path_texels, t + 5);
    uvec4 g = texelFetch(path_texels, t + 6);
    Path st;
    st.origin = uintBitsToFloat(a.xyz);
    st.pixel = a.w;
    st.dir = uintBitsToFloat(b.xyz);
    st.zero_samples = uintBitsToFloat(b.w);
    st.beta = uintBitsToFloat(c.xyz);
    // The vertices before this bounce took one light sample at the first and
    // INDIRECT_LIGHT_SAMPLES at each later one (path_vertex), so the count follows from the
    // bounce, and its place in the queue carries the previous choice's λ instead.
    st.light_samples = params.bounce == 0u ? 0.0 : 1.0 + float((params.bounce - 1u) * INDIRECT_LIGHT_SAMPLES);
    st.prev_cut_lambda = uintBitsToFloat(c.w);
    st.L = uintBitsToFloat(d.xyz);
    st.prev_cut = d.w;
    st.prev_x = uintBitsToFloat(e.xyz);
    st.prev_cut_total = uintBitsToFloat(e.w);
    st.prev_n = uintBitsToFloat(f.xyz);
    st.prev_brdf = uintBitsToFloat(f.w);
    st.prev_wo = uintBitsToFloat(g.xyz);
    st.prev_bsdf_pdf = uintBitsToFloat(g.w);
    st.prev_bsdf = Bsdf(vec3(0.0), 0.0, vec3(0.0), 0.0, 0.0, 0.0, 0.0, true);
    if (BRDF_SELECT) {
        uvec4 h = texelFetch(path_texels, t + 7);
        uvec4 j = texelFetch(path_texels, t + 8);
        uvec4 k = texelFetch(path_texels, t + 9);
        st.prev_bsdf = Bsdf(uintBitsToFloat(h.xyz), uintBitsToFloat(h.w), uintBitsToFloat(j.xyz),
                            uintBitsToFloat(j.w), uintBitsToFloat(k.x), uintBitsToFloat(k.y),
                            uintBitsToFloat(k.z), k.w != 0u);
    }
    return st;
}

void push_path(Path st) {
    uint q = (params.bounce + 1u) & 1u;
    uint i = atomicAdd(queue_head[4u * q + 3u], 1u);
    if ((i & 63u) == 0u) atomicAdd(queue_head[4u * q], 1u);
    int t = int((q * params.queue_cap + i) * PATH_TEXELS);
    imageStore(path_image, t, uvec4(floatBitsToUint(st.origin), st.pixel));
    imageStore(path_image, t + 1, uvec4(floatBitsToUint(st.dir), floatBitsToUint(st.zero_samples)));
    imageStore(path_image, t + 2, uvec4(floatBitsToUint(st.beta), floatBitsToUint(st.prev_cut_lambda)));
    imageStore(path_image, t + 3, uvec4(floatBitsToUint(st.L), st.prev_cut));
    imageStore(path_image, t + 4, uvec4(floatBitsToUint(st.prev_x), floatBitsToUint(st.prev_cut_total)));
    imageStore(path_image, t + 5, uvec4(floatBitsToUint(st.prev_n), floatBitsToUint(st.prev_brdf)));
    imageStore(path_image, t + 6, uvec4(floatBitsToUint(st.prev_wo), floatBitsToUint(st.prev_bsdf_pdf)));
    if (BRDF_SELECT) {
        Bsdf b = st.prev_bsdf;
        imageStore(path_image, t + 7, uvec4(floatBitsToUint(b.base), floatBitsToUint(b.metallic)));
        imageStore(path_image, t + 8, uvec4(floatBitsToUint(b.f0_d), floatBitsToUint(b.specular)));
        imageStore(path_image, t + 9, uvec4(floatBitsToUint(b.alpha), floatBitsToUint(b.p_spec),
                                            floatBitsToUint(b.albedo), b.lambert ? 1u : 0u));
    }
}

#endif
