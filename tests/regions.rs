//! Regions, cuts and the `wang` sampler: every cut covers every light exactly once; the pmf
//! returned with a sample equals the pmf recomputed; pmfs sum to one; every light that can
//! contribute has pmf > 0; the mean of f/p matches the exact sum; GPU and CPU agree.

mod common;

use std::path::Path;

use glam::Vec3;
use lightlearn::lights::regions::{build_cut, Cuts, Grid, RegionSettings};
use lightlearn::lights::tree::LightTree;
use lightlearn::rng::SplitMix64;
use lightlearn::scene::{gltf_load, Scene};

fn scene(name: &str) -> Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    gltf_load::load(&p, &mut |w| panic!("{w}")).unwrap()
}

/// Cuts for the regions hit by rays from random points: as many regions as a render touches.
fn cuts_for(
    s: &Scene,
    tree: &LightTree,
    settings: &RegionSettings,
) -> (Cuts, Vec<(Vec3, Vec3, f32)>) {
    let (lo, hi) = s.bounds();
    let grid = Grid::new(lo, hi, settings);
    let points = common::surface_points(s, 600, 21);
    // Build cuts for two thirds of the regions; the rest must fall back to the global cut.
    let reached: Vec<u32> = points[..400]
        .iter()
        .map(|(p, n, _)| grid.region(*p, *n))
        .collect();
    (Cuts::build(tree, grid, reached, lo, hi, settings), points)
}

#[test]
fn cuts_partition_the_lights() {
    for name in ["rooms.glb", "city.glb", "strings.glb", "cornell.glb"] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        for settings in [
            RegionSettings::default(),
            RegionSettings {
                k_max: 1,
                ..Default::default()
            },
            RegionSettings {
                tau: 0.0,
                k_max: 64,
                normal_bins: false,
                grid: 8,
                in_cluster_importance: true,
                coarse_blocks: false,
            },
        ] {
            let (cuts, _) = cuts_for(&s, &tree, &settings);
            assert!(
                cuts.built() > 10,
                "{name}: only {} cuts built",
                cuts.built()
            );
            let mut o = 0;
            while o < cuts.cuts.len() {
                let k = cuts.cuts[o] as usize;
                assert!(
                    k >= 1 && k as u32 <= settings.k_max,
                    "{name}: cut of {k} nodes"
                );
                let mut next = 0;
                for &node in &cuts.cuts[o + 1..o + 1 + k] {
                    let nd = &tree.nodes[node as usize];
                    assert_eq!(
                        nd.begin, next,
                        "{name}: cut ranges must tile the lights in order"
                    );
                    next += nd.count;
                }
                assert_eq!(
                    next as usize,
                    s.lights.len(),
                    "{name}: a cut must cover every light"
                );
                o += 1 + k;
            }
        }
    }
}

#[test]
fn wang_pmfs_are_exact_normalised_and_cover_every_contributing_light() {
    for (name, importance) in [
        ("rooms.glb", true),
        ("city.glb", true),
        ("strings.glb", true),
        ("cornell.glb", true),
        ("rooms.glb", false),
        ("city.glb", false),
    ] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        let settings = RegionSettings {
            in_cluster_importance: importance,
            ..Default::default()
        };
        let (cuts, points) = cuts_for(&s, &tree, &settings);
        let lbvh = LightTree::build(&s);
        let mut sampled = 0;
        for &(p, n, u) in &points {
            let total: f64 = (0..s.lights.len() as u32)
                .map(|l| cuts.pmf(&tree, p, n, l) as f64)
                .sum();
            match cuts.sample(&tree, p, n, u) {
                Some((l, pmf)) => {
                    sampled += 1;
                    let again = cuts.pmf(&tree, p, n, l);
                    assert!(
                        (pmf - again).abs() <= 1e-5 * pmf,
                        "{name}: pmf {pmf} vs recomputed {again}"
                    );
                    // By power the pmfs sum to 1; by importance they may fall short by the
                    // chance of a dead end inside a cluster (a zero sample, as in lightbvh).
                    assert!(
                        (total - 1.0).abs() < 1e-3 || importance && total < 1.0,
                        "{name}: pmfs sum to {total}"
                    );
                }
                None if importance => assert!(total < 1.0, "{name}: pmfs sum to {total}"),
                None => assert_eq!(total, 0.0, "{name}: no sample, yet pmfs sum to {total}"),
            }
            // Cover: any light the (conservative) tree importance says can contribute here
            // has pmf > 0 (the lightbvh pmf > 0 means some path of non-zero importance).
            for l in 0..s.lights.len() as u32 {
                if lbvh.pmf(p, n, l) > 0.0 {
                    assert!(
                        cuts.pmf(&tree, p, n, l) > 0.0,
                        "{name}: light {l} has lightbvh pmf > 0 but wang pmf 0 at {p}"
                    );
                }
            }
        }
        assert!(
            sampled > 300,
            "{name}: too few points with a sample ({sampled})"
        );
    }
}

