//! `lightlearn animate`: a glTF animation rendered frame by frame, the learned state carried
//! from each frame to the next (`--carry on`) or learned afresh (`--carry off`).
//!
//! Frame k is the scene at t0 + k / fps in one coordinate frame and one region grid
//! ([`AnimatedScene`]). Its light tree is the tree built at frame 0 (or the first frame from
//! 0 whose pose builds: `topology_frame`) refitted to the lights as they are at frame k, so a cut node, and what was learned about it, keeps its meaning;
//! when the refit's SAOH cost exceeds [`DEGRADED`] × a fresh build's, the frame builds its
//! own tree and learns afresh. Its starting statistics are frame k−1's final ones (from
//! memory, or from `--load-stats`: the same bytes, so `--frame k --load-stats
//! frame-(k−1).stats` gives frame k of the sequence bit for bit), tempered by `--forget` when
//! lights or geometry moved between the pose they were learned at and frame k's. Every frame is unbiased whatever it
//! carries: the statistics only shape the pmfs, which stay exact.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context as _, Result};
use serde_json::json;

use super::animate_output::{encode_video, write_summary};
use super::Ui;
use crate::accel::Bvh;
use crate::film::{self, OutputPaths};
use crate::gpu::{Context, ContextOptions};
use crate::learning::stats_file::SavedStats;
use crate::learning::LearnSettings;
use crate::lights::regions::RegionSettings;
use crate::lights::tree::LightTree;
use crate::render::{self, Budget, Checkpoints, GpuScene, LightSampler, RenderSettings, Session};
use crate::scene::animated::{AnimatedScene, Changes};
use crate::scene::Scene;

/// A refitted light tree whose SAOH cost is above this many times a fresh build's for the
/// same frame is replaced by the fresh build (its statistics restart). The committed
/// animated scenes stay far below it (their ratios are in each frame's record).
pub const DEGRADED: f64 = 2.0;

/// What `animate` is asked for.
#[derive(Clone, Debug)]
pub struct AnimateRequest {
    /// None: the built-in default scene (not animated: give --frames).
    pub scene: Option<PathBuf>,
    /// The output folder.
    pub out: PathBuf,
    /// First and last frame, both included (None: the animation's whole span).
    pub frames: Option<(u32, u32)>,
    pub fps: f64,
    pub spp: Option<u32>,
    pub seconds: Option<f64>,
    pub carry: bool,
    pub forget: f32,
    pub sampler: LightSampler,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub max_depth: u32,
    /// `--light-point`: how a point on a triangle light is drawn.
    pub light_point: crate::lights::LightPoint,
    pub regions: RegionSettings,
    pub learn: LearnSettings,
    /// The statistics of the frame before the first (`--frame k --load-stats`).
    pub load_stats: Option<PathBuf>,
    /// `--keep-stats`: every frame's `.stats` (true, the default) or only the newest whole
    /// frame's (false): 2.4–2.6 MB a frame at 320×240 made 25–30 GB over 10,000 frames.
    pub keep_all_stats: bool,
    /// `--force`: replace files in the folder that lightlearn did not write.
    pub force: bool,
    /// Encode DIR/animation.mp4 with ffmpeg when it is installed.
    pub video: bool,
    /// `--exposure`: the PNGs' (and so the video's) factor (2^EV).
    pub exposure: f32,
    /// A farm chunk of a single frame: samples [K·spp, (K+1)·spp) after what it loaded.
    pub chunk: Option<u32>,
    pub device: ContextOptions,
    /// The frames' numbers: Sobol' (`animate`'s default) or independent, which the
    /// evaluation's references use so that their noise can be estimated and subtracted.
    pub stratify: crate::render::Stratify,
}

