//! Every committed scene is exactly what its command in scenes/make.sh writes (provenance),
//! loads with the expected light count, and stays small; the default scene has ≥ 200 lights.

mod common;

use std::path::Path;
use std::process::Command;

/// The `lightlearn scene …` argument lists in scenes/make.sh.
fn commands() -> Vec<Vec<String>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = std::fs::read_to_string(root.join("scenes/make.sh")).unwrap();
    script
        .lines()
        .filter_map(|l| l.trim().strip_prefix("lightlearn scene "))
        .map(|rest| rest.split_whitespace().map(String::from).collect())
        .collect()
}

#[test]
fn committed_scenes_match_their_commands() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let cmds = commands();
    assert!(
        cmds.len() >= 6,
        "scenes/make.sh lists the default scene and one per family"
    );
    let mut families = Vec::new();
    for args in cmds {
        let out = args.iter().position(|a| a == "--out").unwrap() + 1;
        let name = args[out].clone();
        let lights: usize = args[args.iter().position(|a| a == "--lights").unwrap() + 1]
            .parse()
            .unwrap();
        let mut replay = args.clone();
        replay[out] = dir.path().join(&name).display().to_string();
        let o = Command::new(common::exe())
            .arg("scene")
            .args(&replay)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let fresh = std::fs::read(dir.path().join(&name)).unwrap();
        let committed = std::fs::read(root.join("scenes").join(&name)).unwrap();
        assert!(
            fresh == committed,
            "scenes/{name} is stale: run scenes/make.sh"
        );
        assert!(
            committed.len() < 1 << 20,
            "scenes/{name} must stay under 1 MB"
        );
        let scene =
            lightlearn::scene::gltf_load::load(&root.join("scenes").join(&name), &mut |w| {
                panic!("{name}: {w}")
            })
            .unwrap();
        assert_eq!(scene.lights.len(), lights, "{name}");
        if name == "default.glb" {
            assert!(lights >= 200);
        }
        families.push(args[0].clone());
    }
    for f in ["rooms", "hall", "city", "strings", "cornell"] {
        assert!(families.iter().any(|x| x == f), "no committed {f} scene");
    }
    // The binary renders the built-in copy of the default scene.
    assert!(lightlearn::DEFAULT_SCENE == std::fs::read(root.join("scenes/default.glb")).unwrap());
}

#[test]
fn scene_command_refuses_bad_requests() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fail = |args: &[&str], want: &str| {
        let o = Command::new(common::exe())
            .arg("scene")
            .args(args)
            .current_dir(d)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(err.contains(want), "{args:?}: wanted '{want}' in: {err}");
        assert!(!err.contains("panicked"));
        assert_eq!(
            std::fs::read_dir(d).unwrap().count(),
            0,
            "{args:?} wrote something"
        );
    };
    fail(
        &["tower", "--lights", "5", "--out", "x.glb"],
        "invalid value 'tower'",
    );
    fail(
        &["hall", "--lights", "0", "--out", "x.glb"],
        "use 1..=1000000",
    );
    fail(
        &["hall", "--lights", "1000001", "--out", "x.glb"],
        "use 1..=1000000",
    );
    fail(
        &["cornell", "--lights", "65", "--out", "x.glb"],
        "use 1..=64",
    );
    fail(
        &["hall", "--lights", "5", "--out", "missing/x.glb"],
        "does not exist",
    );
    fail(
        &["hall", "--lights", "5", "--out", "x.obj"],
        "must end in .glb or .gltf",
    );
    fail(
        &["rooms", "--lights", "5", "--rooms", "3y4", "--out", "x.glb"],
        "not a grid",
    );
    fail(
        &["rooms", "--lights", "5", "--rooms", "0x4", "--out", "x.glb"],
        "at least 1x1",
    );
    // A product that wraps to 0 in usize passed the limit and ran out of memory (an audit,
    // 2026-12-07: abort, exit 134).
    fail(
        &[
            "rooms",
            "--lights",
            "5",
            "--rooms",
            "9223372036854775808x2",
            "--out",
            "x.glb",
        ],
        "at most",
    );
    // Another family's option was ignored without a word.
    fail(
        &[
            "cornell", "--lights", "5", "--rooms", "2x2", "--out", "x.glb",
        ],
        "--rooms applies to the rooms family only",
    );
    fail(
        &["hall", "--lights", "5", "--blocks", "3", "--out", "x.glb"],
        "--blocks applies to the city family only",
    );
    fail(
        &[
            "rooms",
            "--lights",
            "20",
            "--resolution",
            "3",
            "--out",
            "x.glb",
        ],
        "--resolution applies to the strings family only",
    );
    fail(
        &[
            "city", "--lights", "100000", "--blocks", "1", "--out", "x.glb",
        ],
        "window slots",
    );
    fail(
        &[
            "strings",
            "--lights",
            "5",
            "--resolution",
            "2",
            "--out",
            "x.glb",
        ],
        "3..=512",
    );
}

/// `--glossy=-0` is `--glossy 0`: it wrote "roughnessFactor": -0.0, other bytes for the
/// same scene; and errors name a family as it is typed (an audit, 2026-12-07).
#[test]
fn negative_zero_roughness_is_zero_and_families_are_named_as_typed() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |args: &[&str]| {
        Command::new(common::exe())
            .arg("scene")
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    for (g, out) in [("--glossy=-0", "a.glb"), ("--glossy=0", "b.glb")] {
        let o = scene(&["cornell", "--lights", "3", g, "--out", out]);
        assert!(o.status.success(), "{}", common::stderr(&o));
    }
    let read = |f: &str| std::fs::read(dir.path().join(f)).unwrap();
    assert_eq!(read("a.glb"), read("b.glb"));
    let o = scene(&["cornell", "--lights", "99", "--out", "c.glb"]);
    assert!(common::stderr(&o).contains("out of range for cornell:"));
}

#[test]
fn gltf_text_output_loads_like_glb() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["glb", "gltf"] {
        let out = dir.path().join(format!("s.{ext}"));
        let o = Command::new(common::exe())
            .args(["scene", "strings", "--lights", "40", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success());
        let s = lightlearn::scene::gltf_load::load(&out, &mut |w| panic!("{w}")).unwrap();
        assert_eq!(s.lights.len(), 40);
    }
}

/// The smallest halls (1–3 lights: 3 m) had a partition closed around the camera: a black
/// image at direct light, ~1e-6 at depth 8, an all-zero PNG (an audit, 2026-12-06).
#[test]
fn small_halls_keep_the_camera_in_the_open() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |args: &[&str]| {
        let o = Command::new(common::exe())
            .args(args)
            .current_dir(d)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    for n in ["1", "2", "3"] {
        run(&["scene", "hall", "--lights", n, "--out", "h.glb"]);
        let err = run(&[
            "render",
            "h.glb",
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "4",
            "--max-depth",
            "1",
            "--out",
            "h.exr",
            "--force",
        ]);
        assert!(!err.contains("the image is black"), "hall of {n}: {err}");
    }
}
