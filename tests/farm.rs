//! `lightlearn farm`: the Open Job Description templates it writes pass `openjd check`, and
//! `openjd run` of a written job leaves merged images that are what one machine renders:
//! bit for bit to float rounding for a sampler that learns nothing (chunk k draws the
//! samples [k·n, (k+1)·n)), within noise of a reference for the learned sampler carrying
//! statistics from frame to frame. Skipped, saying so, without openjd-cli (ci/setup.sh
//! installs it).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn lightlearn(args: &[&str]) -> Output {
    Command::new(common::exe())
        .args(args)
        .output()
        .expect("the binary runs")
}

fn openjd(args: &[&str]) -> Option<Output> {
    let o = Command::new("python3")
        .args(["-m", "openjd"])
        .args(args)
        .output()
        .ok()?;
    Some(o)
}

fn have_openjd() -> bool {
    let ok = openjd(&["--version"]).is_some_and(|o| o.status.success());
    if !ok {
        eprintln!("skipped: openjd-cli is not installed (ci/setup.sh installs it with pip)");
    }
    ok
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn farm_output(scene: &Path, job: &Path, extra: &[&str]) -> Output {
    let mut a = vec![
        "farm",
        scene.to_str().unwrap(),
        "--out",
        job.to_str().unwrap(),
        "--width",
        "24",
        "--height",
        "18",
        "--max-depth",
        "1",
    ];
    a.extend_from_slice(extra);
    lightlearn(&a)
}

fn farm(scene: &Path, job: &Path, extra: &[&str]) {
    ok(&farm_output(scene, job, extra));
}

fn image(p: &Path) -> Vec<[f32; 3]> {
    lightlearn::film::read_exr(p).unwrap().2
}

#[test]
fn every_template_passes_openjd_check() {
    if !have_openjd() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cars = root().join("scenes/city-cars.glb");
    let cases: [(&Path, &[&str]); 4] = [
        (&cars, &["--frames", "0..3", "--chunks", "3"]),
        (
            &cars,
            &["--frames", "2..4", "--carry", "off", "--sampler", "wang"],
        ),
        (
            &cars,
            &[
                "--still",
                "--chunks",
                "5",
                "--sampler",
                "bayes",
                "--grid",
                "16",
            ],
        ),
        (
            &root().join("scenes/cornell.glb"),
            &["--chunks", "2", "--seed", "9"],
        ),
    ];
    for (i, (scene, extra)) in cases.iter().enumerate() {
        let job = dir.path().join(format!("job{i}"));
        farm(scene, &job, extra);
        let o = openjd(&["check", job.join("template.yaml").to_str().unwrap()]).unwrap();
        ok(&o);
    }
    // Frames that carry statistics cannot take a sampler that learns none: the job offered
    // every sampler and failed at its first merge, "cannot read the statistics file" (an
    // audit, 2026-12-06). openjd refuses it before any task runs.
    let template = dir.path().join("job0/template.yaml");
    let o = openjd(&["run", template.to_str().unwrap(), "-p", "Sampler=uniform"]).unwrap();
    let said = String::from_utf8_lossy(&o.stdout) + String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{said}");
    assert!(said.contains("not in allowedValues"), "{said}");
    assert!(!dir.path().join("job0/output").exists());
    // A seed past u32 passed `openjd check` and failed every task (an audit, 2026-12-07):
    // refused before any task runs.
    let o = openjd(&["run", template.to_str().unwrap(), "-p", "Seed=4294967296"]).unwrap();
    let said = String::from_utf8_lossy(&o.stdout) + String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{said}");
    assert!(said.contains("must be at most 4294967295"), "{said}");
    assert!(!dir.path().join("job0/output").exists(), "{said}");
    // Frames that do not carry them take any.
    let open = std::fs::read_to_string(dir.path().join("job1/template.yaml")).unwrap();
    assert!(open.contains("\"uniform\""), "{open}");
    // A scene whose file name holds an OpenJD format string, a newline and a long tail:
    // the template failed `openjd check` (farm said nothing). Its bundled copy renders.
    let odd = dir.path().join(format!(
        "it's {{{{Param.X}}}} \"q\"\nline{}.glb",
        "x".repeat(120)
    ));
    std::fs::copy(root().join("scenes/cornell.glb"), &odd).unwrap();
    let job = dir.path().join("odd job");
    farm(&odd, &job, &["--chunks", "2", "--spp", "2"]);
    let template = job.join("template.yaml");
    ok(&openjd(&["check", template.to_str().unwrap()]).unwrap());
    ok(&openjd(&["run", template.to_str().unwrap()]).unwrap());
    assert!(job.join("output/render.exr").exists());
}

#[test]
fn a_still_in_chunks_merges_into_the_one_machine_render() {
    if !have_openjd() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = root().join("scenes/cornell.glb");
    let job = dir.path().join("job");
    farm(
        &scene,
        &job,
        &[
            "--chunks",
            "3",
            "--spp",
            "4",
            "--sampler",
            "lightbvh",
            "--seed",
            "5",
            "--light-point",
            "solid-angle",
            "--stratify",
            "r2",
            "--exposure=-1",
        ],
    );
    // The merge is told the exposure (it would also take the chunks' own).
    let template = std::fs::read_to_string(job.join("template.yaml")).unwrap();
    assert!(
        template.contains("merge") && template.matches("--exposure=-1").count() >= 2,
        "the render and merge steps are not given --exposure: {template}"
    );
    ok(&openjd(&["run", job.join("template.yaml").to_str().unwrap()]).unwrap());
    let one = dir.path().join("one.exr");
    ok(&lightlearn(&[
        "render",
        scene.to_str().unwrap(),
        "--spp",
        "12",
        "--width",
        "24",
        "--height",
        "18",
        "--max-depth",
        "1",
        "--sampler",
        "lightbvh",
        "--seed",
        "5",
        "--light-point",
        "solid-angle",
        "--stratify",
        "r2",
        "-q",
        "--out",
        one.to_str().unwrap(),
    ]));
    let (merged, single) = (image(&job.join("output/render.exr")), image(&one));
    for (i, (a, b)) in merged.iter().zip(&single).enumerate() {
        for c in 0..3 {
            let tol = 1e-5 * b[c].abs().max(1e-3);
            assert!(
                (a[c] - b[c]).abs() <= tol,
                "pixel {i}: merged {a:?} vs one render {b:?}"
            );
        }
    }
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(job.join("output/render.json")).unwrap()).unwrap();
    assert_eq!(report["spp"], 12);
    // The job's sampling options and exposure reach its tasks and its merge (the farm took
    // none of them before 2026-12-07).
    assert_eq!(report["light_point"], "solid-angle", "{report}");
    assert_eq!(report["stratify"], "r2", "{report}");
    assert_eq!(report["png_exposure"], 0.5, "{report}");
}

