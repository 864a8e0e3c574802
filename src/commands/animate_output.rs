//! `animate`'s outputs for the whole sequence: the summary (`DIR/animation.json`, merged
//! with the records of frames an earlier run of the same sequence rendered) and the video
//! (`DIR/animation.mp4` by ffmpeg).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use serde_json::{json, Value};

use super::animate::{AnimateRequest, FrameRecord};
use super::Ui;
use crate::fnv::fnv1a;
use crate::scene::animated::AnimatedScene;

/// Writes DIR/animation.json with this run's frame records and, where the folder's
/// summary is of the same sequence (scene, fps, sampler, size, depth, seed, carrying), the
/// earlier records of the frames this run did not render (`--frame K` re-renders one frame
/// of a sequence: the summary had shrunk to that frame). Returns the span of frames the
/// summary lists without a gap around this run's, (first, count), for the video.
pub(super) fn write_summary(
    req: &AnimateRequest,
    anim: &AnimatedScene,
    key: &str,
    records: &[FrameRecord],
    seconds: f64,
) -> Result<(u32, u32)> {
    let mut frames: Vec<Value> = records
        .iter()
        .map(serde_json::to_value)
        .collect::<std::result::Result<_, _>>()?;
    let path = req.out.join("animation.json");
    // Read, merged and written by one run at a time: runs of single frames into one folder
    // lost each other's records (an audit, 2026-12-07).
    let _summary = crate::io::lock_file(&req.out.join(SUMMARY_LOCK), false, true)?;
    let same = |old: &Value| old["sequence"] == json!(key);
    let old: Option<Value> = crate::io::read_all(&path)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok());
    // Sets, not lists: a run's thousandth frame searched its 999 records for each of the
    // summary's (an audit, 2026-12-07).
    let ours: std::collections::HashSet<u64> = records.iter().map(|r| r.frame as u64).collect();
    if let Some(old) = old.filter(|o| same(o)) {
        for f in old["frames"].as_array().into_iter().flatten() {
            if f["frame"].as_u64().is_some_and(|k| !ours.contains(&k)) {
                frames.push(f.clone());
            }
        }
    }
    frames.sort_by_key(|f| f["frame"].as_u64().unwrap_or(0));
    let listed: std::collections::HashSet<u32> = frames
        .iter()
        .filter_map(|f| f["frame"].as_u64().map(|k| k as u32))
        .collect();
    let span = contiguous_span(&listed, records.first().map_or(0, |r| r.frame));
    let summary = json!({
        "lightlearn_version": env!("CARGO_PKG_VERSION"),
        "scene": anim.doc.name(),
        "animations": anim.doc.animations.names,
        "channels": anim.doc.animations.channels.len(),
        "span_seconds": [anim.span.0, anim.span.1],
        "fps": req.fps,
        "sampler": req.sampler.name(),
        "carry": req.carry,
        "forget": req.forget,
        "width": req.width,
        "height": req.height,
        "max_depth": req.max_depth,
        "seed": req.seed,
        "total_seconds": seconds,
        "sequence": key,
        "frames": frames,
    });
    crate::io::write_atomic(&path, serde_json::to_string_pretty(&summary)?.as_bytes())?;
    Ok(span)
}

/// What makes two runs frames of one sequence: the scene's bytes and every setting but the
/// frames, the output folder, the video and the statistics loaded for the first frame (a
/// summary keyed by the scene's name and a few settings took in frames of an edited scene
/// or of another budget).
pub(super) fn sequence_key(req: &AnimateRequest) -> String {
    let scene = match &req.scene {
        Some(p) => crate::io::read_all(p).map_or(0, |b| fnv1a(&b)),
        None => 0,
    };
    let mut settings = req.clone();
    settings.scene = None;
    settings.frames = None;
    settings.out = PathBuf::new();
    settings.video = false;
    settings.load_stats = None;
    settings.device = Default::default();
    // Which statistics files stay and whether a user's files may be replaced say nothing
    // about the frames: a resume with --keep-stats last or --force was "another sequence"
    // (a review, 2026-12-07).
    settings.keep_all_stats = true;
    settings.force = false;
    // Fields added since keys were first written count only where they are not their
    // defaults, so a folder an earlier build rendered stays this sequence: `light_point`
    // (2026-12-07) made every earlier folder "another sequence" and its frames left the
    // summary (a review). tests/animate.rs pins a key the build before wrote.
    let light_point = settings.light_point;
    let mut text =
        format!("{settings:?}").replace(&format!(", light_point: {:?}", light_point), "");
    if light_point != crate::lights::LightPoint::default() {
        text.push_str(&format!(" light_point {light_point:?}"));
    }
    format!("{scene:016x}-{:016x}", fnv1a(text.as_bytes()))
}

