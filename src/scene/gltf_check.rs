//! Checks of a glTF document that the `gltf` crate does not make before it indexes with them:
//! it panicked on a POSITION accessor index out of range (in its own validation) and on
//! float-typed indices (`unreachable!` in its reader). Each problem becomes one line naming
//! the element and the fix; the crate's validation runs only after these pass. A case none
//! of them knows is caught by [`guarded`] (one line, never a panic's text).

use anyhow::{bail, Result};
use gltf::json::accessor::{ComponentType, GenericComponentType, Type};
use gltf::json::validation::{Checked, Validate};
use gltf::json::Root;

/// Every reference a mesh primitive makes (attribute and index accessors, their buffer views
/// and buffers, its material) points at an element that exists, and index accessors are
/// unsigned integer scalars; then the crate's own validation.
pub fn check(root: &Root, name: &str) -> Result<()> {
    // glTF 2.0 readers must refuse another major version or a minVersion above theirs
    // (§3.2, "asset"): "3.0" and minVersion "2.1" rendered as 2.0 (an audit, 2026-12-07).
    // Read leniently ("2", "2.0.1" and " 2.0" rendered before: a review): a leading number
    // that is not 2 is refused, however many digits it has ("4294967298.0" wrapped a u32
    // parse: a review); one that is no number at all is left to the schema's other checks.
    let major_is = |v: &str| -> Option<bool> {
        let major = v.trim().split('.').next()?;
        (!major.is_empty() && major.bytes().all(|b| b.is_ascii_digit()))
            .then(|| major.trim_start_matches('0') == "2")
    };
    let parts = |v: &str| -> (Option<u32>, u32) {
        let mut it = v.trim().split('.');
        let major = it.next().and_then(|a| a.parse().ok());
        (major, it.next().and_then(|b| b.parse().ok()).unwrap_or(0))
    };
    let version = &root.asset.version;
    if major_is(version) == Some(false) {
        bail!("'{name}' says it is glTF version '{version}' (asset.version); lightlearn reads glTF 2: export it as glTF 2.0");
    }
    if let Some(min) = &root.asset.min_version {
        let above = match parts(min) {
            (Some(major), minor) => (major, minor) > (2, 0),
            (None, _) => major_is(min) == Some(false),
        };
        if above {
            bail!("'{name}' needs a glTF reader of at least version '{min}' (asset.minVersion); lightlearn reads glTF 2.0: export it for glTF 2.0");
        }
    }
    let accessors = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let at = format!("'{name}': mesh {m} primitive {p}");
            // (what, accessor, whether the loader reads its data: only those must lie where
            // the file says; a damaged attribute it never reads, e.g. _BATCHID, is no reason
            // to refuse the file).
            // The texture coordinates read are the set the material's base-colour texture
            // names: an unused set without data refused the file (a review, 2026-12-06).
            let uv_set = prim
                .material
                .and_then(|m| root.materials.get(m.value()))
                .and_then(|m| {
                    // As gltf_mesh::coordinate_map: an emissive texture's set only where the
                    // material emits (a texture under a zero factor is never read), a
                    // metallic-roughness texture's only under a GGX layer, else a normal
                    // texture's.
                    let strength = (m.extensions.as_ref())
                        .and_then(|e| e.emissive_strength.as_ref())
                        .map_or(1.0, |s| s.emissive_strength.0);
                    let emits = m.emissive_factor.0.iter().any(|&c| c * strength > 0.0);
                    let pbr = &m.pbr_metallic_roughness;
                    let specular = (m.extensions.as_ref())
                        .and_then(|e| e.specular.as_ref())
                        .map_or(1.0, |s| s.specular_factor.0);
                    let glossy = !(pbr.metallic_factor.0 == 0.0 && specular == 0.0);
                    // KHR_texture_transform's texCoord overrides the textureInfo's.
                    let set = |t: &gltf::json::texture::Info| {
                        (t.extensions.as_ref())
                            .and_then(|e| e.texture_transform.as_ref())
                            .and_then(|tt| tt.tex_coord)
                            .unwrap_or(t.tex_coord)
                    };
                    // A normal texture's extension is JSON to the crate (UvMap::of_normal).
                    // A malformed one: the loader leaves the map out and reads no set for it.
                    let normal_set = |n: &gltf::json::material::NormalTexture| {
                        use gltf::json::extensions::texture::TextureTransform;
                        match (n.extensions.as_ref())
                            .and_then(|e| e.others.get("KHR_texture_transform"))
                        {
                            None => Some(n.tex_coord),
                            Some(v) => serde_json::from_value::<TextureTransform>(v.clone())
                                .ok()
                                .map(|t| t.tex_coord.unwrap_or(n.tex_coord)),
                        }
                    };
                    (pbr.base_color_texture.as_ref())
                        .or(m.emissive_texture.as_ref().filter(|_| emits))
                        .or(pbr.metallic_roughness_texture.as_ref().filter(|_| glossy))
                        .map(set)
                        .or_else(|| m.normal_texture.as_ref().and_then(normal_set))
                });
            let mut used: Vec<(String, usize, bool)> = prim
                .attributes
                .iter()
                .map(|(k, v)| {
                    use gltf::json::mesh::Semantic;
                    let read = match k {
                        Checked::Valid(Semantic::Positions) => true,
                        Checked::Valid(Semantic::TexCoords(n)) => uv_set == Some(*n),
                        _ => false,
                    };
                    (format!("attribute {}", k.to_string()), v.value(), read)
                })
                .collect();
            if let Some(i) = &prim.indices {
                used.push(("indices".to_string(), i.value(), true));
            }
            for (what, a, read) in &used {
                if *a >= accessors {
                    bail!("{at}: {what} names accessor {a}, but the file has {accessors}; fix the index or export the file again");
                }
                check_accessor(root, *a, &at, *read)?;
            }
            if let Some(i) = &prim.indices {
                let acc = &root.accessors[i.value()];
                let unsigned = matches!(
                    acc.component_type,
                    Checked::Valid(GenericComponentType(
                        ComponentType::U8 | ComponentType::U16 | ComponentType::U32
                    ))
                );
                if !unsigned || acc.type_ != Checked::Valid(Type::Scalar) {
                    bail!("{at}: its index accessor {} is not a scalar of unsigned bytes, shorts or ints (glTF 2.0 §3.7.2.1); export the file again", i.value());
                }
            }
            // glTF 2.0 §3.7.2.1: POSITION is VEC3 of FLOAT (the crate's reader assumes it,
            // and a VEC2 or normalized SHORT accessor rendered as garbage without a word).
            let position = prim
                .attributes
                .get(&Checked::Valid(gltf::json::mesh::Semantic::Positions));
            if let Some(i) = position {
                let acc = &root.accessors[i.value()];
                let float = matches!(
                    acc.component_type,
                    Checked::Valid(GenericComponentType(ComponentType::F32))
                );
                if !float || acc.type_ != Checked::Valid(Type::Vec3) || acc.normalized {
                    let quantized = if float {
                        ""
                    } else {
                        " (quantized positions, KHR_mesh_quantization, are not supported)"
                    };
                    bail!("{at}: its POSITION accessor {} is {}{}, but glTF requires VEC3 of FLOAT{quantized}; export the mesh again", i.value(), accessor_kind(acc), if acc.normalized { " (normalized)" } else { "" });
                }
            }
            if let Some(mat) = &prim.material {
                if mat.value() >= root.materials.len() {
                    bail!(
                        "{at} names material {}, but the file has {}; fix the index",
                        mat.value(),
                        root.materials.len()
                    );
                }
            }
        }
    }
    check_animations(root, name)?;
    check_images(root, name)?;
    check_node_tree(root, name)?;
    check_rotations(root, name)?;
    check_matrices(root, name)?;
    // Required extensions are judged by what lightlearn reads, not by the crate's list: it
    // refused a required KHR_materials_specular, which we read, and called every such file
    // "not a valid glTF 2.0 file" (an audit, 2026-12-06).
    let required: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    if !required.is_empty() {
        bail!(
            "'{name}' requires {}, which lightlearn does not read (it reads {}); export the file without {} (e.g. without Draco or meshopt compression)",
            required.join(", "),
            SUPPORTED_EXTENSIONS.join(", "),
            if required.len() > 1 { "them" } else { "it" }
        );
    }
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, e| {
        let at = path().to_string();
        // An accessor without a bufferView is legal glTF (its values are 0, or its sparse
        // values alone); the crate calls it missing data, which refused files over a NORMAL
        // accessor lightlearn never reads (an audit, 2026-12-06). Those it reads are
        // checked in check_accessor.
        let no_view = at.starts_with("accessors[")
            && at.ends_with("].bufferView")
            && e == gltf::json::validation::Error::Missing;
        if !at.starts_with("extensionsRequired") && !no_view {
            errors.push(format!("{at}: {e}"))
        }
    });
    if !errors.is_empty() {
        bail!(
            "'{name}' is not a valid glTF 2.0 file: {}. Export it again or check it with the Khronos glTF validator.",
            errors.join("; ")
        );
    }
    Ok(())
}

