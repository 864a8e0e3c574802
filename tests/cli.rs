//! The `lightlearn` binary as a user runs it: reproducible renders, and bad input that ends
//! in a clear message, a non-zero exit, no panic and no output file.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use glam::Vec3;
use lightlearn::scene::gltf_write::GltfBuilder;

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(common::exe())
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run lightlearn")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs a render that must fail; checks the message and that nothing was written.
fn expect_failure(args: &[&str], dir: &Path, env: &[(&str, &str)], wants: &[&str]) {
    let out = Command::new(common::exe())
        .args(args)
        .current_dir(dir)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let err = stderr(&out);
    assert!(!out.status.success(), "{args:?} should fail; stderr: {err}");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    for w in wants {
        assert!(
            err.contains(w),
            "{args:?}: message should contain '{w}', got: {err}"
        );
    }
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("out") || n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{args:?} left files behind: {left:?}");
}

const SMALL: &[&str] = &[
    "--width",
    "24",
    "--height",
    "16",
    "--spp",
    "4",
    "--validation",
    "-q",
];

/// Renders the default scene (32×24, 64 spp, direct light, `sampler`) once with each of
/// `values` for `flag`; checks that each report gives the value under `key`, that the images
/// differ (the flag reached the kernel) and that their means agree within 5σ (both are
/// unbiased).
fn flag_reaches_the_kernel(flag: &str, key: &str, values: [&str; 2], sampler: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut means = Vec::new();
    for v in values {
        let out = format!("{v}.exr");
        let args = [
            "render",
            "--out",
            &out,
            flag,
            v,
            "--width",
            "32",
            "--height",
            "24",
            "--spp",
            "64",
            "--max-depth",
            "1",
            "--sampler",
            sampler,
            "-q",
        ];
        let o = run(&args, d);
        assert!(o.status.success(), "render failed: {}", stderr(&o));
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(format!("{v}.json"))).unwrap()).unwrap();
        assert_eq!(report[key], v);
        let (_, _, px) = lightlearn::film::read_exr(&d.join(&out)).unwrap();
        let mean = px.iter().flatten().map(|v| *v as f64).sum::<f64>() / (px.len() * 3) as f64;
        means.push((mean, report["estimated_mse_of_mean"].as_f64().unwrap(), px));
    }
    assert!(
        means[0].2 != means[1].2,
        "{flag} {} drew the same samples as {}",
        values[1],
        values[0]
    );
    // The image means within 5σ: each report's estimated MSE is the variance of a pixel
    // channel's mean averaged over the 3N values, so the image mean's is that / 3N (for a
    // stratified film an upper bound).
    let values_n = 3.0 * means[0].2.len() as f64;
    let sigma = ((means[0].1 + means[1].1) / values_n).sqrt();
    assert!(
        (means[0].0 - means[1].0).abs() < 5.0 * sigma,
        "{} {} vs {} {} (σ {sigma})",
        values[0],
        means[0].0,
        values[1],
        means[1].0
    );
}

/// `--light-point solid-angle` reaches the kernel: the report says so, the default scene's
/// panels are sampled otherwise (another image from the same seed), and its mean agrees with
/// area sampling's. A bad value names the choices.
#[test]
fn light_point_reaches_the_kernel() {
    flag_reaches_the_kernel(
        "--light-point",
        "light_point",
        ["area", "solid-angle"],
        "lightbvh",
    );
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["render", "--light-point", "sphere"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("solid-angle"), "{}", stderr(&o));
}

