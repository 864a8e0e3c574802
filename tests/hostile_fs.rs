//! Outputs on a hostile file system: a folder removed during a render, a stderr nobody
//! reads, names the file system refuses, devices and FIFOs where an output goes, a video
//! encoder that fails. Each case failed with the build before (an audit, 2026-12-06;
//! docs/results.md, twenty-first session). A full or read-only disk needs a mount, which a
//! test cannot count on: those were checked by hand (the same section).

mod common;

use std::os::unix::fs::FileTypeExt;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{files, refused, run_in, stderr};
use serde_json::Value;

const TINY: [&str; 8] = [
    "--width",
    "32",
    "--height",
    "24",
    "--spp",
    "4",
    "--max-depth",
    "1",
];

fn scene(name: &str) -> String {
    format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The render's folder is removed while it renders: the checkpoints that cannot be written
/// are warnings and the render goes on; its outputs go to a rescue folder, which the error
/// names, with every sample (before: exit 1 at the first failed checkpoint, the samples
/// lost).
#[test]
fn a_render_whose_folder_is_removed_keeps_its_samples() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("out")).unwrap();
    let scene = scene("cornell.glb");
    let child = Command::new(common::exe())
        .arg("render")
        .args([&scene, "--time", "4", "--checkpoint", "0.3", "--out"])
        .arg("out/r.exr")
        .args(["--width", "32", "--height", "24", "--max-depth", "1", "-q"])
        .current_dir(d)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The first checkpoint (0.3 s of rendering) is written; then the folder goes.
    let t = Instant::now();
    while !d.join("out/r.exr").exists() {
        assert!(t.elapsed() < Duration::from_secs(60), "no checkpoint came");
        std::thread::sleep(Duration::from_millis(10));
    }
    std::fs::remove_dir_all(d.join("out")).unwrap();
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("warning: checkpoint not written"), "{err}");
    let line = err.lines().find(|l| l.starts_with("error:")).unwrap();
    assert!(line.contains("its folder 'out' no longer exists"), "{line}");
    let saved = line
        .split("saved in '")
        .nth(1)
        .and_then(|s| s.split('\'').next())
        .unwrap_or_else(|| panic!("no rescue folder named: {line}"));
    let saved = std::path::Path::new(saved);
    let rescue = saved.parent().unwrap().to_path_buf();
    let report: Value =
        serde_json::from_slice(&std::fs::read(saved.with_extension("json")).unwrap()).unwrap();
    std::fs::remove_dir_all(&rescue).unwrap();
    assert_eq!(
        files_of(&report),
        (true, false),
        "the rescued report should be the final render's, not a checkpoint's"
    );
    assert!(line.contains(&format!("{} spp", report["spp"])), "{line}");
}

/// (seconds of film ≥ 4, marked as a checkpoint) of a render's report.
fn files_of(report: &Value) -> (bool, bool) {
    (
        report["render_seconds"].as_f64().unwrap() >= 4.0,
        report["checkpoint"].as_bool().unwrap_or(false),
    )
}

/// A stderr whose reader is gone (`2>&1 | head -1`): the messages are dropped, the render
/// is written, exit 0 (before: a panic printing the first message, exit 101, nothing
/// written).
#[test]
fn a_closed_stderr_does_not_end_a_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut child = Command::new(common::exe())
        .args(["render", &scene("cornell.glb")])
        .args(TINY)
        .args(["--out", "r.exr"])
        .current_dir(d)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert!(status.success(), "{status}");
    assert_eq!(files(d), ["r.exr", "r.json", "r.png"]);
}

/// Names the file system refuses and outputs that are not regular files are refused before
/// any rendering (before: a 255-byte EXR name, whose JSON is 256, rendered and lost the
/// render at its end; a FIFO or device under an output's name was replaced, `--force` or
/// not).
#[test]
fn names_too_long_and_outputs_that_are_not_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cornell = scene("cornell.glb");
    let long = format!("{}.exr", "a".repeat(251));
    let o = run_in(&["render", &cornell, "--out", &long], d, &[]);
    refused(&o, &["256 bytes", "shorten --out"]);
    assert!(!stderr(&o).contains("device"), "it rendered first");
    assert!(files(d).is_empty(), "{:?}", files(d));

    let fifo = d.join("r.exr");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let o = run_in(&["render", &cornell, "--out", "r.exr"], d, &[]);
    refused(&o, &["'r.exr'", "not a regular file"]);
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    let stats = d.join("s.stats");
    assert!(Command::new("mkfifo")
        .arg(&stats)
        .status()
        .unwrap()
        .success());
    let mut args = vec![
        "render",
        &cornell,
        "--out",
        "y.exr",
        "--save-stats",
        "s.stats",
    ];
    args.extend(["--force"]);
    args.extend(TINY);
    let o = run_in(&args, d, &[]);
    refused(&o, &["'s.stats'", "not a regular file"]);
    assert!(std::fs::symlink_metadata(&stats)
        .unwrap()
        .file_type()
        .is_fifo());
}

/// ffmpeg is there but fails (a full disk): an error naming the video, exit 1, the frames
/// written and no video of an earlier run left beside them (before: a warning and exit 0).
#[test]
fn a_video_that_cannot_be_encoded_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bin = d.join("bin");
    std::fs::create_dir(&bin).unwrap();
    let ffmpeg = bin.join("ffmpeg");
    std::fs::write(
        &ffmpeg,
        "#!/bin/sh\n[ \"$1\" = -version ] && exit 0\necho 'No space left on device' >&2\nexit 1\n",
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&ffmpeg, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::create_dir(d.join("an")).unwrap();
    std::fs::write(d.join("an/animation.mp4"), b"an earlier run's video").unwrap();
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap());
    let mut args = vec!["animate", "--frames", "0..1", "--out", "an"];
    let walk = scene("city-cars.glb");
    args.insert(1, &walk);
    args.extend(TINY);
    let o = run_in(&args, d, &[("PATH", &path)]);
    refused(
        &o,
        &["ffmpeg failed", "animation.mp4", "the frames are written"],
    );
    let names = files(&d.join("an"));
    assert!(names.contains(&"frame-0001.exr".to_string()), "{names:?}");
    assert!(!names.contains(&"animation.mp4".to_string()), "{names:?}");
}
