//! A normal texture's tangent frames for one glTF primitive: the file's TANGENT (by the
//! node's transform), or tangents computed from the texture coordinates the texture reads,
//! each made orthogonal to its corner's normal with the bitangent's sign (gltf_mesh stores
//! them in `Scene::triangle_tangents`).

use glam::{DMat4, DVec3, DVec4, Vec4};
use gltf::accessor::Dimensions;

use super::gltf_mesh::float_attribute;

/// A primitive's TANGENT in world space (xyz by the node's transform, unit; w ±1, negated by
/// a mirroring transform, which turns cross(normal, tangent) around): None where it has none.
fn file_tangents<'a, 's, F>(
    prim: &gltf::Primitive,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    world: DMat4,
    vertices: usize,
    buffers: &[Vec<u8>],
) -> std::result::Result<Option<Vec<DVec4>>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let tangents = gltf::Semantic::Tangents;
    if !float_attribute(
        prim,
        &tangents,
        Dimensions::Vec4,
        "tangents",
        vertices,
        buffers,
    )? {
        return Ok(None);
    }
    let Some(t) = reader.read_tangents() else {
        return Err("its buffer view lies outside the buffer".to_string());
    };
    let m = glam::DMat3::from_mat4(world);
    let mirror = if world.determinant() < 0.0 { -1.0 } else { 1.0 };
    // As the file gives them (Tangents::corners judges them): w kept, for its sign or its
    // being unusable (0, NaN).
    Ok(Some(
        t.map(|v| {
            let d = m * glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
            d.extend(v[3] as f64 * mirror)
        })
        .collect(),
    ))
}

/// A normal texture's frames for one primitive: the file's TANGENT (with the computed ones
/// for its unusable values), or computed.
pub(super) enum Tangents {
    None,
    File(Vec<DVec4>, UvFrames),
    Computed(UvFrames),
}

/// What [`Tangents::corners`] could not take as given, for the primitive's warnings.
#[derive(Default)]
pub(super) struct FrameCounts {
    /// File tangents replaced by computed ones.
    computed: usize,
    /// Triangles left without a frame.
    missing: usize,
}

impl FrameCounts {
    /// What the primitive (`label`) lost or had replaced, said, where it was silent (an
    /// audit, 2026-12-07: NaN, zero or Inf tangents and coordinates of no area lost the map
    /// without a word).
    pub(super) fn say(&self, label: &str, warn: &mut dyn FnMut(String)) {
        if self.computed > 0 {
            warn(format!("{label} has TANGENT values lightlearn cannot use (zero, not finite, along the normal, or w zero or not finite) at {} triangle corners; their tangents are computed from the texture coordinates", self.computed));
        }
        if self.missing > 0 {
            warn(format!("{label}: {} triangles of its normal-mapped material have no tangent frame (texture coordinates that span no area); they are shaded without the normal texture", self.missing));
        }
    }
}

impl Tangents {
    /// A normal-mapped primitive's frames: its TANGENT where it has NORMAL too and lightlearn
    /// can read it (glTF: without NORMAL, TANGENT is ignored, as flat normals are computed
    /// and the tangents with them: a review, 2026-12-07), else computed from the
    /// coordinates it reads (glTF asks for MikkTSpace's; ours are its core). An unreadable
    /// TANGENT is said (`label` names the primitive).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn of<'a, 's, F>(
        prim: &gltf::Primitive,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        world: DMat4,
        world_pos: &[DVec3],
        uvs: &[[f32; 2]],
        tris: &[[u32; 3]],
        has_normals: bool,
        buffers: &[Vec<u8>],
        label: &str,
        warn: &mut dyn FnMut(String),
    ) -> Tangents
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let frames = UvFrames::new(world_pos, uvs, tris);
        if !has_normals {
            return Tangents::Computed(frames);
        }
        match file_tangents(prim, reader, world, world_pos.len(), buffers) {
            Ok(Some(t)) => Tangents::File(t, frames),
            Ok(None) => Tangents::Computed(frames),
            Err(why) => {
                warn(format!("{label} has tangents (TANGENT) lightlearn cannot read ({why}); they are computed from its texture coordinates"));
                Tangents::Computed(frames)
            }
        }
    }
    /// The frames at a triangle's corners (file vertices `v`; stored in the order the
    /// triangle is, reversed after `flip`): each tangent made orthogonal to its corner's
    /// normal `base`, and its sign; a file tangent that is zero, not finite, along the
    /// normal or of w zero or not finite is replaced by the computed one (another w is
    /// taken by its sign, as glTF's ±1 would be); None (counted) where there is no frame.
    pub(super) fn corners(
        &self,
        v: [u32; 3],
        base: [DVec3; 3],
        flip: bool,
        counts: &mut FrameCounts,
    ) -> Option<[Vec4; 3]> {
        let order = if flip { [0, 2, 1] } else { [0, 1, 2] };
        let mut out = [Vec4::ZERO; 3];
        let orthogonal = |t: DVec3, n: DVec3| {
            let (len, o) = (t.length(), t - n * n.dot(t));
            // Along the normal (or zero): nothing is left but rounding.
            let l = o.length();
            (len.is_finite() && l > 1e-6 * len && l > 0.0).then(|| o / l)
        };
        let computed = |f: &UvFrames, i: usize, n: DVec3| -> Option<(DVec3, f64)> {
            let h = f.handedness(v)?;
            let (t, b) = (f.t.get(i)?[h], f.b.get(i)?[h]);
            let t = orthogonal(t, n)?;
            // The bitangent runs up the image (glTF: +Y is up; v grows downwards).
            Some((t, if n.cross(t).dot(-b) < 0.0 { -1.0 } else { 1.0 }))
        };
        for (k, &c) in order.iter().enumerate() {
            let (i, n) = (v[c] as usize, base[k]);
            let frame = match self {
                Tangents::None => return None,
                Tangents::File(t, f) => {
                    let given = t.get(i).and_then(|t| {
                        let (d, w) = (t.truncate(), t.w);
                        let usable = w.is_finite() && w != 0.0 && d.length() > 1e-6;
                        orthogonal(d, n).filter(|_| usable).map(|t| (t, w.signum()))
                    });
                    if given.is_none() {
                        counts.computed += 1;
                    }
                    given.or_else(|| computed(f, i, n))
                }
                Tangents::Computed(f) => computed(f, i, n),
            };
            let Some((t, w)) = frame else {
                counts.missing += 1;
                return None;
            };
            out[k] = t.as_vec3().extend(w as f32);
        }
        Some(out)
    }
}