/// The lock file around the summary's read and write.
pub const SUMMARY_LOCK: &str = ".lightlearn-summary.lock";

/// The run of consecutive frames in `listed` that holds `k`: (first, count).
fn contiguous_span(listed: &std::collections::HashSet<u32>, k: u32) -> (u32, u32) {
    let (mut a, mut b) = (k, k);
    while a > 0 && listed.contains(&(a - 1)) {
        a -= 1;
    }
    while b < u32::MAX && listed.contains(&(b + 1)) {
        b += 1;
    }
    (a, b - a + 1)
}

/// DIR/animation.mp4 from the frames' PNGs with ffmpeg, when it is installed (else a
/// message says why there is none).
pub(super) fn encode_video(
    req: &AnimateRequest,
    (first, count): (u32, u32),
    ui: &mut dyn Ui,
) -> Result<Option<PathBuf>> {
    let ffmpeg_found = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ffmpeg_found {
        ui.message("ffmpeg is not installed, so no animation.mp4 was written (ci/setup.sh installs it); the frames are the PNG/EXR files");
        return Ok(None);
    }
    // Builds without libx264 (e.g. Fedora's ffmpeg-free) are like no ffmpeg: a message.
    let x264 = std::process::Command::new("ffmpeg")
        .args(["-hide_banner", "-encoders"])
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).contains("libx264"));
    if !x264 {
        ui.message("this ffmpeg has no libx264 encoder, so no animation.mp4 was written; the frames are the PNG/EXR files");
        return Ok(None);
    }
    // ffmpeg's image sequence numbers are ints: frames past 2^31 − 1 made it fail after
    // every frame was written, and `animate` exit 1 (an audit, 2026-12-06); at 2^31 − 1
    // itself it looks for the next number, wrapped to a negative one, and says so.
    let last = first as u64 + count.max(1) as u64 - 1;
    if last >= i32::MAX as u64 {
        ui.message(&format!("frame {last} is past the numbers ffmpeg reads (below 2^31 − 1), so no animation.mp4 was written; the frames are the PNG/EXR files"));
        return Ok(None);
    }
    let out = req.out.join("animation.mp4");
    // The io module's temporary name (…PID.tmp, the container given by -f), so that one an
    // ffmpeg killed mid-encode left is removed like any other stale temporary (a name
    // ending .tmp.mp4 stayed for good).
    crate::io::remove_stale_temps(&out);
    let tmp = crate::io::temp_path(&out);
    // Run in the frames' folder with names relative to it: ffmpeg read a `%` in the folder's
    // name as part of the sequence pattern, a folder starting with `-` as an option and one
    // like `cache:x` as a protocol, and failed after every frame (an audit, 2026-12-07).
    let tmp_name = Path::new(".").join(tmp.file_name().context("a temporary file name")?);
    let status = std::process::Command::new("ffmpeg")
        .current_dir(&req.out)
        .args(["-loglevel", "error", "-y", "-framerate"])
        .arg(format!("{}", req.fps))
        .args(["-start_number", &first.to_string(), "-i"])
        .arg("frame-%04d.png")
        // Only the summary's frames: PNGs of an earlier, longer run in the folder were
        // encoded too (a 2-frame run made a 6-frame video).
        .args(["-frames:v", &count.to_string()])
        // Even dimensions for yuv420p, which every player reads.
        .args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-pix_fmt",
            "yuv420p",
            "-c:v",
            "libx264",
            "-f",
            "mp4",
        ])
        .arg(&tmp_name)
        .status()
        .context("cannot run ffmpeg")?;
    if !status.success() {
        // An error, not a warning: the video was asked for (exit 0 on a full disk before;
        // an audit, 2026-12-06). Without ffmpeg at all, the message above and exit 0.
        let _ = std::fs::remove_file(&tmp);
        bail!(
            "ffmpeg failed ({status}) to encode '{}' (its message is above); the frames are written: encode them yourself (ffmpeg -i frame-%04d.png …), or add --no-video",
            out.display()
        );
    }
    std::fs::rename(&tmp, &out)
        .with_context(|| format!("cannot move the video into place at '{}'", out.display()))?;
    Ok(Some(out))
}
