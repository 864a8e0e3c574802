//! glTF loading: the three file forms, transforms, lights, camera, and bad input.

mod common;

use std::path::Path;

use glam::Vec3;
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::{gltf_load, Light, Scene};

fn small() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    let hot = g.material("hot", Vec3::splat(0.5), Vec3::new(5.0, 4.0, 3.0), true);
    g.cuboid("box", Vec3::ZERO, Vec3::ONE, grey);
    g.quad(
        "lamp",
        [
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(0.0, 2.0, 1.0),
        ],
        hot,
    );
    g.point_light(
        "bulb",
        Vec3::new(0.5, 3.0, 0.5),
        Vec3::new(1.0, 0.5, 0.25),
        2.0,
    );
    g.spot_light(
        "spot",
        Vec3::new(3.0, 3.0, 0.0),
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::ONE,
        4.0,
        0.2,
        0.5,
    );
    g.camera(Vec3::new(0.5, 1.0, 5.0), Vec3::new(0.5, 0.5, 0.0), 0.8);
    g
}

fn load_text(text: &str, dir: &Path) -> anyhow::Result<Scene> {
    gltf_load::load_bytes(text.as_bytes(), "test.gltf", dir, &mut |_| {})
}

#[test]
fn glb_embedded_and_external_buffers_load_the_same_scene() {
    let g = small();
    let a = common::load(&g, "glb");
    let dir = tempfile::tempdir().unwrap();
    let b = load_text(&g.to_gltf_embedded(), dir.path()).unwrap();
    let (text, bin) = g.to_gltf_external("small data.bin");
    std::fs::write(dir.path().join("small data.bin"), bin).unwrap();
    let text = text.replace("small data.bin", "small%20data.bin"); // URIs are percent-encoded
    let c = load_text(&text, dir.path()).unwrap();
    for s in [&b, &c] {
        assert_eq!(s.triangles, a.triangles);
        assert_eq!(s.materials, a.materials);
        assert_eq!(s.lights, a.lights);
    }
    assert_eq!(a.triangles.len(), 14);
    // 2 emissive triangles + point + spot.
    assert_eq!(a.lights.len(), 4);
    let tri_lights = a
        .lights
        .iter()
        .filter(|l| matches!(l, Light::Triangle { .. }))
        .count();
    assert_eq!(tri_lights, 2);
    let hot = a.materials.iter().find(|m| m.name == "hot").unwrap();
    assert_eq!(
        hot.emission,
        Vec3::new(5.0, 4.0, 3.0),
        "emissiveFactor × emissiveStrength"
    );
    assert!(hot.double_sided);
}

#[test]
fn lights_and_camera_keep_their_placement() {
    let s = common::load(&small(), "glb");
    let spot = s.lights.iter().find_map(|l| match l {
        Light::Spot {
            position,
            direction,
            cos_inner,
            cos_outer,
            intensity,
        } => Some((*position, *direction, *cos_inner, *cos_outer, *intensity)),
        _ => None,
    });
    let (p, d, ci, co, i) = spot.unwrap();
    assert!((p - Vec3::new(3.0, 3.0, 0.0)).length() < 1e-5);
    assert!(
        (d - Vec3::new(-1.0, -1.0, 0.0).normalize()).length() < 1e-5,
        "spot axis {d}"
    );
    assert!((ci - 0.2f32.cos()).abs() < 1e-6 && (co - 0.5f32.cos()).abs() < 1e-6);
    assert_eq!(i, Vec3::splat(4.0));
    let point = s.lights.iter().find_map(|l| match l {
        Light::Point { intensity, .. } => Some(*intensity),
        _ => None,
    });
    assert_eq!(
        point.unwrap(),
        Vec3::new(2.0, 1.0, 0.5),
        "intensity × color"
    );
    let want = (Vec3::new(0.5, 0.5, 0.0) - Vec3::new(0.5, 1.0, 5.0)).normalize();
    assert!((s.camera.forward - want).length() < 1e-5);
    assert!((s.camera.position - Vec3::new(0.5, 1.0, 5.0)).length() < 1e-5);
    assert!((s.camera.yfov - 0.8).abs() < 1e-6);
}

