//! Input files that are not what they claim and outputs that would land on inputs, through
//! the command line (found by a hostile-input audit, eighteenth session): each test is one way
//! a run aborted, hung, replaced a user's file or wrote a wrong image with exit 0 before.

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::{files, refused, stderr};
use serde_json::Value;

const TINY: &[&str] = &["--width", "8", "--height", "8", "--spp", "2", "-q"];

fn run(args: &[&str], dir: &Path) -> Output {
    common::run_in(args, dir, &[])
}

/// `lightlearn render SCENE TINY… extra…` in `dir`.
fn render(scene: &str, extra: &[&str], dir: &Path) -> Output {
    let mut args = vec!["render", scene];
    args.extend_from_slice(TINY);
    args.extend_from_slice(extra);
    run(&args, dir)
}

/// `lightlearn compare SCENE ARGS… --width 8 --height 8 --samplers uniform` in `dir` with
/// its reference cache in `cache`.
fn compare(dir: &Path, cache: &str, args: &[&str]) -> Output {
    let mut a = vec!["compare"];
    a.extend_from_slice(args);
    a.extend_from_slice(&["--width", "8", "--height", "8", "--samplers", "uniform"]);
    common::run_in(&a, dir, &[("LIGHTLEARN_CACHE", cache)])
}

/// A small Cornell box as a .gltf with embedded data, and its JSON.
fn cornell(dir: &Path) -> Value {
    let o = run(
        &["scene", "cornell", "--lights", "2", "--out", "c.gltf"],
        dir,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_slice(&std::fs::read(dir.join("c.gltf")).unwrap()).unwrap()
}

fn write_json(path: &Path, v: &Value) {
    std::fs::write(path, serde_json::to_vec(v).unwrap()).unwrap();
}

/// The first material textured with the image `uri`.
fn textured(doc: &Value, uri: &str) -> Value {
    let mut d = doc.clone();
    d["images"] = serde_json::json!([{ "uri": uri }]);
    d["textures"] = serde_json::json!([{ "source": 0 }]);
    d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = serde_json::json!({"index": 0});
    d
}

/// Runs `args` in `dir`, killing it after `limit`: Err(stderr) if it had to be killed.
fn run_within(args: &[&str], dir: &Path, limit: Duration) -> Result<Output, String> {
    let mut child = Command::new(common::exe())
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

/// A 5-KB PNG whose header claims 100000×100000 texels asked for 30 GB and aborted the
/// process (exit 134); a buffer or image URI naming /dev/zero was read until memory ran out;
/// a FIFO as the scene blocked forever. Now: the texture is refused with a warning naming
/// its size (the material keeps its colour), the others with one error line, at once.
#[test]
fn oversized_endless_or_special_files_are_refused_not_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);

    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        c.extend_from_slice(kind);
        c.extend_from_slice(data);
        let crc = crc32(&c[4..]);
        c.extend_from_slice(&crc.to_be_bytes());
        c
    };
    let mut ihdr = 100_000u32.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&100_000u32.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    ));
    png.extend(chunk(b"IEND", &[]));
    std::fs::write(d.join("huge.png"), &png).unwrap();
    write_json(&d.join("tex.gltf"), &textured(&doc, "huge.png"));
    let o = render("tex.gltf", &["--out", "tex.exr"], d);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("100000×100000") && err.contains("using baseColorFactor alone"),
        "{err}"
    );

    let mut zero_buffer = doc.clone();
    zero_buffer["buffers"][0]["uri"] = "/dev/zero".into();
    write_json(&d.join("zb.gltf"), &zero_buffer);
    let o = run_within(
        &["render", "zb.gltf", "--out", "zb.exr", "-q"],
        d,
        Duration::from_secs(60),
    )
    .unwrap();
    refused(&o, &["buffer 0", "/dev/zero", "not a regular file"]);

    write_json(&d.join("zi.gltf"), &textured(&doc, "/dev/zero"));
    let o = run_within(
        &[
            "render", "zi.gltf", "--out", "zi.exr", "-q", "--width", "8", "--height", "8", "--spp",
            "1",
        ],
        d,
        Duration::from_secs(60),
    )
    .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("not a regular file"), "{}", stderr(&o));

    let fifo = d.join("pipe.gltf");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let o = run_within(
            &["render", "pipe.gltf", "--out", "p.exr", "-q"],
            d,
            Duration::from_secs(60),
        )
        .unwrap();
        refused(&o, &["pipe.gltf", "not a regular file"]);
    } else {
        eprintln!("skipped the FIFO case: mkfifo is not available");
    }
    // POSITION must be VEC3 of FLOAT: a VEC2 accessor was read as if it were.
    let mut vec2 = doc.clone();
    let a = vec2["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize;
    vec2["accessors"][a]["type"] = "VEC2".into();
    write_json(&d.join("v2.gltf"), &vec2);
    refused(
        &render("v2.gltf", &["--out", "v2.exr"], d),
        &["POSITION accessor", "VEC3 of FLOAT"],
    );
    for f in ["zb", "zi", "p", "v2"] {
        assert!(
            !d.join(format!("{f}.exr")).exists() || f == "zi",
            "{f}.exr written"
        );
    }
}

