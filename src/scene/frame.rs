//! The coordinate frame a scene's f32 coordinates are taken in (origin and unit), chosen from
//! its f64 bounds so that far-away or very large/small scenes keep their precision.

use glam::{DVec3, Vec3};

/// The frame the f32 coordinates of a scene are taken in: world = origin + local / unit
/// ([`scene_frame`] says how it is chosen).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub origin: DVec3,
    pub unit: f64,
    /// An animation's frame (the union of its poses) where its poses differ in extent: the
    /// time of the pose that reaches farthest, which the lost-triangle message names (a
    /// pose keyed far out of scale shrank every frame's geometry, and the error came on
    /// frame 0 naming its own extent; an audit, 2026-12-07).
    pub far_pose: Option<f64>,
}

impl Frame {
    /// The frame for a scene with f64 bounds [lo, hi].
    pub fn of(lo: DVec3, hi: DVec3) -> Frame {
        let (origin, unit) = scene_frame(lo, hi);
        Frame {
            origin,
            unit,
            far_pose: None,
        }
    }

    pub fn to_local(&self, p: DVec3) -> Vec3 {
        ((p - self.origin) * self.unit).as_vec3()
    }

    /// The extent triangles are measured against in this frame: a rescaled frame's span
    /// (its unit brings it to 4..8, scene_frame) where that is larger than the scene's
    /// `extent` (`animate` takes every frame in the frame of all of them).
    pub fn span(&self, extent: f64) -> f64 {
        if self.unit == 1.0 {
            extent
        } else {
            extent.max(4.0 / self.unit)
        }
    }

    /// `world` triangles in this frame's f32 coordinates, without those that round to zero
    /// area there; `extent` is the scene's largest f64 side and `emits(i)` whether triangle
    /// i emits. Err(i): triangle i lies beyond f32's range.
    pub fn triangles(
        &self,
        world: &[[DVec3; 3]],
        extent: f64,
        emits: impl Fn(usize) -> bool,
    ) -> Result<LocalTriangles, usize> {
        let mut out = LocalTriangles::default();
        // Counted as lost to scale only where the whole triangle is below f32's resolution
        // at the scene's extent: a sliver (a sphere's pole) also rounds to zero area, and is
        // no news. A node scaled by 1e30 left 2 of 36 triangles and a black image, without
        // a word, before these were counted.
        // [`Frame::span`] (the review of 2026-12-06: not for unit 1, where it would count
        // slivers).
        let tiny = self.span(extent) * 1e-6;
        for (i, t) in world.iter().enumerate() {
            let tri = t.map(|p| self.to_local(p));
            if !tri.iter().all(|v| v.is_finite()) {
                return Err(i);
            }
            if (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared() == 0.0 {
                let longest = [t[1] - t[0], t[2] - t[1], t[0] - t[2]]
                    .iter()
                    .map(|e| e.length())
                    .fold(0.0, f64::max);
                // Or small beside where it sits in the frame. Either way, a light keyed 1e20
                // away in `animate` had collapsed frame 0's triangles uncounted ("has no
                // triangles": an audit, 2026-12-06).
                let far = tri
                    .iter()
                    .map(|v| v.abs().max_element())
                    .fold(0.0, f32::max) as f64;
                if longest > 0.0 && (longest < tiny || longest * self.unit < far * 1e-6) {
                    out.collapsed += 1;
                    if emits(i) {
                        out.collapsed_emitters += 1;
                    }
                }
                continue;
            }
            out.triangles.push(tri);
            out.kept.push(i);
        }
        Ok(out)
    }
}

/// A scene's triangles in its frame ([`Frame::triangles`]).
#[derive(Debug, Default)]
pub struct LocalTriangles {
    pub triangles: Vec<[Vec3; 3]>,
    /// The index in the world triangles of each kept one.
    pub kept: Vec<usize>,
    /// Triangles with an area that f32 loses beside the scene's extent (out of scale), and
    /// how many of them emit.
    pub collapsed: usize,
    pub collapsed_emitters: usize,
}

/// The bounds of triangles and points in f64 (what [`Frame::of`] takes).
pub fn bounds64(triangles: &[[DVec3; 3]], points: &[DVec3]) -> (DVec3, DVec3) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for p in triangles.iter().flatten().chain(points) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo, hi)
}

/// Sizes (bounding-box diagonals) the renderer takes as they are: every committed scene
/// (3.5 to 171 units) and real scenes in metres from a table top to a town.
pub const NATIVE_SIZES: std::ops::RangeInclusive<f64> = 1.0..=16384.0;

/// The frame the f32 coordinates of a scene with f64 bounds [lo, hi] are taken in:
/// (origin, unit), world = origin + local / unit.
/// - origin: the centre of the bounds when that lies farther from the file's origin than
///   the scene is large, so coordinates keep their precision relative to the scene's size
///   (measured: cornell moved by 1e7 lost most of its light before); else the file's own
///   origin.
/// - unit: 1 for sizes in [`NATIVE_SIZES`]; else the power of two (exact) that brings the
///   size to 4..8. The light tree's distance clamp (pbrt-v4's max(d², |diagonal|/2)) mixes
///   units, so a tiny scene sampled far worse: cornell × 1e-3 had 75× the relMSE of cornell
///   with lightbvh at 1024 spp.
///
/// Scenes inside the range with their centre near the origin load bit for bit as written.
pub(crate) fn scene_frame(lo: DVec3, hi: DVec3) -> (DVec3, f64) {
    if !lo.is_finite() {
        return (DVec3::ZERO, 1.0);
    }
    let (centre, size) = (0.5 * (lo + hi), (hi - lo).length());
    let origin = if centre.length() > size {
        centre
    } else {
        DVec3::ZERO
    };
    let unit = if NATIVE_SIZES.contains(&size) || size == 0.0 {
        1.0
    } else {
        2f64.powi(2 - size.log2().floor() as i32)
    };
    (origin, unit)
}
