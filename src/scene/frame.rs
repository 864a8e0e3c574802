//! The coordinate frame a scene's f32 coordinates are taken in (origin and unit), chosen from
//! its f64 bounds so that far-away or very large/small scenes keep their precision.

use glam::{DVec3, Vec3};

/// The frame the f32 coordinates of a scene are taken in: world = origin + local / unit
/// ([`scene_frame`] says how it is chosen).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub origin: DVec3,
    pub unit: f64,
}

impl Frame {
    /// The frame for a scene with f64 bounds [lo, hi].
    pub fn of(lo: DVec3, hi: DVec3) -> Frame {
        let (origin, unit) = scene_frame(lo, hi);
        Frame { origin, unit }
    }

    pub fn to_local(&self, p: DVec3) -> Vec3 {
        ((p - self.origin) * self.unit).as_vec3()
    }
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