/// Every image has a source the crate can give: a uri, or a bufferView (with a mimeType)
/// that exists in a buffer that exists. The crate's `Image::source` unwraps both, so an
/// image of `{}`, one in a bufferView without a mimeType, or in a view out of range panicked
/// (an audit, 2026-12-06), even when no material used it. Checked for every image, as the
/// Khronos validator does.
fn check_images(root: &Root, name: &str) -> Result<()> {
    for (i, image) in root.images.iter().enumerate() {
        let at = format!("'{name}': image {i}");
        let Some(v) = &image.buffer_view else {
            if image.uri.is_none() {
                bail!("{at} has neither a uri nor a bufferView, so it has no data (glTF 2.0 §5.18); give it one, or remove it and the textures that use it");
            }
            continue;
        };
        view_in_buffer(root, v.value(), &at)?;
        if image.mime_type.is_none() {
            bail!("{at} lies in bufferView {} without a mimeType, which glTF requires there (§5.18); add \"mimeType\": \"image/png\"", v.value());
        }
    }
    Ok(())
}

/// Every animation channel names a sampler and a node that exist, and every sampler's
/// input and output accessors exist (the crate indexes with them unchecked).
fn check_animations(root: &Root, name: &str) -> Result<()> {
    let accessors = root.accessors.len();
    for (a, anim) in root.animations.iter().enumerate() {
        let label = format!("animation {a} ('{}')", anim.name.as_deref().unwrap_or(""));
        for (c, ch) in anim.channels.iter().enumerate() {
            let at = format!("'{name}': {label} channel {c}");
            if ch.sampler.value() >= anim.samplers.len() {
                bail!(
                    "{at} names sampler {}, but the animation has {}; fix the index",
                    ch.sampler.value(),
                    anim.samplers.len()
                );
            }
            if ch.target.node.value() >= root.nodes.len() {
                bail!("{at} targets node {}, but the file has {} nodes; fix the channel's target or drop the channel", ch.target.node.value(), root.nodes.len());
            }
        }
        // The samplers lightlearn reads: those of channels other than morph-target weights
        // (ignored with a warning, whatever their data).
        let read: Vec<usize> = (anim.channels.iter())
            .filter(|ch| {
                !matches!(
                    ch.target.path,
                    gltf::json::validation::Checked::Valid(
                        gltf::json::animation::Property::MorphTargetWeights
                    )
                )
            })
            .map(|ch| ch.sampler.value())
            .collect();
        for (s, sampler) in anim.samplers.iter().enumerate() {
            let at = format!("'{name}': {label} sampler {s}");
            for (what, acc) in [
                ("input", sampler.input.value()),
                ("output", sampler.output.value()),
            ] {
                if acc >= accessors {
                    bail!("{at}: its {what} names accessor {acc}, but the file has {accessors}; fix the index");
                }
                check_accessor(root, acc, &at, read.contains(&s))?;
            }
        }
    }
    Ok(())
}