/// Each `--stratify` choice reaches the kernel: independent numbers, R2 and Sobol' give other
/// images of the same mean, and the report says which.
#[test]
fn stratify_reaches_the_kernel() {
    flag_reaches_the_kernel("--stratify", "stratify", ["sobol", "off"], "bayes");
    flag_reaches_the_kernel("--stratify", "stratify", ["r2", "sobol"], "wang");
    // `on` (the name before r2 and sobol existed) is sobol: the same bytes, the same report.
    let dir = tempfile::tempdir().unwrap();
    for v in ["on", "sobol"] {
        let out = format!("{v}.exr");
        let args = [
            "render",
            "--out",
            &out,
            "--stratify",
            v,
            "--width",
            "16",
            "--height",
            "12",
        ];
        let o = run(
            &[&args[..], &["--spp", "8", "--max-depth", "1", "-q"]].concat(),
            dir.path(),
        );
        assert!(o.status.success(), "render failed: {}", stderr(&o));
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join(format!("{v}.json"))).unwrap())
                .unwrap();
        assert_eq!(report["stratify"], "sobol");
    }
    let exr = |v: &str| std::fs::read(dir.path().join(format!("{v}.exr"))).unwrap();
    assert!(exr("on") == exr("sobol"), "--stratify on is not sobol");
}

#[test]
fn same_seed_same_bits_other_seed_other_bits() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (out, seed) in [("a.exr", "3"), ("b.exr", "3"), ("c.exr", "4")] {
        let mut args = vec!["render", "--out", out, "--seed", seed];
        args.extend_from_slice(SMALL);
        let o = run(&args, d);
        assert!(o.status.success(), "render failed: {}", stderr(&o));
    }
    let read = |n: &str| std::fs::read(d.join(n)).unwrap();
    assert_eq!(
        read("a.exr"),
        read("b.exr"),
        "same seed must give a bit-identical EXR"
    );
    assert_ne!(
        read("a.exr"),
        read("c.exr"),
        "another seed must give another image"
    );
    // The report and preview come with it.
    let report: serde_json::Value = serde_json::from_slice(&read("a.json")).unwrap();
    assert_eq!(report["spp"], 4);
    assert_eq!(report["seed"], 3);
    assert_eq!(report["sampler"], "bayes");
    assert!(
        report["learning"]["diagnostics"]["observations"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    assert!(report["device"].as_str().unwrap().len() > 3);
    assert!(read("a.png").starts_with(b"\x89PNG"));
    let (w, h, px) = lightlearn::film::read_exr(&d.join("a.exr")).unwrap();
    assert_eq!((w, h), (24, 16));
    assert!(px.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    assert!(
        px.iter().flatten().any(|v| *v > 0.0),
        "the default scene is lit"
    );
}

#[test]
fn time_budget_renders_at_least_one_pass() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "render", "--time", "0.5", "--width", "16", "--height", "16", "-q", "--out", "t.exr",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("t.json")).unwrap()).unwrap();
    assert!(report["spp"].as_u64().unwrap() >= 1);
    assert!(report["render_seconds"].as_f64().unwrap() < 5.0);
}

