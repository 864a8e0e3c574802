// glTF alphaMode MASK: whether a ray meets triangle `tri` at x, for bvh.glsl's
// BVH_ALPHA_TEST: a masked material's surface is there where its alpha (baseColorFactor's ×
// the base-colour texture's, bilinear like the colour) is at least alphaCutoff, and rays pass
// it elsewhere (camera, path and shadow rays alike). Compiled out (SCENE_ALPHA_MASK false)
// for scenes without such a material. Mirrors nothing on the host: the CPU BVH
// (src/accel/traverse.rs, used by the preview's heat map and the coverage of live rows) sees every
// triangle as opaque. The including kernel declares SCENE_ALPHA_MASK, `tri_material`,
// `material_texels` and what texture.glsl needs.
#ifndef ALPHA_GLSL
#define ALPHA_GLSL

#include "texture.glsl"

bool alpha_opaque(BvhTri tri, vec3 x) {
    if (!SCENE_ALPHA_MASK) return true;
    // Of the material's five texels only the words read here (scene_texels.glsl material_at
    // reads all): flags, the base-colour texture, the cutoff and the alpha.
    int base = int(5u * tri_material[tri.prim]);
    if ((texelFetch(material_texels, base).w & MATERIAL_ALPHA_MASK) == 0u) return true;
    uvec4 e = texelFetch(material_texels, base + 4);
    float alpha = uintBitsToFloat(e.w);
    uint tex = texelFetch(material_texels, base + 1).w;
    if (tex != NO_TEXTURE) alpha *= sample_texture4(tex, triangle_uv(tri.prim, x, tri.v0, tri.e1, tri.e2)).a;
    return alpha >= uintBitsToFloat(e.z);
}

#define BVH_ALPHA_TEST(tri, x) alpha_opaque(tri, x)

#endif