/// One frame's record in `animation.json`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameRecord {
    pub frame: u32,
    pub time: f64,
    pub spp: u32,
    pub render_seconds: f64,
    /// What changed since the previous frame.
    pub moved: Changes,
    /// "fresh", "carried", "carried, tempered" or "restarted (light tree rebuilt)".
    pub learning: String,
    /// The refitted light tree's SAOH cost ÷ a fresh build's at this frame; infinite (null
    /// in the JSON) where the frame has other lights than the tree, which it then rebuilds.
    pub tree_cost_ratio: f64,
    pub regions_with_cuts: usize,
    pub regions_added: usize,
    /// The film's own estimate of the image's MSE (per-pixel variance of the mean); None
    /// (null) at 1 spp, where there is no variance.
    pub estimated_mse: Option<f64>,
    /// A frame stopped before its samples (Ctrl-C, a stop signal): its spp is what it holds
    /// (only its spp told, before; an audit, 2026-12-07). Absent when whole.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub interrupted: bool,
    /// Written as text even where the path is not UTF-8 (serde's PathBuf refuses it, and
    /// the summary's `json!` panicked on such an output folder).
    #[serde(serialize_with = "lossy_path")]
    pub exr: PathBuf,
}

fn lossy_path<S: serde::Serializer>(p: &Path, s: S) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_str(&p.to_string_lossy())
}

pub struct AnimateOutcome {
    pub frames: Vec<FrameRecord>,
    pub interrupted: bool,
    /// The stop came inside the last frame's passes (else between frames: all whole).
    pub last_partial: bool,
    pub video: Option<PathBuf>,
}

/// The lock file of a run in its output folder ([`RunLock`]).
pub const RUN_LOCK: &str = ".lightlearn-animate.lock";

/// Frame `k`'s file stem in the output folder.
pub fn frame_stem(out: &Path, k: u32) -> PathBuf {
    out.join(format!("frame-{k:04}"))
}

/// The seed of frame `k`: every frame draws other random numbers, also with `--carry off`
/// (whose frames all start at pass 0).
pub fn frame_seed(seed: u32, k: u32) -> u32 {
    seed ^ k.wrapping_mul(0x9E37_79B9)
}

/// The frame rate and the forgetting factor of a sequence (`animate`, `farm`).
pub fn check_timing(fps: f64, forget: f32) -> Result<()> {
    // When a frame's time was an f32, below 0.001 fps (a frame each 17 minutes) frame 1's
    // time became infinite and was "not moved" from frame 0; times are f64 since, and the
    // range stays.
    if !(fps.is_finite() && (0.001..=1000.0).contains(&fps)) {
        bail!("--fps must be a number of frames per second in [0.001, 1000]");
    }
    if !(forget > 0.0 && forget <= 1.0) {
        bail!("--forget must be in (0, 1]: the weight old statistics keep when lights or geometry move (1 keeps all)");
    }
    Ok(())
}

pub fn check(req: &AnimateRequest) -> Result<()> {
    check_timing(req.fps, req.forget)?;
    super::check_size(req.width, req.height)?;
    if let Some(n) = req.spp {
        super::check_spp("--spp", n)?;
    }
    match (req.spp, req.seconds) {
        (None, Some(t)) if !(t.is_finite() && t > 0.0) => {
            bail!("--time must be a positive number of seconds")
        }
        _ => {}
    }
    if let Some((a, b)) = req.frames {
        if b < a {
            bail!("--frames {a}..{b}: the last frame comes before the first; use A..B with A ≤ B");
        }
    }
    if req.load_stats.is_some() && !(req.sampler.learned() && req.carry) {
        bail!("--load-stats needs a learning sampler (bayes, donikian) and --carry on");
    }
    if req.load_stats.is_some() && req.frames.is_none_or(|(a, _)| a == 0) {
        bail!("--load-stats holds the statistics of the frame before the first; frame 0 has none (start at --frame 1 or later)");
    }
    if req.chunk.is_some() && req.frames.is_none_or(|(a, b)| a != b) {
        bail!("--chunk renders a sample range of one frame: give --frame K");
    }
    super::render::chunk_offset(req.chunk, req.spp)?;
    super::check_depth(req.max_depth)?;
    req.regions.check()?;
    req.learn.check()
}