#[test]
fn bad_input_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fn with(scene: &str) -> Vec<&str> {
        let mut v = vec!["render", scene, "--out", "out.exr"];
        v.extend_from_slice(SMALL);
        v
    }

    expect_failure(
        &with("missing.glb"),
        d,
        &[],
        &["missing.glb", "cannot read"],
    );

    std::fs::write(d.join("text.gltf"), "this is not json").unwrap();
    expect_failure(
        &with("text.gltf"),
        d,
        &[],
        &["text.gltf", "not a valid glTF"],
    );

    let mut g = GltfBuilder::new();
    g.point_light("bulb", Vec3::ONE, Vec3::ONE, 1.0);
    std::fs::write(d.join("empty.glb"), g.to_glb()).unwrap();
    expect_failure(&with("empty.glb"), d, &[], &["empty.glb", "no triangles"]);

    let mut g = GltfBuilder::new();
    let m = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.cuboid("box", Vec3::ZERO, Vec3::ONE, m);
    std::fs::write(d.join("dark.glb"), g.to_glb()).unwrap();
    expect_failure(&with("dark.glb"), d, &[], &["dark.glb", "no lights"]);

    g.point_light("bulb", Vec3::splat(2.0), Vec3::ONE, 1.0);
    g.mesh(
        "nan",
        &[Vec3::ZERO, Vec3::splat(f32::INFINITY), Vec3::ONE],
        &[0, 1, 2],
        m,
    );
    std::fs::write(d.join("inf.glb"), g.to_glb()).unwrap();
    expect_failure(
        &with("inf.glb"),
        d,
        &[],
        &["inf.glb", "'nan'", "non-finite position"],
    );

    // Output problems are found before rendering.
    let mut args = vec!["render", "--out", "no-such-dir/out.exr"];
    args.extend_from_slice(SMALL);
    expect_failure(&args, d, &[], &["no-such-dir", "does not exist"]);
    let mut args = vec!["render", "--out", "out.png"];
    args.extend_from_slice(SMALL);
    expect_failure(&args, d, &[], &["must end in .exr"]);
    let mut args = vec!["render", "--out", "out.exr", "--spp", "0"];
    args.extend_from_slice(&SMALL[..4]);
    expect_failure(&args, d, &[], &["--spp must be at least 1"]);
    expect_failure(
        &["render", "--sampler", "magic", "--out", "out.exr"],
        d,
        &[],
        &["magic", "uniform", "power"],
    );
    let mut args = vec![
        "render",
        "--sampler",
        "wang",
        "--k-max",
        "65",
        "--out",
        "out.exr",
    ];
    args.extend_from_slice(SMALL);
    expect_failure(&args, d, &[], &["--k-max 65", "1..=64"]);
    let mut args = vec![
        "render",
        "--sampler",
        "wang",
        "--control-variates",
        "--out",
        "out.exr",
    ];
    args.extend_from_slice(SMALL);
    expect_failure(&args, d, &[], &["--control-variates", "--sampler bayes"]);

    // No Vulkan driver at all, and a device name that matches nothing.
    let mut args = vec!["render", "--out", "out.exr"];
    args.extend_from_slice(SMALL);
    let no_driver = [
        ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
        ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
    ];
    expect_failure(&args, d, &no_driver, &["Vulkan", "ci/setup.sh"]);
    args.extend_from_slice(&["--device", "no-such-gpu"]);
    expect_failure(&args, d, &[], &["no-such-gpu", "Available"]);
}

#[test]
fn help_describes_every_option() {
    let o = run(&["render", "--help"], Path::new("."));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    for opt in [
        "--sampler",
        "--spp",
        "--time",
        "--width",
        "--height",
        "--seed",
        "--out",
        "--device",
    ] {
        assert!(text.contains(opt), "--help lacks {opt}");
    }
    // `variance` listed --brdf-aware and --control-variates, which it refuses (a note left
    // by the twenty-eighth session): hidden there, still listed by `render`.
    let o = run(&["variance", "--help"], Path::new("."));
    let variance = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && variance.contains("--brdf-select"));
    for opt in ["--brdf-aware", "--control-variates"] {
        assert!(!variance.contains(opt), "variance --help lists {opt}");
        assert!(text.contains(opt), "render --help lacks {opt}");
    }
}

/// The same command twice gives byte-identical EXR, PNG and statistics files, and JSON
/// reports equal but for the timings (the fields named `*_seconds`). Before, the EXR's
/// chunks were written in parallel order: three runs at 256×192 gave different files.
#[test]
fn the_same_command_writes_the_same_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Three runs: the parallel writer's order differed in about one pair of runs in three.
    for n in ["a", "b", "c"] {
        let args = [
            "render",
            "--width",
            "256",
            "--height",
            "192",
            "--spp",
            "1",
            "--max-depth",
            "1",
            "-q",
            "--out",
            &format!("{n}.exr"),
            "--save-stats",
            &format!("{n}.stats"),
        ];
        let o = run(&args, d);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let read = |n: &str| std::fs::read(d.join(n)).unwrap();
    for ext in ["exr", "png", "stats"] {
        for other in ["b", "c"] {
            assert!(
                read(&format!("a.{ext}")) == read(&format!("{other}.{ext}")),
                "the .{ext} files differ"
            );
        }
    }
    fn strip_timings(v: &mut serde_json::Value) {
        if let Some(m) = v.as_object_mut() {
            m.retain(|k, _| !k.ends_with("_seconds"));
            m.values_mut().for_each(strip_timings);
        }
    }
    let mut ja: serde_json::Value = serde_json::from_slice(&read("a.json")).unwrap();
    let mut jb: serde_json::Value = serde_json::from_slice(&read("b.json")).unwrap();
    strip_timings(&mut ja);
    strip_timings(&mut jb);
    assert_eq!(ja, jb, "the reports differ beyond their timings");
}

