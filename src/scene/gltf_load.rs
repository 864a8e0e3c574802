//! glTF 2.0 loading (.gltf with external or `data:` buffers, and .glb).
//!
//! Conventions (also in the README):
//! - KHR_lights_punctual `intensity × color` is radiant intensity in W/sr; `range` is ignored
//!   (physically based falloff only), directional lights are skipped with a warning.
//! - Emission `emissiveFactor × KHR_materials_emissive_strength` is radiance, emitted from the
//!   counter-clockwise front face, from both faces when the material is `doubleSided`. Every
//!   triangle with non-zero emission is an area light.
//! - Point and line primitives are skipped with a warning (an error if nothing else is left);
//!   triangle strips and fans are converted to triangles.
//! - Materials: glTF metallic-roughness (Lambert + GGX; the diffuse base coupled to the
//!   layer as in shaders/shared/bsdf.glsl, which says why) with KHR_materials_specular factors; metallic-roughness, normal and specular textures are
//!   ignored with a warning.
//! - The first camera in the scene is used, else a default camera that frames the scene.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use base64::Engine;
use glam::{Mat4, Vec3, Vec4Swizzles};
use gltf::mesh::Mode;

use super::{Camera, Light, Material, Scene, Texture, Wrap};

/// Largest scene we accept, so a corrupt index count cannot exhaust memory. The GPU BVH and
/// light buffers must fit lavapipe's 128 MiB storage-buffer limit: 48 B per triangle.
pub const MAX_TRIANGLES: usize = 2_500_000;

/// Load a glTF/GLB file. Warnings (skipped primitives, unsupported lights) go to `warn`.
pub fn load(path: &Path, warn: &mut dyn FnMut(String)) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| {
        anyhow!(
            "cannot read scene file '{}': {e}. Check the path (run `lightlearn render --help` for usage).",
            path.display()
        )
    })?;
    let name = path.display().to_string();
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    // The gltf crate indexes with unwrap in a few places after validation; a malformed file
    // that slips past validation must still give an error, never a panic.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        load_bytes(&bytes, &name, &base, warn)
    }));
    match result {
        Ok(r) => r,
        Err(_) => bail!(
            "'{name}': the glTF file is malformed in a way the parser could not report; \
             check it with the Khronos glTF validator"
        ),
    }
}

