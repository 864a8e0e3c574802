//! `lightlearn render`: one image of a scene, with its PNG, JSON report and, on request, the
//! learned statistics, all checked before any rendering and written together.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Result};
use serde_json::json;

use super::{check_depth, prepare, Ui};
use crate::film::{self, OutputPaths};
use crate::gpu::ContextOptions;
use crate::learning::stats_file::{self, SavedStats};
use crate::learning::LearnSettings;
use crate::lights::regions::RegionSettings;
use crate::render::{self, Budget, LightPoint, LightSampler, RenderSettings};

/// What `render` is asked for.
#[derive(Clone, Debug)]
pub struct RenderRequest {
    /// None: the built-in default scene.
    pub scene: Option<PathBuf>,
    pub sampler: LightSampler,
    pub spp: Option<u32>,
    pub seconds: Option<f64>,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub out: PathBuf,
    pub max_depth: u32,
    pub light_point: LightPoint,
    /// `--indirect-light-samples`: RenderSettings::indirect_light_samples.
    pub indirect_light_samples: u32,
    /// `--first-light-samples`: RenderSettings::first_light_samples.
    pub first_light_samples: u32,
    /// `--stratify`: RenderSettings::stratify.
    pub stratify: crate::render::Stratify,
    pub regions: RegionSettings,
    pub learn: LearnSettings,
    pub save_stats: Option<PathBuf>,
    pub load_stats: Option<PathBuf>,
    /// `--save-stats` may replace a file that is not a statistics file.
    pub force: bool,
    /// A farm chunk: this render draws the samples [K·spp, (K+1)·spp) after what it loaded.
    pub chunk: Option<u32>,
    /// Create the output's folder when it is missing (farm tasks); otherwise a missing
    /// folder is an error (a typo must not scatter files).
    pub mkdir: bool,
    pub device: ContextOptions,
    /// `--checkpoint`: seconds of rendering between writes of the image so far (0: none).
    pub checkpoint_seconds: f64,
    /// `--exposure`: the PNG's factor (2^EV).
    pub exposure: f32,
}

/// What a finished (or interrupted) render wrote.
#[derive(Clone, Debug)]
pub struct RenderOutcome {
    pub exr: PathBuf,
    pub spp: u32,
    pub render_seconds: f64,
    pub msamples_per_second: f64,
    pub invalid_samples: u32,
    pub interrupted: bool,
    pub wrote_stats: bool,
}

/// Checks the request, renders and writes the outputs. An interrupted render (Ctrl-C)
/// writes what it has and says so in the outcome.
pub fn run(req: &RenderRequest, ui: &mut dyn Ui) -> Result<RenderOutcome> {
    // --mkdir: a refused or failed render leaves no empty folder behind.
    let made = req
        .out
        .parent()
        .filter(|d| req.mkdir && !d.as_os_str().is_empty());
    crate::io::removing_created_folders_on_error(made, || run_checked(req, ui))
}