/// Where stderr is not a terminal (a farm's log, a pipe) progress is a line every 30 s
/// (`LIGHTLEARN_PROGRESS_EVERY` seconds): a long render there printed nothing after its
/// first line and looked hung (an audit, 2026-12-06). `-q` keeps them out.
#[test]
fn progress_is_logged_where_stderr_is_not_a_terminal() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let dir = tempfile::tempdir().unwrap();
    let render = |quiet: bool| {
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "64",
            "--max-depth",
            "1",
            "--out",
            "p.exr",
        ];
        if quiet {
            args.push("-q");
        }
        Command::new(common::exe())
            .args(&args)
            .current_dir(dir.path())
            .env("LIGHTLEARN_PROGRESS_EVERY", "0")
            .output()
            .unwrap()
    };
    let out = render(false);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("render: ") && l.contains(" spp, ") && l.contains(" % after "))
        .collect();
    assert!(!lines.is_empty(), "no progress lines in:\n{err}");
    let out = render(true);
    assert!(!stderr(&out).contains(" % after "), "{}", stderr(&out));
}

/// lavapipe compiles a kernel at its first dispatch: with no shader cache (a fresh machine,
/// MESA_SHADER_CACHE_DISABLE) `profile` timed that compile, ~0.5-0.7 s, as each variant's
/// passes (rows of -5105 % with exit 0; an audit, 2026-12-06). An untimed pass comes
/// first now: 4 passes of 16×12 take milliseconds. Two repeats (the fastest is kept) so a
/// busy machine's stall is not read as the compile; each repeat makes its pipeline anew,
/// so without the untimed pass both would time a compile.
#[test]
fn profile_does_not_time_the_kernel_compile() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(common::exe())
        .args([
            "profile",
            scene.to_str().unwrap(),
            "--spp",
            "4",
            "--repeats",
            "2",
            "--width",
            "16",
            "--height",
            "12",
            "--max-depth",
            "1",
        ])
        .current_dir(dir.path())
        .env("MESA_SHADER_CACHE_DISABLE", "true")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}{text}", stderr(&out));
    let line = text
        .lines()
        .find(|l| l.starts_with("| nothing (the real kernel)"))
        .unwrap_or_else(|| panic!("no real kernel row in:\n{text}"));
    let seconds: f64 = line.split('|').nth(2).unwrap().trim().parse().unwrap();
    assert!(seconds < 0.25, "the compile was timed: {line}");
}

/// `bench-rays --repeats 1` on a cold shader cache timed lavapipe's kernel compile as the
/// rays (0.05 Mrays/s against ~5 at 64×64: an audit, 2026-12-07); an untimed dispatch comes
/// first now. A busy machine runs the rays slower, never 100× slower.
#[test]
fn bench_rays_does_not_time_the_kernel_compile() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(common::exe())
        .args([
            "bench-rays",
            "--width",
            "64",
            "--height",
            "64",
            "--triangles",
            "2000",
            "--repeats",
            "1",
        ])
        .current_dir(dir.path())
        .env("MESA_SHADER_CACHE_DISABLE", "true")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}{text}", stderr(&out));
    let line = text
        .lines()
        .find(|l| l.starts_with("coherent"))
        .unwrap_or_else(|| panic!("no coherent row in:\n{text}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let gpu = words.iter().position(|w| *w == "GPU").unwrap();
    let rate: f64 = words[gpu + 1].parse().unwrap();
    assert!(rate > 0.5, "the compile was timed: {line}");
}

/// `profile --sampler uniform` has no light-selection row (knocking `uniform`'s selection out
/// leaves `uniform`: the row printed noise as a stage, an audit, 2026-12-07).
#[test]
fn profile_of_uniform_has_no_selection_row() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        &[
            "profile",
            scene.to_str().unwrap(),
            "--sampler",
            "uniform",
            "--spp",
            "2",
            "--repeats",
            "1",
            "--width",
            "8",
            "--height",
            "8",
            "--max-depth",
            "1",
        ],
        dir.path(),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}{text}", stderr(&out));
    assert!(text.contains("| shadow rays"), "{text}");
    assert!(!text.contains("| light selection"), "{text}");
}

