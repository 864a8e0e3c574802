//! Hostile data through the library: damaged statistics files, fuzzed glTF, scenes far from
//! the unit scale or the origin, emission near the f32 limits, and the commit of a set of
//! output files. Each test failed on the code before its fix (see the README's robustness
//! section for what each caught).

mod common;

use std::path::Path;

use lightlearn::accel::Bvh;
use lightlearn::gpu::layout::SlotStats;
use lightlearn::learning::stats_file::SavedStats;
use lightlearn::render::{
    self, Budget, GpuScene, LightPoint, LightSampler, RenderResult, RenderSettings,
};
use lightlearn::rng::SplitMix64;
use lightlearn::scene::{gltf_load, Scene};

fn cornell_bytes() -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb")).unwrap()
}

fn load(bytes: &[u8]) -> anyhow::Result<Scene> {
    gltf_load::load_bytes(bytes, "test.glb", Path::new("."), &mut |_| {})
}

fn settings(sampler: LightSampler, spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: 24,
        height: 18,
        budget: Budget::Samples(spp),
        seed: 5,
        sampler,
        regions: Default::default(),
        learn: Default::default(),
        resume: None,
        stratify: lightlearn::render::Stratify::Sobol,
        max_depth,
        light_point: Default::default(),
        indirect_light_samples: 1,
        first_light_samples: 1,
    }
}

fn render_scene(scene: &Scene, s: &RenderSettings) -> RenderResult {
    let ctx = common::ctx();
    let gpu = GpuScene::upload(&ctx, scene, &Bvh::build(&scene.triangles)).unwrap();
    render::render(&ctx, scene, &gpu, s, &mut |_, _| {}).unwrap()
}

/// cornell under a new root node with `node` (a TRS), its punctual intensities × `k`.
fn transformed(node: serde_json::Value, k: f64) -> Vec<u8> {
    common::edit_glb(&cornell_bytes(), |j| {
        let roots = j["scenes"][0]["nodes"].clone();
        let mut root = node;
        root["children"] = roots;
        let nodes = j["nodes"].as_array_mut().unwrap();
        nodes.push(root);
        j["scenes"][0]["nodes"] = serde_json::json!([nodes.len() - 1]);
        if let Some(lights) = j["extensions"]["KHR_lights_punctual"]["lights"].as_array_mut() {
            for l in lights {
                l["intensity"] = (l["intensity"].as_f64().unwrap_or(1.0) * k).into();
            }
        }
    })
}

/// Relative MSE between two images of the same scene (÷ (b² + 0.01), as the reports).
fn rel_mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let mut e = 0.0;
    for (p, q) in a.iter().zip(b) {
        for k in 0..3 {
            e += (p[k] as f64 - q[k] as f64).powi(2) / ((q[k] as f64).powi(2) + 0.01);
        }
    }
    e / (3 * a.len()) as f64
}

fn mean(img: &[[f32; 3]]) -> f64 {
    img.iter().flatten().map(|&v| v as f64).sum::<f64>() / (3 * img.len()) as f64
}

/// Scaling a scene by s (punctual intensities × s², so the image stays the same) or moving it
/// by 1e7 gives the same image, within the noise of the two renders. Before: × 8e6 rendered
/// black (the camera's target, position + forward in f32, collapsed onto its position), a
/// 1e7 offset lost most light, and × 1e-3 had 75× the relMSE with lightbvh.
#[test]
fn scale_and_offset_leave_the_image_unchanged() {
    // Both ways of drawing a point on the ceiling panel: the solid angle's lengths and
    // triple product span 1e-12 … 1e21 here.
    for light_point in [LightPoint::Area, LightPoint::SolidAngle] {
        let mut s = settings(LightSampler::Lightbvh, 64, 2);
        s.light_point = light_point;
        eprintln!("--light-point {light_point:?}");
        scale_and_offset_leave_the_image_unchanged_with(&s);
    }
}

