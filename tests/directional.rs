//! glTF directional lights (KHR_lights_punctual `directional`, the sun): parallel light of
//! irradiance `intensity × color` along the node's −Z, sampled at every path vertex with a
//! shadow ray of its own (shaders/shared/next_event.glsl `sun_light`), beside the light samplers' choice. They
//! were skipped with a warning before 2026-12-07.

mod common;

use glam::Vec3;
use lightlearn::render::LightSampler;
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::Scene;

const ALBEDO: f32 = 0.5;

/// A grey floor over [−1, 1]² seen from straight above (it fills the view), a dim point light
/// (a scene needs a sampled light), and out of view a blocker quad at height 2 over x in
/// [1.5, 2.5]: a sun travelling along (−1, −1, 0) casts its shadow on x in [−0.5, 0.5].
/// `sun`: irradiance of the directional light; `far`: instead of it, a point light that far
/// back along the sun's direction with the intensity that gives the same irradiance.
fn scene(sun: Option<f32>, far: Option<f32>) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(ALBEDO), Vec3::ZERO, false);
    g.quad("floor", common::FLOOR, grey);
    // Faces down (counter-clockwise seen from below).
    g.quad(
        "blocker",
        [
            Vec3::new(1.5, 2.0, -3.0),
            Vec3::new(2.5, 2.0, -3.0),
            Vec3::new(2.5, 2.0, 3.0),
            Vec3::new(1.5, 2.0, 3.0),
        ],
        grey,
    );
    g.point_light("dim", Vec3::new(-0.3, 3.0, 0.2), Vec3::ONE, 0.5);
    let dir = Vec3::new(-1.0, -1.0, 0.0).normalize();
    if let Some(e) = sun {
        g.directional_light("sun", dir, Vec3::new(1.0, 0.9, 0.8), e);
    }
    if let Some(d) = far {
        g.point_light("far sun", -dir * d, Vec3::new(1.0, 0.9, 0.8), 4.0 * d * d);
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

/// Direct light: a sun adds exactly albedo/π · E · cos 45° to every lit floor pixel and
/// nothing in the blocker's shadow (x in [−0.5, 0.5]), with every sampler: it draws no
/// random numbers, so the render without it draws the same samples.
#[test]
fn the_sun_adds_its_closed_form_and_casts_its_shadow() {
    let e = 4.0;
    let with = common::load(&scene(Some(e), None), "sun");
    let without = common::load(&scene(None, None), "no sun");
    assert_eq!(with.directional.len(), 1);
    assert_eq!(with.lights.len(), 1, "the sun is not a sampled light");
    let want = Vec3::new(1.0, 0.9, 0.8) * (ALBEDO / std::f32::consts::PI * e * 0.5f32.sqrt());
    for sampler in [
        LightSampler::Uniform,
        LightSampler::Lightbvh,
        LightSampler::Bayes,
    ] {
        let a = render(&with, sampler, 1, 4, 3);
        let b = render(&without, sampler, 1, 4, 3);
        let (mut lit, mut shade) = (0, 0);
        for (i, (p, q)) in a.iter().zip(&b).enumerate() {
            let d = Vec3::from(*p) - Vec3::from(*q);
            // Pixel centre x on the floor (32 columns over [−1, 1]); skip the columns at
            // the shadow's edges.
            let x = ((i % 32) as f32 + 0.5) / 16.0 - 1.0;
            if x.abs() < 0.45 {
                assert!(
                    d.abs().max_element() <= 1e-5,
                    "{sampler:?} pixel {i} (x {x}) in the shadow: {d}"
                );
                shade += 1;
            } else if x.abs() > 0.55 {
                assert!(
                    (d - want).abs().max_element() <= 1e-4 * want.max_element(),
                    "{sampler:?} pixel {i} (x {x}): the sun added {d}, want {want}"
                );
                lit += 1;
            }
        }
        // 14 columns of 32 pixels each side.
        assert!(lit >= 448 && shade >= 448, "lit {lit}, shaded {shade}");
    }
}

/// Along paths (depth 4: the sun's light bounced off the floor lights the blocker's
/// underside, which lights the floor) a sun renders as a point light 1000 times the scene's
/// size back along its direction with the same irradiance, to that light's 1/1000 spread:
/// the shadow's and the lit part's means within their noise, independent numbers, two seeds
/// each. The sun's scene under `bayes` and `power` (its one sampled light is the dim one);
/// the far light's under `uniform`, which picks the dim light half the time (`power` gives
/// it 1e-7 of the samples: none in a test's count, its light missing from the estimate).
#[test]
fn the_sun_is_a_point_light_at_infinity() {
    let sun = common::load(&scene(Some(4.0), None), "sun");
    let far = common::load(&scene(None, Some(1000.0)), "far");
    let parts = |img: &[[f32; 3]]| {
        let (mut s, mut l, mut ns, mut nl) = (0f64, 0f64, 0, 0);
        for (i, p) in img.iter().enumerate() {
            let x = ((i % 32) as f32 + 0.5) / 16.0 - 1.0;
            if x.abs() < 0.45 {
                s += p[0] as f64;
                ns += 1;
            } else {
                l += p[0] as f64;
                nl += 1;
            }
        }
        [s / ns as f64, l / nl as f64]
    };
    for sampler in [LightSampler::Bayes, LightSampler::Power] {
        let a = [1, 2].map(|s| parts(&render(&sun, sampler, 4, 256, s)));
        let b = [3, 4].map(|s| parts(&render(&far, LightSampler::Uniform, 4, 512, s)));
        for k in 0..2 {
            let var = ((a[0][k] - a[1][k]).powi(2) + (b[0][k] - b[1][k]).powi(2)) / 4.0;
            let (x, y) = ((a[0][k] + a[1][k]) / 2.0, (b[0][k] + b[1][k]) / 2.0);
            let z = (x - y) / var.max(1e-30).sqrt();
            assert!(
                z.abs() < 5.0 && (x - y).abs() < 0.02 * y,
                "{sampler:?} part {k}: sun {x}, far point light {y} (z {z:.1})"
            );
        }
        assert!(a[0][1] > 3.0 * a[0][0], "no shadow: {:?}", a[0]);
    }
}

/// A scene lit by suns alone is refused naming what to add (the samplers need a light to
/// choose); a sun of zero intensity is skipped with a warning; a sun's report and message
/// say it is there.
#[test]
fn suns_alone_are_refused_and_counted() {
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.quad("floor", common::FLOOR, grey);
    g.directional_light("sun", Vec3::NEG_Y, Vec3::ONE, 3.0);
    let dir = tempfile::tempdir().unwrap();
    let alone = dir.path().join("alone.glb");
    std::fs::write(&alone, g.to_glb()).unwrap();
    let o = common::run_in(
        &[
            "render",
            alone.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            "a.exr",
        ],
        dir.path(),
        &[],
    );
    common::refused(
        &o,
        &[
            "has only directional lights (1)",
            "at least one point, spot or emissive light",
        ],
    );
    let mut g = scene(Some(2.0), None);
    g.directional_light("dark sun", Vec3::NEG_Y, Vec3::ONE, 0.0);
    let path = dir.path().join("sun.glb");
    std::fs::write(&path, g.to_glb()).unwrap();
    let o = common::run_in(
        &[
            "render",
            path.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "2",
            "--out",
            "s.exr",
        ],
        dir.path(),
        &[],
    );
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("'dark sun') has zero intensity; skipped"),
        "{err}"
    );
    assert!(err.contains("1 lights + 1 directional"), "{err}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("s.json")).unwrap()).unwrap();
    assert_eq!(report["directional_lights"], 1, "{report}");
}

/// An animated sun turns with its node: from the blocker's side (its shadow on the floor's
/// middle) to the other side (no shadow), so frame 1's middle is lit and frame 1 records that
/// the lights moved.
#[test]
fn an_animated_sun_turns_with_its_node() {
    let mut g = scene(None, None);
    let [a, b] = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0)]
        .map(|d| glam::Quat::from_rotation_arc(Vec3::NEG_Z, d.normalize()));
    g.directional_light("sun", a * Vec3::NEG_Z, Vec3::ONE, 4.0);
    let node = g.last_node();
    g.animate(
        node,
        "rotation",
        &[0.0, 1.0],
        &[a.to_array().to_vec(), b.to_array().to_vec()],
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sun.glb");
    std::fs::write(&path, g.to_glb()).unwrap();
    let out = dir.path().join("frames");
    let o = common::run_in(
        &[
            "animate",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--fps",
            "1",
            "--spp",
            "4",
            "--width",
            "32",
            "--height",
            "32",
            "--max-depth",
            "1",
            "--no-video",
            "-q",
        ],
        dir.path(),
        &[],
    );
    assert!(o.status.success(), "{}", common::stderr(&o));
    let middle = |k: u32| {
        let img = lightlearn::film::read_exr(&out.join(format!("frame-{k:04}.exr")))
            .unwrap()
            .2;
        let cols = img
            .iter()
            .enumerate()
            .filter(|(i, _)| (12..20).contains(&(i % 32)));
        cols.map(|(_, p)| p[0] as f64).sum::<f64>() / (8 * 32) as f64
    };
    let (m0, m1) = (middle(0), middle(1));
    assert!(m1 > 10.0 * m0, "the middle: frame 0 {m0}, frame 1 {m1}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("animation.json")).unwrap()).unwrap();
    assert_eq!(summary["frames"][1]["moved"]["lights"], true, "{summary}");
}

/// The kernels' units count the suns: a sun of 1000 beside a point light of 1e-36 W/sr was
/// scaled by the point light's 2^120 into an EXR of Inf (exit 0), and a sun of 1e10 beside
/// one of 1e-30 rendered black (an audit, 2026-12-07). Both now render the sun's closed form
/// (the point light's share is below f32's reach).
#[test]
fn a_bright_sun_beside_a_faint_light_renders() {
    for (point, sun) in [(1e-36f32, 1e3f32), (1e-30, 1e10)] {
        // The dim light (the builder's first) made faint, and a sun added.
        let g = scene(None, None);
        let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
        doc["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = point.into();
        let dir = Vec3::new(-1.0, -1.0, 0.0).normalize();
        let rot = glam::Quat::from_rotation_arc(Vec3::NEG_Z, dir);
        let lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
            .as_array_mut()
            .unwrap();
        lights.push(
            serde_json::json!({"type": "directional", "color": [1.0, 1.0, 1.0], "intensity": sun}),
        );
        let n = lights.len() - 1;
        let nodes = doc["nodes"].as_array_mut().unwrap();
        nodes.push(
            serde_json::json!({"name": "sun", "rotation": rot.to_array(),
            "extensions": {"KHR_lights_punctual": {"light": n}}}),
        );
        let k = nodes.len() - 1;
        doc["scenes"][0]["nodes"]
            .as_array_mut()
            .unwrap()
            .push(k.into());
        let (s, _) = common::load_warned(doc.to_string().as_bytes(), "faint.gltf");
        let img = render(&s, LightSampler::Bayes, 1, 2, 1);
        let want = ALBEDO / std::f32::consts::PI * sun * 0.5f32.sqrt();
        // A lit pixel (x > 0.55) and a shaded one.
        let (lit, shade) = (img[28][0], img[16][0]);
        assert!(
            (lit - want).abs() <= 1e-4 * want,
            "point {point}, sun {sun}: lit {lit}, want {want}"
        );
        assert!(
            shade.is_finite() && shade < 1e-6 * want,
            "point {point}, sun {sun}: shade {shade}"
        );
    }
}