/// A mirroring node transform flips winding; the loader restores CCW = front (outward for a
/// box), so one-sided emission keeps facing the right way.
#[test]
fn mirrored_nodes_keep_outward_faces() {
    let g = small();
    let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
    doc["nodes"][0]["scale"] = serde_json::json!([-1.0, 1.0, 1.0]);
    doc["nodes"][0]["translation"] = serde_json::json!([4.0, 0.0, 0.0]);
    let s = load_text(&doc.to_string(), Path::new(".")).unwrap();
    let centre = Vec3::new(3.5, 0.5, 0.5);
    for t in &s.triangles[..12] {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let c = (t[0] + t[1] + t[2]) / 3.0;
        assert!(
            n.dot(c - centre) > 0.0,
            "face normal points inward after mirroring: {t:?}"
        );
        assert!(t.iter().all(|v| v.x >= 3.0 - 1e-6 && v.x <= 4.0 + 1e-6));
    }
}

#[test]
fn bad_scenes_give_clear_errors() {
    let err = |text: &str| load_text(text, Path::new(".")).unwrap_err().to_string();

    assert!(err("hello").contains("not a valid glTF"));

    let mut g = GltfBuilder::new();
    g.point_light("bulb", Vec3::ONE, Vec3::ONE, 1.0);
    assert!(err(&g.to_gltf_embedded()).contains("has no triangles"));

    let mut g = GltfBuilder::new();
    let m = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.cuboid("box", Vec3::ZERO, Vec3::ONE, m);
    let e = err(&g.to_gltf_embedded());
    assert!(
        e.contains("has no lights") && e.contains("KHR_lights_punctual"),
        "{e}"
    );

    let mut g = small();
    let m = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.mesh(
        "broken",
        &[Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE],
        &[0, 1, 2],
        m,
    );
    let e = err(&g.to_gltf_embedded());
    assert!(
        e.contains("'broken'") && e.contains("non-finite position"),
        "{e}"
    );

    // emissiveStrength 1e39 overflows f32 to Inf.
    let text = small()
        .to_gltf_embedded()
        .replace("\"emissiveStrength\": 5.0", "\"emissiveStrength\": 1e39");
    assert!(text.contains("1e39"));
    let e = err(&text);
    assert!(e.contains("'hot'") && e.contains("non-finite"), "{e}");

    // An index past the end of the vertex list.
    let mut g = small();
    g.mesh("bad index", &[Vec3::ZERO, Vec3::X, Vec3::Y], &[0, 1, 7], 0);
    let e = err(&g.to_gltf_embedded());
    assert!(e.contains("index 7 is out of range"), "{e}");
}

#[test]
fn line_primitives_are_skipped_with_a_warning() {
    let mut doc: serde_json::Value = serde_json::from_str(&small().to_gltf_embedded()).unwrap();
    doc["meshes"][0]["primitives"][0]["mode"] = serde_json::json!(1); // LINES
    let (s, warnings) = common::load_warned(doc.to_string().as_bytes(), "lines.gltf");
    assert_eq!(s.triangles.len(), 2, "only the lamp quad is left");
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("Lines") && w.contains("skipped")),
        "{warnings:?}"
    );

    // Nothing but lines: refused, and the message says why.
    let mut g = GltfBuilder::new();
    let m = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.cuboid("box", Vec3::ZERO, Vec3::ONE, m);
    g.point_light("bulb", Vec3::ONE, Vec3::ONE, 1.0);
    let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
    doc["meshes"][0]["primitives"][0]["mode"] = serde_json::json!(1);
    let e = load_text(&doc.to_string(), Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no triangles") && e.contains("skipped"), "{e}");
}

