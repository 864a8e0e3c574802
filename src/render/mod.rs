//! The progressive pass loop: upload the scene once, then dispatch `render.comp` one sample
//! per pixel per pass until the sample count or the time budget is reached.

use std::sync::Arc;

use anyhow::{bail, Result};
use glam::Vec3;

use crate::gpu::layout::RenderParams;
use crate::gpu::Context;
use crate::learning::stats_file::SavedStats;
use crate::learning::LearnSettings;
use crate::lights::regions::RegionSettings;
pub use crate::lights::LightPoint;
use crate::scene::{Camera, Scene};

pub mod coverage;
mod cuts;
mod gpu_scene;
mod learned_state;
mod passes;
pub mod refine;
mod result;
mod session;
pub mod timeline;

pub use cuts::{
    build_cuts, check_region_index_fits, check_resume, initial_stats, stats_header, BOUNCE_RAYS,
};
pub use gpu_scene::{
    check_fits, hit_epsilon, ray_epsilon, surface_epsilon, GpuScene, SCENE_GLOSSY, SCENE_TEXTURED,
};
pub use learned_state::{touched_list, HostReduction};
pub use passes::{FOLD_BINDINGS, RENDER_BINDINGS};
pub use result::{Learned, RegionStats, RenderResult};
pub use session::{
    filled_before, max_film_pixels, Session, MAX_FILM_SPP, MAX_PASSES, POOL_AGE_MAX,
};

/// The light samplers, a closed set: one value per `SAMPLER` case in `shaders/render.comp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LightSampler {
    /// Every light equally likely.
    Uniform,
    /// Lights chosen in proportion to their emitted power (alias table).
    Power,
    /// One stochastic descent of the light tree by unoccluded importance at the shading point
    /// (pbrt-v4's BVHLightSampler).
    Lightbvh,
    /// Wang & Åkerlund 2009: a cluster of the region's light-tree cut ∝ its unoccluded
    /// importance at the shading point, then a light inside by power.
    Wang,
    /// Donikian et al. 2006: the region's cut, clusters by the running mean of their
    /// observed contributions mixed with the unoccluded estimate (λ = 0.1).
    Donikian,
    /// Vévoda et al. 2018: the region's cut, clusters by Bayesian online regression of their
    /// observed contributions, ∝ sqrt(mean² + variance) (the method).
    Bayes,
}

impl LightSampler {
    /// The name users type (`--sampler`, `--samplers`) and reports show.
    pub fn name(self) -> &'static str {
        match self {
            LightSampler::Uniform => "uniform",
            LightSampler::Power => "power",
            LightSampler::Lightbvh => "lightbvh",
            LightSampler::Wang => "wang",
            LightSampler::Donikian => "donikian",
            LightSampler::Bayes => "bayes",
        }
    }

    /// Every sampler, in the order of their shader ids.
    pub const ALL: [LightSampler; 6] = [
        LightSampler::Uniform,
        LightSampler::Power,
        LightSampler::Lightbvh,
        LightSampler::Wang,
        LightSampler::Donikian,
        LightSampler::Bayes,
    ];

    /// One line for `--help`.
    pub fn description(self) -> &'static str {
        match self {
            LightSampler::Uniform => "every light equally likely",
            LightSampler::Power => "lights in proportion to their power",
            LightSampler::Lightbvh => "one descent of the light tree by unoccluded importance (pbrt-v4)",
            LightSampler::Wang => "the region's cut of the light tree, clusters by unoccluded importance (Wang & Åkerlund 2009)",
            LightSampler::Donikian => "the region's cut, clusters by their running mean mixed with the unoccluded estimate (Donikian et al. 2006)",
            LightSampler::Bayes => "the region's cut, clusters by Bayesian online regression of their contributions (Vévoda et al. 2018)",
        }
    }

    /// The sampler a user typed (any case).
    pub fn from_name(name: &str) -> anyhow::Result<LightSampler> {
        LightSampler::ALL
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                let all: Vec<&str> = LightSampler::ALL.iter().map(|v| v.name()).collect();
                anyhow::anyhow!("unknown sampler '{name}'; choose from {}", all.join(", "))
            })
    }

    /// Parses a comma-separated list such as "power,uniform".
    pub fn parse_list(s: &str) -> anyhow::Result<Vec<LightSampler>> {
        let all: Vec<&str> = LightSampler::ALL.iter().map(|v| v.name()).collect();
        let mut out = Vec::new();
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            let v = LightSampler::from_name(name)?;
            if out.contains(&v) {
                bail!("sampler '{name}' is listed twice");
            }
            out.push(v);
        }
        if out.is_empty() {
            bail!("--samplers needs at least one sampler ({})", all.join(", "));
        }
        Ok(out)
    }

    /// The specialization constant of `render.comp`.
    pub fn shader_id(self) -> u32 {
        match self {
            LightSampler::Uniform => 0,
            LightSampler::Power => 1,
            LightSampler::Lightbvh => 2,
            LightSampler::Wang => 3,
            LightSampler::Donikian => 4,
            LightSampler::Bayes => 5,
        }
    }

    /// Learns from its samples (`donikian`, `bayes`).
    pub fn learned(self) -> bool {
        matches!(self, LightSampler::Donikian | LightSampler::Bayes)
    }

    /// Uses regions and cuts.
    pub fn uses_cuts(self) -> bool {
        self == LightSampler::Wang || self.learned()
    }

    /// Weighs lights or clusters by the light tree's unoccluded importance (shaders/shared/
    /// light_tree.glsl).
    pub fn uses_importance(self) -> bool {
        self == LightSampler::Lightbvh || self.uses_cuts()
    }
}

