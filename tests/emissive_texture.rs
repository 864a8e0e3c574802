//! glTF emissive textures: emission = emissiveFactor × the texture (sRGB decoded) at the
//! point a light sample draws and at the point a ray hits. They were ignored with a warning
//! (the factor alone) before 2026-12-07: the uniform orange emitter below lit its room white,
//! the two-tone one as if lit all over. The mutations that drop the texture at the light
//! sample or at an emitter a ray hits each fail the first two tests.

mod common;

use glam::Vec3;
use lightlearn::render::LightSampler;
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::Scene;

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A grey floor, a grey wall beside it (light reaches the floor by a bounce too) and a
/// black-based emitter quad of radiance `emission` over x in `x` (z in ±1) at height 1.5,
/// facing down; `texture`: an emissive texture (PNG, magFilter) over the whole quad (u along
/// x from −1 to 1). The camera sees the floor and the emitter's underside.
fn scene(emission: Vec3, x: (f32, f32), texture: Option<(&[u8], Option<u32>)>) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.quad(
        "floor",
        [
            Vec3::new(-3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, -3.0),
            Vec3::new(-3.0, 0.0, -3.0),
        ],
        grey,
    );
    g.quad(
        "wall",
        [
            Vec3::new(-3.0, 0.0, -3.0),
            Vec3::new(3.0, 0.0, -3.0),
            Vec3::new(3.0, 3.0, -3.0),
            Vec3::new(-3.0, 3.0, -3.0),
        ],
        grey,
    );
    let lamp = g.material("lamp", Vec3::ZERO, emission, false);
    let c = [
        Vec3::new(x.0, 1.5, -1.0),
        Vec3::new(x.1, 1.5, -1.0),
        Vec3::new(x.1, 1.5, 1.0),
        Vec3::new(x.0, 1.5, 1.0),
    ];
    // u from the quad's x in [−1, 1] (the whole texture over the full quad).
    let uv = c.map(|p| [(p.x + 1.0) / 2.0, (p.z + 1.0) / 2.0]);
    if let Some((png, mag)) = texture {
        let t = g.texture_png_filtered(png, [33071, 33071], mag);
        g.set_emissive_texture(lamp, t);
    }
    g.mesh_uv("lamp", &c, Some(&uv), &[0, 1, 2, 0, 2, 3], lamp);
    g.camera(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 0.8, 0.0), 1.3);
    g
}

fn render(scene: &Scene, sampler: LightSampler, depth: u32, spp: u32, seed: u32) -> Vec<[f32; 3]> {
    common::render_mean(scene, sampler, (32, 24), depth, spp, seed)
}

fn mean(img: &[[f32; 3]]) -> f64 {
    img.iter().map(|p| p[0] as f64).sum::<f64>() / img.len() as f64
}

/// A texture of one colour is that colour times the factor: the same image as the
/// untextured emitter of factor × colour, to float rounding, with every sampler, in direct
/// light and along paths (an emitter hit by a BSDF ray, with its MIS weight).
#[test]
fn a_uniform_emissive_texture_is_its_colour() {
    let c = [255u8, 128, 64];
    let lin = Vec3::from_array(c.map(|v| srgb_to_linear(v as f32 / 255.0)));
    let png = common::png_rgb(1, 1, &[c]);
    let textured = common::load(
        &scene(Vec3::splat(3.0), (-1.0, 1.0), Some((&png, None))),
        "t",
    );
    let plain = common::load(&scene(3.0 * lin, (-1.0, 1.0), None), "p");
    assert_eq!(textured.textures.len(), 1);
    assert_eq!(textured.materials[1].emissive_texture, Some(0));
    for sampler in [
        LightSampler::Uniform,
        LightSampler::Power,
        LightSampler::Lightbvh,
        LightSampler::Wang,
        LightSampler::Bayes,
    ] {
        for depth in [1, 3] {
            let a = render(&textured, sampler, depth, 8, 1);
            let b = render(&plain, sampler, depth, 8, 1);
            for (i, (p, q)) in a.iter().zip(&b).enumerate() {
                for k in 0..3 {
                    assert!(
                        (p[k] - q[k]).abs() <= 1e-4 * q[k].abs().max(1e-3),
                        "{sampler:?} depth {depth} pixel {i}: textured {p:?}, plain {q:?}"
                    );
                }
            }
            assert!(mean(&a) > 0.0);
        }
    }
}

