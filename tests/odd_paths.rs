//! File names and paths users really have (an audit, 2026-12-07): a trailing slash, a `~`
//! the shell did not expand, names that are not UTF-8, a line break, HTML in a scene's name,
//! and a job folder that is not a farm job's. Each case fails with the build before its fix.

mod common;

use std::ffi::OsStr;
use std::os::unix::ffi::OsStrExt;
use std::path::Path;
use std::process::Output;

fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/cornell.glb")
        .display()
        .to_string()
}

const TINY: [&str; 8] = [
    "--width",
    "12",
    "--height",
    "9",
    "--spp",
    "2",
    "--max-depth",
    "1",
];

fn run(args: &[&OsStr], dir: &Path) -> Output {
    std::process::Command::new(common::exe())
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run lightlearn")
}

fn os<'a>(v: &[&'a str]) -> Vec<&'a OsStr> {
    v.iter().map(|s| OsStr::new(*s)).collect()
}

/// `--out x.exr/` passed the checks (the path's parts name `x.exr`) and failed at the end:
/// `reference` lost its whole render, `render` wrote into a rescue folder.
#[test]
fn a_trailing_slash_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    for args in [
        vec!["render", s.as_str(), "--out", "x.exr/"],
        vec!["reference", s.as_str(), "--out", "r.exr/"],
        // The same through `/.` (a review, 2026-12-07).
        vec!["render", s.as_str(), "--out", "x.exr/."],
        vec![
            "render",
            s.as_str(),
            "--sampler",
            "bayes",
            "--save-stats",
            "st.stats/",
        ],
    ] {
        let mut a = args.clone();
        a.extend_from_slice(&TINY);
        let o = run(&os(&a), dir.path());
        common::refused(&o, &["ends in a slash"]);
    }
    assert!(
        common::files(dir.path()).is_empty(),
        "{:?}",
        common::files(dir.path())
    );
}

/// `--out=~/x` (the shell expands `~` only at a word's start) made a folder named `~` in
/// the working folder, or was refused as "folder '~' does not exist; create it first".
#[test]
fn a_tilde_the_shell_left_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    for args in [
        vec!["render", s.as_str(), "--out=~/r.exr", "--mkdir"],
        vec!["animate", s.as_str(), "--frames", "0..0", "--out=~/frames"],
        vec!["compare", s.as_str(), "--samplers", "power", "--out=~/cmp"],
        vec!["farm", s.as_str(), "--out=~/job"],
        vec!["render", s.as_str(), "--out=~bob/r.exr"],
    ] {
        let mut a = args.clone();
        a.extend_from_slice(&TINY);
        let o = run(&os(&a), dir.path());
        common::refused(&o, &["starts with '~', which lightlearn does not expand"]);
        assert!(!dir.path().join("~").exists(), "{args:?}");
    }
    // A name of its own that starts with `~` is a name.
    let mut a = vec!["render", s.as_str(), "--out", "~draft.exr"];
    a.extend_from_slice(&TINY);
    let o = run(&os(&a), dir.path());
    assert!(o.status.success(), "{}", common::stderr(&o));
}

/// Two outputs whose names differ only in bytes that are not UTF-8 shared one temporary:
/// the render failed at its end and its samples were lost.
#[test]
fn names_that_are_not_utf8_keep_their_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    let mut a: Vec<&OsStr> = os(&["render", s.as_str(), "--sampler", "bayes", "--out"]);
    a.push(OsStr::from_bytes(b"a\xff.exr"));
    a.push(OsStr::new("--save-stats"));
    a.push(OsStr::from_bytes(b"a\xfe.exr"));
    a.extend(os(&TINY));
    let o = run(&a, dir.path());
    assert!(o.status.success(), "{}", common::stderr(&o));
    for name in [&b"a\xff.exr"[..], b"a\xff.png", b"a\xff.json", b"a\xfe.exr"] {
        assert!(
            dir.path().join(OsStr::from_bytes(name)).is_file(),
            "{name:?}"
        );
    }
}

/// `farm`: a job folder that is not text is refused (openjd failed on it after farm said
/// "wrote"); a line break in its name left the template's comment and the template was no
/// YAML; the hint to paste was not quoted for the shell (`--out=-job` read as an option); a
/// relative `--lightlearn` was the workers' session folder's; a user's template.yaml and a
/// user's file where the bundle goes were replaced.
#[test]
fn farm_job_folders_and_paths() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    let farm = |out: &OsStr, extra: &[&str]| {
        let mut flag = std::ffi::OsString::from("--out=");
        flag.push(out);
        let mut a = os(&["farm", s.as_str(), "--still", "--chunks", "2"]);
        a.push(&flag);
        a.extend(os(extra));
        run(&a, dir.path())
    };
    common::refused(
        &farm(OsStr::from_bytes(b"job\xff"), &[]),
        &["is not valid UTF-8"],
    );
    let o = farm(OsStr::new("j\nnl"), &[]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let text = std::fs::read_to_string(dir.path().join("j\nnl/template.yaml")).unwrap();
    let second = text.lines().nth(1).unwrap();
    assert!(
        second.starts_with("# Run it here: openjd run j_nl/") && text.lines().nth(2) == Some("{"),
        "{text:.300}"
    );
    let o = farm(OsStr::new("-job it's"), &["--lightlearn", "bin/lightlearn"]);
    let err = common::stderr(&o);
    assert!(
        o.status.success() && err.contains("`openjd run './-job it'\\''s/template.yaml'`"),
        "{err}"
    );
    let text = std::fs::read_to_string(dir.path().join("-job it's/template.yaml")).unwrap();
    let want = dir.path().join("bin/lightlearn").display().to_string();
    assert!(text.contains(&format!("\"default\": \"{want}\"")), "{text}");
    // A user's template, and a user's file where the bundle's copy of the scene goes.
    let user = dir.path().join("user");
    std::fs::create_dir_all(user.join("scene")).unwrap();
    std::fs::write(user.join("template.yaml"), "mine").unwrap();
    common::refused(
        &farm(user.as_os_str(), &[]),
        &["was not written by `lightlearn farm`"],
    );
    assert_eq!(std::fs::read(user.join("template.yaml")).unwrap(), b"mine");
    std::fs::remove_file(user.join("template.yaml")).unwrap();
    std::fs::write(user.join("scene/cornell.glb"), "mine").unwrap();
    common::refused(&farm(user.as_os_str(), &[]), &["exists with other content"]);
    assert_eq!(
        std::fs::read(user.join("scene/cornell.glb")).unwrap(),
        b"mine"
    );
    // An earlier job's folder is written again.
    let o = farm(OsStr::new("j\nnl"), &[]);
    assert!(o.status.success(), "{}", common::stderr(&o));
}

/// `animate --reference-spp`'s page put a scene's name into its heading as markup.
#[test]
fn a_scene_name_is_text_on_the_animation_page() {
    let dir = tempfile::tempdir().unwrap();
    let named = dir.path().join("<b>x.glb");
    std::fs::copy(scene(), &named).unwrap();
    let mut a = vec![
        "animate",
        "<b>x.glb",
        "--frames",
        "0..0",
        "--reference-spp",
        "4",
        "--no-video",
        "--out",
        "an",
    ];
    a.extend_from_slice(&TINY);
    let o = run(&os(&a), dir.path());
    assert!(o.status.success(), "{}", common::stderr(&o));
    let page = std::fs::read_to_string(dir.path().join("an/report.html")).unwrap();
    assert!(
        page.contains("&lt;b&gt;x.glb") && !page.contains("<b>x"),
        "{page:.400}"
    );
}