/// A texture that cannot be read is named in a warning and the material keeps its factor;
/// a texture coordinate that is NaN is an error naming the primitive.
#[test]
fn unusable_textures_warn_and_bad_texture_coordinates_fail() {
    let build = |image: &[u8], uv: f32| {
        let mut g = GltfBuilder::new();
        let m = g.material("floor", Vec3::splat(0.5), Vec3::ZERO, false);
        let t = g.texture_png(image, [10497, 10497]);
        g.set_base_color_texture(m, t);
        let c = [Vec3::ZERO, Vec3::Z, Vec3::new(1.0, 0.0, 1.0)];
        g.mesh_uv(
            "tri",
            &c,
            Some(&[[0.0, 0.0], [0.0, uv], [1.0, 1.0]]),
            &[0, 1, 2],
            m,
        );
        g.point_light("bulb", Vec3::ONE, Vec3::ONE, 1.0);
        g.to_glb()
    };
    // A damaged JPEG (JPEG is read since 2026-12-07), a JPEG cut short (decoded with filler
    // texels by default), and neither a PNG nor a JPEG.
    let jpg = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/solid-200-100-50.jpg"
    ))
    .unwrap();
    for (bytes, name, wants) in [
        (&b"\xff\xd8\xff\xe0 a JPEG"[..], "jpeg.glb", "JPEG"),
        (&jpg[..jpg.len() - 6], "cut.glb", "cut short"),
        (&b"GIF89a"[..], "gif.glb", "neither a PNG nor a JPEG"),
    ] {
        let (s, warnings) = common::load_warned(&build(bytes, 1.0), name);
        assert!(s.textures.is_empty() && s.triangle_uv.is_empty());
        assert_eq!(s.materials[0].base_color_texture, None);
        assert!(
            warnings
                .iter()
                .any(|w| w.contains(name) && w.contains(wants) && w.contains("baseColorFactor")),
            "{warnings:?}"
        );
    }
    // A valid 1×1 PNG, so the coordinates are read.
    let mut png1 = Vec::new();
    let mut enc = png::Encoder::new(&mut png1, 1, 1);
    enc.set_color(png::ColorType::Rgb);
    let mut w = enc.write_header().unwrap();
    w.write_image_data(&[200, 100, 50]).unwrap();
    w.finish().unwrap();
    let e = gltf_load::load_bytes(
        &build(&png1, f32::NAN),
        "nan-uv.glb",
        Path::new("."),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("nan-uv.glb")
            && e.contains("mesh 0")
            && e.contains("non-finite texture coordinate"),
        "{e}"
    );
}

#[test]
fn metallic_roughness_materials_load_with_their_factors() {
    let mut g = small();
    let metal = g.glossy_material("metal", Vec3::new(0.9, 0.6, 0.3), 1.0, 0.25);
    g.cuboid("metal box", Vec3::splat(2.0), Vec3::splat(3.0), metal);
    let s = common::load(&g, "glossy");
    let by_name = |n: &str| s.materials.iter().find(|m| m.name == n).unwrap();
    // The writer's plain materials are Lambertian: metallic 0 and specularFactor 0.
    let grey = by_name("grey");
    assert_eq!((grey.metallic, grey.specular), (0.0, 0.0));
    assert!(grey.is_lambertian());
    let m = by_name("metal");
    assert_eq!((m.metallic, m.roughness, m.specular), (1.0, 0.25, 1.0));
    assert_eq!(m.specular_color, Vec3::ONE);
    assert!(!m.is_lambertian());

    // glTF's defaults (no pbrMetallicRoughness factors, no extension): metallic 1, roughness 1.
    let text = g.to_gltf_embedded();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let pbr = &mut doc["materials"][2]["pbrMetallicRoughness"];
    pbr.as_object_mut().unwrap().remove("metallicFactor");
    pbr.as_object_mut().unwrap().remove("roughnessFactor");
    let s = load_text(&doc.to_string(), Path::new(".")).unwrap();
    let m = s.materials.iter().find(|m| m.name == "metal").unwrap();
    assert_eq!((m.metallic, m.roughness, m.specular), (1.0, 1.0, 1.0));

    // Out-of-range factors are errors that name the material and the range.
    doc["materials"][2]["pbrMetallicRoughness"]["roughnessFactor"] = serde_json::json!(1.5);
    let e = load_text(&doc.to_string(), Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("'metal'") && e.contains("roughnessFactor 1.5") && e.contains("[0, 1]"),
        "{e}"
    );
    doc["materials"][2]["pbrMetallicRoughness"]["roughnessFactor"] = serde_json::json!(0.5);
    doc["materials"][2]["extensions"] =
        serde_json::json!({"KHR_materials_specular": {"specularFactor": -0.5}});
    let e = load_text(&doc.to_string(), Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("'metal'") && e.contains("specularFactor -0.5"),
        "{e}"
    );

    // A metallicRoughnessTexture whose image cannot be read: the factors alone, said (it
    // was never sampled before 2026-12-07; tests/metallic_roughness.rs renders one).
    doc["materials"][2]["extensions"] = serde_json::json!({});
    doc["materials"][2]["pbrMetallicRoughness"]["metallicRoughnessTexture"] =
        serde_json::json!({"index": 0});
    doc["textures"] = serde_json::json!([{"source": 0}]);
    doc["images"] = serde_json::json!([{"uri": "missing.png"}]);
    let (_, warnings) = common::load_warned(doc.to_string().as_bytes(), "test.gltf");
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("metallic-roughness texture 0")
                && w.contains("'metal'")
                && w.contains("using metallicFactor and roughnessFactor alone")),
        "{warnings:?}"
    );
}