#[test]
fn wang_mean_of_f_over_p_matches_the_exact_sum() {
    let s = scene("strings.glb");
    let tree = LightTree::build(&s);
    let (cuts, points) = cuts_for(&s, &tree, &RegionSettings::default());
    let contribution = |l: usize, p: Vec3, n: Vec3| -> f64 {
        let lightlearn::scene::Light::Point {
            position,
            intensity,
        } = s.lights[l]
        else {
            unreachable!()
        };
        let d = position - p;
        (lightlearn::scene::luminance(intensity) * n.dot(d.normalize()).max(0.0)
            / d.length_squared()) as f64
    };
    let mut r = SplitMix64(77);
    for &(p, n, _) in points.iter().step_by(40) {
        let exact: f64 = (0..s.lights.len()).map(|l| contribution(l, p, n)).sum();
        let k = 20_000;
        let (mut sum, mut sum2) = (0f64, 0f64);
        for _ in 0..k {
            let x = cuts
                .sample(&tree, p, n, r.f32())
                .map_or(0.0, |(l, pmf)| contribution(l as usize, p, n) / pmf as f64);
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
fn gpu_and_cpu_wang_agree() {
    let ctx = common::ctx();
    for name in ["city.glb", "rooms.glb", "strings.glb"] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        let (cuts, points) = cuts_for(&s, &tree, &RegionSettings::default());
        let got = common::gpu_light_samples(&ctx, &tree, &cuts, 3, &points);
        let mut same = 0;
        for (i, &(p, n, u)) in points.iter().enumerate() {
            let cpu = cuts.sample(&tree, p, n, u).map(|c| c.0);
            let g = got[i];
            same += (cpu == (g.light != u32::MAX).then_some(g.light)) as usize;
            if g.light != u32::MAX {
                let want = cuts.pmf(&tree, p, n, g.light);
                assert!(
                    (g.pmf - want).abs() <= 1e-3 * want,
                    "{name} query {i}: GPU pmf {} vs CPU {want}",
                    g.pmf
                );
            }
        }
        assert!(
            same * 1000 >= points.len() * 995,
            "{name}: only {same} of {} agree",
            points.len()
        );
    }
}

/// `coarse_blocks` (the default): the regions of a block of 2×2×2 cells whose box holds no
/// light share one cut, built for the block; a region of a block with a light has a cut of
/// its own, built for its cell. Off, every region has its own.
#[test]
fn blocks_without_lights_share_one_cut() {
    use std::collections::HashMap;
    for name in ["rooms.glb", "cornell.glb"] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        let on = RegionSettings::default();
        assert!(on.coarse_blocks, "the default shares");
        let (cuts, _) = cuts_for(&s, &tree, &on);
        let cut = |o: u32| {
            let o = o as usize;
            cuts.cuts[o + 1..o + 1 + cuts.cuts[o] as usize].to_vec()
        };
        let mut members: HashMap<u32, Vec<u32>> = HashMap::new();
        for (r, &o) in cuts.index.iter().enumerate() {
            if o != 0 {
                members.entry(o).or_default().push(r as u32);
            }
        }
        let (mut shared, mut own) = (0, 0);
        for (&o, regions) in &members {
            let (key, c, h) = cuts.grid.block_of(regions[0]);
            if lightlearn::lights::regions::light_in_box(&tree, c, h) {
                // Near a light: one region, its own cell's cut.
                assert_eq!(
                    regions.len(),
                    1,
                    "{name}: a block with a light shares cut {o}"
                );
                let (cc, ch) = cuts.grid.cell_box(regions[0]);
                assert_eq!(
                    cut(o),
                    build_cut(&tree, cc, ch, &on),
                    "{name}: region {}",
                    regions[0]
                );
                own += 1;
            } else {
                // Every region of the block has this cut, built for the block.
                for &r in regions {
                    assert_eq!(cuts.grid.block_of(r).0, key, "{name}: cut {o} spans blocks");
                }
                assert_eq!(cut(o), build_cut(&tree, c, h, &on), "{name}: block cut {o}");
                shared += (regions.len() > 1) as usize;
            }
        }
        assert!(
            shared > 0 && own > 0,
            "{name}: {shared} shared cuts, {own} own cuts"
        );
        assert!(
            cuts.built() > cuts.distinct(),
            "{name}: regions {} cuts {}",
            cuts.built(),
            cuts.distinct()
        );
        let off = RegionSettings {
            coarse_blocks: false,
            ..on
        };
        let (fine, _) = cuts_for(&s, &tree, &off);
        assert_eq!(
            fine.built(),
            fine.distinct(),
            "{name}: off, every region its own cut"
        );
        assert_eq!(
            fine.built(),
            cuts.built(),
            "{name}: the same regions reached"
        );
    }
}
