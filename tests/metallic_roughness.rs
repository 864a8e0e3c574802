//! glTF metallicRoughnessTexture: roughness = roughnessFactor × the texture's green, metallic
//! = metallicFactor × its blue, both read as stored (linear, not sRGB). Ignored with a warning
//! (the factors alone) before 2026-12-07. The mutations that drop the texture, swap its two
//! channels or decode it as sRGB each fail the first two tests.

mod common;

use glam::Vec3;
use lightlearn::render::LightSampler;
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::Scene;

/// A floor (x, z in ±2) of base colour 0.8 and `floor` = (metallic, roughness) factors, a grey
/// Lambertian wall behind it and a point light above; `texture`: a metallic-roughness texture
/// (PNG, magFilter) over the floor, u along x (u = 0.5 at x = 0, the image's middle column).
fn scene(floor: (f32, f32), texture: Option<(&[u8], Option<u32>)>) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let m = g.glossy_material("floor", Vec3::splat(0.8), floor.0, floor.1);
    let c = [
        Vec3::new(-2.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, -2.0),
        Vec3::new(-2.0, 0.0, -2.0),
    ];
    let uv = c.map(|p| [(p.x + 2.0) / 4.0, (p.z + 2.0) / 4.0]);
    if let Some((png, mag)) = texture {
        let t = g.texture_png_filtered(png, [33071, 33071], mag);
        g.set_metallic_roughness_texture(m, t);
    }
    g.mesh_uv("floor", &c, Some(&uv), &[0, 1, 2, 0, 2, 3], m);
    let grey = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.quad(
        "wall",
        [
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(2.0, 0.0, -2.0),
            Vec3::new(2.0, 3.0, -2.0),
            Vec3::new(-2.0, 3.0, -2.0),
        ],
        grey,
    );
    g.point_light("bulb", Vec3::new(0.3, 1.2, 0.4), Vec3::ONE, 20.0);
    g.point_light("side", Vec3::new(-1.0, 0.6, 1.0), Vec3::ONE, 5.0);
    g.camera(Vec3::new(0.0, 1.6, 2.6), Vec3::new(0.0, 0.0, 0.0), 1.0);
    g
}

fn render(scene: &Scene, sampler: LightSampler, depth: u32) -> Vec<[f32; 3]> {
    common::render_mean(scene, sampler, (32, 24), depth, 8, 1)
}

fn assert_close(a: &[[f32; 3]], b: &[[f32; 3]], pixels: impl Fn(usize) -> bool, what: &str) {
    let mut compared = 0;
    for (i, (p, q)) in a.iter().zip(b).enumerate().filter(|(i, _)| pixels(*i)) {
        compared += 1;
        for k in 0..3 {
            assert!(
                (p[k] - q[k]).abs() <= 1e-3 * q[k].abs().max(1e-2),
                "{what} pixel {i}: textured {p:?}, factors {q:?}"
            );
        }
    }
    assert!(compared > 100, "{what}: {compared} pixels compared");
}

/// A texture of one texel is its green and blue times the factors: the image of the
/// untextured floor of those factors, to float rounding, in direct light and along paths (the
/// BSDF sample of a path takes the textured values too). Its red (glTF's occlusion slot in
/// packed maps) changes nothing.
#[test]
fn a_uniform_texture_is_its_roughness_and_metallic() {
    let (g, b) = (64u8, 191u8);
    let png = common::png_rgb(1, 1, &[[200, g, b]]);
    let textured = common::load(&scene((1.0, 1.0), Some((&png, None))), "t");
    assert_eq!(textured.textures.len(), 1);
    assert!(textured.textures[0].linear);
    assert_eq!(textured.materials[0].metallic_roughness_texture, Some(0));
    let plain = common::load(
        &scene((b as f32 / 255.0, g as f32 / 255.0), None),
        "factors",
    );
    // The factors alone (the texture dropped) are far from it: the test can tell.
    let untextured = common::load(&scene((1.0, 1.0), None), "untextured");
    for sampler in [LightSampler::Power, LightSampler::Bayes] {
        for depth in [1, 3] {
            let a = render(&textured, sampler, depth);
            let b = render(&plain, sampler, depth);
            assert_close(&a, &b, |_| true, &format!("{sampler:?} depth {depth}"));
            let c = render(&untextured, sampler, depth);
            let diff: f32 = a.iter().zip(&c).map(|(p, q)| (p[0] - q[0]).abs()).sum();
            let total: f32 = a.iter().map(|p| p[0]).sum();
            assert!(
                diff > 0.05 * total,
                "{sampler:?} depth {depth}: {diff} of {total}"
            );
        }
    }
}

