//! Input files that are not what they claim, through the command line (found by two
//! hostile-input audits, eighteenth session): each test is one way a run aborted, hung or
//! wrote a wrong image with exit 0 before. Outputs that landed on inputs:
//! tests/hostile_outputs.rs.

mod common;

use std::process::Command;
use std::time::Duration;

use common::hostile::*;
use common::{refused, stderr};
use serde_json::Value;

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

    // Within the 8192² a texture may have, but past the device's largest buffer together
    // (lavapipe: 128 MiB, 33.5 M texels): the error named no texture ("buffer 'texels'
    // needs … bytes; use a smaller scene or image": an audit, 2026-12-06). A flat grey
    // 8192×4200 PNG (34.4 M texels); skipped where the device's buffers are larger.
    let (w, h) = (8192u32, 4200u32);
    let mut big = Vec::new();
    let mut enc = png::Encoder::new(&mut big, w, h);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_compression(png::Compression::Fast);
    let mut wr = enc.write_header().unwrap();
    wr.write_image_data(&vec![128u8; (w * h) as usize]).unwrap();
    wr.finish().unwrap();
    std::fs::write(d.join("wide.png"), &big).unwrap();
    write_json(&d.join("big.gltf"), &textured(&doc, "wide.png"));
    let o = render("big.gltf", &["--out", "big.exr"], d);
    if (common::ctx().properties.limits.max_storage_buffer_range as u64) < 4 * (w * h) as u64 {
        refused(
            &o,
            &[
                "big.gltf",
                "34406400 texels",
                "largest is 8192×4200",
                "scale it down",
            ],
        );
    }

    let mut zero_buffer = doc.clone();
    zero_buffer["buffers"][0]["uri"] = "/dev/zero".into();
    write_json(&d.join("zb.gltf"), &zero_buffer);
    refused_within(
        &["render", "zb.gltf", "--out", "zb.exr", "-q"],
        d,
        &["buffer 0", "/dev/zero", "not a regular file"],
    );

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
        refused_within(
            &["render", "pipe.gltf", "--out", "p.exr", "-q"],
            d,
            &["pipe.gltf", "not a regular file"],
        );
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

/// A part's report edited to 2^64 − 1 samples made the weights' sum wrap: `merge` wrote an
/// image of +inf with exit 0. A report with a sample count or size no render writes is
/// refused, nothing written.
#[test]
fn a_merge_refuses_counts_and_sizes_no_render_writes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cornell(d);
    two_parts(d);
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
        // So small that a cluster seen dark once is never drawn again: 40 % of rooms16's
        // light was missing at 1024 spp, exit 0 (learning/mod.rs MIN_PRIOR_COUNT).
        ("--prior-scale", "1e-10"),
        ("--prior-nonzero", "1e-30"),
        ("--prior-zero", "1e-4"),
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
            "--prior-nonzero",
            "1e-3",
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
    // A copy translated to 3e38: even f64 cannot hold a triangle's size there, so its
    // triangles lost their area before the f32 frame saw them, without a word (an audit,
    // 2026-12-06). A copy scaled by 0 is hidden on purpose and goes without one.
    write_json(&d.join("far.gltf"), &with_copy(1.0, 3e38));
    let o = render("far.gltf", &["--out", "far.exr"], d);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("lose their area") && err.contains("left out"),
        "{err}"
    );
    write_json(&d.join("hidden.gltf"), &with_copy(0.0, 0.3));
    let o = render("hidden.gltf", &["--out", "hidden.exr"], d);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        !err.contains("lose their area") && !err.contains("too small"),
        "{err}"
    );
    // Every emitting node scaled to 0 (a frame of an animation keyed to it): no light is
    // left, and the refusal says why; it asked for an emissiveFactor the file has (an
    // audit, 2026-12-06).
    let mut v = doc.clone();
    for &m in meshes.iter().filter(|&&m| !dark(m)) {
        v["nodes"][m]["scale"] = serde_json::json!([0.0, 0.0, 0.0]);
    }
    for n in v["nodes"].as_array_mut().unwrap() {
        n.as_object_mut().unwrap().remove("extensions");
    }
    write_json(&d.join("unlit.gltf"), &v);
    refused(
        &render("unlit.gltf", &["--out", "unlit.exr"], d),
        &["unlit.gltf", "emitting triangles are scaled to nothing"],
    );
}

