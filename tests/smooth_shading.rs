//! Smooth shading: glTF vertex normals (NORMAL) that differ from their triangle's own are
//! interpolated into the shading normal (texture.glsl `shading_normal`), turned to the side
//! the ray arrives from; rays still leave by the triangle's own side, and light below it is
//! refused by the light sample and by the BSDF ray alike. Flat-shaded until 2026-12-07 (a
//! sphere 20.5 % off Mitsuba 3's smooth render, warned about since the twenty-ninth session).

mod common;

use glam::Vec3;
use lightlearn::render::LightSampler;
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::Scene;

const ALBEDO: f32 = 0.5;

/// A grey floor over [−1, 1]² seen from straight above, its corners' normals `normals` (None:
/// no NORMAL), a dim point light, and a sun from straight above of irradiance `sun`; an
/// emissive panel `panel` (over x in [1.2, 2.2] at height 1, facing down) where asked.
fn scene(normals: Option<[Vec3; 4]>, sun: Option<f32>, panel: bool) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(ALBEDO), Vec3::ZERO, false);
    let c = common::FLOOR;
    g.mesh_with(
        "floor",
        &c,
        None,
        normals.as_ref().map(|n| &n[..]),
        &[0, 1, 2, 0, 2, 3],
        grey,
    );
    g.point_light("dim", Vec3::new(-0.3, 3.0, 0.2), Vec3::ONE, 0.5);
    if let Some(e) = sun {
        g.directional_light("sun", Vec3::NEG_Y, Vec3::ONE, e);
    }
    if panel {
        let lamp = g.material("lamp", Vec3::ZERO, Vec3::splat(3.0), false);
        g.quad(
            "panel",
            [
                Vec3::new(1.2, 1.0, -1.0),
                Vec3::new(2.2, 1.0, -1.0),
                Vec3::new(2.2, 1.0, 1.0),
                Vec3::new(1.2, 1.0, 1.0),
            ],
            lamp,
        );
        // Facing up just below the floor's plane, beside it: within the bent normals'
        // hemispheres (they reach 25° below the horizon) but under the floor itself, so no
        // light of it may reach the floor's top.
        g.quad(
            "low panel",
            [
                Vec3::new(-3.2, -0.05, 1.0),
                Vec3::new(-1.2, -0.05, 1.0),
                Vec3::new(-1.2, -0.05, -1.0),
                Vec3::new(-3.2, -0.05, -1.0),
            ],
            lamp,
        );
    }
    g.camera(
        Vec3::new(0.0, 40.0, 1e-3),
        Vec3::ZERO,
        2.0 * (1.0f32 / 40.0).atan(),
    );
    g
}

fn render(scene: &Scene, sampler: LightSampler, depth: u32, spp: u32, seed: u32) -> Vec<[f32; 3]> {
    common::render_mean(scene, sampler, (32, 32), depth, spp, seed)
}

fn tilted(deg: f32) -> Vec3 {
    let t = deg.to_radians();
    Vec3::new(t.sin(), t.cos(), 0.0)
}

/// A floor whose normals all lean 30° shades by them: a sun from straight above adds
/// albedo/π · E · cos 30° to every pixel (flat: cos 0°), to 1e-3 (the normals' 16-bit
/// packing), whether the normals point up or down (the kernel turns them to the side it
/// shades). Normals that are the floor's own keep it flat (no shading normals), and flat
/// triangles in a smooth scene render the same bits as in a flat one.
#[test]
fn a_leaning_normal_shades_by_its_cosine() {
    let e = 4.0;
    for (normal, cos) in [
        (tilted(30.0), 30f32.to_radians().cos()),
        (-tilted(30.0), 30f32.to_radians().cos()),
    ] {
        // Normals against the winding are said (and shaded as if they agreed).
        let load = |g: &GltfBuilder, name: &str| {
            let (s, w) = common::load_warned(&g.to_glb(), name);
            assert_eq!(w.len(), (normal.y < 0.0) as usize, "{w:?}");
            s
        };
        let with = load(&scene(Some([normal; 4]), Some(e), false), "sun");
        let without = load(&scene(Some([normal; 4]), None, false), "no sun");
        assert_eq!(with.triangle_normals.len(), 2, "smooth triangles");
        let want = ALBEDO / std::f32::consts::PI * e * cos;
        for sampler in [LightSampler::Uniform, LightSampler::Bayes] {
            let a = render(&with, sampler, 1, 4, 3);
            let b = render(&without, sampler, 1, 4, 3);
            for (i, (p, q)) in a.iter().zip(&b).enumerate() {
                let d = p[0] - q[0];
                assert!(
                    (d - want).abs() <= 1e-3 * want,
                    "{sampler:?} normal {normal} pixel {i}: the sun added {d}, want {want} (flat: {})",
                    want / cos
                );
            }
        }
    }
    let flat = common::load(&scene(Some([Vec3::Y; 4]), Some(e), false), "flat");
    assert!(flat.triangle_normals.is_empty(), "flat normals kept");
    // Flat triangles under the smooth kernel: a smooth quad hidden far below makes the
    // scene smooth (TRI_ATTR_STRIDE 9, the flat marker on the floor's triangles); the floor
    // renders the same bits as beside the same quad without normals, paths included.
    let with_hidden = |normals: Option<[Vec3; 4]>| {
        let mut g = scene(None, Some(e), false);
        let grey = g.material("hidden", Vec3::splat(ALBEDO), Vec3::ZERO, false);
        let c = [
            Vec3::new(-1.0, -50.0, -1.0),
            Vec3::new(1.0, -50.0, -1.0),
            Vec3::new(1.0, -50.0, 1.0),
            Vec3::new(-1.0, -50.0, 1.0),
        ];
        let n = normals.as_ref().map(|n| &n[..]);
        g.mesh_with("hidden", &c, None, n, &[0, 1, 2, 0, 2, 3], grey);
        common::load(&g, "hidden")
    };
    let smooth = with_hidden(Some([tilted(20.0), -Vec3::Y, -Vec3::Y, tilted(-20.0)]));
    let plain = with_hidden(None);
    assert!(smooth.triangle_normals.iter().any(|n| n[0] != Vec3::ZERO));
    assert!(plain.triangle_normals.is_empty());
    for depth in [1, 3] {
        assert!(
            render(&smooth, LightSampler::Bayes, depth, 4, 1)
                == render(&plain, LightSampler::Bayes, depth, 4, 1),
            "flat triangles rendered otherwise under the smooth kernel at depth {depth}"
        );
    }
}