/// A quad whose vertex normals are its own (flat) loads without a word and without shading
/// normals; one whose normals lean is shaded by them (smooth shading since 2026-12-07: it was
/// warned about as rendering faceted before, and silently faceted before that). Normals
/// against the winding are said, naming the primitive.
#[test]
fn vertex_normals_shade_smooth_and_reversed_ones_are_said() {
    use base64::Engine;
    // A quad of `size` at (x, y, z) = `at`, rising by `slope` along x and z, with these
    // vertex normals, emitting.
    let quad_indexed =
        |normals: [[f32; 3]; 4], at: [f32; 3], size: f32, slope: [f32; 2], indices: [u16; 6]| {
            let positions = [[0.0f32, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]].map(|[x, z]| {
                let y = at[1] + size * (slope[0] * x + slope[1] * z);
                [at[0] + size * x, y, at[2] + size * z]
            });
            let mut bytes = Vec::new();
            for v in positions.iter().chain(&normals).flatten() {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
            for i in indices {
                bytes.extend_from_slice(&i.to_le_bytes());
            }
            let data = base64::engine::general_purpose::STANDARD.encode(&bytes);
            serde_json::json!({
                "asset": {"version": "2.0"},
                "scene": 0,
                "scenes": [{"nodes": [0]}],
                "nodes": [{"mesh": 0}],
                "meshes": [{"name": "quad", "primitives": [{
                    "attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
                "materials": [{"emissiveFactor": [1.0, 1.0, 1.0]}],
                "buffers": [{"byteLength": bytes.len(),
                    "uri": format!("data:application/octet-stream;base64,{data}")}],
                "bufferViews": [
                    {"buffer": 0, "byteOffset": 0, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 48, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 96, "byteLength": 12}],
                "accessors": [
                    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                     "min": positions[0], "max": positions[2]},
                    {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                    {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]
            })
        };
    let quad_at =
        |normals, at, size, slope| quad_indexed(normals, at, size, slope, [0, 1, 2, 0, 2, 3]);
    let flat_at_0 = |normals| quad_at(normals, [0.0; 3], 1.0, [0.0; 2]);
    let quad = |normals| flat_at_0(normals).to_string();
    let up = [0.0, 1.0, 0.0];
    let (s, flat) = common::load_warned(quad([up; 4]).as_bytes(), "flat.gltf");
    assert!(flat.is_empty(), "{flat:?}");
    assert!(s.triangle_normals.is_empty(), "flat normals kept");
    let (s, smooth) = common::load_warned(
        quad([up, up, [0.2, 0.98, 0.0], up]).as_bytes(),
        "smooth.gltf",
    );
    assert!(smooth.is_empty(), "{smooth:?}");
    assert_eq!(s.triangle_normals.len(), 2, "smooth normals dropped");
    // Normals that agree with the quad but point against its winding: the lean takes |cos|,
    // so this was silent (an audit, 2026-12-07).
    let (s, flipped) = common::load_warned(quad([[0.0, -1.0, 0.0]; 4]).as_bytes(), "flipped.gltf");
    assert!(
        s.triangle_normals.is_empty(),
        "reversed flat normals are flat"
    );
    assert!(
        flipped
            .iter()
            .any(|w| w.contains("pointing against their triangles' winding")
                && w.contains("mesh 0 ('quad') primitive 0")
                && !w.contains("smooth")),
        "{flipped:?}"
    );
    // Smooth and reversed: shaded smooth, the reversal said.
    let down = [0.0, -1.0, 0.0];
    let (s, both) = common::load_warned(
        quad([down, down, [0.2, -0.98, 0.0], down]).as_bytes(),
        "both.gltf",
    );
    assert!(
        both.len() == 1 && both[0].contains("pointing against their triangles' winding"),
        "{both:?}"
    );
    assert_eq!(s.triangle_normals.len(), 2);
    // A flat, sloping 1-cm quad 5 km out: f32 corners tilt the triangle's own normal by
    // more than 1°, which warned of smooth normals (a review, 2026-12-07); the normals agree.
    // (The normals as the winding faces: against it is its own warning, below.)
    let n = glam::Vec3::new(-0.7, 1.0, -0.3).normalize().to_array();
    let far = quad_at([n; 4], [5000.0, 3000.0, 3000.0], 0.01, [0.7, 0.3]).to_string();
    let (s, far) = common::load_warned(far.as_bytes(), "far.gltf");
    assert!(far.is_empty(), "{far:?}");
    assert!(
        s.triangle_normals.is_empty(),
        "a flat quad far out rendered smooth"
    );
    // Normals that agree but lean 20° off their flat quad (custom normals on a bevel).
    let t = 20f32.to_radians();
    let (s, lean) = common::load_warned(quad([[t.sin(), t.cos(), 0.0]; 4]).as_bytes(), "lean.gltf");
    assert!(lean.is_empty(), "{lean:?}");
    assert_eq!(s.triangle_normals.len(), 2, "leaning normals are shaded by");
    // A NORMAL the loader never reads, malformed: a stride of 4 (the parser's slicing
    // panicked, refusing the file) and a sparse count of 2^40 (an allocation aborted the
    // process). Skipped here, as the loader skips it: both load, silent.
    let mut strided = flat_at_0([up; 4]);
    strided["bufferViews"][1]["byteStride"] = 4.into();
    let mut huge = flat_at_0([up; 4]);
    huge["accessors"][1] = serde_json::json!({"componentType": 5126, "count": 1u64 << 40,
        "type": "VEC3", "sparse": {"count": 1, "indices": {"bufferView": 2,
        "componentType": 5123}, "values": {"bufferView": 1}}});
    // A strip whose degenerate join meets a corner of another face: no triangle, dropped
    // by the loader, and it was warned of as smooth (a flat cube as one strip: a review).
    let side = [1.0, 0.0, 0.0];
    let mut strip = quad_indexed(
        [up, up, up, side],
        [0.0; 3],
        1.0,
        [0.0; 2],
        [0, 1, 2, 2, 3, 3],
    );
    strip["meshes"][0]["primitives"][0]["mode"] = 5.into();
    // A NORMAL of fewer values than vertices, and normalized shorts (KHR_mesh_quantization).
    let mut short = flat_at_0([up; 4]);
    short["accessors"][1]["count"] = 3.into();
    let mut quantized = flat_at_0([up; 4]);
    quantized["accessors"][1]["componentType"] = 5122.into();
    quantized["accessors"][1]["normalized"] = true.into();
    // Unusable normals are said and shaded flat (they were skipped without a word: an audit,
    // 2026-12-07); the strip's dropped join is nothing to say.
    for (file, doc, why) in [
        (
            "strided.gltf",
            strided,
            Some("stride or sparse part is malformed"),
        ),
        (
            "huge.gltf",
            huge,
            Some("1099511627776 normals for 4 vertices"),
        ),
        ("short.gltf", short, Some("3 normals for 4 vertices")),
        ("quantized.gltf", quantized, Some("not float VEC3")),
        ("strip.gltf", strip, None),
    ] {
        let (s, w) = common::load_warned(doc.to_string().as_bytes(), file);
        assert!(s.triangle_normals.is_empty(), "{file}");
        match why {
            None => assert!(w.is_empty(), "{file}: {w:?}"),
            Some(why) => assert!(
                w.len() == 1 && w[0].contains(why) && w[0].contains("shaded flat"),
                "{file}: {w:?}"
            ),
        }
    }
}

/// glTF's application-specific attributes (names starting with `_`, §3.7.2.1, e.g. 3D
/// Tiles' `_BATCHID`) are legal and unread: a file with one was refused as "not a valid
/// glTF 2.0 file: … <invalid semantic name>" (an audit, 2026-12-07).
#[test]
fn underscore_attributes_load_as_unread() {
    let g = small();
    let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
    for mesh in doc["meshes"].as_array_mut().unwrap() {
        for prim in mesh["primitives"].as_array_mut().unwrap() {
            let pos = prim["attributes"]["POSITION"].clone();
            prim["attributes"]["_BATCHID"] = pos;
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let plain = load_text(&g.to_gltf_embedded(), dir.path()).unwrap();
    let tagged = load_text(&doc.to_string(), dir.path()).unwrap();
    assert_eq!(tagged.triangles, plain.triangles);
}

/// KHR_texture_transform maps a texture's coordinates (offset, rotation, scale, and a texCoord
/// that overrides the textureInfo's) as the extension's T · R · S: the loaded coordinates are
/// the mapped ones. It was not read before 2026-12-07 (a warning; the texture rendered
/// untransformed). An emissive texture with another transform than the base colour's is
/// left out with a warning (a triangle's coordinates are mapped once).
#[test]
fn texture_transforms_map_the_coordinates() {
    let png = common::png_rgb(2, 1, &[[0, 0, 0], [255, 255, 255]]);
    let build = |transform: serde_json::Value, emissive: Option<serde_json::Value>| {
        let mut g = GltfBuilder::new();
        let m = g.material("floor", Vec3::ONE, Vec3::ZERO, false);
        let t = g.texture_png(&png, [10497, 10497]);
        g.set_base_color_texture(m, t);
        let c = [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
        ];
        g.mesh_uv(
            "tri",
            &c,
            Some(&[[0.0, 0.0], [0.0, 1.0], [1.0, 0.5]]),
            &[0, 1, 2],
            m,
        );
        let lamp = g.material("lamp", Vec3::ZERO, Vec3::ONE, false);
        g.quad(
            "lamp",
            [
                Vec3::new(-1.0, 2.0, -1.0),
                Vec3::new(1.0, 2.0, -1.0),
                Vec3::new(1.0, 2.0, 1.0),
                Vec3::new(-1.0, 2.0, 1.0),
            ],
            lamp,
        );
        let mut doc: serde_json::Value = serde_json::from_str(&g.to_gltf_embedded()).unwrap();
        doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
            serde_json::json!({ "KHR_texture_transform": transform });
        if let Some(e) = emissive {
            doc["materials"][0]["emissiveFactor"] = serde_json::json!([1.0, 1.0, 1.0]);
            doc["materials"][0]["emissiveTexture"] = serde_json::json!({"index": 0,
                "extensions": {"KHR_texture_transform": e}});
        }
        doc["extensionsUsed"]
            .as_array_mut()
            .unwrap()
            .push("KHR_texture_transform".into());
        common::load_warned(doc.to_string().as_bytes(), "transform.gltf")
    };
    let (s, w) = build(
        serde_json::json!({"offset": [0.5, -0.25], "rotation": std::f32::consts::FRAC_PI_2, "scale": [2.0, 3.0]}),
        None,
    );
    assert!(w.is_empty(), "{w:?}");
    // u' = cos·2u + sin·3v + 0.5, v' = −sin·2u + cos·3v − 0.25 at r = π/2.
    let (sin, cos) = std::f32::consts::FRAC_PI_2.sin_cos();
    for (got, [u, v]) in s.triangle_uv[0]
        .iter()
        .zip([[0.0f32, 0.0], [0.0, 1.0], [1.0, 0.5]])
    {
        let want = [
            cos * 2.0 * u + sin * 3.0 * v + 0.5,
            -sin * 2.0 * u + cos * 3.0 * v - 0.25,
        ];
        assert!(
            (got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6,
            "{got:?} against {want:?}"
        );
    }
    // The same transform on the emissive texture is kept; another is left out, said.
    let t = serde_json::json!({"offset": [0.5, 0.0]});
    let (s, w) = build(t.clone(), Some(t.clone()));
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(
        s.materials[0].emissive_texture,
        s.materials[0].base_color_texture
    );
    let (s, w) = build(t, Some(serde_json::json!({"offset": [0.0, 0.5]})));
    assert_eq!(s.materials[0].emissive_texture, None);
    assert!(
        w.iter()
            .any(|w| w.contains("KHR_texture_transform differs")),
        "{w:?}"
    );
}