/// `profile` times a pass with each stage knocked out (src/bench/stages.rs): every variant's
/// pipeline must be valid (the validation layer is on) and every row of the table there; with
/// `--timeline` also the table of what happens between passes (src/render/timeline.rs). The
/// timings themselves vary with the machine, so only their form is checked.
#[test]
fn profile_times_every_stage_of_a_learning_path_tracer() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        &[
            "profile",
            scene.to_str().unwrap(),
            "--spp",
            "2",
            "--repeats",
            "1",
            "--width",
            "16",
            "--height",
            "12",
            "--max-depth",
            "3",
            "--validation",
            "--timeline",
        ],
        dir.path(),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}{text}", stderr(&out));
    // --timeline: the two passes each alone with its fold, the growth points after passes 1
    // and 2 by part, each with a positive time in all (the last column).
    // The number in column `col` of the first table row that starts with `row`: positive.
    let positive = |row: &str, col: usize| {
        let line = text
            .lines()
            .find(|l| l.starts_with(&format!("| {row}")))
            .unwrap_or_else(|| panic!("no row '{row}' in:\n{text}"));
        let v: f64 = line.split('|').nth(col).unwrap().trim().parse().unwrap();
        assert!(v > 0.0 && v.is_finite(), "{line}");
    };
    for row in [
        "passes in submissions of 1 | 2 |",
        "folds after windows of 1 | 2 |",
        "growth points (",
        "the steps together",
    ] {
        positive(row, 4);
    }
    for row in [
        "nothing (the real kernel)",
        "light selection",
        "shadow rays",
        "the importance's cone and cosine bounds",
        "MIS light pmf",
        "statistics atomics",
        "folds and region growth between passes",
        "all of the above",
        "everything but the camera rays",
    ] {
        positive(row, 2);
    }
    // The learned state the real kernel left: what the atomics and folds scale with.
    let state = text
        .lines()
        .find_map(|l| l.strip_prefix("learned state: "))
        .unwrap_or_else(|| panic!("no learned state in:\n{text}"));
    let words: Vec<&str> = state.split_whitespace().collect();
    let slots: usize = words[0].parse().unwrap();
    let cuts: usize = words[4].parse().unwrap();
    let regions: usize = words[7].parse().unwrap();
    let observations: f64 = words[9].parse().unwrap();
    assert!(
        cuts > 0 && regions >= cuts && slots >= cuts && observations > 0.0,
        "{state}"
    );
    expect_failure(&["profile", "--spp", "0"], dir.path(), &[], &["--spp"]);
}

/// A render of 1 spp has no variance: its report's estimated error is null, not the
/// invented mean of x²/4 it gave (an audit, 2026-12-07); from 2 spp on, a number.
#[test]
fn one_sample_reports_no_estimated_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (spp, known) in [("1", false), ("2", true)] {
        let out = format!("s{spp}.exr");
        let mut args = vec!["render", "--max-depth", "1", "--spp", spp, "--out", &out];
        args.extend_from_slice(&["--width", "8", "--height", "6"]);
        let o = run(&args, d);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(format!("s{spp}.json"))).unwrap())
                .unwrap();
        for key in ["estimated_mse_of_mean", "estimated_rel_mse_of_mean"] {
            assert_eq!(
                report[key].is_f64(),
                known,
                "{spp} spp: {key} {}",
                report[key]
            );
            assert_eq!(report[key].is_null(), !known, "{spp} spp: {key}");
        }
    }
}

