//! The `lightlearn` command line: thin, everything lives in the library.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context as _, Result};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use lightlearn::accel::Bvh;
use lightlearn::compare::{self, reference, report};
use lightlearn::film::{self, OutputPaths};
use lightlearn::gpu::{Context, ContextOptions};
use lightlearn::learning::stats_file::{self, SavedStats};
use lightlearn::learning::LearnSettings;
use lightlearn::lights::regions::RegionSettings;
use lightlearn::render::{self, Budget, GpuScene, LightSampler, RenderSettings};
use lightlearn::scene::families::{self, Family, FamilyParams};
use lightlearn::scene::{gltf_load, Scene};

#[derive(Parser)]
#[command(
    name = "lightlearn",
    version,
    about = "GPU many-light renderer (Vulkan compute). Direct illumination with learned light selection (bayes: Bayesian online regression, Vévoda et al. 2018) and its baselines (donikian, wang, lightbvh, power, uniform)",
    long_about = None
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a glTF scene to FILE.exr (float32 RGB), FILE.png (sRGB preview) and FILE.json
    /// (report). Without SCENE, renders the built-in default many-light scene.
    Render(RenderArgs),
    /// Compare light samplers on one scene at equal time and/or equal samples against a
    /// reference; writes an HTML report, metrics.json, convergence.csv and the EXRs.
    Compare(CompareArgs),
    /// Render a converged reference image (sampler `lightbvh`, long budget); it is also
    /// cached so `compare` reuses it.
    Reference(ReferenceArgs),
    /// Generate a procedural many-light scene as glTF (.glb, or .gltf with embedded data).
    /// The same arguments always give a byte-identical file.
    Scene(SceneArgs),
    /// Benchmark: rays/s of the GPU traversal kernel and of a multithreaded CPU traversal of
    /// the same BVH, side by side, for coherent and incoherent rays.
    BenchRays(BenchArgs),
}

#[derive(Args)]
struct DeviceArgs {
    /// Use the Vulkan device whose name contains this text (case-insensitive). Default: a
    /// discrete GPU if there is one, else integrated, else a CPU device (lavapipe).
    #[arg(long, value_name = "NAME")]
    device: Option<String>,
    /// Turn on the Khronos validation layer and fail on any validation error.
    #[arg(long)]
    validation: bool,
}

/// Regions and cuts (docs/method.md §2), used by `--sampler wang`.
#[derive(Args)]
struct RegionArgs {
    /// Region grid: cells along the longest axis of the scene bounds.
    #[arg(long, default_value_t = 32)]
    grid: u32,
    /// Split each cell by the dominant axis and sign of the shading normal (6 bins).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    normal_bins: String,
    /// Refine a cut until its largest cluster's importance ≤ τ × the cut's total.
    #[arg(long, default_value_t = 0.02)]
    tau: f32,
    /// At most this many clusters per cut (1..=64).
    #[arg(long, default_value_t = 32)]
    k_max: u32,
    /// How a chosen cluster picks its light: by importance at the shading point (a light-BVH
    /// descent of the cluster's subtree; measured better on rooms16 and city) or by power
    /// (Wang & Åkerlund 2009 as published).
    #[arg(long, default_value = "importance", value_parser = ["importance", "power"])]
    in_cluster: String,
}

impl RegionArgs {
    fn settings(&self) -> Result<RegionSettings> {
        let s = RegionSettings {
            grid: self.grid,
            normal_bins: self.normal_bins == "on",
            tau: self.tau,
            k_max: self.k_max,
            in_cluster_importance: self.in_cluster == "importance",
        };
        s.check()?;
        Ok(s)
    }
}

