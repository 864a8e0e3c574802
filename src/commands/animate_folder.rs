//! `animate`'s output folder before the first frame: made if missing, every file name of the
//! run checked (writable, not the scene, not a user's file), the run's lock taken, and a
//! folder of another sequence's frames said. Split from animate.rs (784 lines).

use std::collections::HashSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use serde_json::Value;

use super::animate::{frame_stem, AnimateRequest, RUN_LOCK};
use super::animate_output::{sequence_key, SUMMARY_LOCK};
use super::Ui;

/// Prepares the output folder for frames `first..=last`: returns the run's lock and the
/// sequence's key (`animation.json` merges only records of the same key).
pub(super) fn prepare(
    req: &AnimateRequest,
    first: u32,
    last: u32,
    ui: &mut dyn Ui,
) -> Result<(RunLock, String)> {
    let made = !req.out.exists();
    crate::io::create_output_folder(&req.out, "output folder")?;
    // Every file of the run, checked before the first frame's time is spent: the first and
    // the last frame's in full (the folder takes files, the longest name fits), the others
    // where a file of their name is already there (a folder, a device). Probing every name
    // took 25.6 s for `--frames 0..99999` before its first frame (an audit, 2026-12-07).
    let existing: HashSet<OsString> = std::fs::read_dir(&req.out)
        .with_context(|| format!("cannot list the output folder '{}'", req.out.display()))?
        .filter_map(|e| e.ok().map(|e| e.file_name()))
        .collect();
    for k in first..=last {
        let stem = frame_stem(&req.out, k);
        for ext in ["exr", "png", "json", "stats"] {
            let p = stem.with_extension(ext);
            let there = p.file_name().is_some_and(|n| existing.contains(n));
            if k == first || k == last || there {
                crate::io::check_writable(&p)?;
            }
        }
    }
    crate::io::check_writable(&req.out.join("animation.json"))?;
    // One run of a range of frames a folder at a time: two into one folder interleaved
    // their frames (each frame whole, the sequence and its summary mixed, the statistics'
    // chain broken, exit 0: an audit, 2026-12-07). Runs of one frame each (`--frame K`, as
    // a farm renders them) may share the folder with each other.
    let single = first == last;
    let file = crate::io::lock_file(&req.out.join(RUN_LOCK), single, false)?.ok_or_else(|| {
        anyhow::anyhow!(
            "another `lightlearn animate` is writing frames to '{}'; wait for it to end or give another --out",
            req.out.display()
        )
    })?;
    let run_lock = RunLock {
        file,
        dir: req.out.clone(),
        made,
        finished: false,
    };
    // None of them may be the scene, a file it names or the --load-stats file (a scene
    // named animation.json inside --out was replaced, with exit 0).
    let mut written: Vec<PathBuf> = (first..=last)
        .flat_map(|k| {
            let stem = frame_stem(&req.out, k);
            ["exr", "png", "json", "stats"].map(|e| stem.with_extension(e))
        })
        .collect();
    written.push(req.out.join("animation.json"));
    written.push(req.out.join("animation.mp4"));
    let written: Vec<&Path> = written.iter().map(PathBuf::as_path).collect();
    let mut others: Vec<(&str, &Path)> = Vec::new();
    if let Some(p) = &req.load_stats {
        others.push(("the --load-stats file", p));
    }
    crate::io::check_outputs_spare_scene(&written, req.scene.as_deref(), &others)?;
    // After that check, whose message says more (a scene named animation.json in --out was
    // told to add --force, then refused anyway; a review, 2026-12-07).
    // The folder's summary, read once for both.
    let summary = req.out.join("animation.json");
    let earlier: Option<Option<Value>> = existing
        .contains(std::ffi::OsStr::new("animation.json"))
        .then(|| {
            crate::io::read_regular(&summary, 1 << 30)
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok())
        });
    check_not_foreign(req, first, last, &existing, earlier.as_ref())?;
    // Read once (it hashes the scene file), not once a frame.
    let sequence = sequence_key(req);
    if let Some(Some(old)) = &earlier {
        warn_other_sequence(req, old, &sequence, first, last, ui);
    }
    Ok((run_lock, sequence))
}

/// The run's lock on its output folder ([`RUN_LOCK`]). A run that fails in a folder it made,
/// holding the lock alone, with nothing but the lock files in the folder, removes them on
/// drop, so that the folder goes too: a refused run removed them while another run held
/// them and then the winner's folder (a review, 2026-12-07).
pub(super) struct RunLock {
    file: std::fs::File,
    dir: PathBuf,
    made: bool,
    /// Set when the run ends well: the lock files stay.
    pub(super) finished: bool,
}