/// A camera at 3e38 made the CPU rays that pick the regions for cuts meet boxes at t = ∞,
/// and the traversal took an empty child slot for a node: a panic in `render` for `wang`,
/// `donikian` and `bayes` (an audit, 2026-12-06). It renders now (what it sees is the
/// file's business).
#[test]
fn a_camera_near_the_float_limit_renders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut doc = cornell(d);
    let cam = doc["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n.get("camera").is_some())
        .expect("a camera node");
    doc["nodes"][cam]["translation"] = serde_json::json!([3e38, 3e38, 3e38]);
    write_json(&d.join("camfar.gltf"), &doc);
    // 16×12: at 8×8 no pixel-centre ray met such a box.
    for sampler in ["wang", "bayes"] {
        let exr = format!("{sampler}.exr");
        let o = run(
            &[
                "render",
                "camfar.gltf",
                "--width",
                "16",
                "--height",
                "12",
                "--spp",
                "2",
                "-q",
                "--sampler",
                sampler,
                "--out",
                &exr,
            ],
            d,
        );
        assert!(o.status.success(), "{sampler}: {}", stderr(&o));
    }
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
    two_parts(d);
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
        refused_within(
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
            &["f.exr", "not a regular file"],
        );
        refused_within(
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
            &["f.stats", "not a regular file"],
        );
    } else {
        eprintln!("skipped the FIFO cases: mkfifo is not available");
    }
    assert!(!d.join("cmp").exists() && !d.join("m.exr").exists());
}

/// Mesh data that glTF forbids and that had been read silently (an audit, 2026-12-06): a
/// triangle list whose index count is not a multiple of 3 (its last indices dropped), a
/// TEXCOORD_0 shorter than POSITION (read as (0, 0) past its end); and a baseColorFactor
/// above 1, clamped without a word (now a warning).
#[test]
fn malformed_mesh_data_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let mut idx = doc.clone();
    let i = idx["meshes"][0]["primitives"][0]["indices"]
        .as_u64()
        .unwrap() as usize;
    let n = idx["accessors"][i]["count"].as_u64().unwrap();
    idx["accessors"][i]["count"] = (n - 1).into();
    write_json(&d.join("idx.gltf"), &idx);
    refused(
        &render("idx.gltf", &["--out", "i.exr"], d),
        &[
            "idx.gltf",
            "mesh",
            &format!("{} indices", n - 1),
            "multiple of 3",
        ],
    );
    lightlearn::film::write_png(&d.join("t.png"), 2, 2, &[[0.5; 3]; 4]).unwrap();
    let mut uv = textured(&doc, "t.png");
    let short = uv["accessors"].as_array().unwrap().len();
    uv["accessors"].as_array_mut().unwrap().push(
        serde_json::json!({"bufferView": 0, "componentType": 5126, "type": "VEC2", "count": 1}),
    );
    for m in uv["meshes"].as_array_mut().unwrap() {
        for p in m["primitives"].as_array_mut().unwrap() {
            p["attributes"]["TEXCOORD_0"] = short.into();
        }
    }
    write_json(&d.join("uv.gltf"), &uv);
    refused(
        &render("uv.gltf", &["--out", "u.exr"], d),
        &["uv.gltf", "1 TEXCOORD_0 values", "vertices"],
    );
    let mut bright = doc.clone();
    bright["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] =
        serde_json::json!([5.0, 5.0, 5.0, 1.0]);
    write_json(&d.join("bright.gltf"), &bright);
    let o = render("bright.gltf", &["--out", "b.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning:")
            && stderr(&o).contains("baseColorFactor")
            && stderr(&o).contains("clamped"),
        "{}",
        stderr(&o)
    );
    // A node with a matrix and a translation: glTF forbids both; the translation was
    // dropped without a word (an audit, 2026-12-06). Now a warning names the node.
    let mut both = doc.clone();
    both["nodes"][0]["matrix"] = serde_json::json!([
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0
    ]);
    both["nodes"][0]["translation"] = serde_json::json!([0.0, 0.0, 0.0]);
    write_json(&d.join("both.gltf"), &both);
    let o = render("both.gltf", &["--out", "n.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: 'both.gltf': node 0")
            && stderr(&o).contains("both a matrix and a translation"),
        "{}",
        stderr(&o)
    );
}

