//! glTF normal textures: the texel's tangent-space normal (2c − 1, X and Y × `scale`) in the
//! frame of the surface's tangent (the file's TANGENT, else ∂p/∂u), its bitangent
//! cross(normal, tangent) × w (up the image: glTF's +Y), and its normal. Ignored with a
//! warning before 2026-12-07. The mutations that drop the map, turn the bitangent around,
//! ignore the scale or a TANGENT's sign, decode the texels as sRGB, or sum a vertex's
//! tangents over both halves of a mirrored layout each fail the first test.

mod common;

use glam::{Vec3, Vec4};
use lightlearn::render::LightSampler;
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::Scene;

const ALBEDO: f32 = 0.5;
const SUN: f32 = 4.0;

/// The sun's travel: from above, from −x and −z, so that a tilt either way along either axis
/// changes what the floor gets.
fn sun_direction() -> Vec3 {
    Vec3::new(0.4, -1.0, 0.7).normalize()
}

/// How the floor's vertices carry their frames.
#[derive(Clone, Copy, Debug)]
enum Frames {
    /// Positions and coordinates only: tangents from the coordinates, normals the winding's.
    Computed,
    /// NORMAL +Y too (flat, kept as the frame's normal).
    WithNormals,
    /// NORMAL +Y and TANGENT +X with this w.
    File(f32),
    /// u = |x|: the left half's coordinates mirror the right's, sharing the seam's vertices.
    Mirrored,
    /// Every vertex at (0.5, 0.5): no frame.
    Degenerate,
    /// TANGENT (+X, w −1) without NORMAL: glTF says to ignore it (tangents computed).
    TangentOnly,
}

/// A grey Lambertian floor over [−1, 1]² (two quads sharing the seam x = 0) seen from
/// straight above, with a one-texel normal texture `texel` of `scale`; u = (x + 1)/2 (or |x|),
/// v = (z + 1)/2; a dim point light, and the sun where asked.
fn scene(frames: Frames, texel: [u8; 3], scale: f32, sun: bool) -> GltfBuilder {
    scene_with(frames, &[texel], scale, sun, false)
}

/// [`scene`] with a row of texels (NEAREST, clamped: the left half of the floor's u reads the
/// first of two), seen (and lit by the sun) from below where asked.
fn scene_with(
    frames: Frames,
    texels: &[[u8; 3]],
    scale: f32,
    sun: bool,
    below: bool,
) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(ALBEDO), Vec3::ZERO, false);
    let png = common::png_rgb(texels.len() as u32, 1, texels);
    let t = g.texture_png_filtered(&png, [33071, 33071], Some(9728));
    g.set_normal_texture(grey, t, scale);
    let p = [
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
    ];
    let uv: Vec<[f32; 2]> = p
        .iter()
        .map(|q| match frames {
            Frames::Mirrored => [q.x.abs(), (q.z + 1.0) / 2.0],
            Frames::Degenerate => [0.5, 0.5],
            _ => [(q.x + 1.0) / 2.0, (q.z + 1.0) / 2.0],
        })
        .collect();
    let normals = [Vec3::Y; 6];
    let with_normals = matches!(frames, Frames::WithNormals | Frames::File(_));
    g.mesh_with(
        "floor",
        &p,
        Some(&uv),
        with_normals.then_some(&normals[..]),
        &[0, 1, 2, 0, 2, 3, 3, 2, 4, 3, 4, 5],
        grey,
    );
    match frames {
        Frames::File(w) => g.attribute_on_last_mesh("TANGENT", &[Vec4::new(1.0, 0.0, 0.0, w); 6]),
        Frames::TangentOnly => {
            g.attribute_on_last_mesh("TANGENT", &[Vec4::new(1.0, 0.0, 0.0, -1.0); 6])
        }
        _ => {}
    }
    g.point_light("dim", Vec3::new(-0.3, 3.0, 0.2), Vec3::ONE, 0.5);
    let flip = if below {
        Vec3::new(1.0, -1.0, 1.0)
    } else {
        Vec3::ONE
    };
    if sun {
        g.directional_light("sun", sun_direction() * flip, Vec3::ONE, SUN);
    }
    g.camera(
        Vec3::new(0.0, 40.0, 1e-3) * flip,
        Vec3::ZERO,
        2.0 * (1.0f32 / 40.0).atan(),
    );
    g
}