impl Drop for RunLock {
    fn drop(&mut self) {
        use std::os::fd::AsRawFd;
        if self.finished || !self.made {
            return;
        }
        // SAFETY: flock on a descriptor this guard owns. A shared holder's upgrade fails
        // while another run holds the lock (its shared lock may be gone then: it is ending).
        if unsafe { libc::flock(self.file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            return;
        }
        let locks = [RUN_LOCK, SUMMARY_LOCK];
        let only_locks = std::fs::read_dir(&self.dir).is_ok_and(|d| {
            d.flatten().all(|e| {
                locks
                    .iter()
                    .any(|l| e.file_name() == std::ffi::OsStr::new(l))
            })
        });
        if only_locks {
            for l in locks {
                let _ = std::fs::remove_file(self.dir.join(l));
            }
        }
    }
}

/// Files of the run's names that lightlearn did not write are refused unless `--force`, as
/// `render` refuses them: a user's `frame-0000.json`, `.exr` or `animation.json` in --out
/// were replaced, exit 0 (an audit, 2026-12-07). A frame's JSON is ours when it is a
/// report, its images when such a report is beside them, its `.stats` when it is a
/// statistics file; `animation.json` when it is a summary (it names its sequence).
fn check_not_foreign(
    req: &AnimateRequest,
    first: u32,
    last: u32,
    existing: &HashSet<OsString>,
    earlier: Option<&Option<Value>>,
) -> Result<()> {
    if req.force {
        return Ok(());
    }
    let there = |p: &Path| p.file_name().is_some_and(|n| existing.contains(n));
    let refuse = |p: &Path, why: &str| -> Result<()> {
        bail!(
            "'{}' exists and {why}: animate would replace it; give another --out, move the file, or add --force to replace it",
            p.display()
        )
    };
    let summary = req.out.join("animation.json");
    // A video is animate's where its summary is beside it; a user's own was replaced by the
    // new one, or removed where none was made (a review, 2026-12-07). Kept with --no-video.
    let video = req.out.join("animation.mp4");
    if req.video && there(&video) && !there(&summary) {
        refuse(&video, "has no lightlearn animation.json beside it")?;
    }
    if let Some(read) = earlier {
        // Summaries from before 2026-12-05 name no sequence; every one names its fps, and
        // each frame record its frame and EXR.
        let ours = read.as_ref().is_some_and(|v| {
            v.get("fps").is_some()
                && v["frames"].as_array().is_some_and(|f| {
                    f.iter()
                        .all(|r| r.get("frame").is_some() && r.get("exr").is_some())
                })
        });
        if !ours {
            refuse(&summary, "is not an animation summary lightlearn wrote")?;
        }
    }
    for k in first..=last {
        let stem = frame_stem(&req.out, k);
        let [exr, png, json, stats] =
            ["exr", "png", "json", "stats"].map(|e| stem.with_extension(e));
        if ![&exr, &png, &json, &stats].iter().any(|p| there(p)) {
            continue;
        }
        let report = there(&json) && crate::film::is_report(&json);
        if there(&json) && !report {
            refuse(&json, "is not a lightlearn report")?;
        }
        for img in [&exr, &png] {
            if there(img) && !report {
                refuse(img, "has no lightlearn report beside it")?;
            }
        }
        if there(&stats) && !crate::learning::stats_file::is_stats_file(&stats) {
            refuse(&stats, "is not a lightlearn statistics file")?;
        }
    }
    Ok(())
}

/// A folder whose summary is another sequence's (another scene or settings) keeps that
/// sequence's frames beyond this run's range beside this run's, and the new summary lists
/// only this run's: said, as the folder ends up mixed (an audit, 2026-12-07).
fn warn_other_sequence(
    req: &AnimateRequest,
    old: &Value,
    key: &str,
    first: u32,
    last: u32,
    ui: &mut dyn Ui,
) {
    if old["sequence"] == serde_json::json!(key) {
        return;
    }
    let stale: Vec<u64> = (old["frames"].as_array().into_iter().flatten())
        .filter_map(|f| f["frame"].as_u64())
        .filter(|&k| k < first as u64 || k > last as u64)
        .filter(|&k| {
            u32::try_from(k).is_ok_and(|k| frame_stem(&req.out, k).with_extension("exr").exists())
        })
        .collect();
    if let (Some(a), Some(b)) = (stale.first(), stale.last()) {
        ui.message(&format!(
            "warning: '{}' holds {} frame(s) ({a}..{b}) of another sequence (another scene or settings); they stay beside this run's, and animation.json will list only this run's frames",
            req.out.display(),
            stale.len()
        ));
    }
}
