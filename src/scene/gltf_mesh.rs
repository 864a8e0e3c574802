//! A glTF scene's meshes → triangles in world space (f64, until the scene's frame is known),
//! with their materials and texture coordinates; what cannot be read is refused naming the
//! primitive, and triangles that lose their area are counted for the loader's messages.

use anyhow::{anyhow, bail, Result};
use glam::{DMat4, DVec3, Vec3, Vec4};
use gltf::accessor::Dimensions;
use gltf::mesh::Mode;

use super::gltf_tangents::{FrameCounts, Tangents};

use super::gltf_material::MaterialTable;

/// Largest scene we accept, so a corrupt index count cannot exhaust memory. The GPU BVH and
/// light buffers must fit lavapipe's 128 MiB storage-buffer limit: 48 B per triangle.
pub const MAX_TRIANGLES: usize = 2_500_000;

/// The triangles of every mesh instance met so far, in the file's order.
#[derive(Default)]
pub(super) struct Meshes {
    pub triangles: Vec<[DVec3; 3]>,
    /// Texture coordinates, kept from the first textured triangle on (earlier ones get
    /// zeros), so untextured scenes never hold them.
    pub triangle_uv: Vec<[[f32; 2]; 3]>,
    /// Shading normals (world space, unit), kept from the first smooth triangle on (earlier
    /// ones get zeros: flat), so flat-shaded scenes never hold them.
    pub triangle_normals: Vec<[Vec3; 3]>,
    /// Tangent frames of the triangles of normal-mapped materials, kept from the first one on
    /// (others get zeros), so scenes without normal textures never hold them.
    pub triangle_tangents: Vec<[Vec4; 3]>,
    pub triangle_material: Vec<u32>,
    /// Point and line primitives, skipped with a warning.
    pub skipped_primitives: usize,
    /// Triangles with an area in the file that their node's transform left without one:
    /// a far translation rounds them away even in f64 (walls moved to 3e38 vanished
    /// without a word: an audit, 2026-12-06). A singular transform (a scale of 0, which
    /// hides an object on purpose) is not counted.
    pub lost_to_position: usize,
    /// Those of them that emit.
    pub lost_emitters: usize,
    /// Emitting triangles a singular transform hid (a scale of 0, or an animation keyed
    /// to it): if no light is left, they, not a missing emitter, are why.
    pub hidden_emitters: usize,
}

