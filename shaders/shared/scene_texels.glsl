// The scene's lights and materials as render.comp reads them: uniform texel buffers of
// RGBA32UI texels (src/gpu/buffer.rs Buffer::texels says why). The including kernel declares
// `light_texels` (GpuLight[]) and `material_texels` (GpuMaterial[]).
#ifndef SCENE_TEXELS_GLSL
#define SCENE_TEXELS_GLSL

#include "types.glsl"

// Light i: four texels, in the order of GpuLight's members (round trip: tests/layout.rs).
GpuLight light_at(uint i) {
    int t = int(4u * i);
    uvec4 a = texelFetch(light_texels, t);
    uvec4 b = texelFetch(light_texels, t + 1);
    uvec4 c = texelFetch(light_texels, t + 2);
    uvec4 d = texelFetch(light_texels, t + 3);
    GpuLight l;
    l.p0 = uintBitsToFloat(a.xyz);
    l.kind = a.w;
    l.p1 = uintBitsToFloat(b.xyz);
    l.cos_outer = uintBitsToFloat(b.w);
    l.p2 = uintBitsToFloat(c.xyz);
    l.cos_inner = uintBitsToFloat(c.w);
    l.radiance = uintBitsToFloat(d.xyz);
    l.area = uintBitsToFloat(d.w);
    return l;
}

// Material i: five texels, as GpuMaterial.
GpuMaterial material_at(uint i) {
    int t = int(5u * i);
    uvec4 a = texelFetch(material_texels, t);
    uvec4 b = texelFetch(material_texels, t + 1);
    uvec4 c = texelFetch(material_texels, t + 2);
    uvec4 d = texelFetch(material_texels, t + 3);
    GpuMaterial m;
    m.base_color = uintBitsToFloat(a.xyz);
    m.flags = a.w;
    m.emission = uintBitsToFloat(b.xyz);
    m.texture = b.w;
    m.specular_color = uintBitsToFloat(c.xyz);
    m.specular = uintBitsToFloat(c.w);
    m.metallic = uintBitsToFloat(d.x);
    m.roughness = uintBitsToFloat(d.y);
    m.emissive_texture = d.z;
    m.metallic_roughness_texture = d.w;
    uvec4 e = texelFetch(material_texels, t + 4);
    m.normal_texture = e.x;
    m.normal_scale = uintBitsToFloat(e.y);
    m.alpha_cutoff = uintBitsToFloat(e.z);
    m.alpha = uintBitsToFloat(e.w);
    return m;
}

// A LIGHT_TEXTURED light's triangle and emissive texture: the words GpuLight keeps in
// cos_outer and cos_inner, read as the integers they are (never through a float).
uvec2 light_texture_words(uint i) {
    int t = int(4u * i);
    return uvec2(texelFetch(light_texels, t + 1).w, texelFetch(light_texels, t + 2).w);
}

#endif
