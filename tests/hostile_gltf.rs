//! glTF files from outside the repository and edits of them, through the command line (a
//! helper's audit of the twenty-sixth session, with files from the Khronos glTF-Validator and
//! tinygltf test sets): each test is one way a run panicked, rendered a black or unedited
//! image with exit 0, or named the wrong problem before.

mod common;

use base64::Engine;
use common::hostile::*;
use common::{refused, stderr};
use glam::Vec3;
use lightlearn::scene::gltf_write::GltfBuilder;
use serde_json::{json, Value};

/// `doc` with one more buffer holding `bytes` (embedded) and one view over all of it; the
/// view's index.
fn add_view(doc: &mut Value, bytes: &[u8]) -> usize {
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    );
    let buffers = doc["buffers"].as_array_mut().unwrap();
    buffers.push(json!({"uri": uri, "byteLength": bytes.len()}));
    let b = buffers.len() - 1;
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": b, "byteLength": bytes.len()}));
    views.len() - 1
}

/// An image the crate could not give a source for made it panic (exit 101 and a backtrace)
/// while the command listed the scene's input files, before any check: an image of `{}`,
/// even one no material used, one in a bufferView without a mimeType, or in a view or
/// buffer out of range (the validator's image/empty_object, missing_mime_type_buffer_view,
/// unresolved_buffer_view, and tinygltf's invalid-buffer-index). Now one line naming it.
#[test]
fn images_without_a_source_are_named_not_panicked_on() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    lightlearn::film::write_png(&d.join("t.png"), 2, 2, &[[0.5; 3]; 4]).unwrap();
    let textured = textured(&doc, "t.png");
    let mut empty = textured.clone();
    empty["images"].as_array_mut().unwrap().push(json!({}));
    write_json(&d.join("empty.gltf"), &empty);
    refused(
        &render("empty.gltf", &["--out", "e.exr"], d),
        &["empty.gltf", "image 1", "neither a uri nor a bufferView"],
    );
    let mut no_mime = textured.clone();
    let png = std::fs::read(d.join("t.png")).unwrap();
    let v = add_view(&mut no_mime, &png);
    no_mime["images"] = json!([{ "bufferView": v }]);
    write_json(&d.join("mime.gltf"), &no_mime);
    refused(
        &render("mime.gltf", &["--out", "m.exr"], d),
        &["mime.gltf", "image 0", "without a mimeType", "image/png"],
    );
    // With the mimeType it is a texture like any other.
    no_mime["images"][0]["mimeType"] = json!("image/png");
    write_json(&d.join("mime_ok.gltf"), &no_mime);
    let o = render("mime_ok.gltf", &["--out", "ok.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut view_out = textured.clone();
    view_out["images"] = json!([{ "bufferView": 99, "mimeType": "image/png" }]);
    write_json(&d.join("view.gltf"), &view_out);
    refused(
        &render("view.gltf", &["--out", "v.exr"], d),
        &["view.gltf", "image 0", "bufferView 99"],
    );
    let mut buffer_out = textured;
    let views = buffer_out["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 7, "byteLength": 4}));
    let v = views.len() - 1;
    buffer_out["images"] = json!([{ "bufferView": v, "mimeType": "image/png" }]);
    write_json(&d.join("buffer.gltf"), &buffer_out);
    refused(
        &render("buffer.gltf", &["--out", "b.exr"], d),
        &["buffer.gltf", "image 0", "buffer 7"],
    );
}

/// A required extension that lightlearn reads (KHR_materials_specular) was refused as "not
/// a valid glTF 2.0 file … Unsupported extension" (the crate's own list lacks it); one it
/// does not read now says so instead of calling the file invalid; a buffer at an https
/// address was looked for as a file beside the scene ("No such file").
#[test]
fn required_extensions_and_remote_buffers_are_judged_by_what_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let mut specular = doc.clone();
    specular["extensionsRequired"] = json!(["KHR_materials_specular"]);
    write_json(&d.join("spec.gltf"), &specular);
    let o = render("spec.gltf", &["--out", "s.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut meshopt = doc.clone();
    meshopt["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
    meshopt["extensionsRequired"] = json!(["EXT_meshopt_compression"]);
    write_json(&d.join("meshopt.gltf"), &meshopt);
    refused(
        &render("meshopt.gltf", &["--out", "m.exr"], d),
        &[
            "meshopt.gltf",
            "requires EXT_meshopt_compression",
            "does not read",
        ],
    );
    // Another major version, or a minVersion above 2.0, rendered as 2.0 (an audit,
    // 2026-12-07); a 2.x file renders.
    for (edit, want) in [
        (json!({"version": "3.0"}), "glTF version '3.0'"),
        (
            json!({"version": "4294967298.0"}),
            "glTF version '4294967298.0'",
        ),
        (
            json!({"version": "2.0", "minVersion": "2.1"}),
            "at least version '2.1'",
        ),
    ] {
        let mut v = doc.clone();
        v["asset"] = edit;
        write_json(&d.join("v.gltf"), &v);
        refused(&render("v.gltf", &["--out", "v.exr"], d), &["v.gltf", want]);
    }
    // 2.x renders, and so do the loose spellings three.js reads ("2.0.1" and " 2" were
    // refused by the first form of this check: a review).
    for version in ["2.1", "2.0.1", " 2"] {
        let mut v2 = doc.clone();
        v2["asset"] = json!({ "version": version });
        write_json(&d.join("v2.gltf"), &v2);
        let o = render("v2.gltf", &["--out", "v2.exr", "--force"], d);
        assert!(o.status.success(), "'{version}': {}", stderr(&o));
    }
    // base64 without its `=` padding, read by the validator and browsers, was refused as
    // "Invalid padding": now the same image as the padded file (the buffer one byte
    // longer, so that its base64 needs padding).
    let b64 = base64::engine::general_purpose::STANDARD;
    let uri = doc["buffers"][0]["uri"].as_str().unwrap();
    let (head, data) = uri.split_once(";base64,").unwrap();
    let mut bytes = b64.decode(data).unwrap();
    bytes.push(0);
    let padded_uri = format!("{head};base64,{}", b64.encode(&bytes));
    assert!(
        padded_uri.ends_with('='),
        "{}",
        &padded_uri[padded_uri.len() - 4..]
    );
    for (file, uri) in [
        ("padded.gltf", padded_uri.as_str()),
        ("unpadded.gltf", padded_uri.trim_end_matches('=')),
    ] {
        let mut v = doc.clone();
        v["buffers"][0]["uri"] = json!(uri);
        v["buffers"][0]["byteLength"] = json!(bytes.len());
        write_json(&d.join(file), &v);
        let o = render(file, &["--out", &file.replace("gltf", "exr")], d);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
    }
    assert_eq!(
        std::fs::read(d.join("unpadded.exr")).unwrap(),
        std::fs::read(d.join("padded.exr")).unwrap()
    );
    let mut remote = doc;
    remote["buffers"][0]["uri"] = json!("https://example.com/scene.bin");
    write_json(&d.join("remote.gltf"), &remote);
    refused(
        &render("remote.gltf", &["--out", "r.exr"], d),
        &[
            "remote.gltf",
            "buffer 0",
            "https://example.com/scene.bin",
            "download it",
        ],
    );
}

/// A sparse POSITION index past the accessor's count was dropped without a word: the mesh
/// rendered unedited with exit 0. A valid sparse edit still moves the vertex.
#[test]
fn sparse_indices_out_of_range_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let sparse = |index: u32| {
        let mut s = doc.clone();
        let mut bytes = index.to_le_bytes().to_vec();
        for v in [0.5f32, 1.0, 0.5] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let vi = add_view(&mut s, &bytes[..4]);
        let vv = add_view(&mut s, &bytes[4..]);
        s["accessors"][0]["sparse"] = json!({
            "count": 1,
            "indices": {"bufferView": vi, "componentType": 5125},
            "values": {"bufferView": vv}
        });
        s
    };
    write_json(&d.join("out.gltf"), &sparse(50));
    refused(
        &render("out.gltf", &["--out", "o.exr"], d),
        &["out.gltf", "mesh 0", "sparse index 0 is 50", "count 28"],
    );
    // Counts of 0 and 2^62 (4 × 2^62 wrapped to 0 bytes to read: the edit dropped).
    for (count, file) in [(0u64, "zero.gltf"), (1 << 62, "wrap.gltf")] {
        let mut s = sparse(0);
        s["accessors"][0]["sparse"]["count"] = json!(count);
        write_json(&d.join(file), &s);
        refused(
            &render(file, &["--out", "w.exr"], d),
            &[file, &format!("{count} sparse values for 28 elements")],
        );
    }
    write_json(&d.join("in.gltf"), &sparse(0));
    let o = render("in.gltf", &["--out", "i.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Which scene has no triangles where the file has several, and a file whose every
/// triangle is lost to f32 beside an extent it spans itself (one shared vertex at 3e38):
/// both said "has no triangles" as for a file without meshes.
#[test]
fn empty_scenes_and_triangles_lost_to_scale_are_told_apart() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut doc = cornell(d);
    doc["scenes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "empty", "nodes": []}));
    doc["scene"] = json!(1);
    write_json(&d.join("two.gltf"), &doc);
    refused(
        &render("two.gltf", &["--out", "t.exr"], d),
        &["two.gltf", "no triangles in scene 1 ('empty')", "has 2"],
    );
    let mut b = GltfBuilder::new();
    let white = b.material("white", Vec3::splat(0.8), Vec3::ZERO, false);
    b.quad(
        "floor",
        [
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(3e38, 0.0, -2.0),
            Vec3::new(-2.0, 0.0, -2.0),
        ],
        white,
    );
    b.point_light("bulb", Vec3::new(0.0, 1.5, 0.0), Vec3::ONE, 10.0);
    b.camera(Vec3::new(0.0, 3.0, 5.0), Vec3::ZERO, 0.8);
    std::fs::write(d.join("far.gltf"), b.to_gltf_embedded()).unwrap();
    refused(
        &render("far.gltf", &["--out", "f.exr"], d),
        &["far.gltf", "all 2 of its triangles", "32-bit floats"],
    );
}

/// KHR_materials_specular allows colour factors past 1; at 26 the dielectric layer's F0
/// reaches 1 and every sample came out NaN: a black image with exit 0 (and `compare` saw
/// no warning and reported relMSE 0 and speed-ups of ∞). Now it renders; a camera turned
/// round by a node of negative scale (a legal, black image) is said; and `compare` refuses
/// a black reference rather than divide by its zero errors.
#[test]
fn black_images_are_said_and_not_compared() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let doc = cornell(d);
    let mut mirror = doc.clone();
    mirror["materials"][0]["extensions"]["KHR_materials_specular"] =
        json!({"specularFactor": 1.0, "specularColorFactor": [26.0, 26.0, 26.0]});
    write_json(&d.join("mirror.gltf"), &mirror);
    let o = render("mirror.gltf", &["--out", "m.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("NaN"), "{}", stderr(&o));
    let (_, _, px) = lightlearn::film::read_exr(&d.join("m.exr")).unwrap();
    let lit = px.iter().filter(|p| p.iter().any(|v| *v > 0.0)).count();
    assert!(lit > px.len() / 2, "only {lit} of {} pixels lit", px.len());
    let mut back = doc;
    let camera = back["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n.get("camera").is_some())
        .unwrap();
    back["nodes"][camera]["scale"] = json!([1.0, 1.0, -1.0]);
    write_json(&d.join("back.gltf"), &back);
    let o = render("back.gltf", &["--out", "b.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: the image is black") && stderr(&o).contains("negative scale"),
        "{}",
        stderr(&o)
    );
    let o = render("c.gltf", &["--out", "c.exr"], d);
    assert!(!stderr(&o).contains("black"), "{}", stderr(&o));
    // Lit, but below the PNG's first step everywhere: an all-zero PNG with no word (an
    // audit, 2026-12-06). The emission × 1e-6.
    let mut dim = cornell(d);
    for m in dim["materials"].as_array_mut().unwrap() {
        if let Some(s) =
            m["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"].as_f64()
        {
            m["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] =
                json!(s * 1e-6);
        }
    }
    write_json(&d.join("dim.gltf"), &dim);
    let o = render("dim.gltf", &["--out", "dim.exr"], d);
    assert!(
        stderr(&o).contains("warning: the PNG is black"),
        "{}",
        stderr(&o)
    );
    let cache = d.join("cache");
    let o = compare(
        d,
        cache.to_str().unwrap(),
        &[
            "back.gltf",
            "--out",
            "cmp",
            "--spp",
            "2",
            "--reference-spp",
            "4",
        ],
    );
    refused(&o, &["reference image is black", "camera"]);
    assert!(!d.join("cmp").exists());
}

/// An accessor without a bufferView is legal glTF (every value 0, or its sparse values
/// alone): a NORMAL accessor of that kind, which lightlearn never reads, made the whole file
/// "not a valid glTF 2.0 file … Missing data" (the validator's accessor zero-init files). A
/// POSITION accessor of that kind is named.
#[test]
fn accessors_without_data_are_refused_only_where_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut doc = cornell(d);
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"componentType": 5126, "count": 28, "type": "VEC3"}));
    let zeros = accessors.len() - 1;
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(zeros);
    write_json(&d.join("normals.gltf"), &doc);
    let o = render("normals.gltf", &["--out", "n.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    // A texture-coordinate set no texture uses is not read either (it was refused, by the
    // crate and then by this check); the set a base-colour texture uses is.
    let mut uv = doc.clone();
    uv["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = json!(zeros);
    write_json(&d.join("uv1.gltf"), &uv);
    let o = render("uv1.gltf", &["--out", "u.exr"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    lightlearn::film::write_png(&d.join("t.png"), 2, 2, &[[0.5; 3]; 4]).unwrap();
    let mut used = textured(&uv, "t.png");
    used["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = json!(1);
    write_json(&d.join("uv1_used.gltf"), &used);
    refused(
        &render("uv1_used.gltf", &["--out", "v.exr"], d),
        &[
            "uv1_used.gltf",
            &format!("accessor {zeros} has no bufferView"),
        ],
    );
    doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(zeros);
    // 2^40 zeros with one sparse value: the zeros were allocated (the process aborted).
    let mut huge = doc.clone();
    let view = add_view(&mut huge, &[0u8; 16]);
    huge["accessors"][zeros]["count"] = json!(1u64 << 40);
    huge["accessors"][zeros]["min"] = json!([0.0, 0.0, 0.0]);
    huge["accessors"][zeros]["max"] = json!([1.0, 1.0, 1.0]);
    huge["accessors"][zeros]["sparse"] = json!({
        "count": 1,
        "indices": {"bufferView": view, "componentType": 5125},
        "values": {"bufferView": view, "byteOffset": 4}
    });
    write_json(&d.join("huge.gltf"), &huge);
    refused(
        &render("huge.gltf", &["--out", "h.exr"], d),
        &["huge.gltf", "1099511627776 elements without a bufferView"],
    );
    write_json(&d.join("positions.gltf"), &doc);
    refused(
        &render("positions.gltf", &["--out", "p.exr"], d),
        &[
            "positions.gltf",
            &format!("accessor {zeros} has no bufferView"),
        ],
    );
}
