//! `lightlearn merge` and `merge-stats` as a farm uses them: chunks of one image rendered
//! apart combine into the image of their summed samples, and their statistics sum; parts
//! that do not belong together are refused with one line and nothing written.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(common::exe())
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn refused(o: &Output, want: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(want), "'{want}' missing from: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// `render` of the parts' film (24×16, depth 2) with `seed` into `name`.
fn render_args<'a>(name: &'a str, seed: &'a str) -> Vec<&'a str> {
    vec![
        "render",
        "--width",
        "24",
        "--height",
        "16",
        "--max-depth",
        "2",
        "-q",
        "--seed",
        seed,
        "--out",
        name,
    ]
}

/// A render started in `d` with `args`, once its first checkpoint (a.json) is there.
fn checkpointing(args: &[&str], d: &Path) -> std::process::Child {
    let child = Command::new(common::exe())
        .args(args)
        .current_dir(d)
        .spawn()
        .unwrap();
    let t = std::time::Instant::now();
    while !d.join("a.json").exists() {
        assert!(t.elapsed().as_secs() < 60, "no checkpoint within 60 s");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child
}

fn part(dir: &Path, name: &str, seed: &str, spp: &str, extra: &[&str]) {
    let mut a = render_args(name, seed);
    a.extend_from_slice(&["--spp", spp]);
    a.extend_from_slice(extra);
    ok(&run(&a, dir));
}

#[test]
fn chunks_merge_into_the_image_of_their_samples() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    part(d, "a.exr", "1", "4", &["--save-stats", "a.stats"]);
    part(d, "b.exr", "2", "12", &["--save-stats", "b.stats"]);
    ok(&run(&["merge", "a.exr", "b.exr", "--out", "m.exr"], d));
    let img = |n: &str| lightlearn::film::read_exr(&d.join(n)).unwrap().2;
    let (a, b, m) = (img("a.exr"), img("b.exr"), img("m.exr"));
    for i in 0..m.len() {
        for k in 0..3 {
            let want = (4.0 * a[i][k] as f64 + 12.0 * b[i][k] as f64) / 16.0;
            assert!(
                (m[i][k] as f64 - want).abs() <= 1e-6 * want.abs() + 1e-9,
                "pixel {i}: {} vs {want}",
                m[i][k]
            );
        }
    }
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("m.json")).unwrap()).unwrap();
    assert_eq!(report["spp"], 16);
    assert_eq!(report["merged_from"].as_array().unwrap().len(), 2);
    assert!(d.join("m.png").exists());

    // The statistics sum, and the sum loads for a continuation.
    ok(&run(
        &["merge-stats", "a.stats", "b.stats", "--out", "m.stats"],
        d,
    ));
    let m = lightlearn::learning::stats_file::SavedStats::load(&d.join("m.stats")).unwrap();
    assert_eq!(m.header.samples_done, 16);
    part(d, "c.exr", "3", "2", &["--load-stats", "m.stats"]);
}