/// Light sampling and BSDF sampling agree under bent normals (each corner leaning 25°
/// outwards, a dome's shading on a flat floor, lit by an emissive panel beside it and the
/// dim light, with a panel just below the floor's plane that must not light it): at depth 3 (MIS between the two at every vertex) `uniform`, `lightbvh` and
/// `bayes` give the same halves' means within their noise, and direct light alone (light
/// sampling only) the same as `uniform` at depth 2 (MIS) for the direct part: both strategies
/// see the same integrand, f · cos by the shading normal over the directions above both
/// normals.
#[test]
fn bent_normals_keep_the_estimators_in_agreement() {
    let out = |x: f32, z: f32| {
        let t = 25f32.to_radians();
        Vec3::new(x * t.sin(), t.cos(), z * t.sin()).normalize()
    };
    let normals = [
        out(-1.0, -1.0),
        out(-1.0, 1.0),
        out(1.0, 1.0),
        out(1.0, -1.0),
    ];
    let s = common::load(&scene(Some(normals), None, true), "dome");
    let smooth = s
        .triangle_normals
        .iter()
        .filter(|n| n[0] != Vec3::ZERO)
        .count();
    assert_eq!(
        smooth, 2,
        "the floor's two triangles are smooth, the panels' flat"
    );
    let halves = |img: &[[f32; 3]]| {
        let (mut l, mut r) = (0f64, 0f64);
        for (i, p) in img.iter().enumerate() {
            if i % 32 < 16 {
                l += p[0] as f64;
            } else {
                r += p[0] as f64;
            }
        }
        [l / 512.0, r / 512.0]
    };
    let mean_and_var = |sampler, depth, spp, seeds: [u32; 2]| {
        let h = seeds.map(|seed| halves(&render(&s, sampler, depth, spp, seed)));
        [0, 1].map(|k| ((h[0][k] + h[1][k]) / 2.0, (h[0][k] - h[1][k]).powi(2) / 4.0))
    };
    let base = mean_and_var(LightSampler::Uniform, 3, 1024, [1, 2]);
    for (sampler, depth, spp) in [
        (LightSampler::Lightbvh, 3, 1024),
        (LightSampler::Bayes, 3, 1024),
    ] {
        let other = mean_and_var(sampler, depth, spp, [3, 4]);
        for k in 0..2 {
            let z = (other[k].0 - base[k].0) / (other[k].1 + base[k].1).max(1e-30).sqrt();
            assert!(
                z.abs() < 5.0 && (other[k].0 - base[k].0).abs() < 0.02 * base[k].0,
                "{sampler:?} depth {depth} half {k}: {} against uniform's {} (z {z:.1})",
                other[k].0,
                base[k].0
            );
        }
    }
    // Direct light: light sampling alone (depth 1) against MIS with the BSDF ray (depth 2).
    let d1 = mean_and_var(LightSampler::Uniform, 1, 2048, [5, 6]);
    let d2 = mean_and_var(LightSampler::Uniform, 2, 2048, [7, 8]);
    for k in 0..2 {
        let z = (d1[k].0 - d2[k].0) / (d1[k].1 + d2[k].1).max(1e-30).sqrt();
        assert!(
            z.abs() < 5.0 && (d1[k].0 - d2[k].0).abs() < 0.02 * d2[k].0,
            "half {k}: light sampling {} against MIS {} (z {z:.1})",
            d1[k].0,
            d2[k].0
        );
    }
}