/// When a render stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    Samples(u32),
    Seconds(f64),
}

/// Which numbers the pixel jitter and the first vertex's light choice, point on the light and
/// BSDF direction take over the passes (`--stratify`; rng.glsl, render.comp STRATIFY).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Stratify {
    /// Independent numbers per sample.
    Off,
    /// The R2 jitter and the R5 first vertex, rotated per pixel (the default until
    /// 2026-12-05; docs/results.md, eighth session).
    R2,
    /// Dimensions 0–6 of the Sobol' sequence, Owen-scrambled per pixel and dimension (`on`,
    /// the name from before r2 and sobol, is this).
    #[default]
    #[value(alias = "on")]
    Sobol,
}

impl Stratify {
    /// render.comp's specialization constant STRATIFY (types.glsl STRATIFY_OFF, STRATIFY_R2,
    /// STRATIFY_SOBOL).
    pub fn code(self) -> u32 {
        match self {
            Stratify::Off => 0,
            Stratify::R2 => 1,
            Stratify::Sobol => 2,
        }
    }

    /// The name `--stratify` takes and the report writes.
    pub fn name(self) -> &'static str {
        match self {
            Stratify::Off => "off",
            Stratify::R2 => "r2",
            Stratify::Sobol => "sobol",
        }
    }
}

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub budget: Budget,
    pub seed: u32,
    pub sampler: LightSampler,
    /// Regions and cuts (used by `wang`, `donikian`, `bayes`).
    pub regions: RegionSettings,
    /// The learned samplers' settings.
    pub learn: LearnSettings,
    /// Pixel jitter and the first vertex's light choice, point on the light and BSDF
    /// direction stratified over passes (Owen-scrambled Sobol', or R2/R5 rotated per pixel),
    /// rather than independent per sample (rng.glsl). Each sample stays uniform, so all are unbiased (for the
    /// learned samplers see docs/method.md §9); references use independent numbers so that
    /// their per-pixel variance estimate is the true error of their mean (a stratified film's
    /// estimate is an upper bound).
    pub stratify: Stratify,
    /// Surface vertices of a path: 1 = direct light by light sampling alone; D ≥ 2 = path
    /// tracing with next-event estimation and MIS at every vertex (render.comp).
    pub max_depth: u32,
    /// How a point on a triangle light is drawn (render.comp LIGHT_POINT_SOLID_ANGLE).
    pub light_point: LightPoint,
    /// Next-event samples at every path vertex after the first, averaged (render.comp
    /// INDIRECT_LIGHT_SAMPLES; 1 to [`MAX_INDIRECT_LIGHT_SAMPLES`], 1 by default): a
    /// diagnostic of where a path's variance sits, the light choice after the first vertex
    /// or the rest (docs/results.md, ninth session).
    pub indirect_light_samples: u32,
    /// Next-event samples at the first vertex, averaged, each from independent numbers
    /// (render.comp FIRST_LIGHT_SAMPLES; 1 to [`MAX_INDIRECT_LIGHT_SAMPLES`], 1 by default):
    /// a diagnostic, the floor of what any light choice can take out of a film's variance
    /// (ci/bench_floor.py, docs/results.md, twelfth session).
    pub first_light_samples: u32,
    /// Statistics to start from (`--load-stats`): their cuts replace the built ones and the
    /// sample indices continue after theirs.
    pub resume: Option<Arc<SavedStats>>,
}