#[test]
fn parts_that_do_not_belong_together_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    part(d, "a.exr", "1", "2", &["--save-stats", "a.stats"]);
    part(d, "same.exr", "1", "2", &[]);
    part(d, "wang.exr", "2", "2", &["--sampler", "wang"]);
    part(
        d,
        "grid.exr",
        "3",
        "2",
        &["--grid", "16", "--save-stats", "grid.stats"],
    );
    let mut args = vec![
        "render",
        "--width",
        "32",
        "--height",
        "16",
        "--max-depth",
        "2",
        "-q",
    ];
    args.extend_from_slice(&["--seed", "4", "--spp", "2", "--out", "wide.exr"]);
    ok(&run(&args, d));
    // A pair split apart (a render killed between renaming its EXR and its JSON, or an EXR
    // copied over another): torn.json says seed 5 and 2 spp, its EXR holds 6 spp of seed 6.
    part(d, "torn.exr", "5", "2", &[]);
    part(d, "other.exr", "6", "6", &[]);
    std::fs::copy(d.join("other.exr"), d.join("torn.exr")).unwrap();
    // Other estimators of the same image, and a merge's own output: each was merged with
    // exit 0 (the estimator's switch named nowhere) or refused for a wrong reason (an
    // audit, 2026-12-06).
    part(d, "sa.exr", "7", "2", &["--light-point", "solid-angle"]);
    part(d, "coarse.exr", "8", "2", &["--coarse-blocks", "off"]);
    part(d, "m1.exr", "9", "2", &[]);
    part(d, "m2.exr", "10", "2", &[]);
    ok(&run(&["merge", "m1.exr", "m2.exr", "--out", "m0.exr"], d));
    let before: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    for (other, want) in [
        ("same.exr", "share seed 1"),
        ("wang.exr", "has sampler"),
        (
            "grid.exr",
            "other region settings than 'a.exr' (grid: 16 vs 32)",
        ),
        ("wide.exr", "has width"),
        ("sa.exr", "has light_point"),
        ("coarse.exr", "(coarse_blocks: false vs true)"),
        ("m0.exr", "is itself a merge (of m1.exr, m2.exr)"),
        (
            "torn.exr",
            "is not the image its report 'torn.json' describes",
        ),
    ] {
        refused(&run(&["merge", "a.exr", other, "--out", "m.exr"], d), want);
    }
    refused(
        &run(&["merge", "a.exr", "--out", "m.exr"], d),
        "at least two parts",
    );
    // One file twice was told "they hold the same samples; render the chunks with different
    // --seed" (an audit, 2026-12-07).
    refused(
        &run(&["merge", "a.exr", "./a.exr", "--out", "m.exr"], d),
        "part './a.exr' is given twice (also as 'a.exr'); give each part once",
    );
    refused(
        &run(&["merge", "a.exr", "wang.exr", "--out", "a.exr"], d),
        "would replace the part",
    );
    refused(
        &run(
            &["merge-stats", "a.stats", "grid.stats", "--out", "m.stats"],
            d,
        ),
        // It said "this render uses --grid 32 … or drop --load-stats" (an audit, 2026-12-06).
        "'grid.stats' was saved with --grid 16 but 'a.stats' has --grid 32; merge only",
    );
    refused(
        &run(
            &["merge-stats", "a.stats", "grid.stats", "--out", "a.stats"],
            d,
        ),
        "is one of the parts",
    );
    let after: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        before.len(),
        after.len(),
        "something was written: {after:?}"
    );
}

