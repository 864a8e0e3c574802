//! Every committed scene and a fresh instance of every family (.glb and .gltf) passes the
//! Khronos glTF validator with no errors and no warnings. Needs Node.js and the validator that
//! ci/setup.sh installs into ci/node_modules; skipped with a message otherwise.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;
use lightlearn::scene::gltf_write::GltfBuilder;

fn validator() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let installed = root
        .join("ci/node_modules/gltf-validator/package.json")
        .exists();
    let node = Command::new("node")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !(installed && node) {
        eprintln!("skipping: Node.js or gltf-validator missing (run ci/setup.sh, which installs it with npm)");
        return None;
    }
    Some(root.join("ci/validate_gltf.mjs"))
}

/// (file, errors, warnings, messages) per file.
fn validate(script: &Path, files: &[PathBuf]) -> Vec<(String, u64, u64, String)> {
    let o = Command::new("node")
        .arg(script)
        .args(files)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "validator failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            (
                v["file"].as_str().unwrap().to_string(),
                v["errors"].as_u64().unwrap(),
                v["warnings"].as_u64().unwrap(),
                v["messages"].to_string(),
            )
        })
        .collect()
}

#[test]
fn generated_gltf_passes_the_khronos_validator() {
    let Some(script) = validator() else { return };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(root.join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    for (family, lights) in [
        ("rooms", "60"),
        ("hall", "33"),
        ("city", "500"),
        ("strings", "77"),
        ("cornell", "1"),
    ] {
        for ext in ["glb", "gltf"] {
            let out = dir.path().join(format!("{family}.{ext}"));
            let o = Command::new(common::exe())
                .args(["scene", family, "--lights", lights, "--seed", "9", "--out"])
                .arg(&out)
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            files.push(out);
        }
    }
    // The external-buffer form of the writer too.
    let mut g = GltfBuilder::new();
    let m = g.material("lamp", Vec3::ONE, Vec3::splat(3.0), true);
    g.cuboid("box", Vec3::ZERO, Vec3::ONE, m);
    let (text, bin) = g.to_gltf_external("box.bin");
    std::fs::write(dir.path().join("box.gltf"), text).unwrap();
    std::fs::write(dir.path().join("box.bin"), bin).unwrap();
    files.push(dir.path().join("box.gltf"));

    let reports = validate(&script, &files);
    assert_eq!(reports.len(), files.len());
    for (file, errors, warnings, messages) in &reports {
        assert_eq!((*errors, *warnings), (0, 0), "{file}: {messages}");
    }

    // The check can fail: a file whose accessor bounds lie is reported.
    let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
    doc["accessors"][0]["max"] = serde_json::json!([0.5, 0.5, 0.5]);
    let bad = dir.path().join("bad.gltf");
    std::fs::write(&bad, doc.to_string()).unwrap();
    let r = validate(&script, &[bad]);
    assert!(
        r[0].1 > 0,
        "the validator must report the wrong accessor max: {:?}",
        r[0]
    );
}
