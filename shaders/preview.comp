#version 450
// The preview window's display pass: the film's mean (or its per-pixel relative standard
// error) at the window's size, exposure-scaled and sRGB-encoded into packed 8-bit pixels
// that the swapchain copies as they are (src/gpu/swapchain.rs). The film may be smaller
// than the window while the camera moves (reduced resolution): nearest-pixel upscale.

layout(local_size_x = 8, local_size_y = 8) in;

struct PixelAccum {
    vec4 sum;
    vec4 sum_sq;
};

layout(std430, set = 0, binding = 0) readonly buffer Accum { PixelAccum accum[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Pixels { uint pixels[]; };

// Mirror of `PreviewParams` in src/abi.rs (checked by tests/layout.rs).
struct PreviewParams {
    uint film_width;
    uint film_height;
    uint out_width;
    uint out_height;
    // radiance_scale × exposure / spp: the mean radiance of a pixel, exposed.
    float mean_scale;
    float spp;
    // 0: image; 1: relative standard error of each pixel's mean (0 → black, ≥ 0.5 → white);
    // 2: the share of the pixel's light samples that came out zero (render.comp counts them
    // in sum.w, all light samples in sum_sq.w).
    uint view;
    // Blue first (B8G8R8A8 swapchains).
    uint bgra;
};
layout(push_constant) uniform Push { PreviewParams params; };

float srgb(float v) {
    v = clamp(isnan(v) || isinf(v) ? 0.0 : v, 0.0, 1.0);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= params.out_width || p.y >= params.out_height) {
        return;
    }
    uint fx = min(p.x * params.film_width / params.out_width, params.film_width - 1);
    uint fy = min(p.y * params.film_height / params.out_height, params.film_height - 1);
    PixelAccum a = accum[fy * params.film_width + fx];
    vec3 c = vec3(0.0);
    if (params.spp > 0.0) {
        if (params.view == 0u) {
            c = a.sum.rgb * params.mean_scale;
        } else if (params.view == 2u) {
            c = vec3(a.sum_sq.w > 0.0 ? a.sum.w / a.sum_sq.w : 0.0);
        } else {
            float n = params.spp;
            float m = dot(a.sum.rgb, vec3(1.0 / 3.0)) / n;
            float m2 = dot(a.sum_sq.rgb, vec3(1.0 / 3.0)) / n;
            float var_mean = n > 1.0 ? max(m2 - m * m, 0.0) / (n - 1.0) : 0.0;
            float rel = sqrt(var_mean) / max(m, 1e-6);
            c = vec3(clamp(rel * 2.0, 0.0, 1.0));
        }
    }
    uvec3 b = uvec3(vec3(srgb(c.r), srgb(c.g), srgb(c.b)) * 255.0 + 0.5);
    uint packed = params.bgra != 0u
        ? (b.b | (b.g << 8) | (b.r << 16) | (255u << 24))
        : (b.r | (b.g << 8) | (b.b << 16) | (255u << 24));
    pixels[p.y * params.out_width + p.x] = packed;
}