#[test]
fn chunks_from_one_start_count_it_once() {
    use lightlearn::learning::stats_file::SavedStats;
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    part(d, "base.exr", "1", "8", &["--save-stats", "base.stats"]);
    for k in ["0", "1"] {
        let stats = format!("c{k}.stats");
        part(
            d,
            &format!("c{k}.exr"),
            "1",
            "8",
            &[
                "--load-stats",
                "base.stats",
                "--chunk",
                k,
                "--save-stats",
                &stats,
            ],
        );
    }
    ok(&run(
        &[
            "merge-stats",
            "c0.stats",
            "c1.stats",
            "--base",
            "base.stats",
            "--out",
            "m.stats",
        ],
        d,
    ));
    let load = |n: &str| SavedStats::load(&d.join(n)).unwrap();
    let (base, c0, c1, m) = (
        load("base.stats"),
        load("c0.stats"),
        load("c1.stats"),
        load("m.stats"),
    );
    // Chunk k continues after the base's 8 passes at 8 + 8k.
    assert_eq!((c0.header.samples_done, c1.header.samples_done), (16, 24));
    assert_eq!(m.header.samples_done, 24);
    let mut checked = 0;
    for (r, &bo) in base.index.iter().enumerate() {
        if bo == 0 {
            continue;
        }
        let len = base.cuts[bo as usize] as usize;
        for k in 1..=len {
            let at = |s: &SavedStats| {
                let x = s.stats[s.index[r] as usize + k];
                x.n_zero + x.n_nonzero
            };
            let want = at(&base) + (at(&c0) - at(&base)) + (at(&c1) - at(&base));
            assert!(
                (at(&m) - want).abs() <= 1e-3 * want.max(1.0),
                "region {r} slot {k}: {} vs {want}",
                at(&m)
            );
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked} slots checked");
    // Each chunk's file says it holds the base; the merge holds all three.
    let base_sum = base.checksum();
    for c in [&c0, &c1] {
        assert_eq!(c.header.holds, Some(vec![base_sum.clone()]));
    }
    let mut all = vec![base_sum, c0.checksum(), c1.checksum()];
    all.sort();
    assert_eq!(m.header.holds, Some(all));
    // Without --base the start is counted twice: now said (it was silent, as was a file
    // merged with its own continuation, which is now refused: a note of 2026-12-07).
    let o = run(
        &[
            "merge-stats",
            "c0.stats",
            "c1.stats",
            "--out",
            "plain.stats",
        ],
        d,
    );
    ok(&o);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(
        said.contains("warning: 'c0.stats' and 'c1.stats' both hold the statistics of one start")
            && said.contains("--base"),
        "{said}"
    );
    for (parts, held) in [
        (
            ["base.stats", "c0.stats"],
            "'c0.stats' already holds the statistics of 'base.stats'",
        ),
        (
            ["m.stats", "c1.stats"],
            "'m.stats' already holds the statistics of 'c1.stats'",
        ),
    ] {
        let mut a = vec!["merge-stats"];
        a.extend_from_slice(&parts);
        a.extend_from_slice(&["--out", "x.stats"]);
        refused(&run(&a, d), held);
    }
    assert!(!d.join("x.stats").exists());
    // The parts' order does not change the merge's bytes, so the same merge made twice in
    // two orders is one file twice, refused (it counted every observation twice with exit
    // 0: an audit, 2026-12-07).
    ok(&run(
        &[
            "merge-stats",
            "c1.stats",
            "c0.stats",
            "--out",
            "reversed.stats",
        ],
        d,
    ));
    assert!(
        std::fs::read(d.join("plain.stats")).unwrap()
            == std::fs::read(d.join("reversed.stats")).unwrap(),
        "merges of the same parts in two orders differ"
    );
    refused(
        &run(
            &[
                "merge-stats",
                "plain.stats",
                "reversed.stats",
                "--out",
                "x.stats",
            ],
            d,
        ),
        "hold the same statistics bit for bit",
    );
    let plain = load("plain.stats");
    let total = |s: &SavedStats| {
        s.stats
            .iter()
            .map(|x| (x.n_zero + x.n_nonzero) as f64)
            .sum::<f64>()
    };
    assert!(
        total(&plain) > total(&m) * 1.2,
        "{} vs {}",
        total(&plain),
        total(&m)
    );
}

/// `merge` of a part that a render is still checkpointing reads its report and image as one
/// set: it took one checkpoint's report and the next one's image and refused the pair as
/// split by a kill in 3 of 60 tries (an audit, 2026-12-07; here the build before failed in 1 run of 3 at 40 merges, in 2 of 2 at 150). Each merge now either merges a
/// consistent pair or sees none yet.
#[test]
fn a_part_being_checkpointed_merges_or_waits() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    part(d, "b.exr", "2", "4", &["--sampler", "power"]);
    let mut args = render_args("a.exr", "1");
    args.extend_from_slice(&[
        "--sampler",
        "power",
        "--spp",
        "100000",
        "--checkpoint",
        "0.03",
    ]);
    let mut child = checkpointing(&args, d);
    let mut merged = 0;
    for i in 0..150 {
        let out = format!("m{i}.exr");
        let o = run(&["merge", "a.exr", "b.exr", "--out", &out], d);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("split apart"), "merge {i}: {err}");
        merged += o.status.success() as u32;
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(merged >= 120, "{merged} of 150 merges");
}