#[test]
fn an_animation_job_of_two_frames_in_two_chunks_runs_and_its_frames_are_unbiased() {
    if !have_openjd() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = root().join("scenes/city-cars.glb");
    let job = dir.path().join("job");
    // bayes, statistics carried: frame 1's chunks start from frame 0's merged statistics.
    farm(
        &scene,
        &job,
        &[
            "--frames", "0..1", "--fps", "1", "--chunks", "2", "--spp", "32",
        ],
    );
    let o = openjd(&["run", job.join("template.yaml").to_str().unwrap()]).unwrap();
    ok(&o);
    let out = job.join("output");
    for k in 0..2 {
        let exr = out.join(format!("frame-{k:04}.exr"));
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(exr.with_extension("json")).unwrap()).unwrap();
        assert_eq!(report["spp"], 64, "frame {k}: two chunks of 32");
        assert!(out.join(format!("frame-{k:04}.stats")).exists());
        // Unbiased: the merged frame's mean against a lightbvh render of the same frame.
        let reference = dir.path().join(format!("ref{k}"));
        ok(&lightlearn(&[
            "animate",
            scene.to_str().unwrap(),
            "--frame",
            &k.to_string(),
            "--fps",
            "1",
            "--sampler",
            "lightbvh",
            "--spp",
            "1024",
            "--width",
            "24",
            "--height",
            "18",
            "--max-depth",
            "1",
            "--no-video",
            "-q",
            "--out",
            reference.to_str().unwrap(),
        ]));
        let mean = |p: &Path| {
            let px = image(p);
            px.iter()
                .map(|c| (c[0] + c[1] + c[2]) as f64 / 3.0)
                .sum::<f64>()
                / px.len() as f64
        };
        let var = |p: &Path| {
            let r: serde_json::Value =
                serde_json::from_slice(&std::fs::read(p.with_extension("json")).unwrap()).unwrap();
            // Mean over pixels of the variance of each pixel's mean, over the pixel count.
            r["estimated_mse_of_mean"].as_f64().unwrap_or(0.0) / (24.0 * 18.0)
        };
        let rexr = reference.join(format!("frame-{k:04}.exr"));
        // The merged report carries no variance; a chunk's (half the samples) bounds it.
        let chunk = out.join(format!("chunks/frame-{k:04}/chunk-0/frame-{k:04}.exr"));
        let sigma = (var(&chunk) / 2.0 + var(&rexr)).sqrt();
        let z = (mean(&exr) - mean(&rexr)) / sigma;
        assert!(
            z.abs() < 5.0,
            "frame {k}: merged mean {} vs reference {} ({z:.1} σ)",
            mean(&exr),
            mean(&rexr)
        );
    }
    // The second frame's statistics count frame 0's once: its passes are frame 0's plus one
    // chunk's range past them, not the sum of both chunks' starts.
    let s1 =
        lightlearn::learning::stats_file::SavedStats::load(&out.join("frame-0001.stats")).unwrap();
    let s0 =
        lightlearn::learning::stats_file::SavedStats::load(&out.join("frame-0000.stats")).unwrap();
    assert_eq!(s1.header.samples_done, s0.header.samples_done + 64);
}