fn run_checked(req: &RenderRequest, ui: &mut dyn Ui) -> Result<RenderOutcome> {
    let started = Instant::now();
    if let Some(n) = req.spp {
        super::check_spp("--spp", n)?;
    }
    if !(req.checkpoint_seconds.is_finite() && req.checkpoint_seconds >= 0.0) {
        bail!(
            "--checkpoint {} is out of range: use seconds of rendering between writes of the image so far, 0 for none",
            req.checkpoint_seconds
        );
    }
    let budget = match (req.spp, req.seconds) {
        (Some(n), _) => Budget::Samples(n),
        (None, Some(t)) if !(t.is_finite() && t > 0.0) => {
            bail!("--time must be a positive number of seconds")
        }
        (None, Some(t)) => Budget::Seconds(t),
        (None, None) => Budget::Samples(64),
    };
    super::check_size(req.width, req.height)?;
    check_depth(req.max_depth)?;
    super::check_indirect_light_samples(req.indirect_light_samples, req.max_depth)?;
    super::check_first_light_samples(req.first_light_samples)?;
    let skip = chunk_offset(req.chunk, req.spp)?;
    req.regions.check()?;
    req.learn.check()?;
    if req.learn.control_variates && req.sampler != LightSampler::Bayes {
        bail!("--control-variates needs the learned model: add --sampler bayes");
    }
    if (req.save_stats.is_some() || req.load_stats.is_some()) && !req.sampler.learned() {
        bail!(
            "--save-stats/--load-stats need a learning sampler: add --sampler bayes or --sampler donikian"
        );
    }
    // The output locations and the statistics file, before any time is spent rendering.
    if let Some(dir) = req
        .out
        .parent()
        .filter(|d| req.mkdir && !d.as_os_str().is_empty())
    {
        crate::io::create_output_folder(dir, "folder")?;
    }
    let paths = OutputPaths::new(&req.out)?;
    let mut others: Vec<(&str, &std::path::Path)> = Vec::new();
    if let Some(s) = &req.load_stats {
        others.push(("the --load-stats file", s));
    }
    crate::io::check_outputs_spare_scene(&paths.all(), req.scene.as_deref(), &others)?;
    if let Some(p) = &req.save_stats {
        // The scene and the files it names (a texture too: `--save-stats box.png --force`
        // replaced it); not --load-stats, which a continuation saves over.
        let files = req
            .scene
            .as_deref()
            .map(crate::scene::gltf_load::input_files)
            .unwrap_or_default();
        let inputs: Vec<&std::path::Path> = files.iter().map(PathBuf::as_path).collect();
        stats_file::check_save_target(p, &inputs, &paths.all(), req.force)?;
    }
    if !req.force {
        paths.check_not_foreign()?;
    }
    let loaded = match &req.load_stats {
        Some(p) => Some(SavedStats::load(p)?),
        None => None,
    };
    // The file the saved statistics continue (merge-stats reads it).
    let holds: Vec<String> = loaded.iter().map(SavedStats::checksum).collect();
    let (scene, ctx, gpu, build_seconds) = prepare(
        req.scene.as_deref(),
        (req.width, req.height),
        &req.device,
        ui,
    )?;
    ui.message(&format!(
        "{}: {} triangles, {}; device {}",
        scene.source,
        scene.triangles.len(),
        scene.lights_summary(),
        ctx.describe()
    ));
    let mut settings = RenderSettings {
        width: req.width,
        height: req.height,
        budget,
        seed: req.seed,
        sampler: req.sampler,
        regions: req.regions,
        learn: req.learn,
        resume: None,
        stratify: req.stratify,
        max_depth: req.max_depth,
        light_point: req.light_point,
        indirect_light_samples: req.indirect_light_samples,
        first_light_samples: req.first_light_samples,
    };
    if let (Some(saved), Some(p)) = (loaded, &req.load_stats) {
        render::check_resume(&scene, &gpu, &settings, &saved, p)?;
        settings.resume = Some(Arc::new(saved));
    }
    // A chunk that continues loaded statistics ends past both: the file it saves must still
    // load (chunk_offset counts from pass 0; a review, 2026-12-07).
    if let (Some(saved), Some(_)) = (&settings.resume, &req.save_stats) {
        // The passes this render may take: its budget, or a film's worth for --time.
        let n = match settings.budget {
            Budget::Samples(n) => n,
            Budget::Seconds(_) => render::MAX_FILM_SPP,
        };
        let end = saved.header.samples_done as u64 + skip as u64 + n as u64;
        if end > (render::MAX_PASSES / 2) as u64 {
            let what = if skip > 0 { "--chunk" } else { "--spp" };
            bail!("{what} after the {} passes of --load-stats ends at pass {end}, past the first 2^30, so the statistics it saves could not be loaded; use fewer samples or start from fresh statistics", saved.header.samples_done);
        }
    }
    let mut session = render::Session::new(&ctx, &scene, &gpu, &settings)?;
    session.skip_passes(skip)?;
    // Every output of the render as it stands, to `paths` and the statistics to `stats`: at
    // each checkpoint, at the end, and to the rescue folder if the end's write fails.
    let write = |result: &render::RenderResult,
                 checkpoint: bool,
                 paths: &OutputPaths,
                 stats: Option<&std::path::Path>|
     -> Result<bool> {
        let image = result.mean();
        let mut report = render::report_json(&scene, &settings, result, &ctx.describe());
        report["bvh_build_seconds"] = json!(build_seconds);
        report["light_tree_build_seconds"] = json!(gpu.light_tree_seconds);
        report["total_seconds"] = json!(started.elapsed().as_secs_f64());
        if checkpoint {
            report["checkpoint"] = json!(true);
        }
        let stats = match (stats, &result.learned) {
            (Some(p), Some(l)) => vec![(p, l.saved.to_bytes_holding(&holds))],
            _ => Vec::new(),
        };
        let extra: Vec<(&std::path::Path, &[u8])> =
            stats.iter().map(|(p, b)| (*p, b.as_slice())).collect();
        film::write_outputs_with(
            paths,
            req.width,
            req.height,
            &image,
            &report,
            &extra,
            req.exposure,
        )?;
        Ok(!extra.is_empty())
    };
    let every = req.checkpoint_seconds;
    let mut next = if every > 0.0 { every } else { f64::INFINITY };
    let mut checkpoint_error: Option<String> = None;
    // Across the checkpoints' writes too: a stop asked for during one is honoured after
    // the next batch, with the samples written, instead of ending the program at once.
    let _active = crate::interrupt::Active::begin();
    let result = loop {
        let result = render::run_session_until(
            &mut session,
            settings.budget,
            next,
            &render::Checkpoints::None,
            &mut |_| Ok(()),
            &mut |spp, f| ui.progress("render", spp, f),
        )?;
        let finished = match settings.budget {
            Budget::Samples(n) => session.spp() >= n,
            // Or the film is full (run_session_until runs no more passes then).
            Budget::Seconds(t) => {
                session.film_seconds() >= t || session.spp() >= render::MAX_FILM_SPP
            }
        };
        if result.interrupted || finished {
            break result;
        }
        // What an interrupted render would write, so that a render that is killed or loses
        // its machine keeps its samples; the final outputs replace these. A checkpoint that
        // cannot be written (a full disk) is not a reason to stop: it ended the render,
        // with only the last checkpoint's samples kept (an audit, 2026-12-06).
        match write(&result, true, &paths, req.save_stats.as_deref()) {
            // Said once, and again only when the reason changes.
            Err(e) => {
                let why = format!("{e:#}");
                if checkpoint_error.as_deref() != Some(why.as_str()) {
                    ui.message(&format!(
                        "warning: checkpoint not written ({why}); rendering goes on, and the end writes again"
                    ));
                    checkpoint_error = Some(why);
                }
            }
            Ok(_) => checkpoint_error = None,
        }
        next = session.film_seconds() + every;
    };
    drop(session);
    ui.phase_done();
    let wrote_stats = match write(&result, false, &paths, req.save_stats.as_deref()) {
        Ok(w) => w,
        Err(e) => {
            // The samples are not lost with the write: a folder removed or renamed during
            // the render, a full disk or a name the file system refuses had thrown the whole
            // render away (an audit, 2026-12-06). They go to a folder of their own in the
            // system's temporary folder, and the error says where.
            let (saved, rescue) = rescue(&paths, req.save_stats.as_deref(), |there, stats| {
                write(&result, false, there, stats)
            });
            let gone = paths
                .exr
                .parent()
                .filter(|d| !d.as_os_str().is_empty() && !d.is_dir())
                .map(|d| format!(" (its folder '{}' no longer exists)", d.display()))
                .unwrap_or_default();
            let stopped = if result.interrupted {
                " (interrupted)"
            } else {
                ""
            };
            return Err(match (saved, rescue) {
                (Ok((exr, stats)), _) => e.context(format!(
                    "{} spp{stopped} not written where asked{gone}; they are saved in '{}' (+ .png, .json{}): move them where you want them",
                    result.spp,
                    exr.display(),
                    stats
                        .map(|s| format!(", the statistics '{}'", s.display()))
                        .unwrap_or_default()
                )),
                (Err(e2), dir) => e.context(format!(
                    "{} spp{stopped} not written where asked{gone}, nor in a rescue folder{} ({e2:#})",
                    result.spp,
                    dir.map(|d| format!(" '{}'", d.display())).unwrap_or_default()
                )),
            });
        }
    };
    if matches!(settings.budget, Budget::Seconds(t) if render::filled_before(t, result.spp, result.render_seconds))
        && !result.interrupted
    {
        ui.message(&format!(
            "note: --time ended early, at the {} samples a pixel a film's float sums add without loss; for more, renders of other --seed combined by `lightlearn merge`",
            render::MAX_FILM_SPP
        ));
    }
    if result.invalid_samples > 0 {
        ui.message(&format!(
            "warning: {} samples were NaN/Inf and were dropped; please report this scene",
            result.invalid_samples
        ));
    }
    // A black image is written as asked, but said: a camera looking away from the scene (a
    // node of negative scale turns it round) rendered zeros with exit 0 and no word (an
    // audit, 2026-12-06).
    if result.spp > 0
        && result
            .accum
            .iter()
            .all(|a| a.sum[..3].iter().all(|v| *v <= 0.0))
    {
        ui.message(&format!(
            "warning: the image is black: no light reached the camera in {} spp; check that the camera looks at the scene (a node of negative scale turns it round) and that the lights are not hidden",
            result.spp
        ));
    } else if result.spp > 0 {
        // Lit, but below the PNG's first 8-bit step everywhere (sRGB 12.92·x < 0.5/255): an
        // all-zero PNG with no word (a hall whose camera sat in a partition, 1e-6; strings
        // of one bulb, 1.8e-5: an audit, 2026-12-06).
        let peak = result.mean().iter().flatten().fold(0f32, |m, &v| m.max(v));
        if peak < 0.5 / (255.0 * 12.92) {
            ui.message(&format!(
                "warning: the PNG is black: the brightest pixel is {peak:.2e}, below its first 8-bit step; the EXR holds the image"
            ));
        }
    }
    let samples = result.spp as f64 * req.width as f64 * req.height as f64;
    Ok(RenderOutcome {
        exr: paths.exr.clone(),
        spp: result.spp,
        render_seconds: result.render_seconds,
        msamples_per_second: samples / result.render_seconds.max(1e-9) / 1e6,
        invalid_samples: result.invalid_samples,
        interrupted: result.interrupted,
        wrote_stats,
    })
}

