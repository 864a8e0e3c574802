//! The command line's arguments (clap): what each command accepts, its help text and
//! defaults, and their conversion into the library's plain requests (`lightlearn::commands`).

use std::path::PathBuf;

use anyhow::Result;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand};

use lightlearn::commands::compare::CompareRequest;
use lightlearn::commands::reference::ReferenceRequest;
use lightlearn::commands::render::RenderRequest;
use lightlearn::gpu::ContextOptions;
use lightlearn::learning::{LearnSettings, Regression, UpdateEvery};
use lightlearn::lights::regions::RegionSettings;
use lightlearn::lights::LightPoint;
use lightlearn::render::LightSampler;
use lightlearn::scene::families::{Family, FamilyParams};

mod animate;
mod preview;
mod profile;
mod variance;
pub use animate::{AnimateArgs, FarmArgs};
pub use preview::PreviewArgs;
pub use profile::ProfileArgs;
pub use variance::VarianceArgs;

pub(crate) fn sampler_parser() -> impl TypedValueParser<Value = LightSampler> {
    PossibleValuesParser::new(
        LightSampler::ALL.map(|s| PossibleValue::new(s.name()).help(s.description())),
    )
    .map(|s| LightSampler::from_name(&s).expect("one of the possible values"))
}

fn family_parser() -> impl TypedValueParser<Value = Family> {
    PossibleValuesParser::new(
        Family::ALL.map(|f| PossibleValue::new(f.name()).help(f.description())),
    )
    .map(|s| {
        *Family::ALL
            .iter()
            .find(|f| f.name() == s)
            .expect("one of the possible values")
    })
}

#[derive(Parser)]
#[command(
    name = "lightlearn",
    version,
    about = "GPU many-light renderer (Vulkan compute). Direct illumination with learned light selection (bayes: Bayesian online regression, Vévoda et al. 2018) and its baselines (donikian, wang, lightbvh, power, uniform)",
    long_about = None
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a glTF scene to FILE.exr (float32 RGB), FILE.png (sRGB preview) and FILE.json
    /// (report). Without SCENE, renders the built-in default many-light scene.
    Render(RenderArgs),
    /// Compare light samplers on one scene at equal time and/or equal samples against a
    /// reference; writes an HTML report, metrics.json, convergence.csv and the EXRs.
    Compare(CompareArgs),
    /// Render a converged reference image (sampler `lightbvh`, long budget); it is also
    /// cached so `compare` reuses it.
    Reference(ReferenceArgs),
    /// Render a glTF animation frame by frame (node translation/rotation/scale channels on
    /// cameras, meshes and lights) to DIR/frame-NNNN.{exr,png,json}, DIR/animation.json and,
    /// with ffmpeg installed, DIR/animation.mp4; the learned statistics carry from frame to
    /// frame (--carry on).
    Animate(AnimateArgs),
    /// Open a window that shows the scene converging while you look, and keeps learning
    /// while you move (W/A/S/D/Q/E, arrows/right-drag look, left-drag orbit, wheel speed, F
    /// frame, Home scene camera, 1-6 sampler, R reset learning, V view, +/- exposure, G
    /// direct/paths, P screenshot, Esc quit). Needs a display; `render` is the headless path.
    Preview(PreviewArgs),
    /// Write an Open Job Description job (JOBDIR/template.yaml) that renders a still or an
    /// animation in sample chunks on a render farm and merges them (`openjd run
    /// JOBDIR/template.yaml` runs it here).
    Farm(FarmArgs),
    /// Generate a procedural many-light scene as glTF (.glb, or .gltf with embedded data).
    /// The same arguments always give a byte-identical file.
    Scene(SceneArgs),
    /// Benchmark: rays/s of the GPU traversal kernel and of a multithreaded CPU traversal of
    /// the same BVH, side by side, for coherent and incoherent rays.
    BenchRays(BenchArgs),
    /// Benchmark: where a render pass spends its time. Times the same passes with one stage
    /// of the kernel knocked out at a time (light selection, shadow rays, MIS pmf, statistics
    /// atomics, folds); a stage's cost is what leaving it out saves.
    Profile(ProfileArgs),
    /// Diagnostic: where each sampler's variance per sample comes from — the cluster choice,
    /// the light inside the cluster, the point on the light, the pixel footprint — from exact
    /// per-light sums at fixed first hits, checked against two renders of other seeds.
    Variance(VarianceArgs),
    /// Combine renders of one image made apart (other seeds: farm chunks) into the image
    /// their summed samples give, weighted by each part's spp from its JSON.
    Merge(MergeArgs),
    /// Sum statistics files saved by --save-stats from renders of one scene with the same
    /// settings (other seeds, cameras or machines); the result loads with --load-stats.
    MergeStats(MergeStatsArgs),
}

