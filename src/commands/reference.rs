//! `lightlearn reference`: a converged image by the reference sampler, also stored in the
//! cache where `compare` finds it.

use std::path::PathBuf;

use anyhow::Result;

use super::{check_depth, prepare, Ui};
use crate::compare::reference;
use crate::film::OutputPaths;
use crate::gpu::ContextOptions;

/// What `reference` is asked for.
#[derive(Clone, Debug)]
pub struct ReferenceRequest {
    pub scene: Option<PathBuf>,
    pub out: PathBuf,
    pub spp: u32,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub max_depth: u32,
    pub device: ContextOptions,
}

/// Renders, writes `out` (+ .png, .json) and caches it; returns its JSON report.
pub fn run(a: &ReferenceRequest, ui: &mut dyn Ui) -> Result<serde_json::Value> {
    check_depth(a.max_depth)?;
    let settings = reference::settings(a.width, a.height, a.spp, a.seed, a.max_depth)?;
    let paths = OutputPaths::new(&a.out)?;
    crate::io::check_outputs_spare_scene(&paths.all(), a.scene.as_deref(), &[])?;
    paths.check_not_foreign()?;
    let (scene, ctx, gpu, _) = prepare(a.scene.as_deref(), (a.width, a.height), &a.device, ui)?;
    // From the render to the cache's copy: a stop asked for while the finished reference
    // was being written ended the program there, the reference lost and its temporaries
    // left (an audit, 2026-12-06); now the writes finish first.
    let _active = crate::interrupt::Active::begin();
    let (_, report) = reference::render_to(&ctx, &scene, &gpu, &settings, &paths, &mut |s, f| {
        ui.progress("reference", s, f)
    })?;
    ui.phase_done();
    // Also into the cache, so `compare` with the same settings reuses it.
    if let Err(e) = reference::store_in_cache(&scene, &settings, &paths) {
        let why = format!("{e:#}");
        let fix = if why.contains("LIGHTLEARN_CACHE") {
            ""
        } else {
            "; set LIGHTLEARN_CACHE to a writable folder"
        };
        ui.message(&format!(
            "warning: {} is written but not cached for `compare` ({why}){fix}",
            paths.exr.display()
        ));
    }
    Ok(report)
}