fn scale_and_offset_leave_the_image_unchanged_with(s: &RenderSettings) {
    let base = render_scene(&load(&cornell_bytes()).unwrap(), s);
    let base_image = base.mean();
    let (_, base_noise) = base.estimated_error();
    assert!(mean(&base_image) > 0.01);
    let cases = [
        (
            "scale 1e-4",
            serde_json::json!({"scale": [1e-4, 1e-4, 1e-4]}),
            1e-8,
        ),
        (
            "scale 1e-2",
            serde_json::json!({"scale": [1e-2, 1e-2, 1e-2]}),
            1e-4,
        ),
        (
            "scale 8e6",
            serde_json::json!({"scale": [8e6, 8e6, 8e6]}),
            6.4e13,
        ),
        (
            "scale 1e7",
            serde_json::json!({"scale": [1e7, 1e7, 1e7]}),
            1e14,
        ),
        (
            "offset 1e7",
            serde_json::json!({"translation": [1e7, -5e6, 2.5e6]}),
            1.0,
        ),
    ];
    let mut failed = Vec::new();
    for (what, node, k) in cases {
        let scene = load(&transformed(node, k)).unwrap();
        let r = render_scene(&scene, s);
        let img = r.mean();
        let ratio = mean(&img) / mean(&base_image);
        let e = rel_mse(&img, &base_image);
        let (_, noise) = r.estimated_error();
        eprintln!(
            "{what}: mean ratio {ratio:.5}, relMSE to the unscaled image {e:.2e} (noise of the two {:.2e})",
            noise + base_noise
        );
        // Independent noise of two renders adds: the difference is of that size, no more;
        // and the scaled scene is sampled as well as the original.
        let ok = r.invalid_samples == 0
            && (ratio - 1.0).abs() < 0.03
            && e < 2.0 * (noise + base_noise)
            && noise < 2.0 * base_noise;
        if !ok {
            failed.push(format!(
                "{what}: mean ratio {ratio}, relMSE {e:.3e}, noise {noise:.3e} (unscaled {base_noise:.3e}), {} NaN",
                r.invalid_samples
            ));
        }
    }
    assert!(failed.is_empty(), "{:?}: {failed:#?}", s.light_point);
}

/// Emission near the top of the f32 range renders without a NaN and scales the image exactly
/// as the emission; beyond it, the scene is refused. Before: emissiveStrength 1e25 with
/// `bayes` dropped 11 % of the samples as NaN/Inf (exit 0, a biased image).
#[test]
fn huge_emission_renders_unbiased_or_is_refused() {
    let scaled = |k: f64| {
        common::edit_glb(&cornell_bytes(), |j| {
            for m in j["materials"].as_array_mut().unwrap() {
                let lit = m["emissiveFactor"]
                    .as_array()
                    .is_some_and(|e| e.iter().any(|c| c.as_f64().unwrap() > 0.0));
                if lit {
                    m["extensions"]["KHR_materials_emissive_strength"] =
                        serde_json::json!({"emissiveStrength": k});
                }
            }
            j["extensionsUsed"]
                .as_array_mut()
                .unwrap()
                .push("KHR_materials_emissive_strength".into());
            for l in j["extensions"]["KHR_lights_punctual"]["lights"]
                .as_array_mut()
                .unwrap()
            {
                l["intensity"] = (l["intensity"].as_f64().unwrap_or(1.0) * k).into();
            }
        })
    };
    let s = settings(LightSampler::Bayes, 8, 3);
    let base = render_scene(&load(&scaled(1.0)).unwrap(), &s).mean();
    for k in [1e25, 1e30, 1e-30] {
        let r = render_scene(&load(&scaled(k)).unwrap(), &s);
        assert_eq!(r.invalid_samples, 0, "emission × {k:e}");
        let ratio = mean(&r.mean()) / (k * mean(&base));
        assert!(
            (ratio - 1.0).abs() < 1e-3,
            "emission × {k:e}: ratio {ratio}"
        );
        let (mse, _) = r.estimated_error();
        assert!(mse.is_finite(), "emission × {k:e}: estimated MSE {mse}");
    }
    let err = load(&scaled(3e38)).unwrap_err().to_string();
    assert!(err.contains("32-bit floats"), "{err}");
}