impl RenderSettings {
    /// What the learned sampler's observations are regressed on: `bayes` follows
    /// `--regression`; `donikian` records y = Î (no regression) whatever it says.
    pub fn observed_regression(&self) -> crate::learning::Regression {
        match self.sampler {
            LightSampler::Bayes => self.learn.regression,
            _ => crate::learning::Regression::Off,
        }
    }

    /// `sampler` on a `width`×`height` film with paths of `max_depth` vertices and every
    /// other setting at its default (one pass, seed 0, the default regions and learning,
    /// stratified numbers, area sampling of triangle lights, nothing loaded): for programs
    /// that set a few fields (`RenderSettings { seed: 3, ..RenderSettings::new(…) }`).
    pub fn new(sampler: LightSampler, width: u32, height: u32, max_depth: u32) -> Self {
        RenderSettings {
            width,
            height,
            budget: Budget::Samples(1),
            seed: 0,
            sampler,
            regions: Default::default(),
            learn: Default::default(),
            stratify: Stratify::Sobol,
            max_depth,
            light_point: Default::default(),
            indirect_light_samples: 1,
            first_light_samples: 1,
            resume: None,
        }
    }
}

/// Passes are submitted in batches of about this many seconds: long enough that submission
/// overhead vanishes, short enough for a live progress bar and a tight `--time`.
pub const PASS_BATCH_SECONDS: f64 = 0.25;
const MAX_PASSES_PER_BATCH: u32 = 256;

/// The most `--indirect-light-samples` (render.comp numbers their random dimensions apart up
/// to this many).
pub const MAX_INDIRECT_LIGHT_SAMPLES: u32 = 16;

/// The most surface vertices of a path (`--max-depth`; Russian roulette ends most long
/// before).
pub const MAX_DEPTH: u32 = 100;

impl RenderSettings {
    /// Errors unless the path settings are ones the kernels take: the CLI checks its flags
    /// with messages of its own, and a library caller's `max_depth` u32::MAX recorded 2^32
    /// dispatches, a light-sample count of 0 weighed samples by 1/0 (an audit, 2026-12-07).
    pub fn check_paths(&self) -> Result<()> {
        if !(1..=MAX_DEPTH).contains(&self.max_depth) {
            bail!(
                "max_depth {} is out of range: use 1 (direct light) to {MAX_DEPTH}",
                self.max_depth
            );
        }
        for (what, n) in [
            ("indirect_light_samples", self.indirect_light_samples),
            ("first_light_samples", self.first_light_samples),
        ] {
            if !(1..=MAX_INDIRECT_LIGHT_SAMPLES).contains(&n) {
                bail!("{what} {n} is out of range: use 1 to {MAX_INDIRECT_LIGHT_SAMPLES}");
            }
        }
        Ok(())
    }
}

/// The scene camera's vectors in the form `render.comp` takes.
pub fn camera_params(scene: &Scene, width: u32, height: u32) -> RenderParams {
    camera_vectors(&scene.camera, width, height)
}

/// A camera's vectors in the form `render.comp` takes.
pub fn camera_vectors(c: &crate::scene::Camera, width: u32, height: u32) -> RenderParams {
    let tan = (0.5 * c.yfov).tan();
    let aspect = width as f32 / height as f32;
    let right = c.forward.cross(c.up).normalize();
    let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
    RenderParams {
        cam_pos: v4(c.position),
        cam_u: v4(right * tan * aspect),
        cam_v: v4(c.up * tan),
        cam_w: v4(c.forward),
        width,
        height,
        ..Default::default()
    }
}

/// Where to stop and look at the image during a render (for convergence curves).
#[derive(Clone, Debug, Default)]
pub enum Checkpoints {
    #[default]
    None,
    /// After these many seconds of rendering (the first batch end at or past each).
    Seconds(Vec<f64>),
    /// After exactly these sample counts.
    Samples(Vec<u32>),
}

/// The image at a checkpoint.
pub struct Checkpoint {
    pub spp: u32,
    /// Render time so far (checkpoint work excluded).
    pub seconds: f64,
    pub mean: Vec<[f32; 3]>,
}

/// Renders `scene`; `progress(spp_done, fraction)` is called after every batch of passes.
pub fn render(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    render_with_checkpoints(
        ctx,
        scene,
        gpu,
        settings,
        &Checkpoints::None,
        &mut |_| Ok(()),
        progress,
    )
}