/// A .glb may name external images and buffers by URI as a .gltf does: its bundle held the
/// .glb alone and the job rendered without the texture, exit 0 (an audit, 2026-12-07).
/// Needs no openjd: the bundle is written by `farm` itself.
#[test]
fn a_glb_bundle_holds_the_files_it_names() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let jpeg = std::fs::read(root().join("tests/data/solid-200-100-50.jpg")).unwrap();
    std::fs::write(d.join("solid tex.jpg"), &jpeg).unwrap();
    let glb = std::fs::read(root().join("scenes/cornell.glb")).unwrap();
    let edited = common::edit_glb(&glb, |j| {
        j["images"] = serde_json::json!([{"uri": "solid%20tex.jpg"}]);
        j["textures"] = serde_json::json!([{"source": 0}]);
        j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] =
            serde_json::json!({"index": 0});
    });
    let scene = d.join("textured.glb");
    std::fs::write(&scene, edited).unwrap();
    let job = d.join("job");
    farm(&scene, &job, &["--chunks", "2", "--spp", "1"]);
    let bundled = job.join("scene/solid tex.jpg");
    assert_eq!(
        std::fs::read(&bundled).ok().as_deref(),
        Some(jpeg.as_slice()),
        "{} missing from the bundle",
        bundled.display()
    );
}