/// `render --checkpoint`: a render killed without warning (SIGKILL: no handler runs) keeps
/// the image of its last checkpoint, whole and marked as one, and `merge` finishes it with a
/// render of another seed; checkpoints leave the finished image's bytes as they were. With
/// the build before, a killed render left nothing (and `--checkpoint` did not exist).
#[test]
fn a_killed_render_keeps_its_last_checkpoint_and_merges() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut args = render_args("a.exr", "1");
    args.extend_from_slice(&["--time", "120", "--checkpoint", "0.2"]);
    let mut child = checkpointing(&args, d);
    // One more checkpoint's time, so that the kill may land during a write.
    std::thread::sleep(std::time::Duration::from_millis(300));
    child.kill().unwrap();
    child.wait().unwrap();
    // The outputs are whole; the kill may have left hidden temporaries, which a later write
    // of a.exr removes once they are 10 minutes old (src/io/mod.rs remove_stale_temps).
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("a.json")).unwrap()).unwrap();
    assert_eq!(report["checkpoint"], true, "{report}");
    let spp = report["spp"].as_u64().unwrap();
    assert!(spp >= 1, "{report}");
    let (w, h, a) = lightlearn::film::read_exr(&d.join("a.exr")).unwrap();
    assert_eq!((w, h), (24, 16));
    assert!(a.iter().flatten().all(|v| v.is_finite()) && a.iter().flatten().any(|&v| v > 0.0));
    part(d, "b.exr", "2", "4", &[]);
    let exr_sum = lightlearn::film::exr_checksum(&d.join("a.exr")).unwrap();
    assert!(report["exr_fnv1a"].is_string(), "{report}");
    if report["exr_fnv1a"].as_str() == Some(exr_sum.as_str()) {
        let o = run(&["merge", "a.exr", "b.exr", "--out", "m.exr"], d);
        ok(&o);
        // Merged by what it holds, and said (silent before; an audit, 2026-12-07).
        let said = String::from_utf8_lossy(&o.stderr);
        assert!(
            said.contains(&format!("warning: part 'a.exr' is of a render stopped before its count (interrupted, or a checkpoint), at {spp} spp")),
            "{said}"
        );
        assert!(!said.contains("'b.exr' is of a render stopped"), "{said}");
        let merged: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("m.json")).unwrap()).unwrap();
        assert_eq!(merged["spp"].as_u64().unwrap(), spp + 4, "{merged}");
    } else {
        // The kill landed between the renames of a checkpoint's EXR and its JSON (a few
        // microseconds of each 0.2 s): the pair is refused, never weighed by the wrong spp.
        refused(
            &run(&["merge", "a.exr", "b.exr", "--out", "m.exr"], d),
            "is not the image its report",
        );
    }
    // Checkpoints after every batch leave the final image's bytes alone.
    part(d, "c.exr", "3", "24", &["--checkpoint", "0"]);
    part(d, "e.exr", "3", "24", &["--checkpoint", "0.001"]);
    let bytes = |n: &str| std::fs::read(d.join(n)).unwrap();
    assert!(bytes("c.exr") == bytes("e.exr"));
}

/// Reports edited past what a render writes (an audit, 2026-12-06): a first_sample_index of
/// -1 or "x" was read as 0, two parts whose counts sum past the random streams' passes were
/// merged into a report naming 2147483651 samples, and a part that does not exist was
/// called one with no report. Each is refused by name now.
#[test]
fn reports_edited_past_what_a_render_writes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    part(d, "a.exr", "1", "4", &[]);
    part(d, "b.exr", "2", "4", &[]);
    let original: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("a.json")).unwrap()).unwrap();
    let edited = |field: &str, v: serde_json::Value| {
        let mut r = original.clone();
        r[field] = v;
        std::fs::write(d.join("a.json"), serde_json::to_vec(&r).unwrap()).unwrap();
    };
    for bad in [serde_json::json!(-1), serde_json::json!("x")] {
        edited("first_sample_index", bad);
        refused(
            &run(&["merge", "a.exr", "b.exr", "--out", "m.exr"], d),
            "gives first_sample_index",
        );
    }
    edited("first_sample_index", serde_json::json!(0));
    edited("spp", serde_json::json!(2147483647u64));
    refused(
        &run(&["merge", "a.exr", "b.exr", "--out", "m.exr"], d),
        "past the 2147483648 a render",
    );
    edited("spp", serde_json::json!(0));
    refused(
        &run(&["merge", "a.exr", "b.exr", "--out", "m.exr"], d),
        "gives spp 0, not a positive sample count",
    );
    refused(
        &run(&["merge", "nope.exr", "b.exr", "--out", "m.exr"], d),
        "part 'nope.exr' does not exist",
    );
    assert!(!d.join("m.exr").exists());
}

