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
use lightlearn::lights::LightPoint;
use lightlearn::render::LightSampler;
use lightlearn::scene::families::{Family, FamilyParams};

mod animate;
mod learn;
mod preview;
mod profile;
mod variance;
pub use animate::{AnimateArgs, FarmArgs};
pub use learn::{LearnArgs, RegionArgs};
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
    about = "GPU many-light renderer (Vulkan compute). Path tracing (or direct light alone) with learned light selection (bayes: Bayesian online regression, Vévoda et al. 2018) and its baselines (donikian, wang, lightbvh, power, uniform)",
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
    // It decomposes the plain estimator, so it refuses --brdf-aware and --control-variates
    // (src/commands/variance.rs); they are hidden from its --help, which listed them.
    #[command(
        mut_arg("brdf_aware", |a| a.hide(true)),
        mut_arg("control_variates", |a| a.hide(true))
    )]
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
    /// Exposure of the merged PNG in stops (its pixels × 2^EV before the sRGB curve; the EXR
    /// holds the radiance either way), −20 to 20 [default: the parts' own, from their
    /// reports' `png_exposure`, as `render --exposure` gave it].
    #[arg(long, value_name = "EV", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// No summary line (warnings and errors are still printed).
    #[arg(long, short)]
    pub quiet: bool,
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
    /// Replace --out even where it is not a statistics file (without it such a file is
    /// refused, as `render --save-stats` refuses it).
    #[arg(long)]
    pub force: bool,
    /// No summary line (warnings and errors are still printed).
    #[arg(long, short)]
    pub quiet: bool,
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

#[derive(Args)]
pub struct RenderArgs {
    /// glTF 2.0 scene (.gltf or .glb). Default: the built-in scene (scenes/default.glb).
    pub scene: Option<PathBuf>,
    /// Light-selection strategy. bayes (the learned one) had the lowest MSE per second on 6
    /// of the 7 committed scenes (hall: wang; see docs/results.md)
    #[arg(long, default_value = "bayes", value_parser = sampler_parser())]
    pub sampler: LightSampler,
    /// Samples per pixel [default: 64 unless --time is given]; at most 1048576 (2^20, what
    /// the film's float sums add without loss: more come from renders of other --seed
    /// combined by `lightlearn merge`).
    #[arg(long, value_name = "N", conflicts_with = "time")]
    pub spp: Option<u32>,
    /// Render for this many seconds instead of a fixed sample count (ending early if the film
    /// fills: 2^20 samples a pixel).
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
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// Next-event samples (light choice, point on the light, shadow ray) at every path vertex
    /// after the first, averaged; 1 to 16, needs --max-depth 2 or more. A diagnostic: the
    /// variance that falls from 1 to N is the light choice's at the later vertices, what stays
    /// is the BSDF's directions and the first vertex (rooms16, depth 8: 31 % and 69 % of
    /// `bayes`'s). Costs about N times the shadow rays; it did not pay at equal time there.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub indirect_light_samples: u32,
    /// Next-event samples at the first vertex, averaged, each from independent numbers (above
    /// 1 the first vertex's stratified light numbers are not used); 1 to 16. A diagnostic:
    /// their light sampling's variance falls as 1/N and what stays is the camera ray's
    /// (the pixel footprint), the floor under any light choice: ci/bench_floor.py fits it
    /// from N = 4 and 16 (rooms16, direct, 256 spp: 4.5× below `wang`'s variance).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub first_light_samples: u32,
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
    /// Replace existing files that are not lightlearn's: a --save-stats target that is not a
    /// statistics file, a JSON beside --out that is not a report, a PNG there with neither.
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
    /// Every SECONDS of rendering, write the image so far (EXR, PNG, JSON with
    /// "checkpoint": true, and --save-stats; each file replaced whole), so a render that is
    /// killed or loses its machine keeps its samples (`merge` combines them with a render of
    /// another seed); the final outputs replace them. 0: none.
    #[arg(long, default_value_t = 300.0, value_name = "SECONDS")]
    pub checkpoint: f64,
    #[command(flatten)]
    pub exposure: ExposureArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// `--light-point` and `--stratify`, shared by `render`, `animate`, `farm` and `preview`: how
/// a sample's numbers and a triangle light's point are drawn (`animate`, `farm` and `preview`
/// took neither before 2026-12-07, so an animation could not be rendered as its stills were).
#[derive(Args)]
pub struct SamplingArgs {
    /// How the light sample draws a point on a triangle light.
    #[arg(long, value_enum, default_value_t = LightPoint::Area)]
    pub light_point: LightPoint,
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
}

impl SamplingArgs {
    /// These options as a command line gives them (for the farm's task commands), only where
    /// they are not the defaults: a template stays what it was without them, and workers of
    /// a build before the options take it.
    pub fn to_args(&self) -> Vec<String> {
        use clap::ValueEnum;
        let mut a = Vec::new();
        if self.light_point != LightPoint::default() {
            let v = self.light_point.to_possible_value().expect("not skipped");
            a.extend(["--light-point".to_string(), v.get_name().to_string()]);
        }
        if self.stratify != lightlearn::render::Stratify::default() {
            a.extend(["--stratify".to_string(), self.stratify.name().to_string()]);
        }
        a
    }
}

/// `--exposure`, shared by `render` and `animate` (`farm` and `merge` have their own: a
/// merge's default is its parts').
#[derive(Args)]
pub struct ExposureArgs {
    /// Exposure of the PNG (animate: of every frame's, and so of the video) in stops: its
    /// pixels × 2^EV before the sRGB curve (a dim scene's PNG is black at 0; 4 is 16×
    /// brighter). The EXR holds the radiance as rendered either way; the report records the
    /// factor (`png_exposure`). −20 to 20.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "EV",
        allow_hyphen_values = true
    )]
    pub exposure: f32,
}