/// [`render`] that also hands the running image to `on_checkpoint` at the given points.
///
/// The render clock only runs while passes execute: reading the image back and whatever
/// `on_checkpoint` does are outside it, so checkpoints do not change the measured time or
/// how many samples a time budget buys (only the wall clock grows).
#[allow(clippy::too_many_arguments)]
pub fn render_with_checkpoints(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    checkpoints: &Checkpoints,
    on_checkpoint: &mut dyn FnMut(Checkpoint) -> Result<()>,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    let mut session = Session::new(ctx, scene, gpu, settings)?;
    run_session(
        &mut session,
        settings.budget,
        checkpoints,
        on_checkpoint,
        progress,
    )
}

/// Runs passes of `session` until `budget` (samples or seconds of its film) is reached or a
/// stop is asked for (Ctrl-C: the batch in flight finishes, and the result says
/// `interrupted`); checkpoints as [`render_with_checkpoints`].
pub fn run_session(
    session: &mut Session,
    budget: Budget,
    checkpoints: &Checkpoints,
    on_checkpoint: &mut dyn FnMut(Checkpoint) -> Result<()>,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    run_session_until(
        session,
        budget,
        f64::INFINITY,
        checkpoints,
        on_checkpoint,
        progress,
    )
}

/// [`run_session`] that also returns (not interrupted) once the film's render clock reaches
/// `until` seconds, its batches aimed not to pass it, so that the caller can write the image
/// so far and call again (`render --checkpoint`). The passes are those of one call: growth
/// points and learning windows follow the pass counter, not the batches.
pub fn run_session_until(
    session: &mut Session,
    budget: Budget,
    until: f64,
    checkpoints: &Checkpoints,
    on_checkpoint: &mut dyn FnMut(Checkpoint) -> Result<()>,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    // The CLI checks --time; a library caller's NaN never ended (an audit, 2026-12-07).
    if let Budget::Seconds(s) = budget {
        if !(s.is_finite() && s > 0.0) {
            anyhow::bail!("a time budget of {s} seconds: give a finite number of seconds above 0");
        }
    }
    if let Budget::Samples(n) = budget {
        if n > MAX_FILM_SPP {
            anyhow::bail!("a budget of {n} samples a pixel is more than the {MAX_FILM_SPP} a film's float sums add without loss; render parts of other seeds and merge them (`lightlearn merge`)");
        }
    }
    let _active = crate::interrupt::Active::begin();
    // Checkpoints still ahead, as (seconds, spp) limits; one of the two is infinite.
    let mut pending: std::collections::VecDeque<(f64, u32)> = match checkpoints {
        Checkpoints::None => Default::default(),
        Checkpoints::Seconds(t) => t.iter().map(|&t| (t, u32::MAX)).collect(),
        Checkpoints::Samples(n) => n.iter().map(|&n| (f64::INFINITY, n)).collect(),
    };
    let mut batch = 1u32;
    let mut interrupted = false;
    // The spp of the last checkpoint given (a full film's last image is not given twice).
    let mut last_checkpoint: Option<u32> = None;
    loop {
        let (done, elapsed) = (session.spp(), session.film_seconds());
        let mut k = match budget {
            // A film that already holds the budget (a second call with a smaller one) runs
            // no pass; `n - done` wrapped and ran one more batch.
            Budget::Samples(n) => batch.min(n.saturating_sub(done)),
            // A time budget ends where the film is full ([`MAX_FILM_SPP`]).
            Budget::Seconds(_) => batch.min(MAX_FILM_SPP.saturating_sub(done)),
        };
        if let Some(&(_, n)) = pending.front() {
            if n > done {
                k = k.min(n - done);
            }
        }
        if k == 0 {
            // A time budget's film filled: the checkpoints still ahead get the image as it
            // ends, once (compare's convergence.csv lost its last points: a review,
            // 2026-12-07).
            if matches!(budget, Budget::Seconds(_))
                && !pending.is_empty()
                && done > 0
                && last_checkpoint != Some(done)
            {
                pending.clear();
                on_checkpoint(Checkpoint {
                    spp: done,
                    seconds: elapsed,
                    mean: session.image()?,
                })?;
            }
            break;
        }
        let dt = session.run_passes(k)?;
        let (done, elapsed) = (session.spp(), elapsed + dt);
        let fraction = match budget {
            Budget::Samples(n) => done as f64 / n as f64,
            Budget::Seconds(s) => (elapsed / s).min(1.0),
        };
        progress(done, fraction);
        // Every checkpoint this batch passed, given once: several that fell inside one
        // batch (the first, on a cold shader cache) were each written, the same point up to
        // six times in compare's convergence.csv (an audit, 2026-12-06).
        let mut passed = false;
        while let Some(&(t, n)) = pending.front() {
            if elapsed < t && done < n {
                break;
            }
            pending.pop_front();
            passed = true;
        }
        if passed {
            last_checkpoint = Some(done);
            on_checkpoint(Checkpoint {
                spp: done,
                seconds: elapsed,
                mean: session.image()?,
            })?;
        }
        // A budget met is a finished render, whatever was asked meanwhile: a stop during
        // the last batch of `--spp` was reported as an interruption and a complete
        // reference thrown away (an audit, 2026-12-06).
        let met = match budget {
            Budget::Seconds(s) => elapsed >= s,
            Budget::Samples(n) => done >= n,
        };
        if met {
            break;
        }
        if crate::interrupt::requested() {
            interrupted = true;
            break;
        }
        if elapsed >= until {
            break;
        }
        // Aim the next batch at PASS_BATCH_SECONDS, and never past the next time checkpoint
        // or a time budget's end.
        let per_pass = dt / k as f64;
        let mut target = PASS_BATCH_SECONDS.min(until - elapsed);
        if let Budget::Seconds(s) = budget {
            target = target.min(s - elapsed);
        }
        if let Some(&(t, _)) = pending.front() {
            target = target.min(t - elapsed);
        }
        batch = ((target / per_pass.max(1e-9)) as u32).clamp(1, MAX_PASSES_PER_BATCH);
    }
    let mut result = session.result()?;
    result.interrupted = interrupted;
    Ok(result)
}

