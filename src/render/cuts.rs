//! The learned state's structure for a render: which regions get cuts (those the camera's
//! rays and their bounces reach), their starting statistics, the statistics-file header, and
//! the checks of loaded statistics and of the region index's size.

use anyhow::{bail, Result};
use glam::Vec3;

use super::{camera_vectors, GpuScene, RenderSettings};
use crate::gpu::layout::SlotStats;
use crate::gpu::Context;
use crate::learning::stats_file::{self, SavedStats, StatsHeader};
use crate::learning::Regression;
use crate::lights;
use crate::lights::regions::{Cuts, Grid, RegionSettings};
use crate::scene::Scene;

/// Checks statistics loaded from `path` before a render starts from them: same scene and
/// settings ([`SavedStats::check_matches`]) and cuts and totals that are whole
/// ([`SavedStats::check_cuts`]).
pub fn check_resume(
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    saved: &SavedStats,
    path: &std::path::Path,
) -> Result<()> {
    saved.check_matches(&stats_header(scene, gpu, settings), path)?;
    if saved.header.samples_done > super::session::MAX_PASSES / 2 {
        bail!(
            "'{}' has learned from {} passes, more than a continuation can go on from; start from fresh statistics",
            path.display(),
            saved.header.samples_done
        );
    }
    let (lo, hi) = scene.grid_bounds();
    let regions = Grid::new(lo, hi, &settings.regions).region_count();
    saved.check_cuts(&gpu.tree, regions, path)
}

/// Errors, naming `--grid` and the largest grid that fits, when the region index (one word a
/// region, read as a storage buffer and as R32UI texels) would not fit this device: its
/// storage-buffer range (lavapipe: 128 MiB, 33.5 M regions) or its texel-buffer element count
/// (NVIDIA H200: 2^27 = 134 M regions), whichever is smaller. Before the texel limit was
/// counted here, `--grid 300` on the H200 was refused by the buffer layer with no `--grid`
/// advice (seen 2026-12-04, docs/results.md).
pub fn check_region_index_fits(
    ctx: &Context,
    scene: &Scene,
    regions: &RegionSettings,
) -> Result<()> {
    let (lo, hi) = scene.grid_bounds();
    let count = Grid::new(lo, hi, regions).region_count_u64();
    let limits = &ctx.properties.limits;
    let max_regions = region_capacity(
        limits.max_storage_buffer_range as u64,
        limits.max_texel_buffer_elements as u64,
    );
    if count > max_regions {
        let g = lights::regions::largest_grid(lo, hi, regions, max_regions);
        bail!(
            "--grid {} gives this scene {count} regions, more than this device's region index holds ({max_regions}: {} MiB storage buffers, {} texels a texel buffer); use --grid {g} or less{}",
            regions.grid,
            limits.max_storage_buffer_range >> 20,
            limits.max_texel_buffer_elements,
            if regions.normal_bins { " (or --normal-bins off)" } else { "" }
        );
    }
    Ok(())
}

/// The most regions a region index can have on a device with these limits: one 4-byte word a
/// region in one storage buffer, and one R32UI texel a region in one texel buffer.
pub fn region_capacity(max_storage_bytes: u64, max_texels: u64) -> u64 {
    (max_storage_bytes / 4).min(max_texels)
}

/// The header of a statistics file of this scene and these settings with no cuts yet (what
/// a loaded file must match); [`Cuts`] sizes and the sample count are filled in on saving.
pub fn stats_header(scene: &Scene, gpu: &GpuScene, settings: &RenderSettings) -> StatsHeader {
    let (lo, hi) = scene.grid_bounds();
    let grid = Grid::new(lo, hi, &settings.regions);
    let (grid_params, grid_dims) = stats_file::grid_fields(&grid.params);
    StatsHeader {
        scene: gpu.fingerprint.clone(),
        sampler: settings.sampler.name().to_string(),
        grid: settings.regions.grid,
        normal_bins: settings.regions.normal_bins,
        regression: settings.learn.regression != Regression::Off,
        regression_importance: settings.learn.regression == Regression::Importance,
        brdf_aware: settings.learn.brdf_aware,
        samples_done: 0,
        grid_params,
        grid_dims,
        regions: 0,
        cuts_len: 0,
        tau: Some(settings.regions.tau),
        k_max: Some(settings.regions.k_max),
        coarse_blocks: Some(settings.regions.coarse_blocks),
        in_cluster_importance: Some(settings.regions.in_cluster_importance),
        start_forget: None,
        skipped_passes: None,
        animation_frame: None,
        animation_time: None,
        holds: None,
    }
}

/// Bounce rays per pixel that [`build_cuts`] follows to find the regions paths reach.
pub const BOUNCE_RAYS: u32 = 2;

/// A cosine-distributed direction about the unit normal n.
fn cosine_direction(n: Vec3, u0: f32, u1: f32) -> Vec3 {
    let (t, b) = n.any_orthonormal_pair();
    let r = u0.sqrt();
    let phi = 2.0 * std::f32::consts::PI * u1;
    (r * phi.cos() * t + r * phi.sin() * b + (1.0 - u0).max(0.0).sqrt() * n).normalize()
}