/// Tangents (∂p/∂u) and bitangents (∂p/∂v) of a primitive's vertices, summed over the
/// triangles around each, weighted by area, apart for triangles of either handedness (a
/// mirrored half of a model shares its seam's vertices with the other half, and their sum
/// would cancel: MikkTSpace splits them the same way).
pub(super) struct UvFrames {
    t: Vec<[DVec3; 2]>,
    b: Vec<[DVec3; 2]>,
    pos: Vec<DVec3>,
    uv: Vec<[f64; 2]>,
}

impl UvFrames {
    fn new(pos: &[DVec3], uvs: &[[f32; 2]], tris: &[[u32; 3]]) -> UvFrames {
        let mut f = UvFrames {
            t: vec![[DVec3::ZERO; 2]; pos.len()],
            b: vec![[DVec3::ZERO; 2]; pos.len()],
            pos: pos.to_vec(),
            uv: uvs.iter().map(|c| [c[0] as f64, c[1] as f64]).collect(),
        };
        for &v in tris {
            let (Some((t, b)), Some(h)) = (f.face(v), f.handedness(v)) else {
                continue;
            };
            let area = f.area(v);
            for i in v {
                f.t[i as usize][h] += t.normalize_or_zero() * area;
                f.b[i as usize][h] += b.normalize_or_zero() * area;
            }
        }
        f
    }

    fn corner(&self, i: u32) -> Option<(DVec3, [f64; 2])> {
        Some((*self.pos.get(i as usize)?, *self.uv.get(i as usize)?))
    }

    fn area(&self, v: [u32; 3]) -> f64 {
        match v.map(|i| self.corner(i)) {
            [Some(a), Some(b), Some(c)] => 0.5 * (b.0 - a.0).cross(c.0 - a.0).length(),
            _ => 0.0,
        }
    }

    /// ∂p/∂u and ∂p/∂v over a triangle, where its coordinates span an area.
    fn face(&self, v: [u32; 3]) -> Option<(DVec3, DVec3)> {
        let [a, b, c] = v.map(|i| self.corner(i));
        let (a, b, c) = (a?, b?, c?);
        let (e1, e2) = (b.0 - a.0, c.0 - a.0);
        let (du1, dv1) = (b.1[0] - a.1[0], b.1[1] - a.1[1]);
        let (du2, dv2) = (c.1[0] - a.1[0], c.1[1] - a.1[1]);
        let r = du1 * dv2 - du2 * dv1;
        if r == 0.0 || !r.is_finite() {
            return None;
        }
        let t = (e1 * dv2 - e2 * dv1) / r;
        let b = (e2 * du1 - e1 * du2) / r;
        (t.is_finite() && b.is_finite()).then_some((t, b))
    }

    /// 0 or 1: which side of its winding's normal the triangle's (∂p/∂u, −∂p/∂v) frame turns.
    fn handedness(&self, v: [u32; 3]) -> Option<usize> {
        let (t, b) = self.face(v)?;
        let [a, p, c] = v.map(|i| self.corner(i).map(|x| x.0));
        let n = (p? - a?).cross(c? - a?);
        Some((n.cross(t).dot(-b) < 0.0) as usize)
    }
}