/// Renders the frames; writes DIR/frame-NNNN.{exr,png,json} (+ .stats for a learning
/// sampler with --carry on), DIR/animation.json after every frame, and DIR/animation.mp4
/// at the end when asked for and ffmpeg is present.
pub fn run(req: &AnimateRequest, ui: &mut dyn Ui) -> Result<AnimateOutcome> {
    // A refused or failed run leaves no empty output folder behind (the frames written
    // before a failure stay, with the folder).
    crate::io::removing_created_folders_on_error(Some(&req.out), || run_checked(req, ui))
}

/// The first frame from 0 to `first` whose pose builds, and its scene; where none does,
/// frame `first`'s error (the first frame asked for).
fn topology_frame(
    anim: &AnimatedScene,
    first: u32,
    fps: f64,
    ui: &mut dyn Ui,
) -> Result<(u32, Scene)> {
    // The poses' warnings, each said once however many poses were tried.
    let mut said: Vec<String> = Vec::new();
    let mut note = |w: String| {
        if !said.contains(&w) {
            said.push(w);
        }
    };
    let mut built = None;
    for k in 0..first {
        if let Ok(scene) = anim.scene_at(anim.time(k, fps), &mut note) {
            built = Some(Ok((k, scene)));
            break;
        }
    }
    let t = anim.time(first, fps);
    let built = built.unwrap_or_else(|| {
        let scene = anim
            .scene_at(t, &mut note)
            .with_context(|| format!("frame {first} (t = {t} s)"))?;
        Ok((first, scene))
    });
    for w in said {
        ui.message(&format!("warning: {w}"));
    }
    built
}