/// Starting totals: no data; the first window's fixed-point scale is the slot's largest
/// plausible y: Φ/π (y = Î d² ≈ A L cosθ cosθ ≤ Φ/π for a one-sided emitter), ÷ d² to the
/// region's cell centre without regression (y = Î), 1/π by importance (y = Î / Ĩ, Ĩ ≥ Φ
/// cosθ cosθ / d²).
pub fn initial_stats(
    tree: &lights::tree::LightTree,
    cuts: &Cuts,
    regression: Regression,
) -> Vec<SlotStats> {
    let mut stats = vec![SlotStats::default(); cuts.cuts.len()];
    fill_initial(&mut stats, tree, cuts, 0, None, regression);
    let mut done = std::collections::HashSet::new();
    for (r, &o) in cuts.index.iter().enumerate() {
        if o != 0 && done.insert(o) {
            fill_initial(&mut stats, tree, cuts, o, Some(r as u32), regression);
        }
    }
    stats
}

/// The starting totals of the cut at offset `o` (of `region`; None: the fallback) into
/// `stats` (indexed like `cuts.cuts`); `regression`: what the observations are regressed on
/// ([`RenderSettings::observed_regression`]).
pub fn fill_initial(
    stats: &mut [SlotStats],
    tree: &lights::tree::LightTree,
    cuts: &Cuts,
    o: u32,
    region: Option<u32>,
    regression: Regression,
) {
    let o = o as usize;
    let centre = region.map(|r| cuts.grid.cell_box(r).0);
    for k in 0..cuts.cuts[o] as usize {
        let nd = &tree.nodes[cuts.cuts[o + 1 + k] as usize];
        let y_max = match (regression, centre) {
            (Regression::Importance, _) => std::f32::consts::FRAC_1_PI,
            (Regression::Off, Some(c)) => {
                nd.phi * std::f32::consts::FRAC_1_PI / crate::learning::node_d2(nd, c)
            }
            _ => nd.phi * std::f32::consts::FRAC_1_PI,
        };
        stats[o + 1 + k].scale = y_max.max(1e-30);
    }
}

/// The cuts a render uses. For `wang`, `donikian` and `bayes`: one per region the camera's
/// pixel-centre rays reach (found with the CPU BVH), and when paths go on (`max_depth` ≥ 2)
/// also the regions where [`BOUNCE_RAYS`] cosine-distributed rays per pixel land, for up to
/// two bounces: indirect vertices learn only in regions with a cut of their own (measured on
/// rooms16 at depth 8 without them: 42 % of light samples fell in regions without a cut). A
/// sample that lands in another region uses the whole-scene cut, which is unbiased, only less
/// adapted. Other samplers get just the whole-scene cut.
pub fn build_cuts(
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    camera: &crate::scene::Camera,
) -> Cuts {
    let (lo, hi) = scene.grid_bounds();
    // Samplers without cuts never look a region up: one region, whatever --grid says (a
    // large grid once built a 3 GB index for `power`).
    let grid = if settings.sampler.uses_cuts() {
        Grid::new(lo, hi, &settings.regions)
    } else {
        let one = RegionSettings {
            grid: 1,
            normal_bins: false,
            ..settings.regions
        };
        Grid::new(lo, hi, &one)
    };
    let mut reached = Vec::new();
    if settings.sampler.uses_cuts() {
        use rayon::prelude::*;
        let cam = camera_vectors(camera, settings.width, settings.height);
        let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        let (w, h) = (settings.width, settings.height);
        let bounces = settings.max_depth.saturating_sub(1).min(2);
        // The first hit of a ray: the point, the normal facing the ray and how far rays
        // leave the point (render.comp's offset).
        let hit = |o: Vec3, d: Vec3| -> Option<(Vec3, Vec3, f32)> {
            let (t, prim) = gpu.bvh.intersect(o, d, 0.0, f32::INFINITY)?;
            let [a, b, c] = scene.triangles[prim as usize];
            let ng = (b - a).cross(c - a).normalize();
            let n = if ng.dot(d) < 0.0 { ng } else { -ng };
            let x = o + t * d;
            Some((x, n, super::hit_epsilon(x, o, t, [a, b, c])))
        };
        reached = (0..w * h)
            .into_par_iter()
            .flat_map_iter(|p| {
                let x = ((p % w) as f32 + 0.5) / w as f32 * 2.0 - 1.0;
                let y = 1.0 - ((p / w) as f32 + 0.5) / h as f32 * 2.0;
                let d = (v(cam.cam_w) + x * v(cam.cam_u) + y * v(cam.cam_v)).normalize();
                let mut out = Vec::new();
                if let Some((x0, n0, e0)) = hit(v(cam.cam_pos), d) {
                    out.push(grid.region(x0, n0));
                    for k in 0..BOUNCE_RAYS * (bounces > 0) as u32 {
                        let (mut x, mut n, mut eps) = (x0, n0, e0);
                        for b in 0..bounces {
                            let u = |dim: u32| {
                                crate::rng::sample_rand(settings.seed ^ 0x5eed, p, k, 2 * b + dim)
                            };
                            let dir = cosine_direction(n, u(0), u(1));
                            let Some((x1, n1, e1)) = hit(x + n * eps, dir) else {
                                break;
                            };
                            out.push(grid.region(x1, n1));
                            (x, n, eps) = (x1, n1, e1);
                        }
                    }
                }
                out
            })
            .collect();
        reached.sort_unstable();
        reached.dedup();
    }
    Cuts::build(&gpu.tree, grid, reached, lo, hi, &settings.regions)
}

#[cfg(test)]
mod tests {
    use super::region_capacity;

    /// lavapipe's storage-buffer range bounds the index there; the H200's 2^27-element texel
    /// buffers bound it there (its storage range is 4 GiB).
    #[test]
    fn region_capacity_is_the_smaller_limit() {
        assert_eq!(region_capacity(128 << 20, 1 << 27), 32 << 20);
        assert_eq!(region_capacity(u32::MAX as u64, 1 << 27), 1 << 27);
    }
}