/// The texel's normal as glTF defines it, in the frame (tangent, bitangent, +Y).
fn world_normal(texel: [u8; 3], scale: f32, tangent: Vec3, bitangent: Vec3) -> Vec3 {
    let c = texel.map(|q| 2.0 * q as f32 / 255.0 - 1.0);
    (scale * (c[0] * tangent + c[1] * bitangent) + c[2] * Vec3::Y).normalize()
}

/// A texel of a normal leaning `deg` degrees from +Z towards (x, y) in tangent space.
fn lean(deg: f32, x: f32, y: f32) -> [u8; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    let n = Vec3::new(s * x, s * y, c).normalize();
    n.to_array()
        .map(|v| ((0.5 + 0.5 * v) * 255.0).round() as u8)
}

fn render(scene: &Scene) -> Vec<[f32; 3]> {
    common::render_mean(scene, LightSampler::Uniform, (32, 32), 1, 4, 3)
}

/// What the sun adds is albedo/π · E · (n · towards the sun) with n the texel's normal in
/// each half's frame (x < 0 the left columns), to 1e-3: tilts along the tangent and the
/// bitangent, a scale, normals given or not, a TANGENT of either sign, mirrored
/// coordinates (whose halves' tangents point apart), and a TANGENT without NORMAL, which
/// glTF says to ignore (w −1 there would turn the bitangent).
#[test]
fn the_texture_turns_the_normal_the_sun_sees() {
    let towards = -sun_direction();
    for frames in [
        Frames::Computed,
        Frames::WithNormals,
        Frames::File(1.0),
        Frames::File(-1.0),
        Frames::Mirrored,
        Frames::TangentOnly,
    ] {
        for (texel, scale) in [
            (lean(30.0, 1.0, 0.0), 1.0),
            (lean(30.0, 0.0, 1.0), 1.0),
            (lean(35.0, -0.6, -0.8), 0.5),
        ] {
            let load = |sun: bool| common::load(&scene(frames, texel, scale, sun), "floor");
            let (with, without) = (load(true), load(false));
            assert_eq!(with.triangle_tangents.len(), 4, "{frames:?}");
            let (a, b) = (render(&with), render(&without));
            // glTF's bitangent runs up the image, towards v = 0: −z here, unless the file's
            // w says otherwise.
            let bitangent = match frames {
                Frames::File(w) => -w * Vec3::Z,
                _ => -Vec3::Z,
            };
            let mut want_both = [0.0; 2];
            for (half, tangent) in [(0, Vec3::NEG_X), (1, Vec3::X)] {
                let tangent = match frames {
                    Frames::Mirrored => tangent,
                    _ => Vec3::X,
                };
                let n = world_normal(texel, scale, tangent, bitangent);
                want_both[half] = ALBEDO / std::f32::consts::PI * SUN * n.dot(towards).max(0.0);
            }
            for (i, (p, q)) in a.iter().zip(&b).enumerate() {
                let want = want_both[(i % 32 >= 16) as usize];
                let d = p[0] - q[0];
                assert!(
                    (d - want).abs() <= 1e-3 * want,
                    "{frames:?} texel {texel:?} scale {scale} pixel {i}: the sun added {d}, want {want}"
                );
            }
        }
    }
}

