// Textures: bilinear lookup (or the nearest texel, TEXTURE_NEAREST) with the glTF wrap modes,
// sRGB decoded to linear (glTF stores base and emissive colour in sRGB) unless TEXTURE_LINEAR
// (metallic-roughness: data). Mirror of src/scene
// (Texture, Wrap). The including kernel declares `textures` (GpuTexture[]), `texels` (uint[]:
// packed RGBA8, or RGBA16 in two words with TEXTURE_16_BIT) and `tri_uv` (uint[TRI_ATTR_STRIDE]
// per triangle).
#ifndef TEXTURE_GLSL
#define TEXTURE_GLSL

#include "types.glsl"

float srgb_to_linear(float c) {
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

// Texel index along one axis of size n for integer coordinate i, by wrap mode w
// (0 repeat, 1 clamp to edge, 2 mirrored repeat).
// (GLSL leaves % of negative operands undefined: the modulo is taken with floor.)
int floor_mod(int i, int m) {
    return i - m * int(floor(float(i) / float(m)));
}

uint wrap_index(int i, uint n, uint w) {
    int m = int(n);
    if (w == 1u) return uint(clamp(i, 0, m - 1));
    if (w == 2u) {
        int p = floor_mod(i, 2 * m);
        return uint(p < m ? p : 2 * m - 1 - p);
    }
    return uint(clamp(floor_mod(i, m), 0, m - 1));
}

// A texel's colour (decoded) and alpha (linear in glTF, as stored).
vec4 texel(GpuTexture t, int x, int y) {
    uint ix = wrap_index(x, t.width, t.wrap & 0xffu);
    uint iy = wrap_index(y, t.height, (t.wrap >> 8) & 0xffu);
    uint i = iy * t.width + ix;
    vec4 c;
    if ((t.wrap & TEXTURE_16_BIT) != 0u) {
        c = vec4(unpackUnorm2x16(texels[t.offset + 2u * i]), unpackUnorm2x16(texels[t.offset + 2u * i + 1u]));
    } else {
        c = unpackUnorm4x8(texels[t.offset + i]);
    }
    if ((t.wrap & TEXTURE_LINEAR) != 0u) return c;
    return vec4(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b), c.a);
}

// Bilinear between the four nearest texel centres (decoded to linear first): colour and alpha.
vec4 sample_texture4(uint index, vec2 uv) {
    GpuTexture t = textures[index];
    // Coordinates far outside [0, 1] are reduced first so that the integer texel
    // coordinates stay exact (repeat and mirror have periods 1 and 2).
    if ((t.wrap & 0xffu) != 1u) uv.x -= 2.0 * floor(0.5 * uv.x);
    if (((t.wrap >> 8) & 0xffu) != 1u) uv.y -= 2.0 * floor(0.5 * uv.y);
    uv = clamp(uv, vec2(-1.0), vec2(3.0));
    if ((t.wrap & TEXTURE_NEAREST) != 0u) {
        vec2 q = floor(uv * vec2(t.width, t.height));
        return texel(t, int(q.x), int(q.y));
    }
    vec2 p = uv * vec2(t.width, t.height) - 0.5;
    vec2 f = floor(p);
    vec2 w = p - f;
    int x = int(f.x);
    int y = int(f.y);
    return mix(mix(texel(t, x, y), texel(t, x + 1, y), w.x),
               mix(texel(t, x, y + 1), texel(t, x + 1, y + 1), w.x), w.y);
}

vec3 sample_texture(uint index, vec2 uv) {
    return sample_texture4(index, uv).rgb;
}

// Words of a triangle's attributes in tri_uv (src/render/gpu_scene.rs triangle_attributes):
// six texture-coordinate floats as bits, then in a smooth scene three packed normals, and in a
// normal-mapped one three packed tangents and their signs.
#ifndef TRI_ATTR_STRIDE
#define TRI_ATTR_STRIDE 6u
#endif

// The barycentric weights (b1, b2) of point x in the triangle (v0, edges e1, e2).
vec2 triangle_bary(vec3 x, vec3 v0, vec3 e1, vec3 e2) {
    vec3 v = x - v0;
    float d00 = dot(e1, e1);
    float d01 = dot(e1, e2);
    float d11 = dot(e2, e2);
    float d20 = dot(v, e1);
    float d21 = dot(v, e2);
    float den = d00 * d11 - d01 * d01;
    float b1 = den > 0.0 ? (d11 * d20 - d01 * d21) / den : 0.0;
    float b2 = den > 0.0 ? (d00 * d21 - d01 * d20) / den : 0.0;
    return vec2(b1, b2);
}

