//! Outputs that would land on the files a command reads, and work a failed run damaged,
//! through the command line (found by two hostile-input audits, eighteenth session): each
//! test is one way a run replaced a user's file, left a half-written result or wrote a
//! misleading one with exit 0 before. Inputs that are not what they claim:
//! tests/hostile_files.rs.

mod common;

use std::path::Path;
use std::process::Command;

use common::hostile::*;
use common::{files, refused, stderr};
use serde_json::Value;

/// A scene named like a report (`s.json`) was replaced by the render's report, and
/// `merge-stats --out` replaced any file (a scene, a report) with exit 0; `merge-stats a a`
/// counted one file's samples twice. Now each is refused by name and the file kept;
/// `merge-stats --force` still replaces a foreign file, as `render --save-stats --force` does.
#[test]
fn outputs_never_replace_the_files_a_command_reads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    std::fs::copy(d.join("c.gltf"), d.join("s.json")).unwrap();
    let scene = std::fs::read(d.join("s.json")).unwrap();
    refused(
        &render("s.json", &["--out", "s.exr"], d),
        &["s.json", "the scene", "name another --out"],
    );
    refused(
        &run(
            &[
                "reference",
                "s.json",
                "--out",
                "s.exr",
                "--spp",
                "4",
                "--width",
                "8",
                "--height",
                "8",
            ],
            d,
        ),
        &["s.json", "the scene"],
    );
    assert_eq!(std::fs::read(d.join("s.json")).unwrap(), scene);

    for (seed, name) in [("1", "a"), ("2", "b")] {
        let stats = format!("{name}.stats");
        let exr = format!("{name}.exr");
        let o = render(
            "c.gltf",
            &["--seed", seed, "--out", &exr, "--save-stats", &stats],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    // --load-stats named like this render's report.
    std::fs::copy(d.join("a.stats"), d.join("l.json")).unwrap();
    refused(
        &render("c.gltf", &["--load-stats", "l.json", "--out", "l.exr"], d),
        &["l.json", "the --load-stats file"],
    );
    let report = std::fs::read(d.join("a.json")).unwrap();
    for out in ["c.gltf", "a.json"] {
        refused(
            &run(&["merge-stats", "a.stats", "b.stats", "--out", out], d),
            &[out, "not a lightlearn statistics file", "--force"],
        );
    }
    assert_eq!(std::fs::read(d.join("a.json")).unwrap(), report);
    refused(
        &run(
            &["merge-stats", "a.stats", "./a.stats", "--out", "m.stats"],
            d,
        ),
        &["a.stats", "the same file", "count twice"],
    );
    // A copy under another name (an audit, 2026-12-06: its samples counted twice).
    std::fs::copy(d.join("a.stats"), d.join("copy.stats")).unwrap();
    refused(
        &run(
            &["merge-stats", "a.stats", "copy.stats", "--out", "m.stats"],
            d,
        ),
        &["'a.stats' and 'copy.stats'", "bit for bit", "count twice"],
    );
    assert!(!d.join("m.stats").exists());
    let o = run(
        &["merge-stats", "a.stats", "b.stats", "--out", "m.stats"],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(d.join("notes.txt"), "my notes").unwrap();
    let o = run(
        &[
            "merge-stats",
            "a.stats",
            "b.stats",
            "--out",
            "notes.txt",
            "--force",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(d.join("notes.txt"))
        .unwrap()
        .starts_with(b"LLSTATS"));
}

/// A failing `farm` (a buffer it could not read: its URI was percent-encoded, which the
/// loader decodes and the bundler did not) had already replaced an existing job's scene and
/// left it half-copied; into a new folder it left folders behind. The bundle is read whole
/// before anything is written, and encoded URIs are bundled under their decoded names.
#[test]
fn a_failed_farm_run_leaves_the_job_it_found() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let job = [
        "--still", "--width", "8", "--height", "8", "--spp", "2", "--chunks", "2",
    ];
    let farm = |scene: &str, out: &str| {
        let mut a = vec!["farm", scene, "--out", out];
        a.extend_from_slice(&job);
        run(&a, d)
    };
    let o = farm("c.gltf", "job");
    assert!(o.status.success(), "{}", stderr(&o));
    let before: Vec<(String, Vec<u8>)> = ["template.yaml", "scene/c.gltf"]
        .iter()
        .map(|f| (f.to_string(), std::fs::read(d.join("job").join(f)).unwrap()))
        .collect();

    // The same scene with its buffer in a file whose name has a space, URI-encoded.
    std::fs::create_dir(d.join("sub")).unwrap();
    let uri = doc["buffers"][0]["uri"].as_str().unwrap();
    let data = base64_decode(uri.split_once(";base64,").unwrap().1);
    std::fs::write(d.join("sub").join("my data.bin"), &data).unwrap();
    let mut external = doc.clone();
    external["buffers"][0]["uri"] = "my%20data.bin".into();
    write_json(&d.join("sub").join("c.gltf"), &external);
    // A texture that is not there: the scene loads (the material keeps its colour, with a
    // warning) but the bundle cannot hold it.
    write_json(&d.join("sub").join("m.gltf"), &textured(&doc, "gone.png"));

    refused(&farm("sub/m.gltf", "job"), &["gone.png", "job bundle"]);
    for (f, bytes) in &before {
        assert_eq!(
            &std::fs::read(d.join("job").join(f)).unwrap(),
            bytes,
            "{f} changed"
        );
    }
    assert_eq!(files(&d.join("job").join("scene")), ["c.gltf"]);
    refused(&farm("sub/m.gltf", "fresh/job"), &["gone.png"]);
    assert!(!d.join("fresh").exists(), "a refused job left folders");

    // One image named twice, `t.png` and `./t.png`: one file of the bundle (two entries
    // for one target failed the bundle's commit).
    std::fs::write(d.join("sub").join("t.png"), b"\x89PNG not decoded by farm").unwrap();
    let mut twice = textured(&external, "t.png");
    twice["images"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"uri": "./t.png"}));
    write_json(&d.join("sub").join("c.gltf"), &twice);
    let o = farm("sub/c.gltf", "job2");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        files(&d.join("job2").join("scene")),
        ["c.gltf", "my data.bin", "t.png"]
    );
    let o = render("job2/scene/c.gltf", &["--out", "b.exr"], d);
    assert!(
        o.status.success(),
        "the bundled scene does not load: {}",
        stderr(&o)
    );
}