fn run_checked(req: &AnimateRequest, ui: &mut dyn Ui) -> Result<AnimateOutcome> {
    check(req)?;
    let started = Instant::now();
    if req.out.exists() && !req.out.is_dir() {
        bail!(
            "--out '{}' is a file; animate writes a folder of frames (give a folder path)",
            req.out.display()
        );
    }
    let loaded = match &req.load_stats {
        Some(p) => Some(SavedStats::load(p)?),
        None => None,
    };
    // The help promises frame K of the sequence bit for bit from frame K−1's statistics;
    // any other frame's (or a render's) is a start of its own, said once (an audit,
    // 2026-12-06: any frame's file was taken without a word).
    if let (Some(saved), Some(p), Some((k, _))) = (&loaded, &req.load_stats, req.frames) {
        let from = match saved.header.animation_frame {
            Some(j) if j.checked_add(1) == Some(k) => None,
            Some(j) => Some(format!("frame {j}'s statistics")),
            None => Some(
                "statistics that name no frame (a render's, or a frame's saved before frames were named)"
                    .to_string(),
            ),
        };
        if let Some(from) = from {
            ui.message(&format!(
                "warning: '{}' holds {from}; frame {k} starts from them, but only frame {}'s continue the sequence as it would have run",
                p.display(),
                k.saturating_sub(1)
            ));
        }
    }
    let anim = AnimatedScene::open(req.scene.as_deref(), &mut warn_once(ui))?;
    let (first, last) = match req.frames {
        Some(r) => r,
        None if anim.is_animated() => (0, anim.frame_count(req.fps)? - 1),
        None => bail!(
            "'{}' has no animations; give --frames A..B to render a still scene as frames, or use `lightlearn render`",
            anim.doc.name()
        ),
    };
    // Frames past the animation's end hold its last pose: said once, not silently (an audit,
    // 2026-12-06; a still scene given --frames has no end).
    if anim.is_animated() {
        let end = anim.frame_count(req.fps).unwrap_or(u32::MAX) - 1;
        if last > end {
            ui.message(&format!(
                "warning: '{}' ends at frame {end} at {} fps; frames {}..{last} hold its last pose",
                anim.doc.name(),
                req.fps,
                first.max(end + 1)
            ));
        }
    }
    if last - first >= crate::scene::animated::MAX_FRAMES {
        bail!(
            "--frames {first}..{last} is more than {} frames; render it in parts",
            crate::scene::animated::MAX_FRAMES
        );
    }
    let (mut run_lock, sequence) = super::animate_folder::prepare(req, first, last, ui)?;

    let ctx = Context::new(&req.device)?;
    let mut quiet = |_: String| {};
    // The tree every frame refits: that of the first frame from 0 on whose pose builds.
    // Frame 0's in all but files whose pose there has no lights or no camera (a light
    // switching on, a camera scaling up): every range of them failed on frame 0, asked for
    // or not (an audit, 2026-12-07). Always counted from 0, so that every run of one file
    // at one fps refits the same tree, and a range continues another's statistics.
    let (k0, scene0) = topology_frame(&anim, first, req.fps, ui)?;
    if let Some(w) = scene0.aspect_warning(req.width, req.height) {
        ui.message(&format!("warning: {w}"));
    }
    // Before the tree is built (twice: this and the frame's own), as an upload would.
    crate::render::check_fits(&ctx, &scene0)?;
    let topology = LightTree::build(&scene0);
    ui.message(&format!(
        "{}: {} triangles, {}, {} animation channels; frames {first}..{last} at {} fps; device {}",
        scene0.source,
        scene0.triangles.len(),
        scene0.lights_summary(),
        anim.doc.animations.channels.len(),
        req.fps,
        ctx.describe()
    ));
    let budget = match (req.spp, req.seconds) {
        (Some(n), _) => Budget::Samples(n),
        (None, Some(t)) => Budget::Seconds(t),
        (None, None) => Budget::Samples(64),
    };

    // The pose before the first frame, to tell what moved since (a pose that does not build,
    // as a light switching on has none, compares with nothing: the frames after it render).
    let before = first.checked_sub(1).map(|j| anim.time(j, req.fps));
    // Loaded statistics of another pose than the frame before's (another frame, or another
    // --fps): what moved is told against the pose they were learned at, and said.
    let learned_at = loaded
        .as_ref()
        .and_then(|s| s.header.animation_time)
        .filter(|&t| t.is_finite());
    // Frame K−1's by number (another frame's was said above): another --fps.
    let numbered = loaded
        .as_ref()
        .and_then(|s| s.header.animation_frame?.checked_add(1))
        == Some(first);
    if let (Some(tl), Some(p), true) = (learned_at, &req.load_stats, numbered) {
        if before.is_none_or(|tb| (tl - tb).abs() > 1e-9 * tb.abs().max(1.0)) {
            ui.message(&format!(
                "warning: '{}' was learned at the pose of t = {tl} s, not at that of the frame before frame {first}{}; what moved is told against the pose it was learned at",
                p.display(),
                before.map_or(String::new(), |tb| format!(" (t = {tb} s at {} fps)", req.fps))
            ));
        }
    }
    let mut previous: Option<Scene> = learned_at
        .or(before)
        .and_then(|t| anim.scene_at(t, &mut quiet).ok());
    // The file each frame's statistics continue (merge-stats reads it): the loaded one,
    // then the frame before.
    let mut holds: Vec<String> = loaded.iter().map(SavedStats::checksum).collect();
    let mut carried: Option<SavedStats> = loaded;
    let mut prev_gpu: Option<GpuScene> = None;
    // The statistics file this run wrote for the last whole frame (`--keep-stats last`
    // removes it once the next whole frame's is written; never a file of an earlier run).
    let mut written_stats: Option<PathBuf> = None;
    let mut records = Vec::new();
    let mut interrupted = false;
    let mut last_partial = false;
    let mut span = (first, 0u32);
    // A stop asked for between frames (while a frame's scene is built or its files are
    // written) waits for this loop too, as one inside a frame's passes does: it had
    // ended the process at once (exit 130, no word; an audit, 2026-12-06). Only over the
    // frames: a stop during the video's encoding still ends the process at once.
    let active = crate::interrupt::Active::begin();
    for k in first..=last {
        if crate::interrupt::requested() {
            interrupted = true;
            break;
        }
        let t = anim.time(k, req.fps);
        let scene = if k == k0 {
            scene0.clone()
        } else {
            // A frame's own error names the frame: a camera keyed to a scale of 0 failed
            // after the frames before it with no word of which (an audit, 2026-12-06).
            anim.scene_at(t, &mut quiet)
                .with_context(|| format!("frame {k} (t = {t} s)"))?
        };
        let moved = previous
            .as_ref()
            .map_or(Changes::default(), |p| Changes::between(p, &scene));
        // The frame's light tree: frame 0's refitted, unless that degraded, or the frame has
        // other lights (an emissive mesh keyed to scale 0 loses its triangles): then a tree
        // of its own, and the learning restarts.
        let relit = scene.lights.len() != topology.order.len();
        let ratio = if relit {
            f64::INFINITY
        } else {
            let fresh_cost = LightTree::build(&scene).cost();
            if fresh_cost > 0.0 {
                topology.refit(&scene).cost() / fresh_cost
            } else {
                1.0
            }
        };
        let rebuilt = relit || ratio > DEGRADED;
        let gpu = match prev_gpu.take() {
            Some(g) if !moved.scene_moved() && !rebuilt => g,
            _ => {
                let bvh = Bvh::build(&scene.triangles);
                if rebuilt {
                    GpuScene::upload(&ctx, &scene, &bvh)?
                } else {
                    GpuScene::upload_refit(&ctx, &scene, &bvh, &topology)?
                }
            }
        };
        let mut settings = RenderSettings {
            width: req.width,
            height: req.height,
            budget,
            seed: frame_seed(req.seed, k),
            sampler: req.sampler,
            regions: req.regions,
            learn: req.learn,
            resume: None,
            stratify: req.stratify,
            max_depth: req.max_depth,
            light_point: req.light_point,
            indirect_light_samples: 1,
            first_light_samples: 1,
        };
        let mut learning = "fresh".to_string();
        let mut start_forget = None;
        if let (true, true, Some(mut saved)) = (req.carry, req.sampler.learned(), carried.take()) {
            let what = req
                .load_stats
                .as_deref()
                .filter(|_| k == first)
                .unwrap_or(Path::new("the previous frame's statistics"));
            if rebuilt || saved.header.scene != gpu.fingerprint {
                // This frame's light tree is not the one the statistics were learned on (it
                // degraded and was rebuilt, here or on the frame they come from): its nodes
                // mean other light sets, so the frame learns afresh (unbiased either way).
                if !rebuilt && k == first && req.load_stats.is_some() {
                    ui.message(&format!(
                        "warning: {} were learned on another light tree; frame {k} learns afresh",
                        what.display()
                    ));
                }
                learning = if rebuilt {
                    "restarted (light tree rebuilt)"
                } else {
                    "restarted (the statistics' light tree was rebuilt)"
                }
                .into();
            } else {
                render::check_resume(&scene, &gpu, &settings, &saved, what)?;
                if moved.scene_moved() && req.forget < 1.0 {
                    saved.temper(req.forget);
                    start_forget = Some(req.forget);
                    learning = "carried, tempered".into();
                } else {
                    learning = "carried".into();
                }
                settings.resume = Some(Arc::new(saved));
            }
        }
        let mut session = Session::new(&ctx, &scene, &gpu, &settings)?;
        if settings.resume.is_some() {
            // A view the statistics were not learned from: regions it reaches grow on the
            // film's schedule, as after a camera move.
            session.set_camera(scene.camera)?;
        }
        session.skip_passes(super::render::chunk_offset(req.chunk, req.spp)?)?;
        let label = format!("frame {k}");
        let mut result = render::run_session(
            &mut session,
            budget,
            &Checkpoints::None,
            &mut |_| Ok(()),
            &mut |spp, f| ui.progress(&label, spp, f),
        )?;
        if let Some(l) = &mut result.learned {
            l.saved.header.start_forget = start_forget;
            l.saved.header.animation_frame = Some(k);
            l.saved.header.animation_time = Some(t);
        }
        ui.phase_done();
        if matches!(budget, Budget::Seconds(t) if render::filled_before(t, result.spp, result.render_seconds))
            && !result.interrupted
        {
            ui.message(&format!(
                "note: frame {k}'s --time ended early, at the {} samples a pixel a film's float sums add without loss",
                render::MAX_FILM_SPP
            ));
        }
        drop(session);

        let stem = frame_stem(&req.out, k);
        let paths = OutputPaths::new(&stem.with_extension("exr"))?;
        let mut report = render::report_json(&scene, &settings, &result, &ctx.describe());
        report["animation"] = json!({
            "frame": k, "time": t, "fps": req.fps, "carry": req.carry, "forget": req.forget,
            "learning": learning, "moved": moved, "tree_cost_ratio": ratio,
        });
        if settings.resume.is_none() {
            holds.clear(); // learned afresh
        }
        let stats_bytes = match (&result.learned, req.carry) {
            (Some(l), true) => Some(l.saved.to_bytes_holding(&holds)),
            _ => None,
        };
        // The next frame carries this one's statistics.
        holds = (stats_bytes.iter())
            .map(|b| SavedStats::checksum_of_bytes(b))
            .collect();
        let stats_path = stem.with_extension("stats");
        let extra: Vec<(&Path, &[u8])> = stats_bytes
            .iter()
            .map(|b| (stats_path.as_path(), b.as_slice()))
            .collect();
        film::write_outputs_with(
            &paths,
            req.width,
            req.height,
            &result.mean(),
            &report,
            &extra,
            req.exposure,
        )?;
        records.push(FrameRecord {
            frame: k,
            time: t,
            spp: result.spp,
            render_seconds: result.render_seconds,
            moved,
            learning,
            tree_cost_ratio: ratio,
            regions_with_cuts: result.regions.regions_with_cuts,
            regions_added: result.regions.regions_added_between_frames,
            estimated_mse: result.known_error().map(|e| e.0),
            interrupted: result.interrupted,
            exr: paths.exr.clone(),
        });
        span = write_summary(
            req,
            &anim,
            &sequence,
            &records,
            started.elapsed().as_secs_f64(),
        )?;
        if result.interrupted {
            // A partial frame's statistics do not replace the whole frame's before it:
            // `--frame k --load-stats` of that one renders frame k again.
            interrupted = true;
            last_partial = true;
            break;
        }
        if !req.keep_all_stats && stats_bytes.is_some() {
            if let Some(old) = written_stats.replace(stats_path.clone()) {
                if let Err(e) = std::fs::remove_file(&old) {
                    ui.message(&format!(
                        "warning: --keep-stats last could not remove '{}': {e}",
                        old.display()
                    ));
                }
            }
        }
        carried = result.learned.map(|l| l.saved);
        previous = Some(scene);
        prev_gpu = Some(gpu);
    }
    // A stop while the last frame's files were written: every frame is whole.
    interrupted |= crate::interrupt::requested();
    drop(active);
    let video = if req.video && !interrupted {
        encode_video(req, span, ui)
    } else {
        Ok(None)
    };
    let old_video = req.out.join("animation.mp4");
    if req.video && !matches!(video, Ok(Some(_))) && old_video.exists() {
        // A video of an earlier run's frames would pass for this run's.
        std::fs::remove_file(&old_video)
            .with_context(|| format!("cannot remove the earlier '{}'", old_video.display()))?;
        ui.message(&format!(
            "removed the earlier {} (made from an earlier run's frames)",
            old_video.display()
        ));
    }
    let video = video?;
    run_lock.finished = true;
    Ok(AnimateOutcome {
        frames: records,
        interrupted,
        last_partial,
        video,
    })
}

/// Warnings as messages (given for the file and frame 0's scene only: later frames repeat
/// them).
fn warn_once(ui: &mut dyn Ui) -> impl FnMut(String) + '_ {
    move |w: String| ui.message(&format!("warning: {w}"))
}
