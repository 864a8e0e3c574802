//! The `lightlearn` command line: thin, everything lives in the library.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Result};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use lightlearn::accel::Bvh;
use lightlearn::film::{self, OutputPaths};
use lightlearn::gpu::{Context, ContextOptions};
use lightlearn::render::{self, Budget, GpuScene, LightSampler, RenderSettings};
use lightlearn::scene::families::{self, Family, FamilyParams};
use lightlearn::scene::{gltf_load, Scene};

#[derive(Parser)]
#[command(
    name = "lightlearn",
    version,
    about = "GPU many-light renderer (Vulkan compute): direct illumination with learned light selection",
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

#[derive(Args)]
struct RenderArgs {
    /// glTF 2.0 scene (.gltf or .glb). Default: the built-in scene (scenes/default.glb).
    scene: Option<PathBuf>,
    /// Light-selection strategy.
    #[arg(long, value_enum, default_value_t = LightSampler::Power)]
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
    /// No progress bar or summary (errors and warnings are still printed).
    #[arg(long, short)]
    quiet: bool,
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
    let result = match cli.command {
        Command::Render(a) => cmd_render(a),
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
    // Check the output location before spending time on the render.
    let paths = OutputPaths::new(&a.out)?;
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

    let bar = if a.quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(1000);
        b.set_style(
            ProgressStyle::with_template(
                "{bar:40.cyan/blue} {percent:>3}% {msg} [{elapsed_precise} / ETA {eta}]",
            )
            .expect("valid template"),
        );
        b
    };
    let settings = RenderSettings {
        width: a.width,
        height: a.height,
        budget,
        seed: a.seed,
        sampler: a.sampler,
    };
    let result = render::render(&ctx, &scene, &gpu, &settings, &mut |spp, f| {
        bar.set_position((f * 1000.0) as u64);
        bar.set_message(format!("{spp} spp"));
    })?;
    bar.finish_and_clear();

    let image = result.mean();
    let report = json!({
        "lightlearn_version": env!("CARGO_PKG_VERSION"),
        "scene": scene.source,
        "triangles": scene.triangles.len(),
        "lights": scene.lights.len(),
        "sampler": a.sampler,
        "spp": result.spp,
        "width": a.width,
        "height": a.height,
        "seed": a.seed,
        "budget": match budget { Budget::Samples(n) => json!({"spp": n}), Budget::Seconds(s) => json!({"seconds": s}) },
        "render_seconds": result.render_seconds,
        "bvh_build_seconds": build_seconds,
        "total_seconds": started.elapsed().as_secs_f64(),
        "device": ctx.describe(),
        "invalid_samples_dropped": result.invalid_samples,
        "integrator": "direct illumination, Lambertian, one light sample per pixel sample",
    });
    film::write_outputs(&paths, a.width, a.height, &image, &report)?;
    if result.invalid_samples > 0 {
        eprintln!(
            "warning: {} samples were NaN/Inf and were dropped; please report this scene",
            result.invalid_samples
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
    lightlearn::io::check_parent(&a.out)?;
    let params = FamilyParams {
        lights: a.lights,
        seed: a.seed,
        rooms: a.rooms,
        blocks: a.blocks,
        resolution: a.resolution,
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
    if a.triangles < 1000 || a.width == 0 || a.height == 0 {
        bail!("--triangles must be at least 1000 and --width/--height at least 1");
    }
    let ctx = context(&a.device)?;
    println!("device: {}", ctx.describe());
    lightlearn::bench::rays::run(&ctx, a.triangles, a.width, a.height, a.repeats, &mut |l| {
        println!("{l}")
    })?;
    Ok(())
}