/// A two-tone emitter (black left half, white right half, NEAREST) lights the room as an
/// emitter of its right half alone: light samples draw points over the whole quad and the
/// texture zeroes the left ones, so only the estimate's mean can be compared. Independent
/// numbers, two seeds' difference for the noise; the floor's halves apart too (a texture
/// mirrored in u would light the left). Each triangle of the quad spans both colours.
#[test]
fn a_two_tone_emitter_lights_as_its_lit_half() {
    let png = common::png_rgb(2, 1, &[[0, 0, 0], [255, 255, 255]]);
    let textured = common::load(
        &scene(Vec3::splat(4.0), (-1.0, 1.0), Some((&png, Some(9728)))),
        "two-tone",
    );
    let half = common::load(&scene(Vec3::splat(4.0), (0.0, 1.0), None), "half");
    // Halves of the image (columns), as means.
    let halves = |img: &[[f32; 3]]| {
        let (mut l, mut r) = (0f64, 0f64);
        for (i, p) in img.iter().enumerate() {
            if i % 32 < 16 {
                l += p[0] as f64;
            } else {
                r += p[0] as f64;
            }
        }
        [l / (img.len() / 2) as f64, r / (img.len() / 2) as f64]
    };
    for (sampler, depth, spp) in [
        (LightSampler::Power, 1, 2048),
        (LightSampler::Bayes, 1, 2048),
        (LightSampler::Bayes, 3, 512),
        (LightSampler::Lightbvh, 3, 512),
    ] {
        let t = [1, 2].map(|s| halves(&render(&textured, sampler, depth, spp, s)));
        let h = [3, 4].map(|s| halves(&render(&half, sampler, depth, spp, s)));
        for side in 0..2 {
            // The noise of one render's half-image mean, from each pair's difference.
            let var = ((t[0][side] - t[1][side]).powi(2) + (h[0][side] - h[1][side]).powi(2)) / 4.0;
            let (a, b) = (
                (t[0][side] + t[1][side]) / 2.0,
                (h[0][side] + h[1][side]) / 2.0,
            );
            let z = (a - b) / var.max(1e-30).sqrt();
            assert!(
                z.abs() < 5.0 && (a - b).abs() < 0.03 * b,
                "{sampler:?} depth {depth} side {side}: textured {a}, right half alone {b} (z {z:.1})"
            );
        }
        assert!(
            t[0][1] > 1.5 * t[0][0],
            "the lit half is not on the right: {:?}",
            t[0]
        );
    }
}

/// The light's power follows the texture (every sampler's pmf): a black texture keeps a
/// floor of 1e-3 of the untextured power, so it stays samplable; the power of a white
/// texture is the untextured one.
#[test]
fn an_emitters_power_follows_its_texture() {
    let white = common::png_rgb(1, 1, &[[255, 255, 255]]);
    let black = common::png_rgb(1, 1, &[[0, 0, 0]]);
    let power = |png: Option<&[u8]>| {
        let s = common::load(
            &scene(Vec3::splat(2.0), (-1.0, 1.0), png.map(|p| (p, None))),
            "p",
        );
        s.light_power(&s.lights[0])
    };
    let (plain, w, b) = (power(None), power(Some(&white)), power(Some(&black)));
    assert!((w - plain).abs() <= 1e-6 * plain, "{w} vs {plain}");
    assert!((b / plain - 1e-3).abs() < 1e-6, "{b} vs {plain}");
    // The colour multiplies before the luminance: a blue factor over a blue texture is the
    // blue factor's power (it was luminance × luminance: 1/14 of it; an audit, 2026-12-07).
    let blue = |png: Option<&[u8]>| {
        let s = common::load(
            &scene(
                Vec3::new(0.0, 0.0, 2.0),
                (-1.0, 1.0),
                png.map(|p| (p, None)),
            ),
            "b",
        );
        s.light_power(&s.lights[0])
    };
    let (plain, tex) = (
        blue(None),
        blue(Some(&common::png_rgb(1, 1, &[[0, 0, 255]]))),
    );
    assert!((tex - plain).abs() <= 1e-6 * plain, "{tex} vs {plain}");
}