/// Writes the outputs (`write` to the paths and statistics file given) into a fresh rescue
/// folder under the names of `paths` and `stats`: the EXR and the statistics file written
/// there, or the error; and the folder, where one was made (removed again if still empty).
fn rescue(
    paths: &OutputPaths,
    stats: Option<&std::path::Path>,
    write: impl FnOnce(&OutputPaths, Option<&std::path::Path>) -> Result<bool>,
) -> (Result<(PathBuf, Option<PathBuf>)>, Option<PathBuf>) {
    let mut folder = None;
    let saved = (|| -> Result<(PathBuf, Option<PathBuf>)> {
        let dir = folder.insert(rescue_folder()?);
        let name = |p: &std::path::Path| dir.join(p.file_name().unwrap_or_default());
        let there = OutputPaths::new(&name(&paths.exr))?;
        // A statistics file named like one of the images (`--save-stats b/r.json` beside
        // `--out a/r.exr`) takes the image's stem and .stats there.
        let stats = stats.map(name).map(|s| {
            if there.all().contains(&s.as_path()) {
                there.exr.with_extension("stats")
            } else {
                s
            }
        });
        write(&there, stats.as_deref())?;
        Ok((there.exr, stats))
    })();
    if saved.is_err() {
        if let Some(dir) = &folder {
            let _ = std::fs::remove_dir(dir); // only if still empty
        }
    }
    (saved, folder)
}