/// Accessor `a`'s buffer view and buffer exist; where the loader reads it (`read`), its
/// layout too ([`check_layout`]).
fn check_accessor(root: &Root, a: usize, at: &str, read: bool) -> Result<()> {
    let acc = &root.accessors[a];
    let Some(view) = &acc.buffer_view else {
        if read && acc.sparse.is_none() {
            bail!("{at}: accessor {a} has no bufferView and no sparse values, so every value is 0 (glTF allows it, but lightlearn needs the data here); export the file with its data");
        }
        // Its zeros cost memory without a byte of file: 2^40 of them aborted the process
        // (a review, 2026-12-06). No mesh lightlearn takes needs more than 3 vertices a
        // triangle.
        let most = 3 * super::gltf_load::MAX_TRIANGLES;
        if read && acc.count.0 as usize > most {
            bail!("{at}: accessor {a} holds {} elements without a bufferView, more than the {most} lightlearn reads; fix its count", acc.count.0);
        }
        return Ok(());
    };
    view_in_buffer(root, view.value(), &format!("{at}: accessor {a}"))?;
    if read {
        check_layout(root, a, view.value(), at)?;
    }
    Ok(())
}

/// Buffer view `v`, named by `what` (an image, an accessor), exists and lies in a buffer
/// that exists; the crate indexes with both unchecked.
fn view_in_buffer(root: &Root, v: usize, what: &str) -> Result<()> {
    let Some(view) = root.buffer_views.get(v) else {
        bail!(
            "{what} names bufferView {v}, but the file has {}; fix the index or export the file again",
            root.buffer_views.len()
        );
    };
    if view.buffer.value() >= root.buffers.len() {
        bail!(
            "{what} lies in bufferView {v} of buffer {}, but the file has {} buffers; fix the index or export the file again",
            view.buffer.value(),
            root.buffers.len()
        );
    }
    Ok(())
}

