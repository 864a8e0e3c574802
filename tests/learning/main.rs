//! The learned samplers (`bayes`, `donikian`): posterior math against direct numerical
//! integration; no NaN for any counts; `bayes` starts exactly where `wang` is; pmfs are exact,
//! positive for every light that can contribute whatever the statistics (adversarial ones
//! included) and the same on GPU and CPU; the fold kernel matches its CPU mirror; renders with
//! adversarial statistics stay unbiased; same seed → identical EXR and statistics file;
//! save → load → continue equals an uninterrupted run; bad statistics files are refused.

#[path = "../common/mod.rs"]
mod common;
mod files;
mod fold;
mod pmfs;
mod posterior;
mod refine;
mod unbiased;

use std::path::Path;
use std::process::Command;

use glam::Vec3;
use lightlearn::accel::Bvh;
use lightlearn::gpu::layout::{FoldPush, SlotDelta, SlotStats};
use lightlearn::gpu::Buffer;
use lightlearn::learning::stats_file::SavedStats;
use lightlearn::learning::{
    fold, fold_with_prior, learned_weights, predicted_means, LearnSettings, Posterior, Regression,
    UpdateEvery,
};
use lightlearn::lights::regions::{pmf_in_cut, Cuts, Grid, RegionSettings};
use lightlearn::lights::tree::LightTree;
use lightlearn::render::{self, Budget, GpuScene, LightSampler, RenderSettings};
use lightlearn::rng::SplitMix64;
use lightlearn::scene::{gltf_load, Scene};

fn scene(name: &str) -> Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    gltf_load::load(&p, &mut |w| panic!("{w}")).unwrap()
}

/// Cuts for the regions around random surface points of a scene, and those points.
fn cuts_and_points(
    s: &Scene,
    tree: &LightTree,
    count: usize,
    settings: RegionSettings,
) -> (Cuts, Vec<(Vec3, Vec3, f32)>) {
    let (lo, hi) = s.bounds();
    let grid = Grid::new(lo, hi, &settings);
    let points = common::surface_points(s, count, 5);
    let reached: Vec<u32> = points.iter().map(|(p, n, _)| grid.region(*p, *n)).collect();
    (Cuts::build(tree, grid, reached, lo, hi, &settings), points)
}

/// Statistics that lie within what a render can see (50 observations per slot, relative to
/// the slot's own scale): "always occluded", "10× brighter than it is", "10× dimmer", or
/// nothing. (The extreme kind makes some pmfs ~1e-9: still unbiased, but then 48 spp per
/// pixel cannot show it, so the render test uses this kind.)
fn lying_stats(initial: &[SlotStats], seed: u64) -> Vec<SlotStats> {
    let mut r = SplitMix64(seed);
    initial
        .iter()
        .map(|s0| {
            let y = s0.scale;
            let s = |nz: f32, m: f32| SlotStats {
                n_zero: nz,
                n_nonzero: if m > 0.0 { 50.0 } else { 0.0 },
                sum: 50.0 * m * y,
                sum_sq: 50.0 * 2.0 * (m * y) * (m * y),
                scale: y,
                ..Default::default()
            };
            match (r.f32() * 4.0) as u32 {
                0 => s(50.0, 0.0),
                1 => s(0.0, 10.0),
                2 => s(0.0, 0.1),
                _ => s(0.0, 0.0),
            }
        })
        .collect()
}

/// Statistics that lie: each slot at random says "always occluded" (10⁹ zeros), "blazing"
/// (a huge mean and variance), "tiny", or nothing.
fn adversarial_stats(len: usize, seed: u64) -> Vec<SlotStats> {
    let mut r = SplitMix64(seed);
    (0..len)
        .map(|_| match (r.f32() * 4.0) as u32 {
            0 => SlotStats {
                n_zero: 1e9,
                scale: 1.0,
                ..Default::default()
            },
            1 => SlotStats {
                n_nonzero: 1e4,
                sum: 1e10,
                sum_sq: 1e17,
                scale: 1.0,
                ..Default::default()
            },
            2 => SlotStats {
                n_zero: 10.0,
                n_nonzero: 1e4,
                sum: 1e-8,
                sum_sq: 1e-20,
                scale: 1.0,
                ..Default::default()
            },
            _ => SlotStats {
                scale: 1.0,
                ..Default::default()
            },
        })
        .collect()
}

/// The binary on the device the tests run on: it inherits VK_DRIVER_FILES (it forced
/// lavapipe's ICD before, and so failed on an NVIDIA machine, which has none: 2026-12-04).
fn lightlearn(args: &[&str]) -> std::process::Output {
    Command::new(common::exe()).args(args).output().unwrap()
}

fn ok(o: &std::process::Output) {
    assert!(
        o.status.success(),
        "lightlearn failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}