/// An animation's frame carries the one before it, so its statistics file holds that
/// frame's: merging the two counted the first frame's observations twice with exit 0 (a
/// note of 2026-12-07); refused now, naming both.
#[test]
fn a_frame_and_the_frame_it_carried_are_not_merged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rooms-walk.glb");
    ok(&run(
        &[
            "animate",
            scene.to_str().unwrap(),
            "--frames",
            "0..1",
            "--spp",
            "2",
            "--width",
            "16",
            "--height",
            "12",
            "--max-depth",
            "1",
            "--no-video",
            "-q",
            "--out",
            "walk",
        ],
        d,
    ));
    refused(
        &run(
            &[
                "merge-stats",
                "walk/frame-0000.stats",
                "walk/frame-0001.stats",
                "--out",
                "m.stats",
            ],
            d,
        ),
        "'walk/frame-0001.stats' already holds the statistics of 'walk/frame-0000.stats'",
    );
}

/// `merge-stats` holds every part in memory: parts larger together than the free memory
/// aborted with a failed allocation and a backtrace (an audit, 2026-12-07: 40 parts of
/// 134 MB under a 4 GB limit). Refused before any is read (two sparse files of 1 TiB here).
#[test]
fn statistics_too_large_to_hold_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["a.stats", "b.stats"] {
        let f = std::fs::File::create(dir.path().join(name)).unwrap();
        f.set_len(1 << 40).unwrap();
    }
    let o = run(
        &["merge-stats", "a.stats", "b.stats", "--out", "m.stats"],
        dir.path(),
    );
    refused(&o, "a merge keeps them all in memory");
    assert!(!dir.path().join("m.stats").exists());
}

/// The merged PNG keeps the parts' exposure (`render --exposure`, a farm's chunks): it was
/// written at 0 EV whatever the parts' PNGs showed. `--exposure` chooses another; parts of
/// other exposures are merged (the EXRs hold the radiance) with a warning; `-q` leaves only
/// warnings.
#[test]
fn the_merged_png_keeps_the_parts_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    part(d, "a.exr", "1", "4", &["--exposure", "2"]);
    part(d, "b.exr", "2", "4", &["--exposure", "2"]);
    part(d, "c.exr", "3", "4", &[]);
    let report = |n: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(d.join(n)).unwrap()).unwrap()
    };
    // The PNG is the merged EXR × the factor, through the sRGB curve.
    let png_is = |n: &str, factor: f32| {
        let png = std::fs::File::open(d.join(format!("{n}.png"))).unwrap();
        let mut reader = png::Decoder::new(std::io::BufReader::new(png))
            .read_info()
            .unwrap();
        let mut bytes = vec![0; reader.output_buffer_size()];
        let size = reader.next_frame(&mut bytes).unwrap().buffer_size();
        let radiance = lightlearn::film::read_exr(&d.join(format!("{n}.exr")))
            .unwrap()
            .2;
        let exposed: Vec<[f32; 3]> = radiance.iter().map(|p| p.map(|c| c * factor)).collect();
        bytes[..size] == lightlearn::film::tonemap_srgb8(&exposed)
    };
    let o = run(&["merge", "a.exr", "b.exr", "--out", "m.exr", "-q"], d);
    ok(&o);
    assert!(
        o.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(report("m.json")["png_exposure"], 4.0);
    ok(&run(
        &[
            "merge",
            "a.exr",
            "b.exr",
            "--out",
            "z.exr",
            "--exposure",
            "0",
        ],
        d,
    ));
    assert!(report("z.json")["png_exposure"].is_null());
    assert!(png_is("m", 4.0), "the merged PNG is not the image × 4");
    assert!(png_is("z", 1.0), "the PNG at 0 EV is not the image");
    assert!(!png_is("m", 1.0));
    ok(&run(
        &[
            "merge",
            "a.exr",
            "b.exr",
            "--out",
            "n.exr",
            "--exposure=-1.5",
        ],
        d,
    ));
    assert!((report("n.json")["png_exposure"].as_f64().unwrap() - 2f64.powf(-1.5)).abs() < 1e-6);
    let o = run(&["merge", "a.exr", "c.exr", "--out", "x.exr"], d);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: part 'c.exr' was written with another PNG exposure"),
        "{err}"
    );
    assert_eq!(report("x.json")["png_exposure"], 4.0);
    refused(
        &run(
            &[
                "merge",
                "a.exr",
                "b.exr",
                "--out",
                "y.exr",
                "--exposure",
                "30",
            ],
            d,
        ),
        "--exposure 30 is out of range",
    );
    assert!(!d.join("y.exr").exists());
}