/// A real statistics file of a small bayes render of cornell.
fn saved_stats() -> (Scene, SavedStats, Vec<u8>) {
    let scene = load(&cornell_bytes()).unwrap();
    let r = render_scene(&scene, &settings(LightSampler::Bayes, 4, 1));
    let saved = r.learned.unwrap().saved;
    let bytes = saved.to_bytes();
    (scene, saved, bytes)
}

/// Every single-bit flip of a statistics file is refused with a message naming the file (the
/// checksum), and a file that is whole but holds impossible values is refused by
/// `check_cuts`. Before: a flip in the cut section panicked (`range end index … out of
/// range` in src/learning/mod.rs) and NaN totals reached the image.
#[test]
fn damaged_statistics_files_are_refused() {
    let (scene, saved, bytes) = saved_stats();
    let ctx = common::ctx();
    let gpu = GpuScene::upload(&ctx, &scene, &Bvh::build(&scene.triangles)).unwrap();
    let s = settings(LightSampler::Bayes, 4, 1);
    let ok = SavedStats::from_bytes(&bytes, "a.stats").unwrap();
    render::check_resume(&scene, &gpu, &s, &ok, Path::new("a.stats")).unwrap();

    // Flips spread over the file: header, region index, cuts, totals and checksum.
    let mut rng = SplitMix64(11);
    let mut cases = 0;
    for i in 0..300 {
        let at = if i < 100 {
            (i * 37) % 200
        } else {
            (rng.next_u64() % bytes.len() as u64) as usize
        };
        let mut b = bytes.clone();
        b[at] ^= 1 << (rng.next_u64() % 8);
        let err = match std::panic::catch_unwind(|| SavedStats::from_bytes(&b, "a.stats")) {
            Ok(r) => r.expect_err(&format!("flip at byte {at} was accepted")),
            Err(_) => panic!("flip at byte {at} panicked"),
        };
        assert!(err.to_string().contains("'a.stats'"), "{err}");
        cases += 1;
    }
    // Truncations.
    for n in [0, 7, 15, 16, 100, bytes.len() / 2, bytes.len() - 1] {
        assert!(
            SavedStats::from_bytes(&bytes[..n], "a.stats").is_err(),
            "{n} bytes"
        );
    }
    assert!(cases > 0);

    // Whole files (a valid checksum) with impossible contents.
    let resaved = |f: &dyn Fn(&mut SavedStats)| {
        let mut s = saved.clone();
        f(&mut s);
        SavedStats::from_bytes(&s.to_bytes(), "a.stats").unwrap()
    };
    let o = saved.index.iter().copied().find(|&o| o != 0).unwrap() as usize;
    let bad: Vec<(&str, SavedStats)> = vec![
        ("NaN sum", resaved(&|s| s.stats[o + 1].sum = f32::NAN)),
        ("negative count", resaved(&|s| s.stats[o + 1].n_zero = -3.0)),
        (
            "sum without data",
            resaved(&|s| {
                s.stats[o + 1].n_nonzero = 0.0;
                s.stats[o + 1].sum = 1.0;
            }),
        ),
        ("node out of range", resaved(&|s| s.cuts[o + 1] = 1_000_000)),
        (
            "cut misses lights",
            resaved(&|s| s.cuts[o + 1] = s.cuts[o + 2]),
        ),
        (
            "a scale that makes y / scale overflow",
            resaved(&|s| {
                let t = &mut s.stats[o + 1];
                (t.n_nonzero, t.sum, t.sum_sq, t.scale) = (1.0, 1.0, 1.0, 1e-25);
            }),
        ),
    ];
    // A sample count a continuation cannot go on from (it would overflow the streams).
    let mut late = saved.clone();
    late.header.samples_done = u32::MAX - 5;
    let late = SavedStats::from_bytes(&late.to_bytes(), "a.stats").unwrap();
    let err = render::check_resume(
        &scene,
        &gpu,
        &settings(LightSampler::Bayes, 4, 1),
        &late,
        Path::new("a.stats"),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("fresh statistics"), "{err}");
    for (what, s) in bad {
        let err = render::check_resume(
            &scene,
            &gpu,
            &settings(LightSampler::Bayes, 4, 1),
            &s,
            Path::new("a.stats"),
        )
        .expect_err(what)
        .to_string();
        assert!(err.contains("'a.stats' is damaged"), "{what}: {err}");
    }
    // A count or an offset that points past the data is refused by the parser itself.
    let mut s = saved.clone();
    s.cuts[o] = 60_000;
    assert!(SavedStats::from_bytes(&s.to_bytes(), "a.stats").is_err());
    let mut s = saved.clone();
    s.index[0] = s.cuts.len() as u32 + 5;
    assert!(SavedStats::from_bytes(&s.to_bytes(), "a.stats").is_err());
    // More skipped passes than passes done: `merge-stats` counted 294967304 learned passes
    // (an audit, 2026-12-06).
    let mut s = saved.clone();
    s.header.skipped_passes = Some(s.header.samples_done + 1);
    let err = SavedStats::from_bytes(&s.to_bytes(), "a.stats").unwrap_err();
    assert!(err.to_string().contains("passes were skipped"), "{err}");
    // An animation's tempering factor outside (0, 1]: merge-stats --base multiplied by it
    // (an audit, 2026-12-07: −1 and 1e30 merged with exit 0 into other counts).
    for g in [-1.0, 0.0, 1e30] {
        let mut s = saved.clone();
        s.header.start_forget = Some(g);
        let err = SavedStats::from_bytes(&s.to_bytes(), "a.stats").unwrap_err();
        assert!(err.to_string().contains("start_forget"), "{g}: {err}");
    }
    // Totals that a file may hold but two of which overflow f32 when merged, and a part with
    // a NaN: merge-stats wrote both with exit 0 for --load-stats to call damaged (the same
    // audit). The checks are merge's; the first slot of a used cut is edited.
    let mut big = saved.clone();
    big.stats[o + 1] = SlotStats {
        n_nonzero: 1e30,
        sum: 3e38,
        sum_sq: 3e38,
        scale: 1e19,
        ..big.stats[o + 1]
    };
    let one = SavedStats::merge(&[(big.clone(), "x1".into())]).unwrap();
    assert_eq!(one.stats.len(), big.stats.len());
    let err =
        SavedStats::merge(&[(big.clone(), "x1".into()), (big.clone(), "x2".into())]).unwrap_err();
    assert!(err.to_string().contains("add up past"), "{err}");
    let mut nan = saved.clone();
    nan.stats[o + 1].sum = f32::NAN;
    let err = SavedStats::merge(&[(saved.clone(), "x1".into()), (nan, "x2".into())]).unwrap_err();
    assert!(err.to_string().contains("'x2' is damaged"), "{err}");
    // A cut longer than the kernels' cut array (64) that still lies inside the file.
    let mut s = saved.clone();
    s.cuts[0] = 65;
    let err = SavedStats::from_bytes(&s.to_bytes(), "a.stats").unwrap_err();
    assert!(err.to_string().contains("fallback cut"), "{err}");
}