/// An accessor's elements lie inside its buffer view, and the view inside its buffer, with a
/// stride glTF allows (2.0 §3.6.2.4, §3.6.3: a multiple of 4 from 4 to 252, at least an
/// element). The crate reads what it is given: a stride of 13 rendered silently, one smaller
/// than an element panicked in its reader ("malformed in a way the parser could not
/// report"), and an accessor of 2^62 elements read as none, blamed on its first index (an
/// audit, 2026-12-06).
/// `view`: the accessor's buffer view, which [`check_accessor`] found to exist.
fn check_layout(root: &Root, a: usize, view: usize, at: &str) -> Result<()> {
    let acc = &root.accessors[a];
    let v = &root.buffer_views[view];
    let view_at = format!("buffer view {view}");
    // Matrices of bytes or shorts pad their columns; unknown enums: the crate's validation.
    let elem = match (acc.component_type, acc.type_) {
        (
            Checked::Valid(c),
            Checked::Valid(t @ (Type::Scalar | Type::Vec2 | Type::Vec3 | Type::Vec4)),
        ) => (c.0.size() * t.multiplicity()) as u128,
        _ => return Ok(()),
    };
    if let Some(s) = v.byte_stride {
        let s = s.0 as u128;
        if s < elem || !(4..=252).contains(&s) || !s.is_multiple_of(4) {
            bail!("{at}: {view_at} has byteStride {s}, but glTF requires a multiple of 4 from 4 to 252, and at least accessor {a}'s {elem}-byte elements; export the file again");
        }
    }
    let stride = v.byte_stride.map_or(elem, |s| s.0 as u128);
    let count = acc.count.0 as u128;
    let offset = acc.byte_offset.map_or(0, |o| o.0) as u128;
    let length = v.byte_length.0 as u128;
    if count > 0 && offset + (count - 1) * stride + elem > length {
        bail!("{at}: accessor {a} ({count} elements of {elem} bytes, {stride} apart, from byte {offset}) runs past its {view_at}'s {length} bytes; fix the accessor's count or byteOffset, or export the file again");
    }
    let buffer = &root.buffers[v.buffer.value()];
    let end = v.byte_offset.map_or(0, |o| o.0) as u128 + length;
    if end > buffer.byte_length.0 as u128 {
        bail!("{at}: {view_at} ends at byte {end}, past the {} bytes of buffer {}; fix its byteOffset or byteLength, or export the file again", buffer.byte_length.0, v.buffer.value());
    }
    Ok(())
}