/// CRC-32 (PNG's, ISO 3309) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
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

/// A part's report edited to 2^64 − 1 samples made the weights' sum wrap: `merge` wrote an
/// image of +inf with exit 0. A report with a sample count or size no render writes is
/// refused, nothing written.
#[test]
fn a_merge_refuses_counts_and_sizes_no_render_writes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    for (seed, name) in [("1", "p1"), ("2", "p2")] {
        let exr = format!("{name}.exr");
        let o = render(
            "c.gltf",
            &["--seed", seed, "--out", &exr, "--max-depth", "1"],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let path = d.join("p1.json");
    let original: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    for (field, value, wants) in [
        (
            "spp",
            serde_json::json!(u64::MAX),
            vec!["p1.exr", "past the"],
        ),
        (
            "first_sample_index",
            serde_json::json!(1u64 << 40),
            vec!["p1.exr", "past the"],
        ),
    ] {
        let mut r = original.clone();
        r[field] = value;
        write_json(&path, &r);
        refused(
            &run(&["merge", "p1.exr", "p2.exr", "--out", "m.exr"], d),
            &wants,
        );
    }
    let mut r = original.clone();
    r["width"] = serde_json::json!(100_000u64);
    write_json(&path, &r);
    write_json(&d.join("p2.json"), &{
        let mut r2: Value =
            serde_json::from_slice(&std::fs::read(d.join("p2.json")).unwrap()).unwrap();
        r2["width"] = serde_json::json!(100_000u64);
        r2
    });
    refused(
        &run(&["merge", "p1.exr", "p2.exr", "--out", "m.exr"], d),
        &["100000×8", "no render writes"],
    );
    assert!(!d.join("m.exr").exists() && !d.join("m.json").exists());
}

/// `--prior-cv 1e20` overflowed the learned weights: every learned sample was dropped as
/// NaN and the image was black, with exit 0 and a warning that blamed the scene. Priors
/// past their range are refused by name; at the bounds nothing is dropped.
#[test]
fn priors_out_of_range_are_refused_and_in_range_render_finite() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    for (flag, value) in [
        ("--prior-cv", "1e20"),
        ("--prior-n", "3e38"),
        ("--prior-alpha", "1e7"),
        ("--prior-zero", "1e7"),
        ("--pool-priors", "1e9"),
        ("--prior-scale", "1e30"),
    ] {
        refused(
            &render("c.gltf", &[flag, value, "--out", "p.exr"], d),
            &[flag, "out of range"],
        );
    }
    let o = render(
        "c.gltf",
        &[
            "--prior-cv",
            "1000",
            "--prior-alpha",
            "0.5000001",
            "--prior-n",
            "1e6",
            "--prior-scale",
            "1e6",
            "--out",
            "p.exr",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report: Value = serde_json::from_slice(&std::fs::read(d.join("p.json")).unwrap()).unwrap();
    assert_eq!(report["invalid_samples_dropped"], 0, "{report}");
}

/// A node scaled by 1e30 left 2 of 36 triangles (the rest rounded to zero area in the f32
/// frame) and a black image, with no word; a scene left with none said it "has no
/// triangles". Now the count is in a warning, or the refusal says why.
#[test]
fn triangles_lost_to_an_object_out_of_scale_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let meshes: Vec<usize> = doc["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .filter(|(_, n)| n.get("mesh").is_some())
        .map(|(i, _)| i)
        .collect();
    // A mesh that emits nothing (scaling a light's away would leave no lights instead).
    let dark = |node: usize| {
        let mesh = doc["nodes"][node]["mesh"].as_u64().unwrap() as usize;
        let m = doc["meshes"][mesh]["primitives"][0]["material"]
            .as_u64()
            .unwrap() as usize;
        let e = &doc["materials"][m]["emissiveFactor"];
        e.is_null()
            || e.as_array()
                .unwrap()
                .iter()
                .all(|c| c.as_f64() == Some(0.0))
    };
    let walls = *meshes
        .iter()
        .find(|&&m| dark(m))
        .expect("a mesh without emission");
    // One more node: the walls' mesh with `scale` and `translation`, added to the scene.
    let with_copy = |scale: f64, translation: f64| {
        let mut v = doc.clone();
        let n = v["nodes"].as_array().unwrap().len();
        v["nodes"].as_array_mut().unwrap().push(serde_json::json!({
            "mesh": doc["nodes"][walls]["mesh"],
            "scale": [scale, scale, scale],
            "translation": [translation, translation, translation],
        }));
        v["scenes"][0]["nodes"]
            .as_array_mut()
            .unwrap()
            .push(n.into());
        v
    };
    // A copy a billionth of the box's size: its triangles round to nothing beside the box.
    write_json(&d.join("one.gltf"), &with_copy(1e-9, 0.3));
    let o = render("one.gltf", &["--out", "one.exr"], d);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("too small to keep in 32-bit floats") && err.contains("left out"),
        "{err}"
    );
    // A copy 1e12 away: beside that extent the box with its lights rounds to nothing, and
    // the error says why (it said "has no lights").
    write_json(&d.join("all.gltf"), &with_copy(1.0, 1e12));
    refused(
        &render("all.gltf", &["--out", "all.exr"], d),
        &["all.gltf", "too small to keep in 32-bit floats"],
    );
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

fn base64_decode(s: &str) -> Vec<u8> {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.decode(s).unwrap()
}

/// The value of the EXR header attribute `name` (its offset and length in `bytes`).
fn exr_attribute(bytes: &[u8], name: &str) -> (usize, usize) {
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
fn exr_claiming(path: &Path, side: u32) -> Vec<u8> {
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

/// A 1-KB EXR whose header claimed 100000×100000 pixels made `merge` and `compare` ask for
/// 120 GB and abort; FIFOs as statistics files or references blocked the run forever. Now
/// each is refused in one line and `compare` leaves no folder.
#[test]
fn exr_headers_past_any_film_and_fifo_inputs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    let cache = d.join("cache");
    let cache = cache.to_str().unwrap();
    for (seed, name) in [("1", "p1"), ("2", "p2")] {
        let exr = format!("{name}.exr");
        let o = render(
            "c.gltf",
            &["--seed", seed, "--out", &exr, "--max-depth", "1"],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    std::fs::write(d.join("big.exr"), exr_claiming(&d.join("p1.exr"), 100_000)).unwrap();
    std::fs::copy(d.join("p1.json"), d.join("big.json")).unwrap();
    refused(
        &run(&["merge", "big.exr", "p2.exr", "--out", "m.exr"], d),
        &["big.exr", "100000×100000"],
    );
    refused(
        &compare(
            d,
            cache,
            &[
                "c.gltf",
                "--reference",
                "big.exr",
                "--spp",
                "1",
                "--out",
                "cmp",
            ],
        ),
        &["big.exr", "100000×100000"],
    );
    let fifo = d.join("f.exr");
    if Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        Command::new("mkfifo")
            .arg(d.join("f.stats"))
            .status()
            .unwrap();
        let o = run_within(
            &[
                "compare",
                "c.gltf",
                "--reference",
                "f.exr",
                "--spp",
                "1",
                "--out",
                "cmp",
            ],
            d,
            Duration::from_secs(60),
        )
        .unwrap();
        refused(&o, &["f.exr", "not a regular file"]);
        let o = run_within(
            &[
                "render",
                "c.gltf",
                "--load-stats",
                "f.stats",
                "--out",
                "l.exr",
                "-q",
            ],
            d,
            Duration::from_secs(60),
        )
        .unwrap();
        refused(&o, &["f.stats", "not a regular file"]);
    } else {
        eprintln!("skipped the FIFO cases: mkfifo is not available");
    }
    assert!(!d.join("cmp").exists() && !d.join("m.exr").exists());
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