/// `--exposure EV` scales `render`'s and `animate`'s PNGs by 2^EV (the README's "no exposure
/// for render's PNG": one bulb's strings was almost black in it) and nothing else: the EXR is
/// the same bytes, the report records the factor; a value out of range is refused before
/// any work.
#[test]
fn exposure_scales_the_png_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let s = scene.to_str().unwrap();
    let tiny = [
        "--width",
        "16",
        "--height",
        "12",
        "--spp",
        "4",
        "--max-depth",
        "1",
        "-q",
    ];
    let render = |out: &str, extra: &[&str]| {
        let mut a = vec!["render", s, "--out", out];
        a.extend_from_slice(&tiny);
        a.extend_from_slice(extra);
        let o = run(&a, dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
    };
    render("plain.exr", &[]);
    render("bright.exr", &["--exposure", "1.5"]);
    render("dim.exr", &["--exposure", "-2"]);
    let read = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
    assert_eq!(read("plain.exr"), read("bright.exr"));
    for (name, factor) in [("bright", 2f32.powf(1.5)), ("dim", 0.25)] {
        let report: serde_json::Value =
            serde_json::from_slice(&read(&format!("{name}.json"))).unwrap();
        assert_eq!(report["png_exposure"], factor as f64, "{report}");
        let png = std::fs::File::open(dir.path().join(format!("{name}.png"))).unwrap();
        let mut reader = png::Decoder::new(std::io::BufReader::new(png))
            .read_info()
            .unwrap();
        let mut bytes = vec![0; reader.output_buffer_size()];
        let size = reader.next_frame(&mut bytes).unwrap().buffer_size();
        let radiance = lightlearn::film::read_exr(&dir.path().join(format!("{name}.exr")))
            .unwrap()
            .2;
        let exposed: Vec<[f32; 3]> = radiance.iter().map(|p| p.map(|c| c * factor)).collect();
        assert!(
            bytes[..size] == lightlearn::film::tonemap_srgb8(&exposed),
            "{name}: the PNG is not the image × {factor}"
        );
    }
    let plain: serde_json::Value = serde_json::from_slice(&read("plain.json")).unwrap();
    assert!(plain.get("png_exposure").is_none(), "{plain}");
    // animate's frames too.
    let o = run(
        &[
            "animate",
            s,
            "--frames",
            "0..0",
            "--out",
            "frames",
            "--no-video",
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "2",
            "-q",
            "--exposure",
            "1",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&read("frames/frame-0000.json")).unwrap();
    assert_eq!(report["png_exposure"], 2.0, "{report}");
    for bad in ["21", "nan", "-inf"] {
        let o = run(
            &["render", s, "--out", "bad.exr", "--exposure", bad],
            dir.path(),
        );
        assert!(
            o.status.code() == Some(1) && stderr(&o).contains("--exposure"),
            "{bad}: {}",
            stderr(&o)
        );
        assert!(!dir.path().join("bad.exr").exists());
    }
}

/// `-q` on every command that writes files and says so: `scene`, `farm`, `merge-stats` (and
/// `merge`, tests/merge.rs) print nothing on success; `profile` and `variance` keep their
/// table on stdout and no progress on stderr (none took `-q` before 2026-12-07).
#[test]
fn quiet_commands_print_nothing_but_their_results() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let quiet = |args: &[&str]| {
        let o = run(args, d);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert!(o.stderr.is_empty(), "{args:?} said: {}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    quiet(&["scene", "cornell", "--lights", "2", "--out", "c.glb", "-q"]);
    quiet(&[
        "farm", "c.glb", "--out", "job", "--width", "8", "--height", "8", "-q",
    ]);
    assert!(d.join("job/template.yaml").exists());
    for s in ["1", "2"] {
        quiet(&[
            "render",
            "c.glb",
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "2",
            "--max-depth",
            "1",
            "--seed",
            s,
            "--out",
            &format!("{s}.exr"),
            "--save-stats",
            &format!("{s}.stats"),
            "-q",
        ]);
    }
    quiet(&[
        "merge-stats",
        "1.stats",
        "2.stats",
        "--out",
        "m.stats",
        "-q",
    ]);
    let table = quiet(&[
        "profile",
        "c.glb",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "2",
        "--max-depth",
        "1",
        "--repeats",
        "1",
        "-q",
    ]);
    assert!(table.contains('|'), "profile printed no table: {table}");
    let table = quiet(&[
        "variance",
        "c.glb",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "4",
        "--hits",
        "2",
        "--area-samples",
        "2",
        "--samplers",
        "wang",
        "-q",
    ]);
    assert!(table.contains('|'), "variance printed no table: {table}");
}