/// Random byte changes to a small glTF never panic or hang the loader: each either loads or
/// gives an error naming the file.
#[test]
fn fuzzed_gltf_never_panics_or_hangs() {
    let mut g = lightlearn::scene::gltf_write::GltfBuilder::new();
    let m = g.material("grey", glam::Vec3::splat(0.5), glam::Vec3::ZERO, false);
    let e = g.material("lamp", glam::Vec3::ONE, glam::Vec3::splat(4.0), false);
    g.cuboid("box", glam::Vec3::ZERO, glam::Vec3::ONE, m);
    g.quad(
        "lamp",
        [
            glam::Vec3::new(0.2, 2.0, 0.2),
            glam::Vec3::new(0.8, 2.0, 0.2),
            glam::Vec3::new(0.8, 2.0, 0.8),
            glam::Vec3::new(0.2, 2.0, 0.8),
        ],
        e,
    );
    g.point_light("bulb", glam::Vec3::splat(2.0), glam::Vec3::ONE, 3.0);
    g.camera(glam::Vec3::new(0.5, 1.0, 4.0), glam::Vec3::splat(0.5), 0.8);
    let glb = g.to_glb();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.glb");
    let mut rng = SplitMix64(3);
    let (mut loaded, mut refused) = (0, 0);
    for case in 0..300 {
        let mut b = glb.clone();
        for _ in 0..1 + case % 3 {
            let at = (rng.next_u64() % b.len() as u64) as usize;
            b[at] = if case % 2 == 0 {
                b[at] ^ (1 << (rng.next_u64() % 8))
            } else {
                rng.next_u64() as u8
            };
        }
        std::fs::write(&path, &b).unwrap();
        let t = std::time::Instant::now();
        match gltf_load::load(&path, &mut |_| {}) {
            Ok(s) => {
                assert!(!s.triangles.is_empty() && !s.lights.is_empty());
                loaded += 1;
            }
            Err(e) => {
                let e = e.to_string();
                assert!(e.contains("f.glb"), "case {case}: {e}");
                // Caught by our checks, not by catching a panic of the gltf crate.
                assert!(
                    !e.contains("could not report"),
                    "case {case} panicked inside: {e}"
                );
                refused += 1;
            }
        }
        assert!(t.elapsed().as_secs_f64() < 5.0, "case {case} took too long");
    }
    eprintln!("fuzzed glTF: {loaded} loaded, {refused} refused");
    assert!(refused > 50, "most damage is caught ({refused} of 300)");
}