/// An emissive texture on another coordinate set than the base colour's is left out, said
/// (a triangle holds one set); an emissive texture on a material that emits nothing changes
/// nothing and is not read.
#[test]
fn an_emissive_texture_on_another_set_is_named() {
    let png = common::png_rgb(1, 1, &[[255, 0, 0]]);
    let mut g = scene(Vec3::splat(2.0), (-1.0, 1.0), Some((&png, None)));
    let t = g.texture_png(&png, [10497, 10497]);
    g.set_base_color_texture(1, t);
    let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
    doc["materials"][1]["emissiveTexture"]["texCoord"] = 1.into();
    let (s, warnings) = common::load_warned(doc.to_string().as_bytes(), "sets.gltf");
    assert_eq!(s.materials[1].emissive_texture, None);
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("emissive texture reads TEXCOORD_1")
                && w.contains("base-colour texture TEXCOORD_0")),
        "{warnings:?}"
    );
    let mut g = scene(Vec3::splat(2.0), (-1.0, 1.0), None);
    let t = g.texture_png(&png, [10497, 10497]);
    g.set_emissive_texture(0, t);
    let s = common::load(&g, "dark");
    assert_eq!(s.materials[0].emissive_texture, None);
}

/// An emissive texture on a mesh without TEXCOORD_0 renders (sampled at (0, 0), said),
/// also where no triangle of the scene has coordinates: the loader keeps zeros for them.
#[test]
fn an_emissive_texture_without_coordinates_renders() {
    let png = common::png_rgb(1, 1, &[[255, 128, 64]]);
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.quad(
        "floor",
        [
            Vec3::new(-3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, -3.0),
            Vec3::new(-3.0, 0.0, -3.0),
        ],
        grey,
    );
    let lamp = g.material("lamp", Vec3::ZERO, Vec3::splat(2.0), false);
    let t = g.texture_png(&png, [10497, 10497]);
    g.set_emissive_texture(lamp, t);
    g.quad(
        "lamp",
        [
            Vec3::new(-1.0, 1.5, -1.0),
            Vec3::new(1.0, 1.5, -1.0),
            Vec3::new(1.0, 1.5, 1.0),
            Vec3::new(-1.0, 1.5, 1.0),
        ],
        lamp,
    );
    g.camera(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 0.8, 0.0), 1.3);
    let (s, w) = common::load_warned(&g.to_glb(), "no-uv");
    assert!(w.iter().any(|w| w.contains("no TEXCOORD_0")), "{w:?}");
    let img = render(&s, LightSampler::Bayes, 2, 2, 1);
    assert!(mean(&img) > 0.0);
}

/// A negative emissiveFactor times a negative emissiveStrength is refused, not rendered as
/// the positive product (it passed the product's check: a review, 2026-12-07).
#[test]
fn negative_emission_factors_are_refused() {
    let g = scene(Vec3::splat(1.0), (-1.0, 1.0), None);
    let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
    let lamp = &mut doc["materials"][1];
    lamp["emissiveFactor"] = serde_json::json!([-1.0, -1.0, -1.0]);
    lamp["extensions"]["KHR_materials_emissive_strength"] =
        serde_json::json!({"emissiveStrength": -2.0});
    let err = lightlearn::scene::gltf_load::load_bytes(
        doc.to_string().as_bytes(),
        "negative.gltf",
        std::path::Path::new("."),
        &mut |_| {},
    )
    .map(|_| ())
    .expect_err("refused");
    assert!(
        format!("{err:#}").contains("negative emissiveFactor"),
        "{err:#}"
    );
}