/// A two-texel texture (NEAREST): a rough dielectric left half (green 255, blue 0) and a
/// shiny metal right half (green 26, blue 255). Each half of the image is the floor of that
/// half's factors (a non-learning sampler: each pixel its own estimate; the middle columns
/// left out); swapped channels or a mirrored u would show.
#[test]
fn each_half_of_a_two_texel_texture_is_its_own_material() {
    let png = common::png_rgb(2, 1, &[[0, 255, 0], [0, 26, 255]]);
    let textured = common::load(&scene((1.0, 1.0), Some((&png, Some(9728)))), "two");
    let rough = common::load(&scene((0.0, 1.0), None), "rough");
    let shiny = common::load(&scene((1.0, 26.0 / 255.0), None), "shiny");
    for depth in [1, 2] {
        let a = render(&textured, LightSampler::Power, depth);
        let l = render(&rough, LightSampler::Power, depth);
        let r = render(&shiny, LightSampler::Power, depth);
        // In direct light every pixel; along paths the floor's alone (rows 10 on: the wall's
        // foot is at row ~7), as the wall is lit by light off both halves of the floor.
        let rows = |i: usize| depth == 1 || i / 32 >= 10;
        assert_close(
            &a,
            &l,
            |i| rows(i) && i % 32 < 15,
            &format!("left, depth {depth}"),
        );
        assert_close(
            &a,
            &r,
            |i| rows(i) && i % 32 > 16,
            &format!("right, depth {depth}"),
        );
        let differ = l
            .iter()
            .zip(&r)
            .filter(|(p, q)| (p[0] - q[0]).abs() > 0.01 * q[0].max(1e-2))
            .count();
        assert!(
            differ > 100,
            "the two materials look alike ({differ} pixels differ)"
        );
    }
}

/// Read only where it can matter, and on the triangles' one coordinate mapping: a Lambertian
/// material's texture is not loaded; one on another TEXCOORD set than the base-colour
/// texture's is left out with a warning naming the material and the fix.
#[test]
fn a_texture_that_cannot_matter_or_cannot_be_mapped_is_left_out() {
    let png = common::png_rgb(1, 1, &[[0, 128, 128]]);
    let mut g = GltfBuilder::new();
    let lambert = g.material("matte", Vec3::splat(0.5), Vec3::ZERO, false);
    let t = g.texture_png(&png, [10497, 10497]);
    g.set_metallic_roughness_texture(lambert, t);
    g.quad(
        "floor",
        [
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, -1.0),
        ],
        lambert,
    );
    g.point_light("bulb", Vec3::Y, Vec3::ONE, 1.0);
    g.camera(Vec3::new(0.0, 2.0, 2.0), Vec3::ZERO, 1.0);
    let (s, warnings) = common::load_warned(&g.to_glb(), "matte.glb");
    assert!(s.textures.is_empty(), "{:?}", s.textures.len());
    assert_eq!(s.materials[0].metallic_roughness_texture, None);
    assert!(warnings.is_empty(), "{warnings:?}");

    let mut g = scene((1.0, 1.0), Some((&png, None)));
    let base = g.texture_png(&common::png_rgb(1, 1, &[[255, 255, 255]]), [10497, 10497]);
    g.set_base_color_texture(0, base);
    let bytes = common::edit_glb(&g.to_glb(), |j| {
        j["materials"][0]["pbrMetallicRoughness"]["metallicRoughnessTexture"]["texCoord"] =
            serde_json::json!(1);
    });
    let (s, warnings) = common::load_warned(&bytes, "sets.glb");
    assert_eq!(s.materials[0].metallic_roughness_texture, None);
    assert_eq!(s.materials[0].base_color_texture, Some(0));
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("metallicRoughnessTexture")
                && w.contains("material 0 ('floor')")
                && w.contains("give the textures one set")),
        "{warnings:?}"
    );
}