/// A set of output files is committed together: when one cannot be moved into place, the
/// files that were there before are all back and no new one is left.
#[test]
fn a_failed_commit_leaves_the_old_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (a, b) = (d.join("a.exr"), d.join("a.png"));
    std::fs::write(&a, "old a").unwrap();
    std::fs::write(&b, "old b").unwrap();
    let (ta, tb) = (d.join(".a.tmp"), d.join(".b.tmp"));
    std::fs::write(&ta, "new a").unwrap();
    // tb is missing: its move fails after a's has been made.
    let r = lightlearn::io::commit_all(&[(a.clone(), ta.clone()), (b.clone(), tb)]);
    assert!(r.is_err());
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "old b");
    let mut left: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    left.sort();
    assert_eq!(left, ["a.exr", "a.png"]);
    // And a commit that works replaces both.
    std::fs::write(&ta, "new a").unwrap();
    let tb = d.join(".b2.tmp");
    std::fs::write(&tb, "new b").unwrap();
    lightlearn::io::commit_all(&[(a.clone(), ta), (b.clone(), tb)]).unwrap();
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 2);
}

/// A node rotation that is not a unit quaternion was used as given: [0, 0, 0, 0] (no rotation
/// at all) rendered as the identity, and a quaternion of another length skewed the mesh (its
/// rotation matrix is not orthogonal), both without a word. Now length 0 is refused by node,
/// and another length is normalized with a warning: the mesh lands where the unit quaternion
/// puts it.
#[test]
fn node_rotations_that_are_not_unit_quaternions_are_refused_or_normalized() {
    let base = cornell_bytes();
    let mesh_node = |j: &serde_json::Value| {
        j["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .position(|n| n.get("mesh").is_some())
            .unwrap()
    };
    let rotated = |q: [f64; 4]| {
        common::edit_glb(&base, |j| {
            let k = mesh_node(j);
            j["nodes"][k]["rotation"] = serde_json::json!(q);
        })
    };
    let err = load(&rotated([0.0; 4])).unwrap_err().to_string();
    assert!(
        err.contains("not a quaternion") && err.contains("node "),
        "{err}"
    );
    // 40° about y: unit, and twice as long.
    let (s, c) = (20f64.to_radians().sin(), 20f64.to_radians().cos());
    let unit = load(&rotated([0.0, s, 0.0, c])).unwrap();
    let (long, warnings) = common::load_warned(&rotated([0.0, 2.0 * s, 0.0, 2.0 * c]), "test.glb");
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("length 2") && w.contains("normalized")),
        "{warnings:?}"
    );
    assert_eq!(unit.triangles.len(), long.triangles.len());
    let worst = unit
        .triangles
        .iter()
        .zip(&long.triangles)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(p, q)| (*p - *q).length()))
        .fold(0f32, f32::max);
    assert!(
        worst < 1e-5,
        "a normalized rotation moved a vertex by {worst}"
    );
}