/// "VEC3 of FLOAT": an accessor's type as glTF spells it.
fn accessor_kind(acc: &gltf::json::Accessor) -> String {
    let t = match acc.type_ {
        Checked::Valid(t) => match t {
            Type::Scalar => "SCALAR",
            Type::Vec2 => "VEC2",
            Type::Vec3 => "VEC3",
            Type::Vec4 => "VEC4",
            Type::Mat2 => "MAT2",
            Type::Mat3 => "MAT3",
            Type::Mat4 => "MAT4",
        },
        Checked::Invalid => "an unknown type",
    };
    let c = match acc.component_type {
        Checked::Valid(GenericComponentType(c)) => match c {
            ComponentType::I8 => "BYTE",
            ComponentType::U8 => "UNSIGNED_BYTE",
            ComponentType::I16 => "SHORT",
            ComponentType::U16 => "UNSIGNED_SHORT",
            ComponentType::U32 => "UNSIGNED_INT",
            ComponentType::F32 => "FLOAT",
        },
        Checked::Invalid => "an unknown component type",
    };
    format!("{t} of {c}")
}

/// glTF node hierarchies are trees (glTF 2.0 §3.5.3): a node that is its own ancestor is
/// named (before, a cycle was walked until the triangle limit and reported as a huge scene),
/// and so is a node with two parents or a scene root listed twice or also a child: each was
/// flattened once per path to it, a coincident copy of its triangles and lights with exit 0
/// (an audit, 2026-12-06: the lamp counted twice, 3 lights became 5).
fn check_node_tree(root: &Root, name: &str) -> Result<()> {
    // A cycle first, so that one through a root is named as a cycle.
    check_node_cycles(root, name)?;
    let mut parent: Vec<Option<usize>> = vec![None; root.nodes.len()];
    for (p, node) in root.nodes.iter().enumerate() {
        for c in node.children.as_deref().unwrap_or(&[]) {
            let c = c.value();
            // Out of range: the crate's validation names it.
            let Some(slot) = parent.get_mut(c) else {
                continue;
            };
            match *slot {
                Some(q) if q == p => bail!("'{name}': node {p} lists node {c} twice among its children; list it once"),
                Some(q) => bail!("'{name}': node {c} is a child of node {q} and of node {p}; a glTF node hierarchy must be a tree (one parent a node): give one of them its own copy of the node"),
                None => *slot = Some(p),
            }
        }
    }
    for (i, scene) in root.scenes.iter().enumerate() {
        let mut listed = std::collections::HashSet::new();
        for n in &scene.nodes {
            let n = n.value();
            if !listed.insert(n) {
                bail!(
                    "'{name}': scene {i} lists node {n} twice among its root nodes; list it once"
                );
            }
            if let Some(Some(p)) = parent.get(n) {
                bail!("'{name}': scene {i} lists node {n} as a root node, but it is a child of node {p}; list only nodes without a parent");
            }
        }
    }
    Ok(())
}

fn check_node_cycles(root: &Root, name: &str) -> Result<()> {
    // 0: not seen, 1: on the current path, 2: done. Iterative depth-first search.
    let mut state = vec![0u8; root.nodes.len()];
    for start in 0..root.nodes.len() {
        if state[start] != 0 {
            continue;
        }
        let mut stack = vec![(start, 0usize)];
        state[start] = 1;
        while let Some((n, next)) = stack.last_mut() {
            let children = root.nodes[*n].children.as_deref().unwrap_or(&[]);
            let Some(c) = children.get(*next) else {
                state[*n] = 2;
                stack.pop();
                continue;
            };
            *next += 1;
            let c = c.value();
            match state.get(c) {
                Some(1) => bail!("'{name}': node {c} is its own ancestor (a cycle in the nodes' `children`); a glTF node hierarchy must be a tree"),
                Some(0) => {
                    state[c] = 1;
                    stack.push((c, 0));
                }
                _ => {} // done already, or out of range (the crate's validation names it)
            }
        }
    }
    Ok(())
}

