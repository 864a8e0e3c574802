//! Statistics files: the same seed gives the same bytes, save → load → continue equals an
//! uninterrupted run, bad files are refused with the fix.

use super::*;

#[test]
fn same_seed_same_image_and_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for k in ["a", "b"] {
        let out = d.join(format!("{k}.exr"));
        let st = d.join(format!("{k}.stats"));
        ok(&lightlearn(&[
            "render",
            "scenes/rooms.glb",
            "--sampler",
            "bayes",
            "--spp",
            "6",
            "--width",
            "48",
            "--height",
            "32",
            "--seed",
            "5",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
            "--save-stats",
            st.to_str().unwrap(),
        ]));
    }
    assert_eq!(
        std::fs::read(d.join("a.exr")).unwrap(),
        std::fs::read(d.join("b.exr")).unwrap(),
        "EXR differs between identical runs"
    );
    assert_eq!(
        std::fs::read(d.join("a.stats")).unwrap(),
        std::fs::read(d.join("b.stats")).unwrap(),
        "statistics differ between identical runs"
    );
}

#[test]
fn save_load_continue_equals_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |n: &str| d.join(n).to_str().unwrap().to_string();
    let base = [
        "render",
        "scenes/rooms.glb",
        "--sampler",
        "bayes",
        "--width",
        "48",
        "--height",
        "32",
        "--seed",
        "3",
        "--quiet",
    ];
    let run = |extra: &[&str]| {
        let mut a: Vec<&str> = base.to_vec();
        a.extend_from_slice(extra);
        ok(&lightlearn(&a));
    };
    run(&[
        "--spp",
        "8",
        "--out",
        &p("full.exr"),
        "--save-stats",
        &p("full.stats"),
    ]);
    run(&[
        "--spp",
        "4",
        "--out",
        &p("half1.exr"),
        "--save-stats",
        &p("half1.stats"),
    ]);
    run(&[
        "--spp",
        "4",
        "--out",
        &p("half2.exr"),
        "--load-stats",
        &p("half1.stats"),
        "--save-stats",
        &p("half2.stats"),
    ]);
    // The same bytes but for the header's record of the file it continued (which
    // merge-stats reads: 2026-12-07).
    use lightlearn::learning::stats_file::SavedStats;
    let (half1, half2) = (
        SavedStats::load(Path::new(&p("half1.stats"))).unwrap(),
        SavedStats::load(Path::new(&p("half2.stats"))).unwrap(),
    );
    assert_eq!(half2.header.holds, Some(vec![half1.checksum()]));
    assert_eq!(
        std::fs::read(p("full.stats")).unwrap(),
        half2.to_bytes_holding(&[]),
        "statistics after save → load → continue differ from an uninterrupted run"
    );
    let img = |n: &str| lightlearn::film::read_exr(Path::new(&p(n))).unwrap().2;
    let (full, h1, h2) = (img("full.exr"), img("half1.exr"), img("half2.exr"));
    let mut lit = 0;
    for i in 0..full.len() {
        for c in 0..3 {
            let joined = 0.5 * (h1[i][c] + h2[i][c]);
            assert!(
                (joined - full[i][c]).abs() <= 1e-5 * full[i][c].abs() + 1e-7,
                "pixel {i}: continued {joined} vs uninterrupted {}",
                full[i][c]
            );
            lit += (full[i][c] > 0.0) as usize;
        }
    }
    assert!(lit > full.len(), "the test image is mostly black");
}

#[test]
fn bad_statistics_files_are_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |n: &str| d.join(n).to_str().unwrap().to_string();
    let common_args = [
        "render",
        "scenes/rooms.glb",
        "--spp",
        "1",
        "--width",
        "16",
        "--height",
        "16",
        "--quiet",
    ];
    let run = |extra: &[&str]| {
        let mut a: Vec<&str> = common_args.to_vec();
        a.extend_from_slice(extra);
        lightlearn(&a)
    };
    ok(&run(&[
        "--sampler",
        "bayes",
        "--out",
        &p("a.exr"),
        "--save-stats",
        &p("a.stats"),
    ]));
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "--sampler".into(),
                "bayes".into(),
                "--grid".into(),
                "16".into(),
            ],
            "--grid 32",
        ),
        (
            vec!["--sampler".into(), "donikian".into()],
            "--sampler bayes",
        ),
        (
            vec![
                "--sampler".into(),
                "bayes".into(),
                "--regression".into(),
                "off".into(),
            ],
            "--regression importance",
        ),
        (
            vec![
                "--sampler".into(),
                "bayes".into(),
                "--regression".into(),
                "distance".into(),
            ],
            "--regression importance",
        ),
        (vec!["--sampler".into(), "wang".into()], "learning sampler"),
        // Not in the files before 2026-12-07: loaded under either without a word.
        (
            vec![
                "--sampler".into(),
                "bayes".into(),
                "--coarse-blocks".into(),
                "off".into(),
            ],
            "--coarse-blocks on",
        ),
        (
            vec![
                "--sampler".into(),
                "bayes".into(),
                "--in-cluster".into(),
                "power".into(),
            ],
            "--in-cluster importance",
        ),
    ];
    for (extra, want) in cases {
        let mut a: Vec<&str> = extra.iter().map(String::as_str).collect();
        let out = p("b.exr");
        let st = p("a.stats");
        a.extend_from_slice(&["--out", &out, "--load-stats", &st]);
        let o = run(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {err}");
        assert!(
            err.contains(want),
            "{extra:?}: error should name '{want}': {err}"
        );
        assert!(
            !Path::new(&out).exists(),
            "{extra:?}: an output was written"
        );
    }
    // Another scene; a damaged file; not a statistics file at all.
    let c_out = p("c.exr");
    let a_stats = p("a.stats");
    let o = lightlearn(&[
        "render",
        "scenes/city.glb",
        "--spp",
        "1",
        "--width",
        "16",
        "--height",
        "16",
        "--quiet",
        "--sampler",
        "bayes",
        "--out",
        &c_out,
        "--load-stats",
        &a_stats,
    ]);
    let bytes = std::fs::read(p("a.stats")).unwrap();
    std::fs::write(p("short.stats"), &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(p("junk.stats"), b"hello").unwrap();
    let mut errs = vec![(o, "other lights")];
    errs.push((
        run(&[
            "--sampler",
            "bayes",
            "--out",
            &p("d.exr"),
            "--load-stats",
            &p("short.stats"),
        ]),
        "truncated",
    ));
    errs.push((
        run(&[
            "--sampler",
            "bayes",
            "--out",
            &p("e.exr"),
            "--load-stats",
            &p("junk.stats"),
        ]),
        "not a lightlearn statistics file",
    ));
    for (o, want) in errs {
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(want), "error should say '{want}': {err}");
    }
}