// The texture coordinate at point x of triangle `prim` (v0, edges e1, e2): barycentrics
// from the point, then the corners' coordinates interpolated.
vec2 triangle_uv(uint prim, vec3 x, vec3 v0, vec3 e1, vec3 e2) {
    vec2 b = triangle_bary(x, v0, e1, e2);
    uint o = TRI_ATTR_STRIDE * prim;
    vec2 t0 = uintBitsToFloat(uvec2(tri_uv[o], tri_uv[o + 1u]));
    vec2 t1 = uintBitsToFloat(uvec2(tri_uv[o + 2u], tri_uv[o + 3u]));
    vec2 t2 = uintBitsToFloat(uvec2(tri_uv[o + 4u], tri_uv[o + 5u]));
    return t0 + b.x * (t1 - t0) + b.y * (t2 - t0);
}

// A unit normal from its two 16-bit octahedral coordinates (src/render/gpu_scene.rs
// pack_normal).
vec3 unpack_normal(uint w) {
    vec2 e = unpackSnorm2x16(w);
    vec3 v = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (v.z < 0.0) {
        v.xy = (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
    }
    return normalize(v);
}

// The shading normal at x of smooth triangle `prim`: its corners' normals interpolated
// (unit); the zero vector for a flat triangle.
vec3 shading_normal(uint prim, vec3 x, vec3 v0, vec3 e1, vec3 e2) {
    uint o = TRI_ATTR_STRIDE * prim + 6u;
    if (tri_uv[o] == 0u) return vec3(0.0);
    vec2 b = triangle_bary(x, v0, e1, e2);
    vec3 n = (1.0 - b.x - b.y) * unpack_normal(tri_uv[o]) + b.x * unpack_normal(tri_uv[o + 1u]) + b.y * unpack_normal(tri_uv[o + 2u]);
    float l = length(n);
    return l > 0.0 ? n / l : vec3(0.0);
}

// The normal at x of normal-mapped triangle `prim` (glTF normalTexture): the texture's
// tangent-space normal (2c − 1, its X and Y × scale) in the frame of the corners' tangents
// (interpolated, made orthogonal to `base`), their bitangent cross(base, t) × sign, and
// `base`; unit. `base` itself where the triangle has no frame (TriUv words 9–12: three
// octahedral tangents, 0 for none, and the signs' bits).
vec3 mapped_normal(uint prim, vec3 x, vec3 v0, vec3 e1, vec3 e2, vec3 base, vec2 uv, uint tex, float scale) {
    uint o = TRI_ATTR_STRIDE * prim + 9u;
    if (tri_uv[o] == 0u) return base;
    vec2 b = triangle_bary(x, v0, e1, e2);
    vec3 w3 = vec3(1.0 - b.x - b.y, b.x, b.y);
    vec3 t = w3.x * unpack_normal(tri_uv[o]) + w3.y * unpack_normal(tri_uv[o + 1u]) + w3.z * unpack_normal(tri_uv[o + 2u]);
    uint signs = tri_uv[o + 3u];
    float w = dot(w3, vec3((signs & 1u) != 0u ? -1.0 : 1.0, (signs & 2u) != 0u ? -1.0 : 1.0, (signs & 4u) != 0u ? -1.0 : 1.0));
    t -= base * dot(base, t);
    float l = length(t);
    if (!(l > 1e-6)) return base;
    t /= l;
    vec3 bt = cross(base, t) * (w < 0.0 ? -1.0 : 1.0);
    vec3 c = 2.0 * sample_texture(tex, uv) - 1.0;
    // Divided by its largest component first: at a scale of 1e20 the length overflowed to
    // ∞ and the map vanished (an audit, 2026-12-07).
    vec3 ts = vec3(scale * c.xy, c.z);
    float big = max(max(abs(ts.x), abs(ts.y)), abs(ts.z));
    if (!(big > 0.0) || isinf(big)) return base;
    ts /= big;
    vec3 n = ts.x * t + ts.y * bt + ts.z * base;
    float ln = length(n);
    return ln > 0.0 ? n / ln : base;
}

#endif