/// Load from bytes; `name` is used in messages and `base` resolves relative buffer URIs.
pub fn load_bytes(
    bytes: &[u8],
    name: &str,
    base: &Path,
    warn: &mut dyn FnMut(String),
) -> Result<Scene> {
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| {
        anyhow!(
            "'{name}' is not a valid glTF 2.0 file (.gltf or .glb): {e}. \
             Export it again or check it with the Khronos glTF validator."
        )
    })?;
    let buffers = load_buffers(&gltf, name, base)?;
    let doc = &gltf.document;

    let gltf_scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| anyhow!("'{name}' has no scene (glTF `scenes` is empty); add a scene that lists the root nodes"))?;

    let mut materials: Vec<Material> = Vec::new();
    let mut material_index: HashMap<Option<usize>, u32> = HashMap::new();
    let mut scene = Scene {
        triangles: Vec::new(),
        triangle_material: Vec::new(),
        materials: Vec::new(),
        lights: Vec::new(),
        camera: Camera::framing(Vec3::ZERO, Vec3::ONE),
        textures: Vec::new(),
        triangle_uv: Vec::new(),
        source: name.to_string(),
    };
    // glTF texture index → our texture (None: could not be used, already warned about).
    let mut texture_index: HashMap<usize, Option<u32>> = HashMap::new();
    let images = Images {
        buffers: &buffers,
        base,
        file: name,
    };
    let mut camera: Option<Camera> = None;
    let mut skipped_primitives = 0usize;
    let mut lights_with_range = 0usize;

    // Depth-first over the node hierarchy with accumulated world transforms, in document
    // order (the stack is filled in reverse), so triangles and lights keep the file's order.
    let mut stack: Vec<(gltf::Node, Mat4)> =
        gltf_scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 1_000_000 {
            bail!("'{name}': the node hierarchy is too deep or cyclic");
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        let node_label = node_label(&node);
        if !world.is_finite() {
            bail!("'{name}': {node_label} has a non-finite transform (NaN or Inf); fix its matrix/TRS");
        }

        if let Some(mesh) = node.mesh() {
            // Negative determinant mirrors the mesh and flips its winding (glTF 2.0 §3.7.4).
            let flip = world.determinant() < 0.0;
            for prim in mesh.primitives() {
                let mesh_label = format!(
                    "mesh {} ('{}') primitive {}",
                    mesh.index(),
                    mesh.name().unwrap_or(""),
                    prim.index()
                );
                let mode = prim.mode();
                if matches!(
                    mode,
                    Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
                ) {
                    skipped_primitives += 1;
                    warn(format!(
                        "'{name}': {mesh_label} has mode {mode:?}, not triangles; skipped"
                    ));
                    continue;
                }
                let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
                let positions: Vec<[f32; 3]> = reader
                    .read_positions()
                    .ok_or_else(|| {
                        anyhow!("'{name}': {mesh_label} has no readable POSITION attribute (missing, or its buffer view lies outside the buffer)")
                    })?
                    .collect();
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None if prim.indices().is_some() => {
                        bail!("'{name}': {mesh_label}: its index accessor lies outside its buffer")
                    }
                    None => (0..positions.len() as u32).collect(),
                };
                let tris = triangulate(mode, &indices);
                let world_pos: Vec<Vec3> = positions
                    .iter()
                    .map(|p| (world * Vec3::from(*p).extend(1.0)).xyz())
                    .collect();
                if let Some(bad) = world_pos.iter().position(|p| !p.is_finite()) {
                    bail!(
                        "'{name}': {mesh_label} vertex {bad} has a non-finite position (NaN or Inf); fix the mesh data"
                    );
                }
                let mat = material_slot(
                    &prim.material(),
                    name,
                    &mut materials,
                    &mut material_index,
                    &mut scene.textures,
                    &mut texture_index,
                    &images,
                    warn,
                )?;
                // Texture coordinates of the set the material's base-colour texture uses.
                let uvs: Vec<[f32; 2]> = match (
                    materials[mat as usize].base_color_texture,
                    prim.material()
                        .pbr_metallic_roughness()
                        .base_color_texture(),
                ) {
                    (Some(_), Some(info)) => match reader.read_tex_coords(info.tex_coord()) {
                        Some(t) => {
                            let uvs: Vec<[f32; 2]> = t.into_f32().collect();
                            if let Some(bad) = uvs
                                .iter()
                                .position(|t| !(t[0].is_finite() && t[1].is_finite()))
                            {
                                bail!("'{name}': {mesh_label} vertex {bad} has a non-finite texture coordinate (NaN or Inf); fix the mesh data");
                            }
                            uvs
                        }
                        None => {
                            warn(format!(
                                "'{name}': {mesh_label} has a base-colour texture but no TEXCOORD_{}; it samples the texture at (0, 0)",
                                info.tex_coord()
                            ));
                            Vec::new()
                        }
                    },
                    _ => Vec::new(),
                };
                let uv = |i: u32| uvs.get(i as usize).copied().unwrap_or([0.0, 0.0]);
                for [a, b, c] in tris {
                    let get = |i: u32| {
                        world_pos.get(i as usize).copied().ok_or_else(|| {
                            anyhow!(
                                "'{name}': {mesh_label} index {i} is out of range ({} vertices)",
                                world_pos.len()
                            )
                        })
                    };
                    let (va, vb, vc) = (get(a)?, get(b)?, get(c)?);
                    let tri = if flip { [va, vc, vb] } else { [va, vb, vc] };
                    // Degenerate triangles can never be hit and have no area to emit from.
                    if (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared() == 0.0 {
                        continue;
                    }
                    scene.triangles.push(tri);
                    // Coordinates are kept from the first textured triangle on (earlier ones
                    // get zeros), so untextured scenes never hold them.
                    if !uvs.is_empty() || !scene.triangle_uv.is_empty() {
                        scene
                            .triangle_uv
                            .resize(scene.triangles.len() - 1, [[0.0; 2]; 3]);
                        scene.triangle_uv.push(if flip {
                            [uv(a), uv(c), uv(b)]
                        } else {
                            [uv(a), uv(b), uv(c)]
                        });
                    }
                    scene.triangle_material.push(mat);
                    if scene.triangles.len() > MAX_TRIANGLES {
                        bail!(
                            "'{name}' has more than {MAX_TRIANGLES} triangles, the most lightlearn supports; simplify the scene"
                        );
                    }
                }
            }
        }

        if camera.is_none() {
            if let Some(cam) = node.camera() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) => {
                        let position = (world * glam::Vec4::new(0.0, 0.0, 0.0, 1.0)).xyz();
                        let forward = (world * glam::Vec4::new(0.0, 0.0, -1.0, 0.0)).xyz();
                        let up = (world * glam::Vec4::new(0.0, 1.0, 0.0, 0.0)).xyz();
                        let yfov = p.yfov();
                        if !(yfov > 1e-4 && yfov < std::f32::consts::PI - 1e-4)
                            || forward.length_squared() == 0.0
                        {
                            bail!("'{name}': camera {} has an invalid yfov ({yfov}) or a degenerate transform; use 0 < yfov < π", cam.index());
                        }
                        camera = Some(Camera::look_at(
                            position,
                            position + forward.normalize(),
                            up.normalize(),
                            yfov,
                        ));
                    }
                    gltf::camera::Projection::Orthographic(_) => warn(format!(
                        "'{name}': camera {} is orthographic, which is not supported; ignored",
                        cam.index()
                    )),
                }
            }
        }

        if let Some(light) = node.light() {
            let label = format!("light {} ('{}')", light.index(), light.name().unwrap_or(""));
            let intensity = Vec3::from(light.color()) * light.intensity();
            if !intensity.is_finite() || intensity.min_element() < 0.0 {
                bail!("'{name}': {label} has a non-finite or negative color × intensity ({intensity}); use finite values ≥ 0");
            }
            let position = (world * glam::Vec4::new(0.0, 0.0, 0.0, 1.0)).xyz();
            let direction = (world * glam::Vec4::new(0.0, 0.0, -1.0, 0.0)).xyz();
            lights_with_range += light.range().is_some() as usize;
            if intensity.max_element() == 0.0 {
                warn(format!("'{name}': {label} has zero intensity; skipped"));
            } else {
                match light.kind() {
                    gltf::khr_lights_punctual::Kind::Point => scene.lights.push(Light::Point {
                        position,
                        intensity,
                    }),
                    gltf::khr_lights_punctual::Kind::Spot {
                        inner_cone_angle,
                        outer_cone_angle,
                    } => {
                        if direction.length_squared() == 0.0 {
                            bail!("'{name}': {label} sits on a node with a degenerate transform; its direction is undefined");
                        }
                        let outer = outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2);
                        let inner = inner_cone_angle.clamp(0.0, outer);
                        scene.lights.push(Light::Spot {
                            position,
                            direction: direction.normalize(),
                            intensity,
                            cos_inner: inner.cos(),
                            cos_outer: outer.cos(),
                        })
                    }
                    gltf::khr_lights_punctual::Kind::Directional => warn(format!(
                        "'{name}': {label} is directional, which lightlearn does not support yet; skipped (use an emissive quad or point lights)"
                    )),
                }
            }
        }

        let first_child = stack.len();
        stack.extend(node.children().map(|c| (c, world)));
        stack[first_child..].reverse();
    }

    if lights_with_range > 0 {
        warn(format!(
            "'{name}': {lights_with_range} lights set `range`; lightlearn ignores it (inverse-square falloff only)"
        ));
    }
    if scene.triangles.is_empty() {
        let extra = if skipped_primitives > 0 {
            format!(" ({skipped_primitives} point/line primitives were skipped)")
        } else {
            String::new()
        };
        bail!("'{name}' has no triangles{extra}; lightlearn needs triangle meshes to render");
    }

    // Every emissive triangle is an area light.
    for (i, &m) in scene.triangle_material.iter().enumerate() {
        if materials[m as usize].emission.max_element() > 0.0 {
            scene.lights.push(Light::Triangle { triangle: i as u32 });
        }
    }
    scene.materials = materials;
    if scene.textures.is_empty() {
        scene.triangle_uv = Vec::new();
    } else {
        scene
            .triangle_uv
            .resize(scene.triangles.len(), [[0.0; 2]; 3]);
    }
    if scene.lights.is_empty() {
        bail!(
            "'{name}' has no lights: add KHR_lights_punctual point/spot lights or give a material a non-zero emissiveFactor"
        );
    }
    let (lo, hi) = scene.bounds();
    scene.camera = camera.unwrap_or_else(|| Camera::framing(lo, hi));
    Ok(scene)
}