#[derive(Args)]
pub struct MergeArgs {
    /// The parts (EXR files written by render, each with its .json beside it).
    #[arg(required = true, value_name = "PART.exr")]
    pub parts: Vec<PathBuf>,
    /// The merged EXR (the PNG and JSON are written next to it).
    #[arg(long, value_name = "FILE.exr")]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct MergeStatsArgs {
    /// The statistics files.
    #[arg(required = true, value_name = "FILE.stats")]
    pub parts: Vec<PathBuf>,
    /// The merged statistics file.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// The statistics every part started from (--load-stats of farm chunks): counted once,
    /// not once per part.
    #[arg(long, value_name = "FILE")]
    pub base: Option<PathBuf>,
}

#[derive(Args)]
pub struct DeviceArgs {
    /// Use the Vulkan device whose name contains this text (case-insensitive). Default: a
    /// discrete GPU if there is one, else integrated, else a CPU device (lavapipe).
    #[arg(long, value_name = "NAME")]
    pub device: Option<String>,
    /// Turn on the Khronos validation layer and fail on any validation error.
    #[arg(long)]
    pub validation: bool,
}

/// Regions and cuts (docs/method.md §2), used by `--sampler wang`.
#[derive(Args)]
pub struct RegionArgs {
    /// Region grid: cells along the longest axis of the scene bounds.
    #[arg(long, default_value_t = 32)]
    pub grid: u32,
    /// Split each cell by the dominant axis and sign of the shading normal (6 bins).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub normal_bins: String,
    /// Refine a cut until its largest cluster's importance ≤ τ × the cut's total.
    #[arg(long, default_value_t = 0.02)]
    pub tau: f32,
    /// At most this many clusters per cut (1..=64).
    #[arg(long, default_value_t = 32)]
    pub k_max: u32,
    /// How a chosen cluster picks its light: by importance at the shading point (a light-BVH
    /// descent of the cluster's subtree; measured better on rooms16 and city) or by power
    /// (Wang & Åkerlund 2009 as published).
    #[arg(long, default_value = "importance", value_parser = ["importance", "power"])]
    pub in_cluster: String,
    /// The regions of a block of 2×2×2 cells (one normal bin) that holds no light share one
    /// cut and one set of statistics; near lights each region keeps its own. Measured: the
    /// same variance (0.96–1.04× on ten scenes), 0.84× the time on cornell40 (3.7× fewer
    /// slots), elsewhere within the noise (docs/results.md, seventh session).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub coarse_blocks: String,
}

impl RegionArgs {
    pub fn settings(&self) -> Result<RegionSettings> {
        let s = RegionSettings {
            grid: self.grid,
            normal_bins: self.normal_bins == "on",
            tau: self.tau,
            k_max: self.k_max,
            in_cluster_importance: self.in_cluster == "importance",
            coarse_blocks: self.coarse_blocks == "on",
        };
        s.check()?;
        Ok(s)
    }
}