impl ExposureArgs {
    pub fn factor(&self) -> Result<f32> {
        lightlearn::film::exposure_factor(self.exposure)
    }
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
    /// Seed: `compare`'s renders use it, and the reference (`compare`'s or `reference`'s)
    /// draws from an independent stream derived from it, so `reference --seed S` makes the
    /// reference `compare --seed S` finds.
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
#[command(allow_negative_numbers = true)]
pub struct SceneArgs {
    /// Scene family.
    #[arg(value_parser = family_parser())]
    pub family: Family,
    /// Number of lights, exact (each emissive triangle counts as one). cornell: 1..=64,
    /// city: 16..=1000000, hall: 1..=about 290000 (the triangle cap), others: 1..=1000000.
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
    /// strings: segments around each curved object (3..=512) [default: 24].
    #[arg(long, value_name = "N")]
    pub resolution: Option<u32>,
    /// Glossy variant: floors (cornell: the tall box, white) become a glTF metal
    /// (metallic 1, GGX) with this roughness in [0, 1]; all else stays Lambertian. Below
    /// 0.0316 it renders as 0.0316 (no perfect mirrors; the load warns).
    #[arg(long, value_name = "ROUGHNESS")]
    pub glossy: Option<f32>,
    /// Animated variant, 4 s (rooms: a camera walk from a room through its door along the
    /// corridor into another room; city: cars with spot headlights driving the streets,
    /// taken from the lamp budget so --lights stays exact).
    #[arg(long)]
    pub animate: bool,
    /// Replace an existing --out that `lightlearn scene` did not write (a scene of yours is
    /// refused otherwise).
    #[arg(long)]
    pub force: bool,
    /// No summary line (errors are still printed).
    #[arg(long, short)]
    pub quiet: bool,
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
    /// About this many triangles in the procedural benchmark mesh (rounded to its grid).
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
            light_point: self.sampling.light_point,
            indirect_light_samples: self.indirect_light_samples,
            first_light_samples: self.first_light_samples,
            stratify: self.sampling.stratify,
            regions: self.regions.settings()?,
            learn: self.learn.settings()?,
            checkpoint_seconds: self.checkpoint,
            exposure: self.exposure.factor()?,
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
    pub fn params(&self) -> Result<FamilyParams> {
        // An option of another family is refused, as families::generate does for --rooms and
        // --blocks (`rooms --resolution 3` wrote the same file as without it: an audit,
        // 2026-12-06).
        if self.resolution.is_some() && self.family != Family::Strings {
            anyhow::bail!(
                "--resolution applies to the strings family only; {:?} has no curved objects",
                self.family
            );
        }
        Ok(FamilyParams {
            animate: self.animate,
            lights: self.lights,
            seed: self.seed,
            rooms: self.rooms,
            blocks: self.blocks,
            resolution: self.resolution.unwrap_or(24),
            // -0 is 0: `--glossy=-0` wrote "roughnessFactor": -0.0, other bytes than
            // `--glossy 0` for the same scene (an audit, 2026-12-07).
            glossy: self.glossy.map(|r| r + 0.0),
        })
    }
}