/// The learned samplers (`--sampler bayes|donikian`, docs/method.md §3–§8).
#[derive(Args)]
struct LearnArgs {
    /// Fold new observations into the posteriors every K passes (1 pass = 1 spp).
    #[arg(long, default_value_t = 1, value_name = "K")]
    update_every: u32,
    /// bayes: the 1/d² regression of a cluster's contribution (off: one constant per slot).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    regression: String,
    /// bayes: pick clusters ∝ sqrt(mean² + variance) (the method) or ∝ the mean.
    #[arg(long, default_value = "sqrt", value_parser = ["sqrt", "mean"])]
    target: String,
    /// bayes: Beta and Normal-inverse-gamma priors from the unoccluded estimate (off: no
    /// pseudo-counts; divisions guarded, a slot never seen lit keeps chance ≥ 1/(n+1)).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    priors: String,
    /// bayes: observations include the BRDF towards the sampled light (luminance of f(v, l)), so glossy receivers learn the reflected contribution; the prior uses the BRDF's albedo / π.
    #[arg(long)]
    brdf_aware: bool,
    /// bayes: multiply each cluster's learned weight by the BRDF at the shading point towards
    /// the cluster (its direction nearest the mirror direction, plus a floor of 0.1 × albedo/π
    /// so no cluster drops to 0); observations stay BRDF-free. Only glossy materials change
    /// (measured 2.0× and 3.5× better than off at equal time on two glossy scenes; README).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    brdf_select: String,
    /// bayes: subtract the model's predicted mean of every cluster as a control variate
    /// (unbiased; measured 1.4× better on rooms16, no gain on city, so off by default; see
    /// README).
    #[arg(long)]
    control_variates: bool,
    /// bayes: Beta prior pseudo-count of zero observations (n̄_o).
    #[arg(long, default_value_t = 2.0)]
    prior_zero: f32,
    /// bayes: Beta prior pseudo-count of non-zero observations (n̄_v).
    #[arg(long, default_value_t = 2.0)]
    prior_nonzero: f32,
    /// bayes: pseudo-count of the Normal prior on the regression constant (n̄).
    #[arg(long, default_value_t = 1.0)]
    prior_n: f32,
    /// bayes: shape of the inverse-gamma prior on the variance (n̄_α).
    #[arg(long, default_value_t = 1.0)]
    prior_alpha: f32,
    /// bayes: prior coefficient of variation c_v (β = n̄_α (c_v μ0)²).
    #[arg(long, default_value_t = 1.0)]
    prior_cv: f32,
    /// donikian: weight of the unoccluded estimate in the defensive mixture.
    #[arg(long, default_value_t = 0.1)]
    lambda: f32,
    /// bayes: prior mean μ0 = Ĩ · d² · S, Ĩ's power in the units of the observations
    /// [default: 1/(4π), exact for point lights (1/π would be for one-sided area lights);
    /// measured better on rooms16 and city, see README].
    #[arg(long, value_name = "S")]
    prior_scale: Option<f32>,
}

impl LearnArgs {
    fn settings(&self) -> Result<LearnSettings> {
        let s = LearnSettings {
            update_every: self.update_every,
            regression: self.regression == "on",
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
        };
        s.check()?;
        Ok(s)
    }
}

#[derive(Args)]
struct RenderArgs {
    /// glTF 2.0 scene (.gltf or .glb). Default: the built-in scene (scenes/default.glb).
    scene: Option<PathBuf>,
    /// Light-selection strategy. bayes (the learned one) had the lowest MSE per second on 6
    /// of the 7 committed scenes (hall: wang; see README)
    #[arg(long, value_enum, default_value_t = LightSampler::Bayes)]
    sampler: LightSampler,
    /// Samples per pixel [default: 64 unless --time is given].
    #[arg(long, value_name = "N", conflicts_with = "time")]
    spp: Option<u32>,
    /// Render for this many seconds instead of a fixed sample count.
    #[arg(long, value_name = "SECONDS")]
    time: Option<f64>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Image height in pixels (the aspect ratio follows the image size).
    #[arg(long, default_value_t = 480)]
    height: u32,
    /// Random seed: the same seed, scene and settings give a bit-identical image on the same
    /// device.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Output EXR path; the PNG and JSON are written next to it with the same stem.
    #[arg(long, default_value = "render.exr", value_name = "FILE.exr")]
    out: PathBuf,
    /// Surface vertices of a path: 1 = direct light by light sampling alone; D ≥ 2 = path
    /// tracing with next-event estimation and MIS at every vertex, Russian roulette from the
    /// third vertex.
    #[arg(long, default_value_t = 8, value_name = "D")]
    max_depth: u32,
    /// No progress bar or summary (errors and warnings are still printed).
    #[arg(long, short)]
    quiet: bool,
    #[command(flatten)]
    regions: RegionArgs,
    #[command(flatten)]
    learn: LearnArgs,
    /// Save the learned statistics (with their regions and cuts) to FILE after the render
    /// (bayes, donikian).
    #[arg(long, value_name = "FILE")]
    save_stats: Option<PathBuf>,
    /// Start from statistics saved by --save-stats (same scene and region settings); the
    /// sample indices continue after the saved render's.
    #[arg(long, value_name = "FILE")]
    load_stats: Option<PathBuf>,
    /// Let --save-stats replace an existing file that is not a statistics file.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    device: DeviceArgs,
}

