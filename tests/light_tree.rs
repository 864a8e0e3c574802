//! The `lightbvh` sampler: the pmf returned with a sample equals the pmf recomputed for that
//! light; the pmfs over all lights sum to one; every light that can contribute has pmf > 0;
//! the mean of f/p over many samples matches the exact sum; GPU and CPU agree.

mod common;

use std::path::Path;

use glam::Vec3;
use lightlearn::lights::regions::{Cuts, Grid, RegionSettings};
use lightlearn::lights::tree::LightTree;
use lightlearn::rng::SplitMix64;
use lightlearn::scene::{gltf_load, spot_falloff, Light, Scene};

fn scene(name: &str) -> Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    gltf_load::load(&p, &mut |w| panic!("{w}")).unwrap()
}

/// Random shading points inside the scene bounds with random unit normals.
fn queries(s: &Scene, n: usize, seed: u64) -> Vec<(Vec3, Vec3, f32)> {
    let (lo, hi) = s.bounds();
    let mut r = SplitMix64(seed);
    (0..n)
        .map(|_| {
            let p = lo + (hi - lo) * Vec3::new(r.f32(), r.f32(), r.f32());
            let nrm = Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
                .normalize_or(Vec3::Y);
            (p, nrm, r.f32())
        })
        .collect()
}

/// Unoccluded contribution (luminance, no BRDF) of a light at (p, n), with the point on a
/// triangle light given by (u, v); and whether it can be non-zero at all.
fn contribution(s: &Scene, light: &Light, p: Vec3, n: Vec3, u: f32, v: f32) -> f32 {
    let (y, radiance, facing) = match *light {
        Light::Point {
            position,
            intensity,
        } => (position, intensity, 1.0),
        Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
        } => {
            let wo = (p - position).normalize();
            (
                position,
                intensity,
                spot_falloff(direction.dot(wo), cos_inner, cos_outer),
            )
        }
        Light::Triangle { triangle } => {
            let [a, b, c] = s.triangles[triangle as usize];
            let su = u.sqrt();
            let (b0, b1) = (1.0 - su, v * su);
            let y = b0 * a + b1 * b + (1.0 - b0 - b1) * c;
            let cross = (b - a).cross(c - a);
            let (e, two) = s.triangle_emission(triangle);
            let mut cos_y = cross.normalize().dot((p - y).normalize());
            if two {
                cos_y = cos_y.abs();
            }
            (y, e, cos_y.max(0.0) * 0.5 * cross.length())
        }
    };
    let d = y - p;
    let cos_x = n.dot(d.normalize()).max(0.0);
    lightlearn::scene::luminance(radiance) * facing * cos_x / d.length_squared()
}

#[test]
fn cpu_pmfs_are_exact_normalised_and_cover_every_contributing_light() {
    for name in ["cornell.glb", "rooms.glb", "city.glb", "strings.glb"] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        assert_eq!(tree.nodes[0].count as usize, s.lights.len());
        let mut sampled = 0;
        for (p, n, u) in queries(&s, 300, 1) {
            // A descent can dead-end where a parent's looser bounds allow light but neither
            // child's do: that sample is wasted (contributes 0), never biased. So the pmfs sum
            // to 1 − P(dead end): at most 1, and below 1 whenever this u dead-ended.
            let total: f64 = (0..s.lights.len() as u32)
                .map(|l| tree.pmf(p, n, l) as f64)
                .sum();
            assert!(total <= 1.0 + 1e-4, "{name}: pmfs sum to {total}");
            match tree.sample(p, n, u) {
                Some((l, pmf)) => {
                    sampled += 1;
                    let again = tree.pmf(p, n, l);
                    assert!(
                        (pmf - again).abs() <= 1e-5 * pmf,
                        "{name}: pmf {pmf} vs recomputed {again}"
                    );
                }
                None => assert!(
                    total < 1.0 - 1e-6,
                    "{name}: a dead end, yet the pmfs sum to {total}"
                ),
            }
            // The dead-end probability, measured by sampling, matches 1 − Σ pmf.
            let k = 4000;
            let dead = (0..k)
                .filter(|j| tree.sample(p, n, (*j as f32 + 0.5) / k as f32).is_none())
                .count();
            assert!(
                (dead as f64 / k as f64 - (1.0 - total)).abs() < 0.01,
                "{name}: dead ends {dead}/{k} but 1 − Σ pmf = {}",
                1.0 - total
            );
            // Unbiasedness of the cover: a light that can contribute here has pmf > 0.
            for (l, light) in s.lights.iter().enumerate() {
                let mut r = SplitMix64(l as u64);
                let can = (0..8).any(|_| contribution(&s, light, p, n, r.f32(), r.f32()) > 0.0);
                if can {
                    assert!(
                        tree.pmf(p, n, l as u32) > 0.0,
                        "{name}: light {l} can contribute at {p} but has pmf 0"
                    );
                }
            }
        }
        assert!(
            sampled > 100,
            "{name}: too few points where some light can contribute"
        );
    }
}

#[test]
fn mean_of_f_over_p_matches_the_exact_sum() {
    let s = scene("strings.glb"); // 1000 point lights: the exact sum is a plain sum
    let tree = LightTree::build(&s);
    let mut r = SplitMix64(5);
    for (p, n, _) in queries(&s, 20, 9) {
        let exact: f64 = s
            .lights
            .iter()
            .map(|l| contribution(&s, l, p, n, 0.0, 0.0) as f64)
            .sum();
        let k = 20_000;
        let (mut sum, mut sum2) = (0f64, 0f64);
        for _ in 0..k {
            let x = match tree.sample(p, n, r.f32()) {
                Some((l, pmf)) => {
                    contribution(&s, &s.lights[l as usize], p, n, 0.0, 0.0) as f64 / pmf as f64
                }
                None => 0.0,
            };
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / k as f64;
        let se = ((sum2 / k as f64 - mean * mean).max(0.0) / k as f64).sqrt();
        assert!(
            (mean - exact).abs() <= 5.0 * se + 1e-6 * exact,
            "at {p}: mean {mean} vs exact {exact} (σ {se})"
        );
    }
}

#[test]
fn gpu_and_cpu_descents_agree() {
    let ctx = common::ctx();
    for name in ["city.glb", "strings.glb", "cornell.glb"] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        let qs = queries(&s, 4000, 3);
        let (lo, hi) = s.bounds();
        let settings = RegionSettings::default();
        let cuts = Cuts::build(&tree, Grid::new(lo, hi, &settings), [], lo, hi, &settings);
        let got = common::gpu_light_samples(&ctx, &tree, &cuts, 2, &qs);
        let mut same = 0;
        for (i, (p, n, u)) in qs.iter().enumerate() {
            let g = got[i];
            let cpu = tree.sample(*p, *n, *u);
            if cpu.map(|c| c.0) == (g.light != u32::MAX).then_some(g.light) {
                same += 1;
            }
            if g.light != u32::MAX {
                // Whatever the GPU picked, its pmf is the CPU's pmf of that light.
                let want = tree.pmf(*p, *n, g.light);
                assert!(
                    (g.pmf - want).abs() <= 1e-3 * want,
                    "{name} query {i}: GPU pmf {} vs CPU {want}",
                    g.pmf
                );
            }
        }
        // Only u right at a decision boundary may go the other way (float rounding).
        assert!(
            same * 1000 >= qs.len() * 998,
            "{name}: only {same} of {} agree",
            qs.len()
        );
    }
}