/// Buffer layouts glTF does not allow, a perspective node matrix and camera planes that
/// would hide geometry (an audit, 2026-12-06). With the build before: a byteStride of 13
/// rendered with exit 0, one of 4 gave "malformed in a way the parser could not report", an
/// accessor of 2^62 elements was blamed on its first index, the matrix was applied as if
/// affine, quantized positions were named in Rust's debug spelling, and both camera cases
/// rendered without a word.
#[test]
fn buffer_layouts_matrices_and_camera_planes_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let prim = &doc["meshes"][0]["primitives"][0];
    let pos = prim["attributes"]["POSITION"].as_u64().unwrap() as usize;
    let view = doc["accessors"][pos]["bufferView"].as_u64().unwrap() as usize;
    let edited = |file: &str, edit: &dyn Fn(&mut Value)| render_edited(&doc, d, file, edit);
    for stride in [13u64, 4] {
        let o = edited("stride.gltf", &|g| {
            g["bufferViews"][view]["byteStride"] = stride.into()
        });
        refused(
            &o,
            &[
                "stride.gltf",
                &format!("buffer view {view} has byteStride {stride}"),
                "multiple of 4",
            ],
        );
    }
    let o = edited("count.gltf", &|g| {
        g["accessors"][pos]["count"] = (1u64 << 62).into()
    });
    refused(
        &o,
        &[
            "count.gltf",
            &format!("accessor {pos}"),
            "runs past",
            "count",
        ],
    );
    let o = edited("quantized.gltf", &|g| {
        g["accessors"][pos]["componentType"] = 5121.into()
    });
    refused(&o, &["quantized.gltf", "VEC3 of UNSIGNED_BYTE", "FLOAT"]);
    let o = edited("projective.gltf", &|g| {
        let m = [
            1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0.5, 0., 0., 0., 2.,
        ];
        g["nodes"][0]["matrix"] = serde_json::json!(m);
        for k in ["translation", "rotation", "scale"] {
            g["nodes"][0].as_object_mut().unwrap().remove(k);
        }
    });
    refused(&o, &["projective.gltf", "node 0", "last row", "affine"]);
    for (znear, zfar, wants) in [
        (50.0, None, "znear 50 may hide geometry"),
        (1.0, Some(0.5), "zfar 0.5 ≤ znear 1"),
    ] {
        let o = edited("clip.gltf", &|g| {
            g["cameras"][0]["perspective"]["znear"] = znear.into();
            if let Some(f) = zfar {
                g["cameras"][0]["perspective"]["zfar"] = f.into();
            }
        });
        assert!(o.status.success(), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("warning:") && e.contains(wants), "{e}");
    }
    // The file as written says nothing.
    let o = render("c.gltf", &["--out", "c.exr"], d);
    assert!(
        o.status.success() && !stderr(&o).contains("warning"),
        "{}",
        stderr(&o)
    );
}