/// The learned samplers (`--sampler bayes|donikian`, docs/method.md §3–§8).
#[derive(Args)]
pub struct LearnArgs {
    /// Fold new observations into the posteriors every K passes (1 pass = 1 spp); auto:
    /// every pass up to pass 16, then windows of 2, 4, 8 and (from pass 128) 16 passes,
    /// counted from the last camera move.
    #[arg(long, default_value = "auto", value_name = "K|auto")]
    pub update_every: UpdateEvery,
    /// bayes: what a cluster's contribution is regressed on across its region. importance:
    /// its unoccluded importance at the shading point (wang's weight), so what is learned is
    /// the share that arrives (measured on strings 1.29× less variance direct, 1.47× path
    /// traced; 0.99–1.07× elsewhere);
    /// distance: 1/d² (the paper's; `on` is its old name); off: one constant per slot.
    #[arg(long, default_value = "importance", value_parser = ["importance", "distance", "on", "off"])]
    pub regression: String,
    /// bayes: pick clusters ∝ sqrt(mean² + variance) (the method) or ∝ the mean.
    #[arg(long, default_value = "sqrt", value_parser = ["sqrt", "mean"])]
    pub target: String,
    /// bayes: Beta and Normal-inverse-gamma priors from the unoccluded estimate (off: no
    /// pseudo-counts; divisions guarded, a slot never seen lit keeps chance ≥ 1/(n+1)).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub priors: String,
    /// bayes: observations include the BRDF towards the sampled light (luminance of f(v, l)), so glossy receivers learn the reflected contribution; the prior uses the BRDF's albedo / π.
    #[arg(long)]
    pub brdf_aware: bool,
    /// bayes: multiply each cluster's learned weight by the BRDF at the shading point towards
    /// the cluster (its direction nearest the mirror direction, plus a floor of 0.1 × albedo/π
    /// so no cluster drops to 0); observations stay BRDF-free. Only glossy materials change
    /// (measured 2.0× and 3.5× better than off at equal time on two glossy scenes; docs/results.md).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub brdf_select: String,
    /// bayes: subtract the model's predicted mean of every cluster as a control variate
    /// (unbiased; measured 1.4× better on rooms16, no gain on city, so off by default; see
    /// docs/results.md).
    #[arg(long)]
    pub control_variates: bool,
    /// bayes: Beta prior pseudo-count of zero observations (n̄_o).
    #[arg(long, default_value_t = 2.0)]
    pub prior_zero: f32,
    /// bayes: Beta prior pseudo-count of non-zero observations (n̄_v).
    #[arg(long, default_value_t = 2.0)]
    pub prior_nonzero: f32,
    /// bayes: pseudo-count of the Normal prior on the regression constant (n̄).
    #[arg(long, default_value_t = 1.0)]
    pub prior_n: f32,
    /// bayes: shape of the inverse-gamma prior on the variance (n̄_α).
    #[arg(long, default_value_t = 1.0)]
    pub prior_alpha: f32,
    /// bayes: prior coefficient of variation c_v (β = n̄_α (c_v μ0)²).
    #[arg(long, default_value_t = 1.0)]
    pub prior_cv: f32,
    /// donikian: weight of the unoccluded estimate in the defensive mixture.
    #[arg(long, default_value_t = 0.1)]
    pub lambda: f32,
    /// bayes: prior mean μ0 = Ĩ · d² · S (S itself by --regression importance), Ĩ's power in the units of the observations
    /// [default: 1/(4π), exact for point lights (1/π would be for one-sided area lights);
    /// measured better on rooms16 and city, see docs/results.md].
    #[arg(long, value_name = "S")]
    pub prior_scale: Option<f32>,
    /// bayes/donikian: learned cut refinement. Observations are also counted by the child
    /// of the cluster they came through, and at each growth point (passes 1, 2, 4, …, 32,
    /// then every 64) a region splits up to N of its clusters into their two children where
    /// the children's observations differ enough that drawing them apart saves more than the
    /// longer cut costs (≥ 64 observations); the children inherit the cluster's statistics as
    /// their prior, up to 64 clusters (--k-max caps the cut as built). 0: cuts never change
    /// (the default: at equal time 1.05× on rooms36, 1.01× on rooms16, and 1–7 % lost where
    /// little splits; docs/results.md).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub refine_cuts: u32,
    /// bayes: a cluster slot with no observation of its own borrows up to N observations of
    /// the same cluster from the regions around it (the same 4×4×4 block of grid cells and
    /// normal bin), recomputed at each growth point until it has data of its own; they move
    /// only its posterior. Measured 1.29× less variance on city at 64 spp (1.14× at 256),
    /// 7–9 % more on strings; 0: off.
    #[arg(long, default_value_t = 4.0, value_name = "N")]
    pub pool_priors: f32,
    /// bayes: defensive mixture. Clusters are drawn with (1 − ε) × the learned pmf + ε ×
    /// wang's, so none gets less than ε times wang's chance. 0: off.
    #[arg(long, default_value_t = 0.0, value_name = "ε")]
    pub defensive: f32,
}

impl RegionArgs {
    /// These options as a command line gives them (for the farm's task commands).
    pub fn to_args(&self) -> Vec<String> {
        [
            ("--grid", self.grid.to_string()),
            ("--normal-bins", self.normal_bins.clone()),
            ("--tau", self.tau.to_string()),
            ("--k-max", self.k_max.to_string()),
            ("--in-cluster", self.in_cluster.clone()),
        ]
        .into_iter()
        .flat_map(|(k, v)| [k.to_string(), v])
        .collect()
    }
}