/// A job written over an earlier one says what the earlier left: its bundled scene and its
/// outputs stayed without a word (an audit, 2026-12-07); neither is removed.
#[test]
fn a_job_over_an_earlier_one_names_what_it_left() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job");
    farm(
        &root().join("scenes/city-cars.glb"),
        &job,
        &["--frames", "0..0"],
    );
    std::fs::create_dir(job.join("output")).unwrap();
    std::fs::write(job.join("output/frame-0000.exr"), b"earlier").unwrap();
    let o = farm_output(&root().join("scenes/rooms-walk.glb"), &job, &[]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("of an earlier job (city-cars.glb), left as they are"),
        "{err}"
    );
    assert!(err.contains("holds an earlier job's outputs"), "{err}");
    assert!(job.join("scene/city-cars.glb").exists() && job.join("output/frame-0000.exr").exists());
}

#[test]
fn bad_farm_requests_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job");
    let cornell = root().join("scenes/cornell.glb");
    for (args, want) in [
        (vec!["--chunks", "1"], "--chunks must be 2"),
        (vec!["--spp", "0"], "at least 1"),
        (vec!["--forget", "0"], "--forget"),
        // 2000 frames × 10000 chunks (each within its limit) ran out of memory and aborted.
        (
            vec!["--frames", "0..1999", "--chunks", "51"],
            "is 102000 render tasks, more than the 100000",
        ),
        // A merge lists every chunk's file on one command line: 10000 in a job folder of
        // ~170 bytes passed the system's 2 MiB (an audit, 2026-12-07). (2000 chunks of 2^20
        // samples were refused as ending past 2^30, naming a flag of the tasks before.)
        (vec!["--chunks", "1001"], "--chunks must be 2..=1000"),
        // Past a film's 2^20 samples every task failed (a review, 2026-12-07).
        (
            vec!["--spp", "1048577"],
            "--spp 1048577 is more than the 1048576",
        ),
        // A frame's chunks refined their cuts apart and the job failed at its first merge
        // of statistics (an audit, 2026-12-07).
        (
            vec!["--frames", "0..1", "--refine-cuts", "4"],
            "--refine-cuts with statistics carried from frame to frame",
        ),
    ] {
        let mut a = vec![
            "farm",
            cornell.to_str().unwrap(),
            "--out",
            job.to_str().unwrap(),
        ];
        a.extend(args);
        let o = lightlearn(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(want), "{want}: {err}");
    }
    let o = lightlearn(&["farm", "/nonexistent/x.glb", "--out", job.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot find the scene"));
}

/// The scene loader's warnings and frames past the animation's end are said when the job is
/// written: `farm` dropped them (an audit, 2026-12-07), and a job of frames holding the last
/// pose, or of a file with channels left out, was written without a word.
#[test]
fn a_job_says_what_its_frames_will_warn_of() {
    let dir = tempfile::tempdir().unwrap();
    let cars = root().join("scenes/city-cars.glb");
    let job = dir.path().join("job");
    let o = lightlearn(&[
        "farm",
        cars.to_str().unwrap(),
        "--out",
        job.to_str().unwrap(),
        "--frames",
        "0..99",
        "--chunks",
        "2",
    ]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: ")
            && err.contains("ends at frame 96 at 24 fps; frames 97..99 hold its last pose"),
        "{err}"
    );
    // The loader's, as they come, also where the job is then refused (a review,
    // 2026-12-07: the note on ignored channels that renumbers the rest was lost with it).
    let bytes = std::fs::read(&cars).unwrap();
    let edited = common::edit_glb(&bytes, |j| {
        let channels = j["animations"][0]["channels"].as_array_mut().unwrap();
        channels.insert(
            0,
            serde_json::json!({"sampler": 0, "target": {"path": "pointer"}}),
        );
    });
    let pointer = dir.path().join("pointer.glb");
    std::fs::write(&pointer, edited).unwrap();
    let o = lightlearn(&[
        "farm",
        pointer.to_str().unwrap(),
        "--out",
        dir.path().join("job2").to_str().unwrap(),
        "--frames",
        "3..2",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && err.contains("warning: ")
            && err.contains("1 animation channel targets no node's")
            && err.contains("the last frame comes before the first"),
        "{err}"
    );
}