/// Node rotations must be unit quaternions (glTF 2.0 §3.5.3). One of length 0 (or not
/// finite) names no rotation at all: refused. The loader normalizes one whose length is off
/// by more than float noise (`rotation_is_unit`) and says so: without that, the rotation
/// matrix of a quaternion of length 0 is the identity and of any other length a skew, so
/// the image came out silently wrong.
fn check_rotations(root: &Root, name: &str) -> Result<()> {
    for (i, node) in root.nodes.iter().enumerate() {
        if let Some(r) = &node.rotation {
            let len = rotation_length(r.0);
            if !(len.is_finite() && len > 1e-6) {
                bail!(
                    "'{name}': node {i} ('{}') has the rotation {:?}, which is not a quaternion (length {len}); use a unit quaternion [x, y, z, w], [0, 0, 0, 1] for none",
                    node.name.as_deref().unwrap_or(""),
                    r.0
                );
            }
        }
    }
    Ok(())
}

/// Node matrices are affine, as TRS is (glTF 2.0 §3.5.2): the loader applies a matrix as an
/// affine map, so a perspective last row was dropped without a word (an audit, 2026-12-06).
fn check_matrices(root: &Root, name: &str) -> Result<()> {
    for (i, node) in root.nodes.iter().enumerate() {
        if let Some(m) = &node.matrix {
            // Column-major: the last row is elements 3, 7, 11 and 15.
            let row = [m[3], m[7], m[11], m[15]];
            // Written so that a NaN fails too.
            let affine = row[..3].iter().all(|c| c.abs() <= 1e-6) && (row[3] - 1.0).abs() <= 1e-6;
            if !affine {
                bail!(
                    "'{name}': node {i} ('{}') has a matrix whose last row is {row:?}, not [0, 0, 0, 1]: glTF node matrices are affine (translation, rotation, scale); export it again",
                    node.name.as_deref().unwrap_or("")
                );
            }
        }
    }
    Ok(())
}

/// Whether a node rotation's length is 1 within float noise (the Khronos validator's 5e-4 is
/// looser; 1e-3 here keeps every file it accepts exactly as before).
pub fn rotation_is_unit(r: [f32; 4]) -> bool {
    (rotation_length(r) - 1.0).abs() <= 1e-3
}

/// The length of a node rotation's quaternion [x, y, z, w].
pub fn rotation_length(r: [f32; 4]) -> f32 {
    r.iter().map(|c| c * c).sum::<f32>().sqrt()
}

/// The glTF extensions the loader reads; every other one a file uses is ignored.
pub const SUPPORTED_EXTENSIONS: [&str; 4] = [
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_texture_transform",
];

/// The gltf crate indexes with unwrap in a few places; gltf_check catches the cases we know,
/// and a malformed file that slips past it must still give one clear line, never a panic's
/// text (the hook is silenced while the loader runs).
pub fn guarded<T>(name: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    let result = silenced(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)));
    match result {
        Ok(r) => r,
        Err(_) => bail!(
            "'{name}': the glTF file is malformed in a way the parser could not report; \
             check it with the Khronos glTF validator"
        ),
    }
}

thread_local! {
    static SILENT: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with panic messages of this thread silenced (other threads' panics still print):
/// a hook installed once that defers to the previous one unless the panicking thread asked
/// for silence.
fn silenced<T>(f: impl FnOnce() -> T) -> T {
    static INSTALL: std::sync::Once = std::sync::Once::new();
    INSTALL.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !SILENT.with(|s| s.get()) {
                previous(info)
            }
        }));
    });
    SILENT.with(|s| s.set(true));
    let out = f();
    SILENT.with(|s| s.set(false));
    out
}