/// What the one-texel test cannot see: the coordinates the texture is read at (a two-texel
/// map, a lean along the tangent on the left half and along the bitangent on the right), a
/// TANGENT under a mirroring and under a rotating node (the tangent transformed, w negated
/// by the mirror; computed tangents alike), and the back face seen from below, lit from
/// below (glTF: the whole mapped normal reversed). A review, 2026-12-07.
#[test]
fn coordinates_node_transforms_and_back_faces() {
    let (x, y) = (lean(30.0, 1.0, 0.0), lean(30.0, 0.0, 1.0));
    // What the sun adds, pixel by pixel: the scene `g(sun)` rendered with and without it,
    // its JSON edited by `edit` alike.
    let added = |g: &dyn Fn(bool) -> GltfBuilder, edit: &dyn Fn(&mut serde_json::Value)| {
        let load = |sun: bool| {
            let bytes = common::edit_glb(&g(sun).to_glb(), edit);
            render(&common::load_warned(&bytes, "node").0)
        };
        let (a, b) = (load(true), load(false));
        a.iter()
            .zip(&b)
            .map(|(p, q)| p[0] - q[0])
            .collect::<Vec<f32>>()
    };
    let want =
        |n: Vec3, towards: Vec3| ALBEDO / std::f32::consts::PI * SUN * n.dot(towards).max(0.0);
    let check = |d: &[f32], want: &dyn Fn(usize) -> f32, what: &str| {
        for (i, d) in d.iter().enumerate() {
            let w = want(i);
            assert!(
                (d - w).abs() <= 1e-3 * w,
                "{what} pixel {i}: the sun added {d}, want {w}"
            );
        }
    };
    let towards = -sun_direction();
    let none = |_: &mut serde_json::Value| {};
    // Two texels: each half its own lean.
    let d = added(
        &|sun| scene_with(Frames::Computed, &[x, y], 1.0, sun, false),
        &none,
    );
    let left = want(world_normal(x, 1.0, Vec3::X, -Vec3::Z), towards);
    let right = want(world_normal(y, 1.0, Vec3::X, -Vec3::Z), towards);
    check(
        &d,
        &|i| if i % 32 < 16 { left } else { right },
        "two texels",
    );
    // Nodes: the floor's node (the first) mirrored in x, or turned 90° about +Y.
    let turn = std::f32::consts::FRAC_1_SQRT_2;
    for frames in [Frames::File(1.0), Frames::WithNormals] {
        let mirror = |j: &mut serde_json::Value| {
            j["nodes"][0]["scale"] = serde_json::json!([-1.0, 1.0, 1.0])
        };
        for texel in [x, y] {
            let d = added(
                &|sun| scene_with(frames, &[texel], 1.0, sun, false),
                &mirror,
            );
            let w = want(world_normal(texel, 1.0, Vec3::NEG_X, -Vec3::Z), towards);
            check(&d, &|_| w, &format!("{frames:?} mirrored, texel {texel:?}"));
        }
        let rotate = |j: &mut serde_json::Value| {
            j["nodes"][0]["rotation"] = serde_json::json!([0.0, turn, 0.0, turn])
        };
        for texel in [x, y] {
            let d = added(
                &|sun| scene_with(frames, &[texel], 1.0, sun, false),
                &rotate,
            );
            // +X turns to −Z, and −Z (the bitangent) to −X.
            let w = want(world_normal(texel, 1.0, Vec3::NEG_Z, Vec3::NEG_X), towards);
            check(&d, &|_| w, &format!("{frames:?} turned, texel {texel:?}"));
        }
    }
    // From below, the sun from below: the front's mapped normal, reversed.
    for texel in [x, y] {
        let d = added(
            &|sun| scene_with(Frames::Computed, &[texel], 1.0, sun, true),
            &none,
        );
        let front = world_normal(texel, 1.0, Vec3::X, -Vec3::Z);
        let w = want(-front, towards * Vec3::new(1.0, -1.0, 1.0));
        check(&d, &|_| w, &format!("below, texel {texel:?}"));
    }
}

/// A texel of +Z (128, 128, 255) is the surface's own normal: the image of the floor without
/// a normal texture, to the texel's rounding.
#[test]
fn a_flat_texel_changes_nothing() {
    let mapped = common::load(&scene(Frames::Computed, [128, 128, 255], 1.0, true), "m");
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(ALBEDO), Vec3::ZERO, false);
    g.quad("floor", common::FLOOR, grey);
    g.point_light("dim", Vec3::new(-0.3, 3.0, 0.2), Vec3::ONE, 0.5);
    g.directional_light("sun", sun_direction(), Vec3::ONE, SUN);
    g.camera(
        Vec3::new(0.0, 40.0, 1e-3),
        Vec3::ZERO,
        2.0 * (1.0f32 / 40.0).atan(),
    );
    let plain = common::load(&g, "plain");
    for (depth, (a, b)) in [1, 3].into_iter().map(|d| {
        let r = |s: &Scene| common::render_mean(s, LightSampler::Bayes, (32, 32), d, 4, 3);
        (d, (r(&mapped), r(&plain)))
    }) {
        for (i, (p, q)) in a.iter().zip(&b).enumerate() {
            assert!(
                (p[0] - q[0]).abs() <= 1e-2 * q[0],
                "depth {depth} pixel {i}: mapped {p:?}, plain {q:?}"
            );
        }
    }
}

