//! The bodies of the commands (`render`, `compare`, `reference`, `scene`): plain requests in,
//! files out, progress and messages through a [`Ui`]. The binary only parses arguments into
//! these requests and prints; anything else (a farm task, a test) can run them the same way.

pub mod animate;
mod animate_folder;
mod animate_output;
pub mod animate_report;
pub mod compare;
pub mod farm;
pub mod merge;
pub mod reference;
pub mod render;
pub mod scene;
pub mod variance;
pub mod variance_report;

use std::path::Path;
use std::sync::Arc;

use anyhow::{bail, Result};

use crate::accel::Bvh;
use crate::gpu::{Context, ContextOptions};
use crate::render::GpuScene;
use crate::scene::{gltf_load, Scene};

/// Where a command's progress and messages go (the binary: a progress bar and stderr).
pub trait Ui {
    /// `fraction` (0..1) of the phase `label` is done, at `spp` samples per pixel.
    fn progress(&mut self, label: &str, spp: u32, fraction: f64);
    /// The current phase is over (a progress bar is cleared).
    fn phase_done(&mut self) {}
    /// A line for the user (warnings are prefixed `warning:`).
    fn message(&mut self, line: &str);
}

/// A [`Ui`] that shows nothing.
pub struct Silent;

impl Ui for Silent {
    fn progress(&mut self, _: &str, _: u32, _: f64) {}
    fn message(&mut self, _: &str) {}
}

/// Path tracing depth: 1 (direct light) to [`MAX_DEPTH`] vertices.
pub const MAX_DEPTH: u32 = crate::render::MAX_DEPTH;

/// Largest image side (also the farm's Width/Height parameter bound).
pub const MAX_SIZE: u32 = 16384;

/// An image size every command accepts: 1..=[`MAX_SIZE`] on each side.
pub fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 || width > MAX_SIZE || height > MAX_SIZE {
        bail!("--width/--height must be between 1 and {MAX_SIZE}");
    }
    Ok(())
}

/// A sample count: at least 1, and within the passes a pixel's random streams hold, so that a
/// count past them is refused before any work rather than after 2^31 passes.
pub fn check_spp(flag: &str, n: u32) -> Result<()> {
    if n == 0 {
        bail!("{flag} must be at least 1");
    }
    let max = crate::render::MAX_FILM_SPP;
    if n > max {
        bail!("{flag} {n} is more than the {max} samples per pixel a film's float sums add without loss (a darker image past them): use at most {max}, and for more, renders of other --seed combined by `lightlearn merge`");
    }
    Ok(())
}

pub fn check_depth(d: u32) -> Result<()> {
    if !(1..=MAX_DEPTH).contains(&d) {
        bail!("--max-depth {d} is out of range: use 1 (direct light) to {MAX_DEPTH} (Russian roulette ends most paths long before)");
    }
    Ok(())
}

/// `--indirect-light-samples N`: 1 to [`crate::render::MAX_INDIRECT_LIGHT_SAMPLES`], and more
/// than 1 only where a path has vertices after the first.
pub fn check_indirect_light_samples(n: u32, max_depth: u32) -> Result<()> {
    check_light_samples("--indirect-light-samples", n)?;
    if n > 1 && max_depth < 2 {
        bail!(
            "--indirect-light-samples {n} needs paths with more than one vertex: add --max-depth 2 or more (--max-depth {max_depth} is direct light alone)"
        );
    }
    Ok(())
}

/// `--first-light-samples N`: 1 to [`crate::render::MAX_INDIRECT_LIGHT_SAMPLES`], at any depth.
pub fn check_first_light_samples(n: u32) -> Result<()> {
    check_light_samples("--first-light-samples", n)
}

/// Next-event samples a vertex takes (`flag` N): 1 to
/// [`crate::render::MAX_INDIRECT_LIGHT_SAMPLES`], as many as render.comp numbers their random
/// dimensions apart.
fn check_light_samples(flag: &str, n: u32) -> Result<()> {
    let max = crate::render::MAX_INDIRECT_LIGHT_SAMPLES;
    if !(1..=max).contains(&n) {
        bail!("{flag} must be 1 to {max} (got {n})");
    }
    Ok(())
}

/// The scene at `path`, or the built-in default scene; warnings go to `ui`.
pub fn load_scene(path: Option<&Path>, ui: &mut dyn Ui) -> Result<Scene> {
    let mut warn = |w: String| ui.message(&format!("warning: {w}"));
    match path {
        Some(p) => {
            let doc = gltf_load::open(p, &mut warn)?;
            let scene = doc.scene(&Default::default(), None, &mut warn)?;
            // Every command but `animate` renders the nodes' own transforms; a walk-through
            // rendered as its rest pose in silence (an audit, 2026-12-07). A note, not a
            // warning: the still is what was asked for.
            if !doc.animations.is_empty() {
                let channels = doc.animations.channels.len();
                ui.message(&format!(
                    "note: '{}' is animated ({channels} channel{}); this renders the nodes' own transforms, without the animation (`lightlearn animate` renders it)",
                    doc.name(),
                    if channels == 1 { "" } else { "s" }
                ));
            }
            Ok(scene)
        }
        None => gltf_load::load_bytes(
            crate::DEFAULT_SCENE,
            crate::DEFAULT_SCENE_NAME,
            Path::new("."),
            &mut warn,
        ),
    }
}

/// Loads the scene, opens the device and uploads the scene: what every rendering command
/// does. Also returns the BVH build's seconds.
pub fn prepare(
    scene: Option<&Path>,
    film: (u32, u32),
    device: &ContextOptions,
    ui: &mut dyn Ui,
) -> Result<(Scene, Arc<Context>, GpuScene, f64)> {
    let scene = load_scene(scene, ui)?;
    if let Some(w) = scene.aspect_warning(film.0, film.1) {
        ui.message(&format!("warning: {w}"));
    }
    let ctx = Context::new(device)?;
    let t0 = std::time::Instant::now();
    let bvh = Bvh::build(&scene.triangles);
    let build_seconds = t0.elapsed().as_secs_f64();
    let gpu = GpuScene::upload(&ctx, &scene, &bvh)?;
    Ok((scene, ctx, gpu, build_seconds))
}