/// Path tracing depth: 1 (direct light) to MAX_DEPTH vertices.
fn check_depth(d: u32) -> Result<()> {
    const MAX_DEPTH: u32 = 100;
    if !(1..=MAX_DEPTH).contains(&d) {
        bail!("--max-depth {d} is out of range: use 1 (direct light) to {MAX_DEPTH} (Russian roulette ends most paths long before)");
    }
    Ok(())
}

#[derive(Args)]
struct CompareArgs {
    /// glTF scene (.gltf or .glb). Default: the built-in scene.
    scene: Option<PathBuf>,
    /// Comma-separated samplers; the first is the baseline of the speed-ups.
    #[arg(long, value_name = "A,B,...", default_value = "uniform,power")]
    samplers: String,
    /// Equal-time comparison: seconds of rendering per sampler.
    #[arg(long, value_name = "SECONDS")]
    time: Option<f64>,
    /// Equal-sample comparison: samples per pixel per sampler (with --time: both are run).
    #[arg(long, value_name = "N")]
    spp: Option<u32>,
    /// Reference image (float EXR of the same size). Default: rendered once and cached
    /// (see `lightlearn reference`).
    #[arg(long, value_name = "REF.exr")]
    reference: Option<PathBuf>,
    /// Samples per pixel of a reference rendered here.
    #[arg(long, default_value_t = lightlearn::compare::reference::DEFAULT_REFERENCE_SPP)]
    reference_spp: u32,
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    image: StudyArgs,
    #[command(flatten)]
    regions: RegionArgs,
    #[command(flatten)]
    learn: LearnArgs,
    #[command(flatten)]
    device: DeviceArgs,
}

/// Image settings shared by `compare` and `reference` (so a reference made by one is found by
/// the other).
#[derive(Args)]
struct StudyArgs {
    /// Image width in pixels.
    #[arg(long, default_value_t = 320)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 240)]
    height: u32,
    /// Seed of the compared renders; a reference draws from an independent stream derived
    /// from it.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Surface vertices of a path: 1 = direct light by light sampling alone; D ≥ 2 = path
    /// tracing with next-event estimation and MIS at every vertex, Russian roulette from the
    /// third vertex.
    #[arg(long, default_value_t = 8, value_name = "D")]
    max_depth: u32,
    /// No progress bar or summary (errors and warnings are still printed).
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args)]
struct ReferenceArgs {
    /// glTF scene (.gltf or .glb). Default: the built-in scene.
    scene: Option<PathBuf>,
    /// Output EXR (the PNG and JSON are written next to it).
    #[arg(long, value_name = "FILE.exr")]
    out: PathBuf,
    /// Samples per pixel.
    #[arg(long, default_value_t = lightlearn::compare::reference::DEFAULT_REFERENCE_SPP)]
    spp: u32,
    #[command(flatten)]
    image: StudyArgs,
    #[command(flatten)]
    device: DeviceArgs,
}

#[derive(Args)]
struct SceneArgs {
    /// Scene family.
    #[arg(value_enum)]
    family: Family,
    /// Number of lights, exact (each emissive triangle counts as one). cornell: 1..=64,
    /// city: 16..=1000000, others: 1..=1000000.
    #[arg(long, value_name = "N")]
    lights: usize,
    /// Random seed of the layout and light placement.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output file: .glb (binary) or .gltf (text, buffers embedded).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// rooms: grid of rooms, e.g. 4x3 [default: about 25 lights per room].
    #[arg(long, value_name = "XxZ", value_parser = parse_grid)]
    rooms: Option<(usize, usize)>,
    /// city: blocks per side (1..=100) [default: enough for about half the windows lit].
    #[arg(long, value_name = "N")]
    blocks: Option<usize>,
    /// strings: segments around each curved object (3..=512).
    #[arg(long, default_value_t = 24)]
    resolution: u32,
    /// Glossy variant: floors (cornell: the tall box, white) become a glTF metal
    /// (metallic 1, GGX) with this roughness in [0, 1]; all else stays Lambertian.
    #[arg(long, value_name = "ROUGHNESS")]
    glossy: Option<f32>,
}

