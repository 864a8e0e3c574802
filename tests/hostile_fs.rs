//! Outputs on a hostile file system: a folder removed during a render, a stderr nobody
//! reads, names the file system refuses, devices and FIFOs where an output goes, a video
//! encoder that fails. Each case failed with the build before (an audit, 2026-12-06;
//! docs/results.md, twenty-first session). A full or read-only disk needs a mount, which a
//! test cannot count on: those were checked by hand (the same section).

mod common;

use std::os::unix::fs::FileTypeExt;
use std::path::Path;
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

fn mkfifo(p: &Path) {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(p.as_os_str().as_bytes()).unwrap();
    // SAFETY: a NUL-terminated path that lives across the call.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0, "mkfifo");
}

fn is_fifo(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_fifo())
}

/// The render's folder is renamed away while it renders: the checkpoints that cannot be
/// written give one warning and the render goes on; its outputs go to a rescue folder in
/// TMPDIR, which the error names, with every sample (before: exit 1 at the first failed
/// checkpoint, the samples lost).
#[test]
fn a_render_whose_folder_is_removed_keeps_its_samples() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("out")).unwrap();
    std::fs::create_dir(d.join("tmp")).unwrap();
    let mut child = Command::new(common::exe())
        .args(["render", &scene("cornell.glb"), "--time", "4"])
        .args(["--checkpoint", "0.3", "--out", "out/r.exr", "-q"])
        .args(["--width", "32", "--height", "24", "--max-depth", "1"])
        .env("TMPDIR", d.join("tmp"))
        .current_dir(d)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The first checkpoint (0.3 s of rendering) is written; then the folder goes (a rename:
    // atomic, whatever the render is writing into it at that moment).
    let t = Instant::now();
    while !d.join("out/r.exr").exists() {
        if t.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("no checkpoint came");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    std::fs::rename(d.join("out"), d.join("gone")).unwrap();
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        err.matches("warning: checkpoint not written").count(),
        1,
        "one warning, not one a checkpoint: {err}"
    );
    let line = err.lines().find(|l| l.starts_with("error:")).unwrap();
    assert!(line.contains("its folder 'out' no longer exists"), "{line}");
    // The rescue folder is in TMPDIR, and holds the whole render.
    let rescued = files(&d.join("tmp"));
    assert_eq!(rescued.len(), 1, "{rescued:?}");
    let rescue = d.join("tmp").join(&rescued[0]);
    assert!(line.contains(&rescue.display().to_string()), "{line}");
    assert_eq!(files(&rescue), ["r.exr", "r.json", "r.png"]);
    let report: Value =
        serde_json::from_slice(&std::fs::read(rescue.join("r.json")).unwrap()).unwrap();
    assert!(
        report["render_seconds"].as_f64().unwrap() >= 4.0,
        "{report}"
    );
    assert!(
        report.get("checkpoint").is_none(),
        "a checkpoint's: {report}"
    );
    assert!(line.contains(&format!("{} spp", report["spp"])), "{line}");
}

/// A stderr whose reader is gone (`2>&1 | head -1`): the messages are dropped, the render
/// is written, exit 0 (before: a panic printing the first message, exit 101, nothing
/// written).
#[test]
fn a_closed_stderr_does_not_end_a_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut child = Command::new(common::exe())
        .args(["render", &scene("cornell.glb"), "--out", "r.exr"])
        .args(TINY)
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
/// not); a name with a newline gets a one-line error.
#[test]
fn names_too_long_and_outputs_that_are_not_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cornell = scene("cornell.glb");
    let render = |out: &str, more: &[&str]| {
        let mut args = vec!["render", &cornell, "--out", out];
        args.extend(more);
        args.extend(TINY);
        run_in(&args, d, &[])
    };
    let o = render(&format!("{}.exr", "a".repeat(251)), &[]);
    refused(&o, &["256 bytes", "shorten the name"]);
    assert!(!stderr(&o).contains("device"), "it rendered first");
    assert!(files(d).is_empty(), "{:?}", files(d));

    // A newline in a name is shown as \n: the error stays one line (it spanned two).
    let o = render("new\nline/r.exr", &["-q"]);
    refused(&o, &["'new\\nline/r.exr'", "does not exist"]);
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));

    mkfifo(&d.join("r.exr"));
    refused(&render("r.exr", &[]), &["'r.exr'", "not a regular file"]);
    assert!(is_fifo(&d.join("r.exr")));
    mkfifo(&d.join("s.stats"));
    let o = render("y.exr", &["--save-stats", "s.stats", "--force"]);
    refused(&o, &["'s.stats'", "not a regular file"]);
    assert!(is_fifo(&d.join("s.stats")));
}

/// ffmpeg is there, with libx264, but fails (a full disk): an error naming the video and
/// what to do, exit 1, the frames written and no video of an earlier run left beside them
/// (before: a warning and exit 0); a dead encoder's temporary is cleaned up.
#[test]
fn a_video_that_cannot_be_encoded_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bin = d.join("bin");
    std::fs::create_dir(&bin).unwrap();
    let ffmpeg = bin.join("ffmpeg");
    let stub = "#!/bin/sh\n\
                case \"$*\" in\n\
                  -version) exit 0 ;;\n\
                  *-encoders*) echo ' V..... libx264'; exit 0 ;;\n\
                esac\n\
                echo 'No space left on device' >&2\n\
                exit 1\n";
    std::fs::write(&ffmpeg, stub).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&ffmpeg, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::create_dir(d.join("an")).unwrap();
    std::fs::write(d.join("an/animation.mp4"), b"an earlier run's video").unwrap();
    // ... and that run's summary beside it: a video with none is a user's, refused before
    // any frame (a review, 2026-12-07).
    std::fs::write(
        d.join("an/animation.json"),
        br#"{"fps": 24.0, "sequence": "earlier", "frames": []}"#,
    )
    .unwrap();
    // What an ffmpeg killed mid-encode an hour ago left (a process id no longer running).
    let stale = d.join("an/.animation.mp4.999999999.tmp");
    let f = std::fs::File::create(&stale).unwrap();
    f.set_modified(std::time::SystemTime::now() - Duration::from_secs(3600))
        .unwrap();
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap());
    let walk = scene("city-cars.glb");
    let mut args = vec!["animate", &walk, "--frames", "0..1", "--out", "an"];
    args.extend(TINY);
    let o = run_in(&args, d, &[("PATH", &path)]);
    let wants = [
        "ffmpeg failed",
        "animation.mp4",
        "frames are written",
        "--no-video",
    ];
    refused(&o, &wants);
    let names = files(&d.join("an"));
    assert!(names.contains(&"frame-0001.exr".to_string()), "{names:?}");
    assert!(!names.contains(&"animation.mp4".to_string()), "{names:?}");
    assert!(
        !stale.exists(),
        "a dead encoder's temporary stayed: {names:?}"
    );
}