/// What the loader cannot use is said and left out: an unreadable TANGENT (computed from the
/// coordinates instead, the same image), a normal texture on another TEXCOORD set than the
/// base colour's, and a malformed KHR_texture_transform on it.
#[test]
fn unusable_tangents_and_mappings_are_said() {
    let texel = lean(30.0, 0.0, 1.0);
    let good = common::load(&scene(Frames::Computed, texel, 1.0, true), "computed");
    let bytes = common::edit_glb(&scene(Frames::File(1.0), texel, 1.0, true).to_glb(), |j| {
        let a = j["meshes"][0]["primitives"][0]["attributes"]["TANGENT"]
            .as_u64()
            .unwrap() as usize;
        j["accessors"][a]["type"] = serde_json::json!("VEC3");
        j["accessors"][a]["count"] = serde_json::json!(8);
    });
    let (s, w) = common::load_warned(&bytes, "tangents.glb");
    assert!(
        w.iter().any(|w| w.contains("TANGENT")
            && w.contains("computed from its texture coordinates")
            && w.contains("mesh 0")),
        "{w:?}"
    );
    let (a, b) = (render(&s), render(&good));
    for (p, q) in a.iter().zip(&b) {
        assert!((p[0] - q[0]).abs() <= 1e-3 * q[0], "{p:?} {q:?}");
    }

    // TANGENT values it cannot use (NaN, zero, w = 0): those corners computed, said (the map
    // vanished without a word: an audit, 2026-12-07).
    for bad in [
        Vec4::new(f32::NAN, 0.0, 0.0, 1.0),
        Vec4::ZERO,
        Vec4::new(1.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0, 0.0, 1.0),
    ] {
        let mut g = scene(Frames::WithNormals, texel, 1.0, true);
        g.attribute_on_last_mesh("TANGENT", &[bad; 6]);
        let (s, w) = common::load_warned(&g.to_glb(), "bad.glb");
        assert!(
            w.iter()
                .any(|w| w.contains("TANGENT values lightlearn cannot use")
                    && w.contains("at 12 triangle corners")),
            "{bad}: {w:?}"
        );
        let a = render(&s);
        for (p, q) in a.iter().zip(&b) {
            assert!((p[0] - q[0]).abs() <= 1e-3 * q[0], "{bad}: {p:?} {q:?}");
        }
    }
    // Coordinates of no area: no frame, said (silent before).
    let (s, w) = common::load_warned(
        &scene(Frames::Degenerate, texel, 1.0, true).to_glb(),
        "degenerate.glb",
    );
    assert!(s.triangle_tangents.is_empty());
    assert!(
        w.iter()
            .any(|w| w.contains("4 triangles of its normal-mapped material have no tangent frame")),
        "{w:?}"
    );
    // No coordinates at all: the warning says the map is not applied.
    let bytes = common::edit_glb(&scene(Frames::Computed, texel, 1.0, true).to_glb(), |j| {
        let attributes = &mut j["meshes"][0]["primitives"][0]["attributes"];
        attributes.as_object_mut().unwrap().remove("TEXCOORD_0");
    });
    let (_, w) = common::load_warned(&bytes, "no-uv.glb");
    assert!(
        w.iter()
            .any(|w| w.contains("no TEXCOORD_0") && w.contains("normal texture is not applied")),
        "{w:?}"
    );
    let mut g = scene(Frames::Computed, texel, 1.0, true);
    let base = g.texture_png(&common::png_rgb(1, 1, &[[255, 255, 255]]), [10497, 10497]);
    g.set_base_color_texture(0, base);
    for (edit, says) in [
        (
            serde_json::json!({"index": 0, "texCoord": 1}),
            "another texture coordinate set",
        ),
        (
            serde_json::json!({"index": 0, "extensions": {"KHR_texture_transform": {"scale": "big"}}}),
            "KHR_texture_transform is malformed",
        ),
    ] {
        let bytes = common::edit_glb(&g.to_glb(), |j| {
            j["materials"][0]["normalTexture"] = edit.clone();
        });
        let (s, w) = common::load_warned(&bytes, "sets.glb");
        assert_eq!(s.materials[0].normal_texture, None);
        assert!(s.triangle_tangents.is_empty());
        assert!(
            w.iter().any(|w| w.contains("normal texture")
                && w.contains("material 0 ('grey')")
                && w.contains(says)),
            "{w:?}"
        );
    }
}