/// Where a render whose outputs could not be written puts them instead: a new folder in the
/// system's temporary folder (`TMPDIR`), named by the process and the time, made fresh here
/// (never one that is already there, which another user of /tmp could have prepared).
fn rescue_folder() -> Result<PathBuf> {
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let base =
        std::env::temp_dir().join(format!("lightlearn-rescue-{}-{stamp}", std::process::id()));
    let mut last = None;
    for k in 0..100 {
        let dir = if k == 0 {
            base.clone()
        } else {
            base.with_file_name(format!(
                "{}-{k}",
                base.file_name().unwrap_or_default().to_string_lossy()
            ))
        };
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(dir),
            Err(e) => bail!("cannot create '{}': {e}", dir.display()),
        }
    }
    bail!(
        "cannot create a rescue folder: '{}' and 99 more exist",
        last.unwrap_or(base).display()
    )
}

/// The passes a farm chunk skips: chunk K of N samples starts K·N passes on. The chunk must
/// end within the first 2^30 passes, the most a statistics file can be continued from
/// (check_resume): a chunk that only started there saved a file no render could load (an
/// audit, 2026-12-07).
pub fn chunk_offset(chunk: Option<u32>, spp: Option<u32>) -> Result<u32> {
    match (chunk, spp) {
        (None, _) => Ok(0),
        (Some(_), None) => bail!("--chunk needs --spp (each chunk renders a fixed sample range)"),
        (Some(k), Some(n)) => k
            .checked_mul(n)
            .filter(|&o| o.checked_add(n).is_some_and(|end| end <= render::MAX_PASSES / 2))
            .ok_or_else(|| {
                anyhow::anyhow!("--chunk {k} × --spp {n} ends at pass {}, past the first 2^30 passes of the random streams, where a chunk must end; use fewer or smaller chunks", (k as u64 + 1) * n as u64)
            }),
    }
}