/// A file where a folder of `--out` should be was called a missing folder ("create it
/// first"), and with `--mkdir` the error was "File exists (os error 17)" (an audit,
/// 2026-12-06): both now name the file in the way.
#[test]
fn a_file_in_the_way_of_the_output_folder_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    std::fs::write(d.join("afile"), "x").unwrap();
    refused(
        &render("c.gltf", &["--out", "afile/o.exr"], d),
        &["'afile' is not a folder"],
    );
    for out in ["afile/o.exr", "afile/deeper/o.exr"] {
        refused(
            &render("c.gltf", &["--mkdir", "--out", out], d),
            &["'afile' is something else than a folder"],
        );
    }
    assert_eq!(std::fs::read(d.join("afile")).unwrap(), b"x");
}

/// Refused runs left the folders they had made: `render --mkdir` before its checks, and
/// `animate` before its first frame.
#[test]
fn refused_runs_leave_no_folder_behind() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    refused(
        &render("missing.glb", &["--mkdir", "--out", "nd/deep/o.exr"], d),
        &["missing.glb"],
    );
    refused(
        &run(&["render", "--mkdir", "--out", "nd2/o.png", "-q"], d),
        &["must end in .exr"],
    );
    // A scene that parses but has no lights: refused after the output folder was made.
    let mut dark = cornell(d);
    for m in dark["materials"].as_array_mut().unwrap() {
        m.as_object_mut().unwrap().remove("emissiveFactor");
    }
    write_json(&d.join("dark.gltf"), &dark);
    refused(
        &run(
            &[
                "animate",
                "dark.gltf",
                "--frames",
                "0..1",
                "--out",
                "an/sub",
                "-q",
            ],
            d,
        ),
        &["dark.gltf", "no lights"],
    );
    for f in ["c.gltf", "dark.gltf"] {
        std::fs::remove_file(d.join(f)).unwrap();
    }
    assert!(files(d).is_empty(), "{:?}", files(d));
}