fn node_label(node: &gltf::Node) -> String {
    format!("node {} ('{}')", node.index(), node.name().unwrap_or(""))
}

/// Index of our material for a glTF material (the default material gets its own slot).
#[allow(clippy::too_many_arguments)]
fn material_slot(
    m: &gltf::Material,
    file: &str,
    materials: &mut Vec<Material>,
    index: &mut HashMap<Option<usize>, u32>,
    textures: &mut Vec<Texture>,
    texture_index: &mut HashMap<usize, Option<u32>>,
    images: &Images,
    warn: &mut dyn FnMut(String),
) -> Result<u32> {
    if let Some(&i) = index.get(&m.index()) {
        return Ok(i);
    }
    let label = match m.index() {
        Some(i) => format!("material {i} ('{}')", m.name().unwrap_or("")),
        None => "the default material".to_string(),
    };
    let base = m.pbr_metallic_roughness().base_color_factor();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emission = Vec3::from(m.emissive_factor()) * strength;
    let base_color = Vec3::new(base[0], base[1], base[2]);
    if !emission.is_finite() || emission.min_element() < 0.0 {
        bail!("'{file}': {label} has a non-finite or negative emission (emissiveFactor × emissiveStrength = {emission}); use finite values ≥ 0");
    }
    if !base_color.is_finite() || base_color.min_element() < 0.0 {
        bail!(
            "'{file}': {label} has a non-finite or negative baseColorFactor; use values in [0, 1]"
        );
    }
    let pbr = m.pbr_metallic_roughness();
    let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
    if !(0.0..=1.0).contains(&metallic) || !(0.0..=1.0).contains(&roughness) {
        bail!(
            "'{file}': {label} has metallicFactor {metallic} and roughnessFactor {roughness}; \
             both must be in [0, 1]"
        );
    }
    let (specular, specular_color) = match m.specular() {
        Some(sp) => (sp.specular_factor(), Vec3::from(sp.specular_color_factor())),
        None => (1.0, Vec3::ONE),
    };
    if !(0.0..=1.0).contains(&specular)
        || !specular_color.is_finite()
        || specular_color.min_element() < 0.0
    {
        bail!(
            "'{file}': {label} has KHR_materials_specular specularFactor {specular} and \
             specularColorFactor {specular_color}; use a factor in [0, 1] and colours ≥ 0"
        );
    }
    let ignored = [
        (
            pbr.metallic_roughness_texture().is_some(),
            "a metallicRoughnessTexture",
        ),
        (m.normal_texture().is_some(), "a normal texture"),
        (
            m.specular().is_some_and(|sp| {
                sp.specular_texture().is_some() || sp.specular_color_texture().is_some()
            }),
            "a specular texture",
        ),
    ];
    for (present, what) in ignored {
        if present {
            warn(format!(
                "'{file}': {label} has {what}; lightlearn uses the material's factors only"
            ));
        }
    }
    if m.emissive_texture().is_some() {
        // Not sampled: say so instead of silently rendering a flat colour.
        warn(format!(
            "'{file}': {label} has an emissive texture; lightlearn uses emissiveFactor only"
        ));
    }
    let base_color_texture = match m.pbr_metallic_roughness().base_color_texture() {
        None => None,
        Some(info) => {
            let t = info.texture();
            if let Some(&known) = texture_index.get(&t.index()) {
                known
            } else {
                let loaded = match images.decode(&t) {
                    Ok(tex) => {
                        textures.push(tex);
                        Some(textures.len() as u32 - 1)
                    }
                    Err(e) => {
                        warn(format!("'{file}': {label}: base-colour texture {}: {e}; using baseColorFactor alone", t.index()));
                        None
                    }
                };
                texture_index.insert(t.index(), loaded);
                loaded
            }
        }
    };
    let slot = materials.len() as u32;
    materials.push(Material {
        name: m.name().unwrap_or("").to_string(),
        base_color: base_color.clamp(Vec3::ZERO, Vec3::ONE),
        metallic,
        roughness,
        specular,
        specular_color,
        emission,
        double_sided: m.double_sided(),
        base_color_texture,
    });
    index.insert(m.index(), slot);
    Ok(slot)
}