fn parse_grid(s: &str) -> std::result::Result<(usize, usize), String> {
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
struct BenchArgs {
    /// Triangles in the procedural benchmark mesh.
    #[arg(long, default_value_t = 120_000)]
    triangles: usize,
    /// Rays per kind = width × height.
    #[arg(long, default_value_t = 512)]
    width: u32,
    #[arg(long, default_value_t = 512)]
    height: u32,
    /// Timed runs per measurement; the fastest counts (best of 3 still varied by ±12 % on
    /// lavapipe on a shared 2-core machine).
    #[arg(long, default_value_t = 7)]
    repeats: u32,
    #[command(flatten)]
    device: DeviceArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // First Ctrl-C during a render: finish the current batch and write what is done; a
    // second one, or one at any other time (loading, building, writing): quit now.
    let _ = ctrlc::set_handler(|| {
        if lightlearn::interrupt::requested() || !lightlearn::interrupt::active() {
            std::process::exit(130);
        }
        lightlearn::interrupt::request();
        eprintln!("\ninterrupted: finishing the current batch (Ctrl-C again to quit at once)");
    });
    let result = match cli.command {
        Command::Render(a) => cmd_render(a),
        Command::Compare(a) => cmd_compare(a),
        Command::Reference(a) => cmd_reference(a),
        Command::Scene(a) => cmd_scene(a),
        Command::BenchRays(a) => cmd_bench_rays(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// A progress bar on a terminal (0..1000 = fraction done), hidden otherwise.
fn progress_bar(quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(1000);
    b.set_style(
        ProgressStyle::with_template(
            "{bar:40.cyan/blue} {percent:>3}% {msg} [{elapsed_precise} / ETA {eta}]",
        )
        .expect("valid template"),
    );
    b
}

fn context(d: &DeviceArgs) -> Result<std::sync::Arc<Context>> {
    Context::new(&ContextOptions {
        device: d.device.clone(),
        validation: d.validation,
    })
}

fn load_scene(path: Option<&Path>) -> Result<Scene> {
    let mut warn = |w: String| eprintln!("warning: {w}");
    match path {
        Some(p) => gltf_load::load(p, &mut warn),
        None => gltf_load::load_bytes(
            lightlearn::DEFAULT_SCENE,
            lightlearn::DEFAULT_SCENE_NAME,
            Path::new("."),
            &mut warn,
        ),
    }
}

fn cmd_render(a: RenderArgs) -> Result<()> {
    let started = Instant::now();
    let budget = match (a.spp, a.time) {
        (Some(0), _) => bail!("--spp must be at least 1"),
        (Some(n), _) => Budget::Samples(n),
        (None, Some(t)) if !(t.is_finite() && t > 0.0) => {
            bail!("--time must be a positive number of seconds")
        }
        (None, Some(t)) => Budget::Seconds(t),
        (None, None) => Budget::Samples(64),
    };
    if a.width == 0 || a.height == 0 || a.width > 16384 || a.height > 16384 {
        bail!("--width/--height must be between 1 and 16384");
    }
    check_depth(a.max_depth)?;
    let regions = a.regions.settings()?;
    let learn = a.learn.settings()?;
    if learn.control_variates && a.sampler != LightSampler::Bayes {
        bail!("--control-variates needs the learned model: add --sampler bayes");
    }
    if (a.save_stats.is_some() || a.load_stats.is_some()) && !a.sampler.learned() {
        bail!(
            "--save-stats/--load-stats need a learning sampler: add --sampler bayes or --sampler donikian"
        );
    }
    // Check the output locations and the statistics file before spending time on the render.
    let paths = OutputPaths::new(&a.out)?;
    if let Some(p) = &a.save_stats {
        let inputs: Vec<&Path> = a.scene.iter().map(PathBuf::as_path).collect();
        stats_file::check_save_target(p, &inputs, &paths.all(), a.force)?;
    }
    let loaded = match &a.load_stats {
        Some(p) => Some(SavedStats::load(p)?),
        None => None,
    };
    let scene = load_scene(a.scene.as_deref())?;
    let ctx = context(&a.device)?;
    let t0 = Instant::now();
    let bvh = Bvh::build(&scene.triangles);
    let build_seconds = t0.elapsed().as_secs_f64();
    let gpu = GpuScene::upload(&ctx, &scene, &bvh)?;
    if !a.quiet {
        eprintln!(
            "{}: {} triangles, {} lights; device {}",
            scene.source,
            scene.triangles.len(),
            scene.lights.len(),
            ctx.describe()
        );
    }

    let bar = progress_bar(a.quiet);
    let settings = RenderSettings {
        width: a.width,
        height: a.height,
        budget,
        seed: a.seed,
        sampler: a.sampler,
        regions,
        learn,
        resume: None,
        stratified: true,
        max_depth: a.max_depth,
    };
    let mut settings = settings;
    if let (Some(saved), Some(p)) = (loaded, &a.load_stats) {
        render::check_resume(&scene, &gpu, &settings, &saved, p)?;
        settings.resume = Some(std::sync::Arc::new(saved));
    }
    let result = render::render(&ctx, &scene, &gpu, &settings, &mut |spp, f| {
        bar.set_position((f * 1000.0) as u64);
        bar.set_message(format!("{spp} spp"));
    })?;
    bar.finish_and_clear();

    let image = result.mean();
    let mut report = render::report_json(&scene, &settings, &result, &ctx.describe());
    report["bvh_build_seconds"] = json!(build_seconds);
    report["light_tree_build_seconds"] = json!(gpu.light_tree_seconds);
    report["total_seconds"] = json!(started.elapsed().as_secs_f64());
    let stats = match (&a.save_stats, &result.learned) {
        (Some(p), Some(l)) => vec![(p.as_path(), l.saved.to_bytes())],
        _ => Vec::new(),
    };
    let extra: Vec<(&Path, &[u8])> = stats.iter().map(|(p, b)| (*p, b.as_slice())).collect();
    film::write_outputs_with(&paths, a.width, a.height, &image, &report, &extra)?;
    if result.invalid_samples > 0 {
        eprintln!(
            "warning: {} samples were NaN/Inf and were dropped; please report this scene",
            result.invalid_samples
        );
    }
    if result.interrupted {
        bail!(
            "interrupted (Ctrl-C) after {} spp; wrote the image so far to {} (+ .png, .json{})",
            result.spp,
            paths.exr.display(),
            if extra.is_empty() { "" } else { ", statistics" }
        );
    }
    if !a.quiet {
        eprintln!(
            "wrote {} (+ .png, .json): {} spp in {:.2} s ({:.1} Msamples/s)",
            paths.exr.display(),
            result.spp,
            result.render_seconds,
            result.spp as f64 * a.width as f64 * a.height as f64 / result.render_seconds / 1e6
        );
    }
    Ok(())
}

fn cmd_scene(a: SceneArgs) -> Result<()> {
    let ext = a
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_lowercase);
    let text = match ext.as_deref() {
        Some("glb") => false,
        Some("gltf") => true,
        _ => bail!("--out '{}' must end in .glb or .gltf", a.out.display()),
    };
    lightlearn::io::check_writable(&a.out)?;
    let params = FamilyParams {
        lights: a.lights,
        seed: a.seed,
        rooms: a.rooms,
        blocks: a.blocks,
        resolution: a.resolution,
        glossy: a.glossy,
    };
    let builder = families::generate(a.family, &params)?;
    let bytes = if text {
        builder.to_gltf_embedded().into_bytes()
    } else {
        builder.to_glb()
    };
    lightlearn::io::write_atomic(&a.out, &bytes)?;
    eprintln!(
        "wrote {} ({:?}, {} lights, {} bytes)",
        a.out.display(),
        a.family,
        a.lights,
        bytes.len()
    );
    Ok(())
}

fn cmd_bench_rays(a: BenchArgs) -> Result<()> {
    lightlearn::bench::rays::check_args(a.triangles, a.width, a.height, a.repeats)?;
    let ctx = context(&a.device)?;
    println!("device: {}", ctx.describe());
    lightlearn::bench::rays::run(&ctx, a.triangles, a.width, a.height, a.repeats, &mut |l| {
        println!("{l}")
    })?;
    Ok(())
}

/// Loads the scene, opens the device and uploads the scene: what every rendering command does.
fn prepare(scene: Option<&Path>, device: &DeviceArgs) -> Result<(Scene, Arc<Context>, GpuScene)> {
    let scene = load_scene(scene)?;
    let ctx = context(device)?;
    let bvh = Bvh::build(&scene.triangles);
    let gpu = GpuScene::upload(&ctx, &scene, &bvh)?;
    Ok((scene, ctx, gpu))
}

/// A progress callback that drives `bar` with a label.
fn bar_progress<'a>(bar: &'a ProgressBar, label: &'a str) -> impl FnMut(u32, f64) + 'a {
    move |spp, f| {
        bar.set_position((f * 1000.0) as u64);
        bar.set_message(format!("{label}: {spp} spp"));
    }
}

fn cmd_reference(a: ReferenceArgs) -> Result<()> {
    check_depth(a.image.max_depth)?;
    let settings = reference::settings(
        a.image.width,
        a.image.height,
        a.spp,
        a.image.seed,
        a.image.max_depth,
    )?;
    let paths = OutputPaths::new(&a.out)?;
    let (scene, ctx, gpu) = prepare(a.scene.as_deref(), &a.device)?;
    let bar = progress_bar(a.image.quiet);
    let (_, report) = reference::render_to(
        &ctx,
        &scene,
        &gpu,
        &settings,
        &paths,
        &mut bar_progress(&bar, "reference"),
    )?;
    bar.finish_and_clear();
    // Also into the cache, so `compare` with the same settings reuses it.
    reference::store_in_cache(&scene, &settings, &paths);
    if !a.image.quiet {
        eprintln!(
            "wrote {} ({} spp in {:.1} s; estimated relMSE {:.2e})",
            paths.exr.display(),
            a.spp,
            report["render_seconds"].as_f64().unwrap_or(0.0),
            report["estimated_rel_mse_of_mean"]
                .as_f64()
                .unwrap_or(f64::NAN)
        );
    }
    Ok(())
}

/// `compare`, leaving no empty output folder behind when it refuses its inputs.
fn cmd_compare(a: CompareArgs) -> Result<()> {
    // The folders this run creates (the output folder and missing parents), outermost last.
    let created: Vec<PathBuf> = a
        .out
        .ancestors()
        .take_while(|p| !p.as_os_str().is_empty() && !p.exists())
        .map(Path::to_path_buf)
        .collect();
    let result = run_compare(&a);
    if result.is_err() {
        for d in &created {
            let _ = std::fs::remove_dir(d); // only if still empty
        }
    }
    result
}

fn run_compare(a: &CompareArgs) -> Result<()> {
    // Everything that can be wrong with the request is checked before any rendering.
    check_depth(a.image.max_depth)?;
    let samplers = LightSampler::parse_list(&a.samplers)?;
    let regions = a.regions.settings()?;
    let learn = a.learn.settings()?;
    if learn.control_variates && !samplers.contains(&LightSampler::Bayes) {
        bail!("--control-variates applies to bayes only: add bayes to --samplers");
    }
    let mut budgets = Vec::new();
    if let Some(t) = a.time {
        if !(t.is_finite() && t > 0.0) {
            bail!("--time must be a positive number of seconds");
        }
        budgets.push(Budget::Seconds(t));
    }
    if let Some(n) = a.spp {
        if n == 0 {
            bail!("--spp must be at least 1");
        }
        budgets.push(Budget::Samples(n));
    }
    if budgets.is_empty() {
        bail!("give --time SECONDS (equal time) and/or --spp N (equal samples)");
    }
    let ref_settings = reference::settings(
        a.image.width,
        a.image.height,
        a.reference_spp,
        a.image.seed,
        a.image.max_depth,
    )?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create the output folder '{}'", a.out.display()))?;
    lightlearn::io::write_atomic(&a.out.join(".write-test"), b"")
        .with_context(|| format!("the output folder '{}' is not writable", a.out.display()))?;
    let _ = std::fs::remove_file(a.out.join(".write-test"));
    let given = match &a.reference {
        Some(p) => {
            let (w, h, px) = film::read_exr(p)?;
            if (w, h) != (a.image.width, a.image.height) {
                bail!(
                    "reference '{}' is {w}×{h} but the comparison renders {}×{}; pass --width {w} --height {h} or another reference",
                    p.display(),
                    a.image.width,
                    a.image.height
                );
            }
            if let Some(i) = px.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
                bail!(
                    "reference '{}' has a NaN or Inf at pixel ({}, {}); render it again",
                    p.display(),
                    i as u32 % w,
                    i as u32 / w
                );
            }
            Some((p.clone(), px))
        }
        None => None,
    };

    let (scene, ctx, gpu) = prepare(a.scene.as_deref(), &a.device)?;
    if samplers.iter().any(|s| s.uses_cuts()) {
        render::check_region_index_fits(&ctx, &scene, &regions)?;
    }
    let (reference_image, reference_note, reference_noise) = match given {
        Some((p, px)) => {
            let sidecar: Option<serde_json::Value> = std::fs::read(p.with_extension("json"))
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok());
            let noise = sidecar.as_ref().and_then(reference::noise);
            let note = noise.map_or(
                String::from("its own error is unknown (no JSON beside it)"),
                |e| format!("its own estimated relMSE {:.2e}", e.rel_mse),
            );
            (px, format!("{} (given); {note}", p.display()), noise)
        }
        None => {
            let bar = progress_bar(a.image.quiet);
            let r = reference::cached(
                &ctx,
                &scene,
                &gpu,
                &ref_settings,
                &mut bar_progress(&bar, "reference"),
                &mut |m| {
                    if !a.image.quiet {
                        bar.suspend(|| eprintln!("{m}"))
                    }
                },
            )?;
            bar.finish_and_clear();
            r
        }
    };

    let mut comparisons = Vec::new();
    for budget in budgets {
        let bar = progress_bar(a.image.quiet);
        let c = compare::compare(
            &ctx,
            &scene,
            &gpu,
            &samplers,
            &regions,
            &learn,
            budget,
            a.image.width,
            a.image.height,
            a.image.seed,
            a.image.max_depth,
            &reference_image,
            reference_noise,
            &mut |sampler, spp, f| bar_progress(&bar, sampler.name())(spp, f),
        )?;
        bar.finish_and_clear();
        comparisons.push(c);
    }

    // Outputs: EXRs, metrics.json, convergence.csv, index.html, moved into place together.
    let (w, h) = (a.image.width, a.image.height);
    let mut out = lightlearn::io::FileSet::default();
    let mut exr = |name: String, img: &[[f32; 3]]| {
        out.add_with(&a.out.join(name), |tmp| film::write_exr(tmp, w, h, img))
    };
    exr("reference.exr".into(), &reference_image)?;
    for c in &comparisons {
        let prefix = if c.budget_seconds.is_some() {
            "time"
        } else {
            "spp"
        };
        for r in &c.runs {
            exr(format!("{prefix}-{}.exr", r.sampler.name()), &r.image)?;
        }
    }
    let metrics = json!({
        "scene": scene.source,
        "width": w,
        "height": h,
        "seed": a.image.seed,
        "device": ctx.describe(),
        "reference": reference_note,
        "comparisons": comparisons,
    });
    out.add(
        &a.out.join("metrics.json"),
        (serde_json::to_string_pretty(&metrics)? + "\n").as_bytes(),
    )?;
    out.add(
        &a.out.join("convergence.csv"),
        report::convergence_csv(&comparisons).as_bytes(),
    )?;
    let page = report::html(&report::ReportInput {
        scene: &scene.source,
        width: w,
        height: h,
        device: &ctx.describe(),
        reference: &reference_image,
        reference_note: &reference_note,
        comparisons: &comparisons,
    })?;
    out.add(&a.out.join("index.html"), page.as_bytes())?;
    out.commit()?;

    if !a.image.quiet {
        for c in &comparisons {
            eprintln!("{}:", c.kind);
            for r in &c.runs {
                let corrected = match (r.corrected, r.speedup_corrected) {
                    (Some(m), Some(s)) => format!(
                        "  (reference noise out: relMSE {:.3e}, MSE {:.3e}, speed-up {s:.2})",
                        m.rel_mse, m.mse
                    ),
                    _ => String::new(),
                };
                eprintln!(
                    "  {:<8} {:>6} spp {:>7.2} s  relMSE {:.3e}  MSE {:.3e}  speed-up vs {} {:.2}{corrected}",
                    r.sampler.name(),
                    r.spp,
                    r.seconds,
                    r.metrics.rel_mse,
                    r.metrics.mse,
                    c.runs[0].sampler.name(),
                    r.speedup
                );
            }
        }
        eprintln!("report: {}", a.out.join("index.html").display());
    }
    Ok(())
}