impl Meshes {
    /// Adds the triangles of `mesh` placed by `world`.
    pub fn add(
        &mut self,
        mesh: &gltf::Mesh,
        world: DMat4,
        buffers: &[Vec<u8>],
        name: &str,
        table: &mut MaterialTable,
        warn: &mut dyn FnMut(String),
    ) -> Result<()> {
        // Negative determinant mirrors the mesh and flips its winding (glTF 2.0 §3.7.4).
        let det = world.determinant();
        let flip = det < 0.0;
        let regular = det != 0.0 && det.is_finite();
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
                self.skipped_primitives += 1;
                warn(format!(
                    "'{name}': {mesh_label} has mode {mode:?}, not triangles; skipped"
                ));
                continue;
            }
            // The accessors read below: positions, indices and the texture-coordinate
            // set the material's textures read (gltf_check checks the same).
            let uv_set = coordinate_map(&prim.material()).map(|u| gltf::Semantic::TexCoords(u.set));
            let read = [Some(gltf::Semantic::Positions), uv_set]
                .into_iter()
                .flatten()
                .filter_map(|sem| prim.get(&sem));
            for a in read.chain(prim.indices()) {
                super::gltf_data::check_sparse(&a, buffers, &format!("'{name}': {mesh_label}"))?;
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
            // A triangle list of 3k + 1 or + 2 indices is malformed glTF; its last
            // indices were dropped without a word (an audit, 2026-12-06).
            if mode == Mode::Triangles && !indices.len().is_multiple_of(3) {
                bail!("'{name}': {mesh_label} is a triangle list of {} {}, not a multiple of 3; fix the mesh data", indices.len(), if prim.indices().is_some() { "indices" } else { "vertices" });
            }
            let tris = triangulate(mode, &indices);
            let world_pos: Vec<DVec3> = positions
                .iter()
                .map(|p| world.transform_point3(Vec3::from(*p).as_dvec3()))
                .collect();
            if let Some(bad) = world_pos.iter().position(|p| !p.is_finite()) {
                bail!(
                    "'{name}': {mesh_label} vertex {bad} has a non-finite position (NaN or Inf); fix the mesh data"
                );
            }
            let mat = table.slot(&prim.material(), name, warn)?;
            let emits = table.emits(mat);
            // Texture coordinates of the set the material's textures use, where one of them
            // loaded (gltf_material keeps an emissive or metallic-roughness texture only on
            // the mapping coordinate_map picks, so this is the set checked above).
            let material = &table.materials[mat as usize];
            let map = (material.base_color_texture.is_some()
                || material.emissive_texture.is_some()
                || material.metallic_roughness_texture.is_some()
                || material.normal_texture.is_some())
            .then(|| coordinate_map(&prim.material()))
            .flatten();
            let uvs: Vec<[f32; 2]> = match map {
                Some(UvMap { set, .. }) => match reader.read_tex_coords(set) {
                    Some(t) => {
                        // As KHR_texture_transform maps them (once here, not per lookup).
                        let map = map.expect("matched");
                        let uvs: Vec<[f32; 2]> = t.into_f32().map(|c| map.apply(c)).collect();
                        // One coordinate a vertex (glTF: every attribute has POSITION's
                        // count); a short one was read as (0, 0) past its end.
                        if uvs.len() != positions.len() {
                            bail!("'{name}': {mesh_label} has {} TEXCOORD_{} values for {} vertices; an attribute needs one a vertex", uvs.len(), set, positions.len());
                        }
                        if let Some(bad) = uvs
                            .iter()
                            .position(|t| !(t[0].is_finite() && t[1].is_finite()))
                        {
                            bail!("'{name}': {mesh_label} vertex {bad} has a non-finite texture coordinate (NaN or Inf, in the file or after its KHR_texture_transform); fix the mesh data");
                        }
                        uvs
                    }
                    None => {
                        // A normal texture needs the coordinates for its frames too: without
                        // them it is not applied (an audit, 2026-12-07, found this said as
                        // "sampled at (0, 0)").
                        let normal = if material.normal_texture.is_some() {
                            "; its normal texture is not applied (its frames need them)"
                        } else {
                            ""
                        };
                        warn(format!(
                            "'{name}': {mesh_label} has a texture but no TEXCOORD_{}; it samples the texture at (0, 0){normal}",
                            set
                        ));
                        Vec::new()
                    }
                },
                None => Vec::new(),
            };
            let uv = |i: u32| uvs.get(i as usize).copied().unwrap_or([0.0, 0.0]);
            let normals = if regular {
                match world_normals(&prim, &reader, world, positions.len(), buffers) {
                    Ok(n) => n,
                    // Said, as the smooth-normals warning before interpolation said them (an
                    // audit, 2026-12-07: such a mesh rendered flat without a word).
                    Err(why) => {
                        warn(format!("'{name}': {mesh_label} has vertex normals (NORMAL) lightlearn cannot read ({why}); it is shaded flat"));
                        Vec::new()
                    }
                }
            } else {
                Vec::new()
            };
            // A normal texture's frames: the file's TANGENT, else computed from the
            // coordinates it reads (gltf_tangents.rs).
            let normal_mapped = material.normal_texture.is_some() && regular && !uvs.is_empty();
            let tangents = if normal_mapped {
                let label = format!("'{name}': {mesh_label}");
                Tangents::of(
                    &prim,
                    &reader,
                    world,
                    &world_pos,
                    &uvs,
                    &tris,
                    !normals.is_empty(),
                    buffers,
                    &label,
                    warn,
                )
            } else {
                Tangents::None
            };
            let mut frames = FrameCounts::default();
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
                // Degenerate triangles can never be hit and have no area to emit from
                // (those that become degenerate in f32 are dropped by the loader).
                if (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared() == 0.0 {
                    let file = [a, b, c].map(|i| Vec3::from(positions[i as usize]).as_dvec3());
                    let had_area = (file[1] - file[0])
                        .cross(file[2] - file[0])
                        .length_squared()
                        > 0.0;
                    let lost = regular && had_area;
                    self.lost_to_position += lost as usize;
                    self.lost_emitters += (lost && emits) as usize;
                    self.hidden_emitters += (!regular && had_area && emits) as usize;
                    continue;
                }
                self.triangles.push(tri);
                if !uvs.is_empty() || !self.triangle_uv.is_empty() {
                    self.triangle_uv
                        .resize(self.triangles.len() - 1, [[0.0; 2]; 3]);
                    self.triangle_uv.push(if flip {
                        [uv(a), uv(c), uv(b)]
                    } else {
                        [uv(a), uv(b), uv(c)]
                    });
                }
                let corners = if flip { [a, c, b] } else { [a, b, c] };
                // A normal-mapped triangle keeps its vertex normals, flat or not: they are its
                // frames' normals, as the tangents were made for them.
                let kept = smooth_corners(&normals, corners, &tri).or_else(|| {
                    normal_mapped
                        .then(|| usable_corners(&normals, corners))
                        .flatten()
                });
                if let Some(n) = kept {
                    self.triangle_normals
                        .resize(self.triangles.len() - 1, [Vec3::ZERO; 3]);
                    self.triangle_normals.push(n);
                } else if !self.triangle_normals.is_empty() {
                    self.triangle_normals.push([Vec3::ZERO; 3]);
                }
                // The frame's normal at each corner: the kept vertex normal, else the
                // triangle's own (the kernel's for a flat triangle: its winding's).
                let face = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
                let base = kept.map_or([face; 3], |n| n.map(|v| v.as_dvec3()));
                if let Some(t) = tangents.corners([a, b, c], base, flip, &mut frames) {
                    self.triangle_tangents
                        .resize(self.triangles.len() - 1, [Vec4::ZERO; 3]);
                    self.triangle_tangents.push(t);
                } else if !self.triangle_tangents.is_empty() {
                    self.triangle_tangents.push([Vec4::ZERO; 3]);
                }
                self.triangle_material.push(mat);
                if self.triangles.len() > MAX_TRIANGLES {
                    bail!(
                        "'{name}' has more than {MAX_TRIANGLES} triangles, the most lightlearn supports; simplify the scene"
                    );
                }
            }
            frames.say(&format!("'{name}': {mesh_label}"), warn);
        }
        Ok(())
    }
}