/// `animate` checks every frame's names before its first frame: a folder in the way of a
/// frame in the middle or at the end of the range is refused before any frame is written,
/// and quickly (`--frames 0..99999` probed 400000 names for 25.6 s before its first frame).
#[test]
fn animate_checks_its_frames_names_before_the_first_frame_quickly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    let tiny = ["--width", "8", "--height", "6", "--spp", "1", "-q"];
    for (frames, blocked) in [("0..4", "frame-0002.png"), ("0..99999", "frame-99999.json")] {
        let out = d.join("an");
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(out.join(blocked)).unwrap();
        let mut args = vec!["animate", "c.gltf", "--frames", frames, "--out", "an"];
        args.extend(tiny);
        let t = std::time::Instant::now();
        let o = run_within(&args, d, std::time::Duration::from_secs(60)).unwrap();
        refused(&o, &[blocked, "is a folder"]);
        assert!(
            t.elapsed().as_secs_f64() < 10.0,
            "--frames {frames}: refused after {:?}",
            t.elapsed()
        );
        assert_eq!(files(&out), vec![blocked.to_string()], "--frames {frames}");
    }
}

/// `scene --out` over a file it did not write (a user's own scene, even read-only) is
/// refused unless `--force`; its own scenes are replaced as before. With the build before
/// a Blender file and a text file were replaced, exit 0 (an audit, 2026-12-07).
#[test]
fn scene_keeps_a_users_file_of_its_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let blender = br#"{"asset":{"version":"2.0","generator":"Blender"}}"#;
    std::fs::write(d.join("user.gltf"), blender).unwrap();
    std::fs::write(d.join("mine.glb"), b"mine").unwrap();
    for name in ["user.gltf", "mine.glb"] {
        let o = run(&["scene", "cornell", "--lights", "2", "--out", name], d);
        refused(&o, &[name, "not written by `lightlearn scene`", "--force"]);
    }
    assert_eq!(std::fs::read(d.join("user.gltf")).unwrap(), blender);
    assert_eq!(std::fs::read(d.join("mine.glb")).unwrap(), b"mine");
    // Its own scenes, binary and text, are written over; --force replaces any file.
    for name in ["own.glb", "own.gltf", "own.glb", "own.gltf"] {
        let o = run(&["scene", "cornell", "--lights", "3", "--out", name], d);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = run(
        &[
            "scene", "cornell", "--lights", "2", "--out", "mine.glb", "--force",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(&std::fs::read(d.join("mine.glb")).unwrap()[..4], b"glTF");
}

/// Files a command writes into its output folder replaced a scene (or the scene's texture,
/// or a given reference) of the same name there, with exit 0: `compare` (metrics.json, a
/// run's EXR), `animate` (animation.json), `variance` (variance.json), `render` (the
/// scene's `box.png` as the preview of `--out box.exr`). Each is refused, the files kept.
#[test]
fn files_in_the_output_folder_that_a_command_reads_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let cache = d.join("cache");
    let cache = cache.to_str().unwrap();
    for sub in ["out", "a2", "v"] {
        std::fs::create_dir(d.join(sub)).unwrap();
    }
    let scene = std::fs::read(d.join("c.gltf")).unwrap();
    for f in ["out/metrics.json", "a2/animation.json", "v/variance.json"] {
        std::fs::write(d.join(f), &scene).unwrap();
    }
    let o = compare(
        d,
        cache,
        &[
            "out/metrics.json",
            "--spp",
            "1",
            "--reference-spp",
            "4",
            "--out",
            "out",
        ],
    );
    refused(&o, &["metrics.json", "the scene"]);
    let o = run(
        &[
            "animate",
            "a2/animation.json",
            "--frames",
            "0..1",
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "1",
            "--out",
            "a2",
            "--no-video",
            "-q",
        ],
        d,
    );
    refused(&o, &["animation.json", "the scene"]);
    let o = run(
        &[
            "variance",
            "v/variance.json",
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "2",
            "--stride",
            "4",
            "--hits",
            "2",
            "--samplers",
            "wang",
            "--out",
            "v",
        ],
        d,
    );
    refused(&o, &["variance.json", "the scene is read from"]);
    for f in ["out/metrics.json", "a2/animation.json", "v/variance.json"] {
        assert_eq!(std::fs::read(d.join(f)).unwrap(), scene, "{f} replaced");
    }
    // A given reference named like one of compare's own EXRs in --out.
    let o = common::run_in(
        &[
            "reference",
            "c.gltf",
            "--out",
            "out/spp-uniform.exr",
            "--spp",
            "4",
            "--width",
            "8",
            "--height",
            "8",
        ],
        d,
        &[("LIGHTLEARN_CACHE", cache)],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let reference = std::fs::read(d.join("out/spp-uniform.exr")).unwrap();
    let o = compare(
        d,
        cache,
        &[
            "c.gltf",
            "--reference",
            "out/spp-uniform.exr",
            "--spp",
            "1",
            "--out",
            "out",
        ],
    );
    refused(&o, &["spp-uniform.exr", "the --reference"]);
    assert_eq!(
        std::fs::read(d.join("out/spp-uniform.exr")).unwrap(),
        reference
    );
    // The scene's own texture, named like the render's preview.
    let png = std::fs::read(d.join("out/spp-uniform.png")).unwrap();
    std::fs::write(d.join("box.png"), &png).unwrap();
    write_json(&d.join("box.gltf"), &textured(&doc, "box.png"));
    refused(
        &render("box.gltf", &["--out", "box.exr"], d),
        &["box.png", "a file of the scene"],
    );
    refused(
        &render(
            "box.gltf",
            &["--out", "s.exr", "--save-stats", "box.png", "--force"],
            d,
        ),
        &["box.png", "a file it names"],
    );
    assert_eq!(std::fs::read(d.join("box.png")).unwrap(), png);
    // One hit a pixel has no footprint term: it read 0 % and a total too small.
    refused(
        &run(
            &[
                "variance", "c.gltf", "--hits", "1", "--width", "8", "--height", "8",
            ],
            d,
        ),
        &["--hits 2..=256"],
    );
}

/// A reference cache that cannot be written failed `compare` after the whole reference was
/// rendered; the cache is best effort: the comparison goes on with a warning.
#[test]
fn an_unwritable_reference_cache_is_skipped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    std::fs::write(d.join("not-a-folder"), "x").unwrap();
    let cache = d.join("not-a-folder");
    let args = [
        "c.gltf",
        "--spp",
        "1",
        "--reference-spp",
        "4",
        "--out",
        "cmp",
    ];
    let o = compare(d, cache.to_str().unwrap(), &args);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("not cached"), "{err}");
    let metrics: Value =
        serde_json::from_slice(&std::fs::read(d.join("cmp/metrics.json")).unwrap()).unwrap();
    assert!(
        metrics["reference"]
            .as_str()
            .unwrap()
            .contains("not cached"),
        "{metrics}"
    );
}

