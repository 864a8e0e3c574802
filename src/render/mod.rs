//! Rendering: upload the scene once, then dispatch `render.comp` one sample per pixel per pass
//! until the sample count or the time budget is reached. This module holds the settings; the
//! pass loop is `run.rs`, the session (scene, learned state, film) `session/`, the JSON
//! report `report.rs`.

use std::sync::Arc;

use anyhow::{bail, Result};
use glam::Vec3;

use crate::gpu::layout::RenderParams;
use crate::learning::stats_file::SavedStats;
use crate::learning::LearnSettings;
use crate::lights::regions::RegionSettings;
pub use crate::lights::LightPoint;
use crate::scene::Scene;

pub mod coverage;
mod cuts;
mod gpu_scene;
mod learned_state;
mod passes;
pub mod refine;
mod report;
mod result;
mod run;
mod session;
pub mod timeline;

pub use cuts::{
    build_cuts, check_region_index_fits, check_resume, initial_stats, stats_header, BOUNCE_RAYS,
};
pub use gpu_scene::{
    check_fits, hit_epsilon, pack_normal, ray_epsilon, surface_epsilon, GpuScene, SCENE_ALPHA_MASK,
    SCENE_EMISSIVE_TEXTURED, SCENE_GLOSSY, SCENE_NORMAL_MAPPED, SCENE_SMOOTH, SCENE_TEXTURED,
};
pub use learned_state::{touched_list, HostReduction};
pub use passes::{FOLD_BINDINGS, RENDER_BINDINGS};
pub use report::{camera_json, report_json};
pub use result::{Learned, RegionStats, RenderResult};
pub use run::{
    render, render_with_checkpoints, run_session, run_session_until, Checkpoint, Checkpoints,
};
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
pub(crate) const MAX_PASSES_PER_BATCH: u32 = 256;

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