/// Whether the primitive has attribute `semantic` (false: it has none) as lightlearn reads
/// it: plain floats of `dims`, one a vertex, an accessor the reader can read; else why not.
pub(super) fn float_attribute(
    prim: &gltf::Primitive,
    semantic: &gltf::Semantic,
    dims: gltf::accessor::Dimensions,
    what: &str,
    vertices: usize,
    buffers: &[Vec<u8>],
) -> std::result::Result<bool, String> {
    let Some(a) = prim.get(semantic) else {
        return Ok(false);
    };
    if a.dimensions() != dims || a.data_type() != gltf::accessor::DataType::F32 || a.normalized() {
        return Err(format!(
            "{:?} {:?}{}, not float {}",
            a.data_type(),
            a.dimensions(),
            if a.normalized() { " normalized" } else { "" },
            format!("{dims:?}").to_uppercase()
        ));
    }
    if a.count() != vertices {
        return Err(format!("{} {what} for {vertices} vertices", a.count()));
    }
    if !readable(&a, buffers) {
        return Err("its accessor's stride or sparse part is malformed".to_string());
    }
    Ok(true)
}

/// A primitive's vertex normals (NORMAL) in world space, unit (the inverse transpose of the
/// node's transform), where it has plain f32 normals, one a vertex; else none (flat shading;
/// the normals the warnings below read are the same).
fn world_normals<'a, 's, F>(
    prim: &gltf::Primitive,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    world: DMat4,
    vertices: usize,
    buffers: &[Vec<u8>],
) -> std::result::Result<Vec<DVec3>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let normals = gltf::Semantic::Normals;
    if !float_attribute(
        prim,
        &normals,
        Dimensions::Vec3,
        "normals",
        vertices,
        buffers,
    )? {
        return Ok(Vec::new());
    }
    let Some(n) = reader.read_normals() else {
        return Err("its buffer view lies outside the buffer".to_string());
    };
    let m = glam::DMat3::from_mat4(world).inverse().transpose();
    Ok(
        n.map(|v| (m * Vec3::from(v).as_dvec3()).normalize_or_zero())
            .collect(),
    )
}

/// KHR_texture_transform's (offset, rotation, scale, texCoord).
type Transform = ([f32; 2], f32, [f32; 2], Option<u32>);

/// How a texture reads a triangle's coordinates: the TEXCOORD set (KHR_texture_transform's
/// `texCoord` overrides the textureInfo's) and the affine map the extension applies to them,
/// u' = m0 u + m1 v + m2, v' = m3 u + m4 v + m5 (its offset, rotation and scale; the identity
/// without the extension).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvMap {
    pub set: u32,
    pub m: [f32; 6],
}

