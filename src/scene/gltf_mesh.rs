//! A glTF scene's meshes → triangles in world space (f64, until the scene's frame is known),
//! with their materials and texture coordinates; what cannot be read is refused naming the
//! primitive, and triangles that lose their area are counted for the loader's messages.

use anyhow::{anyhow, bail, Result};
use glam::{DMat4, DVec3, Vec3};
use gltf::mesh::Mode;

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
            // set of the material's base-colour texture (gltf_check reads the same).
            let uv_set = prim
                .material()
                .pbr_metallic_roughness()
                .base_color_texture()
                .or_else(|| prim.material().emissive_texture())
                .map(|info| gltf::Semantic::TexCoords(info.tex_coord()));
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
            // Texture coordinates of the set the material's textures use (the base colour's,
            // else the emissive one's: gltf_material keeps an emissive texture only on the
            // base colour's set).
            let material = &table.materials[mat as usize];
            let set = match (material.base_color_texture, material.emissive_texture) {
                (Some(_), _) => prim
                    .material()
                    .pbr_metallic_roughness()
                    .base_color_texture()
                    .map(|i| i.tex_coord()),
                (None, Some(_)) => prim.material().emissive_texture().map(|i| i.tex_coord()),
                (None, None) => None,
            };
            let uvs: Vec<[f32; 2]> = match set {
                Some(set) => match reader.read_tex_coords(set) {
                    Some(t) => {
                        let uvs: Vec<[f32; 2]> = t.into_f32().collect();
                        // One coordinate a vertex (glTF: every attribute has POSITION's
                        // count); a short one was read as (0, 0) past its end.
                        if uvs.len() != positions.len() {
                            bail!("'{name}': {mesh_label} has {} TEXCOORD_{} values for {} vertices; an attribute needs one a vertex", uvs.len(), set, positions.len());
                        }
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
                            "'{name}': {mesh_label} has a texture but no TEXCOORD_{}; it samples the texture at (0, 0)",
                            set
                        ));
                        Vec::new()
                    }
                },
                None => Vec::new(),
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
                self.triangle_material.push(mat);
                if self.triangles.len() > MAX_TRIANGLES {
                    bail!(
                        "'{name}' has more than {MAX_TRIANGLES} triangles, the most lightlearn supports; simplify the scene"
                    );
                }
            }
        }
        Ok(())
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

/// Vertex normals (NORMAL) that differ across a triangle by more than 1°, or lean more than
/// 10° off it: smooth or custom shading,
/// which lightlearn does not interpolate (it shades with flat triangle normals), so the
/// surface renders faceted. A sphere of smooth normals rendered bit-identical to one
/// without them, 20 % off Mitsuba 3's smooth image, with no word (an audit, 2026-12-07).
/// Flat-shaded files (one normal a face, as many exporters write) are not warned about; the
/// normals are compared with each other, not with the triangle's normal from its corners,
/// which f32 rounding tilts by more than 1° on a 1-cm quad 5 km out (a review). Only a
/// NORMAL the loader's own checks would pass is read: the loader never reads it, so a
/// malformed one (a huge sparse count aborted the process, a stride of 4 refused the file:
/// a review) is skipped here. Normals that agree with their triangle but point against its
/// winding are said too. Returns the warning, naming the first such primitive.
pub(super) fn smooth_normals_warning(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    name: &str,
) -> Option<String> {
    use gltf::accessor::{DataType, Dimensions};
    // cos 1°: exporters round normals to a few digits.
    const COS_LIMIT: f32 = 0.99985;
    // cos 10°.
    const COS_LEAN: f32 = 0.9848;
    let mut first: Option<String> = None;
    let mut count = 0usize;
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
            let readable = |a: &gltf::Accessor| {
                super::gltf_data::check_sparse(a, buffers, "").is_ok()
                    && a.view()
                        .is_none_or(|v| v.stride().is_none_or(|s| s >= a.size()))
            };
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
            let smooth = triangulate(prim.mode(), &indices).into_iter().any(|t| {
                // A strip's joins (a repeated index) are no triangle: the loader drops them,
                // and their corners' normals belong to two faces (a flat cube as one strip
                // was warned of: a review).
                if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                    return false;
                }
                let corner = |i: u32| Some((*n.get(i as usize)?, *p.get(i as usize)?));
                let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) else {
                    return false;
                };
                let given: Vec<Vec3> = [a.0, b.0, c.0]
                    .into_iter()
                    .filter(|v| *v != Vec3::ZERO)
                    .collect();
                // Normals that differ across the triangle (smooth shading) ...
                let differ = (0..given.len())
                    .any(|i| given[i].dot(given[(i + 1) % given.len()]) < COS_LIMIT);
                // ... or agree but lean off the triangle (weighted or custom normals on a
                // bevel) by more than 10°: f32 corners far out tilt the triangle's own
                // normal by a few degrees (a review).
                let face = (b.1 - a.1).cross(c.1 - a.1).normalize_or_zero().as_vec3();
                let lean = face != Vec3::ZERO && given.iter().any(|v| v.dot(face).abs() < COS_LEAN);
                differ || lean
            });
            // Normals pointing against their triangles' winding, in most of the primitive's
            // triangles (their corners' mean against the face): the lean above takes |cos|,
            // so a 180° flip was not said (an audit, 2026-12-07), and a pass of its own, as
            // the one above stops at its first smooth triangle (a review).
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
            if smooth {
                count += 1;
                first.get_or_insert_with(label);
            }
        }
    }
    let smooth = first.map(|f| format!("'{name}': {count} primitive(s) have smooth vertex normals (NORMAL), first {f}; lightlearn shades with flat triangle normals, so curved surfaces render faceted"));
    let reversed = first_reversed.map(|f| format!("'{name}': {reversed} primitive(s) have vertex normals (NORMAL) pointing against their triangles' winding, first {f}; lightlearn shades both sides by the triangle (and a one-sided emitter lights from its winding's front), so they render as if the normals agreed, where a renderer that shades by NORMAL shows them dark: check the export"));
    match (smooth, reversed) {
        (Some(a), Some(b)) => Some(format!("{a}; and {b}")),
        (a, b) => a.or(b),
    }
}