/// Where a glTF file's images come from: its buffers and folder.
struct Images<'a> {
    buffers: &'a [Vec<u8>],
    base: &'a Path,
    file: &'a str,
}

impl Images<'_> {
    /// The texture's image decoded (PNG only; the error says why it cannot be used).
    fn decode(&self, t: &gltf::Texture) -> Result<Texture> {
        let image = t.source();
        let bytes: Vec<u8> = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let data = self
                    .buffers
                    .get(view.buffer().index())
                    .ok_or_else(|| anyhow!("image {} lies in a missing buffer", image.index()))?;
                data.get(view.offset()..view.offset() + view.length())
                    .ok_or_else(|| {
                        anyhow!(
                            "image {}'s buffer view lies outside its buffer",
                            image.index()
                        )
                    })?
                    .to_vec()
            }
            gltf::image::Source::Uri { uri, .. } => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
                        anyhow!("image {} has a data: URI that is not base64", image.index())
                    })?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| anyhow!("image {}: bad base64 data ({e})", image.index()))?
                } else {
                    let path = self.base.join(percent_decode(uri));
                    std::fs::read(&path).map_err(|e| {
                        anyhow!(
                            "cannot read image '{}' ({e}); keep it next to '{}'",
                            path.display(),
                            self.file
                        )
                    })?
                }
            }
        };
        if !bytes.starts_with(b"\x89PNG") {
            bail!(
                "image {} is not a PNG (only PNG textures are supported so far)",
                image.index()
            );
        }
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut reader = decoder
            .read_info()
            .map_err(|e| anyhow!("image {}: {e}", image.index()))?;
        let mut buf = vec![0u8; reader.output_buffer_size()];
        let frame = reader
            .next_frame(&mut buf)
            .map_err(|e| anyhow!("image {}: {e}", image.index()))?;
        let (w, h) = (frame.width, frame.height);
        let data = &buf[..frame.buffer_size()];
        let texels: Vec<[u8; 4]> = match frame.color_type {
            png::ColorType::Rgba => data
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect(),
            png::ColorType::Rgb => data
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2], 255])
                .collect(),
            png::ColorType::GrayscaleAlpha => data
                .chunks_exact(2)
                .map(|c| [c[0], c[0], c[0], c[1]])
                .collect(),
            png::ColorType::Grayscale => data.iter().map(|&g| [g, g, g, 255]).collect(),
            png::ColorType::Indexed => bail!("image {}: palette not expanded", image.index()),
        };
        if w == 0 || h == 0 || texels.len() != (w * h) as usize {
            bail!("image {} has a bad size {w}×{h}", image.index());
        }
        let wrap = |m: gltf::texture::WrappingMode| match m {
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        };
        let s = t.sampler();
        Ok(Texture {
            width: w,
            height: h,
            texels,
            wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())],
        })
    }
}

/// Triangles of a primitive as index triples.
fn triangulate(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => Vec::new(),
    }
}

fn load_buffers(gltf: &gltf::Gltf, name: &str, base: &Path) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                anyhow!(
                    "'{name}': buffer {} refers to the GLB binary chunk, but the file has none",
                    buffer.index()
                )
            })?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
                        anyhow!(
                            "'{name}': buffer {} has a data: URI that is not base64",
                            buffer.index()
                        )
                    })?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| {
                            anyhow!("'{name}': buffer {}: bad base64 data ({e})", buffer.index())
                        })?
                } else {
                    let path: PathBuf = base.join(percent_decode(uri));
                    std::fs::read(&path).with_context(|| {
                        format!(
                            "'{name}': cannot read buffer {} from '{}'; keep the .bin file next to the .gltf",
                            buffer.index(),
                            path.display()
                        )
                    })?
                }
            }
        };
        if data.len() < buffer.length() {
            bail!(
                "'{name}': buffer {} holds {} bytes but declares {}; the file is truncated",
                buffer.index(),
                data.len(),
                buffer.length()
            );
        }
        out.push(data);
    }
    Ok(out)
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = std::str::from_utf8(&b[i + 1..i + 3]).ok();
            if let Some(v) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}