impl UvMap {
    pub fn of(info: &gltf::texture::Info) -> UvMap {
        let t = info.texture_transform();
        UvMap::from_parts(
            info.tex_coord(),
            t.map(|t| (t.offset(), t.rotation(), t.scale(), t.tex_coord())),
        )
    }

    /// A normal texture's mapping: the gltf crate gives its KHR_texture_transform only as
    /// JSON, read here as the extension's schema reads it (a malformed one is an error,
    /// as the crate's parser makes it for the other textures).
    pub fn of_normal(info: &gltf::material::NormalTexture) -> Result<UvMap, String> {
        let t = match info.extension_value("KHR_texture_transform") {
            None => None,
            Some(v) => Some(
                serde_json::from_value::<gltf::json::extensions::texture::TextureTransform>(
                    v.clone(),
                )
                .map_err(|e| format!("its KHR_texture_transform is malformed ({e})"))?,
            ),
        };
        Ok(UvMap::from_parts(
            info.tex_coord(),
            t.map(|t| (t.offset.0, t.rotation.0, t.scale.0, t.tex_coord)),
        ))
    }

    /// The textureInfo's set, and KHR_texture_transform's (offset, rotation, scale, texCoord)
    /// where it is given.
    fn from_parts(set: u32, transform: Option<Transform>) -> UvMap {
        let Some(([ox, oy], r, [sx, sy], tex_coord)) = transform else {
            return UvMap {
                set,
                m: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            };
        };
        // KHR_texture_transform: T · R · S (scale, then rotation, then offset), the rotation
        // in the sense three.js's `setUvTransform` turns (u' = cos·u + sin·v), which the
        // extension README's GLSL listing, read column-major, turns the other way; not
        // checked here against the TextureTransformTest model.
        let (sin, cos) = r.sin_cos();
        UvMap {
            set: tex_coord.unwrap_or(set),
            m: [cos * sx, sin * sy, ox, -sin * sx, cos * sy, oy],
        }
    }

    fn apply(&self, [u, v]: [f32; 2]) -> [f32; 2] {
        let m = self.m;
        [m[0] * u + m[1] * v + m[2], m[3] * u + m[4] * v + m[5]]
    }
}

/// The coordinate mapping a material's textures read: its base-colour texture's, else (an
/// emitting material's) its emissive texture's, else (a material with a GGX layer) its
/// metallic-roughness texture's, else its normal texture's.
pub(super) fn coordinate_map(m: &gltf::Material) -> Option<UvMap> {
    // As gltf_material decides it: emissiveFactor × emissiveStrength (both refused when
    // negative); a GGX layer unless metallicFactor and specularFactor are both 0.
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emits = m.emissive_factor().iter().any(|&c| c * strength > 0.0);
    let pbr = m.pbr_metallic_roughness();
    let specular = m.specular().map_or(1.0, |s| s.specular_factor());
    let glossy = !(pbr.metallic_factor() == 0.0 && specular == 0.0);
    (pbr.base_color_texture())
        .or_else(|| m.emissive_texture().filter(|_| emits))
        .or_else(|| pbr.metallic_roughness_texture().filter(|_| glossy))
        .map(|info| UvMap::of(&info))
        .or_else(|| m.normal_texture().and_then(|n| UvMap::of_normal(&n).ok()))
}

/// Whether the gltf reader can read accessor `a` without panicking or exhausting memory: its
/// sparse part is sound and its stride is at least an element (a stride of 4 panicked the
/// parser's slicing; a sparse count of 2^40 aborted an allocation: a review, 2026-12-07).
fn readable(a: &gltf::Accessor, buffers: &[Vec<u8>]) -> bool {
    super::gltf_data::check_sparse(a, buffers, "").is_ok()
        && a.view()
            .is_none_or(|v| v.stride().is_none_or(|s| s >= a.size()))
}