/// `animate` into a folder of an earlier, longer run encoded the old PNGs into its video (a
/// 2-frame run made a 6-frame video); `--frame K` replaced the summary with frame K alone;
/// a failed or skipped encoding left the earlier video; an output folder whose name is not
/// UTF-8 panicked writing the summary. Needs ffmpeg for the video part.
#[test]
fn animation_summaries_and_videos_hold_the_folders_frames() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let walk = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rooms-walk.glb");
    let walk = walk.to_str().unwrap();
    cornell(d);
    let animate = |scene: &str, frames: &[&str], out: &str| {
        let mut a = vec![
            "animate", scene, "--width", "16", "--height", "12", "--spp", "2",
        ];
        a.extend_from_slice(&["--max-depth", "1", "--out", out, "-q"]);
        a.extend_from_slice(frames);
        run(&a, d)
    };
    let listed = |out: &str| -> Vec<u64> {
        let v: Value =
            serde_json::from_slice(&std::fs::read(d.join(out).join("animation.json")).unwrap())
                .unwrap();
        v["frames"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f["frame"].as_u64().unwrap())
            .collect()
    };
    let ffprobe = Command::new("ffprobe")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    let video_frames = |out: &str| -> u64 {
        let o = Command::new("ffprobe")
            .args([
                "-v",
                "error",
                "-count_frames",
                "-select_streams",
                "v:0",
                "-show_entries",
            ])
            .args(["stream=nb_read_frames", "-of", "csv=p=0"])
            .arg(d.join(out).join("animation.mp4"))
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout).trim().parse().unwrap()
    };
    let o = animate(walk, &["--frames", "0..3"], "an");
    assert!(o.status.success(), "{}", stderr(&o));
    // Only where this machine encodes videos (ffmpeg with libx264) and counts their frames.
    let video = ffprobe && d.join("an").join("animation.mp4").exists();
    let o = animate(
        walk,
        &["--frame", "2", "--load-stats", "an/frame-0001.stats"],
        "an",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        listed("an"),
        [0, 1, 2, 3],
        "the summary lost the sequence's other frames"
    );
    if video {
        assert_eq!(video_frames("an"), 4);
    }
    let o = animate("c.gltf", &["--frames", "0..1"], "an");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(listed("an"), [0, 1]);
    if video {
        assert_eq!(
            video_frames("an"),
            2,
            "the video holds an earlier run's frames"
        );
    } else {
        eprintln!("skipped the video checks: ffmpeg/ffprobe are not installed (ci/setup.sh installs them)");
    }
    // Linux file systems take any bytes in a name (macOS refuses names that are not UTF-8).
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::ffi::OsStrExt;
        let name = std::ffi::OsStr::from_bytes(b"an\xff");
        let o = Command::new(common::exe())
            .args([
                "animate", "c.gltf", "--frames", "0..0", "--width", "8", "--height", "8",
            ])
            .args(["--spp", "1", "--no-video", "-q", "--out"])
            .arg(name)
            .current_dir(d)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(d.join(name).join("animation.json").exists());
    }
}