impl LearnArgs {
    /// These options as a command line gives them (for the farm's task commands).
    pub fn to_args(&self) -> Vec<String> {
        let mut a: Vec<String> = [
            ("--update-every", self.update_every.to_string()),
            ("--regression", self.regression.clone()),
            ("--target", self.target.clone()),
            ("--priors", self.priors.clone()),
            ("--brdf-select", self.brdf_select.clone()),
            ("--prior-zero", self.prior_zero.to_string()),
            ("--prior-nonzero", self.prior_nonzero.to_string()),
            ("--prior-n", self.prior_n.to_string()),
            ("--prior-alpha", self.prior_alpha.to_string()),
            ("--prior-cv", self.prior_cv.to_string()),
            ("--lambda", self.lambda.to_string()),
            ("--refine-cuts", self.refine_cuts.to_string()),
            ("--pool-priors", self.pool_priors.to_string()),
            ("--defensive", self.defensive.to_string()),
        ]
        .into_iter()
        .flat_map(|(k, v)| [k.to_string(), v])
        .collect();
        if let Some(s) = self.prior_scale {
            a.extend(["--prior-scale".to_string(), s.to_string()]);
        }
        for (on, flag) in [
            (self.brdf_aware, "--brdf-aware"),
            (self.control_variates, "--control-variates"),
        ] {
            if on {
                a.push(flag.to_string());
            }
        }
        a
    }

    pub fn settings(&self) -> Result<LearnSettings> {
        let s = LearnSettings {
            update_every: self.update_every,
            regression: match self.regression.as_str() {
                "importance" => Regression::Importance,
                "distance" | "on" => Regression::Distance,
                _ => Regression::Off,
            },
            target_mean: self.target == "mean",
            priors: self.priors == "on",
            brdf_aware: self.brdf_aware,
            brdf_select: self.brdf_select == "on",
            control_variates: self.control_variates,
            prior_zero: self.prior_zero,
            prior_nonzero: self.prior_nonzero,
            prior_n: self.prior_n,
            prior_alpha: self.prior_alpha,
            prior_cv: self.prior_cv,
            lambda: self.lambda,
            prior_scale: self
                .prior_scale
                .unwrap_or(LearnSettings::default().prior_scale),
            refine_cuts: self.refine_cuts,
            pool_priors: self.pool_priors,
            defensive: self.defensive,
        };
        s.check()?;
        Ok(s)
    }
}

#[derive(Args)]
pub struct RenderArgs {
    /// glTF 2.0 scene (.gltf or .glb). Default: the built-in scene (scenes/default.glb).
    pub scene: Option<PathBuf>,
    /// Light-selection strategy. bayes (the learned one) had the lowest MSE per second on 6
    /// of the 7 committed scenes (hall: wang; see docs/results.md)
    #[arg(long, default_value = "bayes", value_parser = sampler_parser())]
    pub sampler: LightSampler,
    /// Samples per pixel [default: 64 unless --time is given].
    #[arg(long, value_name = "N", conflicts_with = "time")]
    pub spp: Option<u32>,
    /// Render for this many seconds instead of a fixed sample count.
    #[arg(long, value_name = "SECONDS")]
    pub time: Option<f64>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels (the aspect ratio follows the image size).
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Random seed: the same seed, scene and settings give a bit-identical image on the same
    /// device.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Output EXR path; the PNG and JSON are written next to it with the same stem.
    #[arg(long, default_value = "render.exr", value_name = "FILE.exr")]
    pub out: PathBuf,
    /// Surface vertices of a path: 1 = direct light by light sampling alone; D ≥ 2 = path
    /// tracing with next-event estimation and MIS at every vertex, Russian roulette from the
    /// third vertex.
    #[arg(long, default_value_t = 8, value_name = "D")]
    pub max_depth: u32,
    /// How the light sample draws a point on a triangle light.
    #[arg(long, value_enum, default_value_t = LightPoint::Area)]
    pub light_point: LightPoint,
    /// Next-event samples (light choice, point on the light, shadow ray) at every path vertex
    /// after the first, averaged; 1 to 16, needs --max-depth 2 or more. A diagnostic: the
    /// variance that falls from 1 to N is the light choice's at the later vertices, what stays
    /// is the BSDF's directions and the first vertex (rooms16, depth 8: 31 % and 69 % of
    /// `bayes`'s). Costs about N times the shadow rays; it did not pay at equal time there.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub indirect_light_samples: u32,
    /// sobol (or on): the pixel jitter and the first vertex's light choice, point on the light
    /// and BSDF direction are dimensions of the Sobol' sequence over the passes, Owen-scrambled
    /// per pixel (a pixel's samples split between the lights close to their probabilities and
    /// cover the pixel evenly: rooms16 direct light `wang` 1.8× and `bayes` 1.6× less
    /// variance than r2); r2: the R2 jitter and R5 numbers of the builds before; off:
    /// independent numbers, which keeps the learned samplers exactly unbiased
    /// (docs/method.md §9) at a price where emitters are in view (rooms16: 15.7× r2's
    /// variance, mostly the jitter at their edges).
    #[arg(long, value_enum, default_value_t = lightlearn::render::Stratify::Sobol)]
    pub stratify: lightlearn::render::Stratify,
    /// No progress bar or summary (errors and warnings are still printed).
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub regions: RegionArgs,
    #[command(flatten)]
    pub learn: LearnArgs,
    /// Save the learned statistics (with their regions and cuts) to FILE after the render
    /// (bayes, donikian).
    #[arg(long, value_name = "FILE")]
    pub save_stats: Option<PathBuf>,
    /// Start from statistics saved by --save-stats (same scene and region settings); the
    /// sample indices continue after the saved render's.
    #[arg(long, value_name = "FILE")]
    pub load_stats: Option<PathBuf>,
    /// Let --save-stats replace an existing file that is not a statistics file.
    #[arg(long)]
    pub force: bool,
    /// Render farm chunk K: the samples [K·spp, (K+1)·spp) (after what --load-stats
    /// learned), so chunks never share random numbers; `lightlearn merge` combines them (for
    /// uniform, power and lightbvh into the one-machine render, to float rounding).
    #[arg(long, value_name = "K")]
    pub chunk: Option<u32>,
    /// Create the --out file's folder when it is missing (farm tasks write into new folders).
    #[arg(long)]
    pub mkdir: bool,
    #[command(flatten)]
    pub device: DeviceArgs,
}

