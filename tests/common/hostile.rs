//! Helpers of the hostile-input tests through the binary (tests/hostile_files.rs,
//! tests/hostile_outputs.rs): small scenes, runs with a time limit, crafted files.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

use super::stderr;

pub const TINY: &[&str] = &["--width", "8", "--height", "8", "--spp", "2", "-q"];

pub fn run(args: &[&str], dir: &Path) -> Output {
    super::run_in(args, dir, &[])
}

/// `lightlearn render SCENE TINY… extra…` in `dir`.
pub fn render(scene: &str, extra: &[&str], dir: &Path) -> Output {
    let mut args = vec!["render", scene];
    args.extend_from_slice(TINY);
    args.extend_from_slice(extra);
    run(&args, dir)
}

/// `lightlearn compare SCENE ARGS… --width 8 --height 8 --samplers uniform` in `dir` with
/// its reference cache in `cache`.
pub fn compare(dir: &Path, cache: &str, args: &[&str]) -> Output {
    let mut a = vec!["compare"];
    a.extend_from_slice(args);
    a.extend_from_slice(&["--width", "8", "--height", "8", "--samplers", "uniform"]);
    super::run_in(&a, dir, &[("LIGHTLEARN_CACHE", cache)])
}

/// p1.exr and p2.exr (+ .json) in `dir`: c.gltf's direct light with seeds 1 and 2, parts
/// of one image for `merge`.
pub fn two_parts(dir: &Path) {
    for (seed, name) in [("1", "p1"), ("2", "p2")] {
        let exr = format!("{name}.exr");
        let o = render(
            "c.gltf",
            &["--seed", seed, "--out", &exr, "--max-depth", "1"],
            dir,
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

/// A small Cornell box as a .gltf with embedded data, and its JSON.
pub fn cornell(dir: &Path) -> Value {
    let o = run(
        &["scene", "cornell", "--lights", "2", "--out", "c.gltf"],
        dir,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_slice(&std::fs::read(dir.join("c.gltf")).unwrap()).unwrap()
}

pub fn write_json(path: &Path, v: &Value) {
    std::fs::write(path, serde_json::to_vec(v).unwrap()).unwrap();
}

/// The first material textured with the image `uri`.
pub fn textured(doc: &Value, uri: &str) -> Value {
    let mut d = doc.clone();
    d["images"] = serde_json::json!([{ "uri": uri }]);
    d["textures"] = serde_json::json!([{ "source": 0 }]);
    d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = serde_json::json!({"index": 0});
    d
}

/// Runs `args` in `dir` (60 s at most: a hang fails the test) and expects a refusal whose
/// one error line holds every piece of `wants`.
pub fn refused_within(args: &[&str], dir: &Path, wants: &[&str]) {
    let o = run_within(args, dir, Duration::from_secs(60)).unwrap();
    super::refused(&o, wants);
}

/// Runs `args` in `dir`, killing it after `limit`: Err(stderr) if it had to be killed.
pub fn run_within(args: &[&str], dir: &Path, limit: Duration) -> Result<Output, String> {
    let mut child = Command::new(super::exe())
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while t.elapsed() < limit {
        if child.try_wait().unwrap().is_some() {
            return Ok(child.wait_with_output().unwrap());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let o = child.wait_with_output().unwrap();
    Err(format!("still running after {limit:?}: {}", stderr(&o)))
}

/// CRC-32 (PNG's, ISO 3309) of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

pub fn base64_decode(s: &str) -> Vec<u8> {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.decode(s).unwrap()
}

/// The value of the EXR header attribute `name` (its offset and length in `bytes`).
pub fn exr_attribute(bytes: &[u8], name: &str) -> (usize, usize) {
    let mut p = 8;
    while bytes[p] != 0 {
        let end = |from: usize| from + bytes[from..].iter().position(|&b| b == 0).unwrap();
        let name_end = end(p);
        let type_end = end(name_end + 1);
        let size =
            i32::from_le_bytes(bytes[type_end + 1..type_end + 5].try_into().unwrap()) as usize;
        if &bytes[p..name_end] == name.as_bytes() {
            return (type_end + 5, size);
        }
        p = type_end + 5 + size;
    }
    panic!("no attribute {name}");
}

/// A render's EXR whose header claims `side`×`side` pixels (windows and chunk count agree,
/// so a reader takes it as valid until it allocates the pixels).
pub fn exr_claiming(path: &Path, side: u32) -> Vec<u8> {
    let mut b = std::fs::read(path).unwrap();
    let mut window = Vec::new();
    for v in [0i32, 0, side as i32 - 1, side as i32 - 1] {
        window.extend_from_slice(&v.to_le_bytes());
    }
    for name in ["dataWindow", "displayWindow"] {
        let (o, n) = exr_attribute(&b, name);
        b[o..o + n].copy_from_slice(&window);
    }
    let (t, _) = exr_attribute(&b, "tiles");
    let tile = |i: usize| u32::from_le_bytes(b[t + 4 * i..t + 4 * i + 4].try_into().unwrap());
    let chunks = side.div_ceil(tile(0)) * side.div_ceil(tile(1));
    let (c, _) = exr_attribute(&b, "chunkCount");
    b[c..c + 4].copy_from_slice(&chunks.to_le_bytes());
    b
}