/// What lightlearn renders without is said (an audit, 2026-12-06; each rendered with exit 0
/// and silence with the build before: tried): an extension it does not read, a material that
/// is not opaque, vertex colours (2026-12-07), a skinned node, morph targets with weights, a
/// glossy layer smoother than the BRDF renders, a camera's aspectRatio other than the film's
/// (2026-12-07). Required extensions it does not read are refused.
#[test]
fn features_rendered_without_are_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let warned = |file: &str, edit: &dyn Fn(&mut Value), wants: &[&str]| {
        let o = render_edited(&doc, d, file, edit);
        assert!(o.status.success(), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("warning:") && wants.iter().all(|w| e.contains(w)),
            "{e}"
        );
    };
    warned(
        "glass.gltf",
        &|g| {
            g["extensionsUsed"] = serde_json::json!(["KHR_materials_transmission"]);
            g["materials"][0]["extensions"] =
                serde_json::json!({"KHR_materials_transmission": {"transmissionFactor": 1.0}});
        },
        &["KHR_materials_transmission", "does not read"],
    );
    // The same on an element without extensionsUsed listing it (an invalid file exporters
    // write): silent before, as a texture transform was (an audit, 2026-12-07).
    warned(
        "undeclared.gltf",
        &|g| {
            g["materials"][0]["extensions"] =
                serde_json::json!({"KHR_materials_transmission": {"transmissionFactor": 1.0}});
        },
        &[
            "KHR_materials_transmission without listing it in extensionsUsed",
            "does not read",
        ],
    );
    // An application's own data under `extras` is no extension (a review, 2026-12-07).
    let o = render_edited(&doc, d, "extras.gltf", &|g| {
        g["materials"][0]["extras"] = serde_json::json!({"extensions": {"APP_private": {"x": 1}}});
    });
    assert!(
        o.status.success() && !stderr(&o).contains("APP_private"),
        "{}",
        stderr(&o)
    );
    // BLEND is transparency, rendered opaque; MASK cutouts are read (tests/alpha_mask.rs).
    warned(
        "see-through.gltf",
        &|g| g["materials"][0]["alphaMode"] = "BLEND".into(),
        &["material 0", "alphaMode BLEND", "opaque"],
    );
    warned(
        "painted.gltf",
        &|g| {
            let pos = g["meshes"][0]["primitives"][0]["attributes"]["POSITION"].clone();
            g["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = pos;
        },
        &["mesh 0", "COLOR_0", "renders without them"],
    );
    warned(
        "skinned.gltf",
        &|g| {
            g["skins"] = serde_json::json!([{"joints": [0]}]);
            g["nodes"][0]["skin"] = 0.into();
        },
        &["node 0", "skinned", "bind pose"],
    );
    warned(
        "morph.gltf",
        &|g| {
            let pos = g["meshes"][0]["primitives"][0]["attributes"]["POSITION"].clone();
            g["meshes"][0]["primitives"][0]["targets"] = serde_json::json!([{"POSITION": pos}]);
            g["meshes"][0]["weights"] = serde_json::json!([0.5]);
        },
        &["node 0", "morph-target weights"],
    );
    warned(
        "mirror.gltf",
        &|g| {
            g["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = 1.0.into();
            g["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 0.0.into();
        },
        &[
            "material 0",
            "roughnessFactor below 0.0316",
            "no perfect mirrors",
        ],
    );
    // A camera of another shape than the film: the vertical field of view is kept, so the
    // picture loses or gains width (a 16:9 camera on the default 4:3 film lost a quarter
    // of it without a word: an audit, 2026-12-07).
    warned(
        "wide.gltf",
        &|g| g["cameras"][0]["perspective"]["aspectRatio"] = 1.5.into(),
        &[
            "aspectRatio is 1.5000 but the film is 8×8",
            "--width 12 --height 8",
        ],
    );
    // Roughness means nothing to an exactly Lambertian material (the box's: metallic 0,
    // specularFactor 0): no word.
    let o = render_edited(&doc, d, "matte.gltf", &|g| {
        g["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 0.0.into()
    });
    assert!(
        o.status.success() && !stderr(&o).contains("roughnessFactor"),
        "{}",
        stderr(&o)
    );
    // The film's own shape: no word.
    let o = render_edited(&doc, d, "square.gltf", &|g| {
        g["cameras"][0]["perspective"]["aspectRatio"] = 1.0.into()
    });
    assert!(
        o.status.success() && !stderr(&o).contains("aspectRatio"),
        "{}",
        stderr(&o)
    );
    let mut draco = doc.clone();
    draco["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    draco["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    write_json(&d.join("draco.gltf"), &draco);
    refused(
        &render("draco.gltf", &["--out", "d.exr"], d),
        &[
            "draco.gltf",
            "requires KHR_draco_mesh_compression",
            "does not read",
        ],
    );
}

/// `doc` changed by `edit`, written as `file` in `d` and rendered (the tiny film) to o.exr.
fn render_edited(
    doc: &Value,
    d: &std::path::Path,
    file: &str,
    edit: &dyn Fn(&mut Value),
) -> std::process::Output {
    let mut g = doc.clone();
    edit(&mut g);
    write_json(&d.join(file), &g);
    render(file, &["--out", "o.exr"], d)
}