#[derive(Args)]
pub struct CompareArgs {
    /// glTF scene (.gltf or .glb). Default: the built-in scene.
    pub scene: Option<PathBuf>,
    /// Comma-separated samplers; the first is the baseline of the speed-ups.
    #[arg(long, value_name = "A,B,...", default_value = "uniform,power")]
    pub samplers: String,
    /// Equal-time comparison: seconds of rendering per sampler.
    #[arg(long, value_name = "SECONDS")]
    pub time: Option<f64>,
    /// Equal-sample comparison: samples per pixel per sampler (with --time: both are run).
    #[arg(long, value_name = "N")]
    pub spp: Option<u32>,
    /// Reference image (float EXR of the same size). Default: rendered once and cached
    /// (see `lightlearn reference`).
    #[arg(long, value_name = "REF.exr")]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of a reference rendered here.
    #[arg(long, default_value_t = lightlearn::compare::reference::DEFAULT_REFERENCE_SPP)]
    pub reference_spp: u32,
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub image: StudyArgs,
    /// How the light sample draws a point on a triangle light, for every sampler (a reference
    /// rendered here samples by area either way: both are unbiased).
    #[arg(long, value_enum, default_value_t = LightPoint::Area)]
    pub light_point: LightPoint,
    #[command(flatten)]
    pub regions: RegionArgs,
    #[command(flatten)]
    pub learn: LearnArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// Image settings shared by `compare` and `reference` (so a reference made by one is found by
/// the other).
#[derive(Args)]
pub struct StudyArgs {
    /// Image width in pixels.
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 240)]
    pub height: u32,
    /// Seed of the compared renders; a reference draws from an independent stream derived
    /// from it.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Surface vertices of a path: 1 = direct light by light sampling alone; D ≥ 2 = path
    /// tracing with next-event estimation and MIS at every vertex, Russian roulette from the
    /// third vertex.
    #[arg(long, default_value_t = 8, value_name = "D")]
    pub max_depth: u32,
    /// No progress bar or summary (errors and warnings are still printed).
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args)]
pub struct ReferenceArgs {
    /// glTF scene (.gltf or .glb). Default: the built-in scene.
    pub scene: Option<PathBuf>,
    /// Output EXR (the PNG and JSON are written next to it).
    #[arg(long, value_name = "FILE.exr")]
    pub out: PathBuf,
    /// Samples per pixel.
    #[arg(long, default_value_t = lightlearn::compare::reference::DEFAULT_REFERENCE_SPP)]
    pub spp: u32,
    #[command(flatten)]
    pub image: StudyArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

#[derive(Args)]
pub struct SceneArgs {
    /// Scene family.
    #[arg(value_parser = family_parser())]
    pub family: Family,
    /// Number of lights, exact (each emissive triangle counts as one). cornell: 1..=64,
    /// city: 16..=1000000, others: 1..=1000000.
    #[arg(long, value_name = "N")]
    pub lights: usize,
    /// Random seed of the layout and light placement.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output file: .glb (binary) or .gltf (text, buffers embedded).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// rooms: grid of rooms, e.g. 4x3 [default: about 25 lights per room].
    #[arg(long, value_name = "XxZ", value_parser = parse_grid)]
    pub rooms: Option<(usize, usize)>,
    /// city: blocks per side (1..=100) [default: enough for about half the windows lit].
    #[arg(long, value_name = "N")]
    pub blocks: Option<usize>,
    /// strings: segments around each curved object (3..=512).
    #[arg(long, default_value_t = 24)]
    pub resolution: u32,
    /// Glossy variant: floors (cornell: the tall box, white) become a glTF metal
    /// (metallic 1, GGX) with this roughness in [0, 1]; all else stays Lambertian.
    #[arg(long, value_name = "ROUGHNESS")]
    pub glossy: Option<f32>,
    /// Animated variant, 4 s (rooms: a camera walk from a room through its door along the
    /// corridor into another room; city: cars with spot headlights driving the streets,
    /// taken from the lamp budget so --lights stays exact).
    #[arg(long)]
    pub animate: bool,
}

pub fn parse_grid(s: &str) -> std::result::Result<(usize, usize), String> {
    let (a, b) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not a grid like 4x3"))?;
    let n = |t: &str| {
        t.trim()
            .parse::<usize>()
            .map_err(|_| format!("'{s}' is not a grid like 4x3"))
    };
    Ok((n(a)?, n(b)?))
}

#[derive(Args)]
pub struct BenchArgs {
    /// Triangles in the procedural benchmark mesh.
    #[arg(long, default_value_t = 120_000)]
    pub triangles: usize,
    /// Rays per kind = width × height.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Timed runs per measurement; the fastest counts (best of 3 still varied by ±12 % on
    /// lavapipe on a shared 2-core machine).
    #[arg(long, default_value_t = 7)]
    pub repeats: u32,
    #[command(flatten)]
    pub device: DeviceArgs,
}

impl DeviceArgs {
    pub fn options(&self) -> ContextOptions {
        ContextOptions {
            device: self.device.clone(),
            validation: self.validation,
        }
    }
}

impl RenderArgs {
    pub fn request(&self) -> Result<RenderRequest> {
        Ok(RenderRequest {
            scene: self.scene.clone(),
            sampler: self.sampler,
            spp: self.spp,
            seconds: self.time,
            width: self.width,
            height: self.height,
            seed: self.seed,
            out: self.out.clone(),
            max_depth: self.max_depth,
            light_point: self.light_point,
            indirect_light_samples: self.indirect_light_samples,
            stratify: self.stratify,
            regions: self.regions.settings()?,
            learn: self.learn.settings()?,
            save_stats: self.save_stats.clone(),
            load_stats: self.load_stats.clone(),
            force: self.force,
            chunk: self.chunk,
            mkdir: self.mkdir,
            device: self.device.options(),
        })
    }
}

impl CompareArgs {
    pub fn request(&self) -> Result<CompareRequest> {
        Ok(CompareRequest {
            scene: self.scene.clone(),
            samplers: LightSampler::parse_list(&self.samplers)?,
            time: self.time,
            spp: self.spp,
            reference: self.reference.clone(),
            reference_spp: self.reference_spp,
            out: self.out.clone(),
            width: self.image.width,
            height: self.image.height,
            seed: self.image.seed,
            max_depth: self.image.max_depth,
            light_point: self.light_point,
            regions: self.regions.settings()?,
            learn: self.learn.settings()?,
            device: self.device.options(),
        })
    }
}

impl ReferenceArgs {
    pub fn request(&self) -> ReferenceRequest {
        ReferenceRequest {
            scene: self.scene.clone(),
            out: self.out.clone(),
            spp: self.spp,
            width: self.image.width,
            height: self.image.height,
            seed: self.image.seed,
            max_depth: self.image.max_depth,
            device: self.device.options(),
        }
    }
}

impl SceneArgs {
    pub fn params(&self) -> FamilyParams {
        FamilyParams {
            animate: self.animate,
            lights: self.lights,
            seed: self.seed,
            rooms: self.rooms,
            blocks: self.blocks,
            resolution: self.resolution,
            glossy: self.glossy,
        }
    }
}