/// A triangle's corner normals where it is shaded smooth: every corner's normal is finite,
/// and they differ from each other by more than 1° or lean more than 10° off the triangle's
/// own normal (either side: the kernel turns them to the side it shades); None where it is
/// flat or a normal is unusable. The normals are compared with each other first, as f32
/// corners far out tilt the triangle's own normal by degrees (a flat 1-cm quad 5 km out
/// would otherwise render smooth: a review, 2026-12-07).
fn smooth_corners(normals: &[DVec3], corners: [u32; 3], tri: &[DVec3; 3]) -> Option<[Vec3; 3]> {
    // cos 1°: exporters round normals to a few digits; cos 10°.
    const COS_1: f64 = 0.999_847_7;
    const COS_10: f64 = 0.984_807_8;
    let n = corners.map(|i| normals.get(i as usize).copied().unwrap_or(DVec3::ZERO));
    if n.iter().any(|v| !v.is_finite() || v.length_squared() < 0.5) {
        return None;
    }
    let differ = (0..3).any(|i| n[i].dot(n[(i + 1) % 3]) < COS_1);
    let face = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
    let lean = face != DVec3::ZERO && n.iter().any(|v| v.dot(face).abs() < COS_10);
    (differ || lean).then(|| n.map(|v| v.as_vec3()))
}

/// A triangle's corner normals as they are (unit, finite), where all three are usable.
fn usable_corners(normals: &[DVec3], corners: [u32; 3]) -> Option<[Vec3; 3]> {
    let n = corners.map(|i| normals.get(i as usize).copied().unwrap_or(DVec3::ZERO));
    n.iter()
        .all(|v| v.is_finite() && v.length_squared() >= 0.5)
        .then(|| n.map(|v| v.as_vec3()))
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

/// Vertex normals (NORMAL) that point against their triangles' winding in most of a
/// primitive's triangles: the kernel turns a shading normal to the side it shades, so they
/// render as if they agreed, where a renderer that shades one side by NORMAL shows them dark
/// (an audit, 2026-12-07). Only a NORMAL the loader's own checks would pass is read (a
/// malformed one, a huge sparse count or a stride of 4, aborted or refused the file: a
/// review). Returns the warning, naming the first such primitive. (Smooth normals were
/// warned about here until they were interpolated, 2026-12-07.)
pub(super) fn reversed_normals_warning(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    name: &str,
) -> Option<String> {
    use gltf::accessor::{DataType, Dimensions};
    let mut first_reversed: Option<String> = None;
    let mut reversed = 0usize;
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let (Some(normals), Some(positions)) = (
                prim.get(&gltf::Semantic::Normals),
                prim.get(&gltf::Semantic::Positions),
            ) else {
                continue;
            };
            let readable = |a: &gltf::Accessor| readable(a, buffers);
            let plain_vec3 = normals.dimensions() == Dimensions::Vec3
                && normals.data_type() == DataType::F32
                && !normals.normalized();
            if !plain_vec3
                || normals.count() != positions.count()
                || !matches!(
                    prim.mode(),
                    Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
                )
                || ![&normals, &positions].into_iter().all(readable)
                || prim.indices().is_some_and(|i| !readable(&i))
            {
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
            let Some(n) = reader.read_normals() else {
                continue;
            };
            let n: Vec<Vec3> = n.map(|v| Vec3::from(v).normalize_or_zero()).collect();
            let Some(p) = reader.read_positions() else {
                continue;
            };
            let p: Vec<DVec3> = p.map(|v| Vec3::from(v).as_dvec3()).collect();
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..n.len() as u32).collect(),
            };
            // Normals pointing against their triangles' winding, in most of the primitive's
            // triangles (their corners' mean against the face).
            let (mut against, mut with) = (0usize, 0usize);
            for t in triangulate(prim.mode(), &indices) {
                let corner = |i: u32| Some((*n.get(i as usize)?, *p.get(i as usize)?));
                let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) else {
                    continue;
                };
                let face = (b.1 - a.1).cross(c.1 - a.1).normalize_or_zero().as_vec3();
                let d = face.dot(a.0 + b.0 + c.0);
                if face == Vec3::ZERO || d == 0.0 {
                    continue;
                }
                if d < 0.0 {
                    against += 1;
                } else {
                    with += 1;
                }
            }
            let label = || {
                format!(
                    "mesh {} ('{}') primitive {}",
                    mesh.index(),
                    mesh.name().unwrap_or(""),
                    prim.index()
                )
            };
            if against > with {
                reversed += 1;
                first_reversed.get_or_insert_with(label);
            }
        }
    }
    first_reversed.map(|f| format!("'{name}': {reversed} primitive(s) have vertex normals (NORMAL) pointing against their triangles' winding, first {f}; lightlearn shades both sides (and a one-sided emitter lights from its winding's front), so they render as if the normals agreed, where a renderer that shades by NORMAL shows them dark: check the export"))
}