/// A long `--out` name (legal: 242 bytes, or 120 two-byte characters) was refused with
/// "its folder does not take new files (permissions?)": the hidden temporary's prefix and
/// suffix took it past the 255 bytes a file name may have. It is written.
#[test]
fn long_output_names_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    for stem in ["a".repeat(242 - 4), "é".repeat(120)] {
        let out = format!("{stem}.exr");
        let o = render("c.gltf", &["--out", &out], d);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(d.join(&out).exists() && d.join(format!("{stem}.json")).exists());
    }
    assert!(
        !files(d).iter().any(|f| f.ends_with(".tmp")),
        "{:?}",
        files(d)
    );
}

/// The PNG and JSON are named after `--out`, not by the user: `--out notes.exr` replaced a
/// user's notes.json with a report (and a notes.png with a preview), exit 0 (an audit,
/// 2026-12-06). Now a JSON that is not a lightlearn report, or a PNG with no report
/// beside it, is refused by name and kept; a render's own outputs are replaced as before,
/// and `merge` and `reference` refuse the same.
#[test]
fn files_named_after_the_exr_that_are_not_ours_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    std::fs::write(d.join("notes.json"), b"{\"mine\": 1}\n").unwrap();
    refused(
        &render("c.gltf", &["--out", "notes.exr"], d),
        &[
            "notes.json",
            "is not a lightlearn report",
            "name another --out",
        ],
    );
    assert_eq!(
        std::fs::read(d.join("notes.json")).unwrap(),
        b"{\"mine\": 1}\n"
    );
    assert!(!d.join("notes.exr").exists() && !d.join("notes.png").exists());
    std::fs::write(d.join("photo.png"), b"not ours").unwrap();
    refused(
        &render("c.gltf", &["--out", "photo.exr"], d),
        &["photo.png", "no lightlearn EXR or report beside it"],
    );
    assert_eq!(std::fs::read(d.join("photo.png")).unwrap(), b"not ours");
    // --force replaces them (render); a set whose report was removed is still ours.
    let o = render("c.gltf", &["--out", "photo.exr", "--force"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::remove_file(d.join("photo.json")).unwrap();
    let o = render("c.gltf", &["--out", "photo.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    // A render's own set is replaced, again and again.
    for seed in ["1", "2"] {
        let o = render("c.gltf", &["--out", "r.exr", "--seed", seed], d);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = render("c.gltf", &["--out", "r2.exr", "--seed", "3"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    refused(
        &run(&["merge", "r.exr", "r2.exr", "--out", "notes.exr"], d),
        &["notes.json", "is not a lightlearn report"],
    );
    refused(
        &run(
            &[
                "reference",
                "c.gltf",
                "--spp",
                "4",
                "--width",
                "8",
                "--height",
                "8",
                "--out",
                "notes.exr",
            ],
            d,
        ),
        &["notes.json", "is not a lightlearn report"],
    );
    assert_eq!(
        std::fs::read(d.join("notes.json")).unwrap(),
        b"{\"mine\": 1}\n"
    );
}