/// The JSON report written beside every rendered image.
pub fn report_json(
    scene: &Scene,
    settings: &RenderSettings,
    result: &RenderResult,
    device: &str,
) -> serde_json::Value {
    // Null at 1 spp, where there is no variance.
    let (mse, rel) = result.known_error().unzip();
    serde_json::json!({
        "lightlearn_version": env!("CARGO_PKG_VERSION"),
        "scene": scene.source,
        "scene_hash": crate::compare::reference::scene_hash(scene),
        // The random streams of the passes: `first_sample_index` .. + spp (a continuation of
        // loaded statistics starts after theirs). Parts to merge must not share them.
        "first_sample_index": result.first_sample_index,
        "triangles": scene.triangles.len(),
        "lights": scene.lights.len(),
        "sampler": settings.sampler.name(),
        "spp": result.spp,
        "width": settings.width,
        "height": settings.height,
        "seed": settings.seed,
        "budget": match settings.budget {
            Budget::Samples(n) => serde_json::json!({"spp": n}),
            Budget::Seconds(s) => serde_json::json!({"seconds": s}),
        },
        "render_seconds": result.render_seconds,
        "device": device,
        "invalid_samples_dropped": result.invalid_samples,
        "interrupted": result.interrupted,
        "learning": match &result.learned {
            Some(l) => serde_json::json!({
                "settings": settings.learn,
                "diagnostics": l.diagnostics,
                "samples_done_including_loaded": l.saved.header.samples_done,
            }),
            None => serde_json::Value::Null,
        },
        "regions": if settings.sampler.uses_cuts() {
            serde_json::json!({
                "grid": settings.regions.grid,
                "normal_bins": settings.regions.normal_bins,
                "tau": settings.regions.tau,
                "k_max": settings.regions.k_max,
                "in_cluster": if settings.regions.in_cluster_importance { "importance" } else { "power" },
                "coarse_blocks": settings.regions.coarse_blocks,
                "stats": result.regions,
            })
        } else {
            serde_json::Value::Null
        },
        "estimated_mse_of_mean": mse,
        "estimated_rel_mse_of_mean": rel,
        "zero_light_sample_fraction": result.zero_sample_fraction(),
        "integrator": if settings.max_depth == 1 {
            "direct illumination by light sampling, glTF metallic-roughness BRDF, one light sample per pixel sample".to_string()
        } else {
            format!("path tracing, up to {} surface vertices, glTF metallic-roughness BRDF (Lambert + GGX), next-event estimation + BSDF sampling with MIS (power heuristic), Russian roulette", settings.max_depth)
        },
        "max_depth": settings.max_depth,
        "light_point": settings.light_point,
        "indirect_light_samples": settings.indirect_light_samples,
        "first_light_samples": settings.first_light_samples,
        "stratify": settings.stratify.name(),
        "camera": camera_json(&scene.camera),
    })
}

/// The camera an image was rendered from, as its report gives it (the preview's screenshots
/// say where the user had flown to).
pub fn camera_json(camera: &Camera) -> serde_json::Value {
    serde_json::json!({
        "position": camera.position.to_array(),
        "forward": camera.forward.to_array(),
        "up": camera.up.to_array(),
        "yfov_degrees": camera.yfov.to_degrees(),
    })
}
