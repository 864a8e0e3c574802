//! A glTF camera: the view of its node, and its near and far planes (`znear`, `zfar`).
//!
//! lightlearn's camera rays start at
//! the camera and end at the first hit, as pbrt-v4's do, so the planes are not applied; where
//! they would have cut what a viewer shows (Blender's clip start and end export as these),
//! the load says so instead of rendering a different picture without a word (an audit,
//! 2026-12-06: znear 50 in a 3-unit room and zfar < znear rendered with exit 0 and silence).

use anyhow::{bail, Result};
use glam::{DMat4, DVec3, DVec4};

/// A perspective camera's position, unit view and up directions (world, f64) and vertical
/// field of view in radians.
pub type View = (DVec3, DVec3, DVec3, f32);

/// The view and planes of the camera `cam` on `node` with world transform `world`; None
/// (with a warning) for an orthographic camera, which is not supported.
pub fn read_camera(
    cam: &gltf::Camera,
    node: &gltf::Node,
    world: DMat4,
    name: &str,
    warn: &mut dyn FnMut(String),
) -> Result<Option<(View, Clip)>> {
    let p = match cam.projection() {
        gltf::camera::Projection::Perspective(p) => p,
        gltf::camera::Projection::Orthographic(_) => {
            warn(format!(
                "'{name}': camera {} is orthographic, which is not supported; ignored",
                cam.index()
            ));
            return Ok(None);
        }
    };
    let position = world.transform_point3(DVec3::ZERO);
    let forward = (world * DVec4::new(0.0, 0.0, -1.0, 0.0)).truncate();
    let up = (world * DVec4::new(0.0, 1.0, 0.0, 0.0)).truncate();
    let yfov = p.yfov();
    if !(yfov > 1e-4 && yfov < std::f32::consts::PI - 1e-4) {
        bail!(
            "'{name}': camera {} has an invalid yfov ({yfov}); use 1e-4 < yfov < π − 1e-4 radians",
            cam.index()
        );
    }
    // One message for both had blamed a valid yfov for a node scaled to 0 (an audit,
    // 2026-12-06).
    if forward.length_squared() == 0.0
        || up.length_squared() == 0.0
        || forward.normalize().cross(up.normalize()).length_squared() < 1e-12
    {
        bail!("'{name}': camera {} sits on node {} ('{}') whose transform is degenerate (a scale of 0, or view and up directions parallel), so it has no view direction; give the node a non-zero scale", cam.index(), node.index(), node.name().unwrap_or(""));
    }
    // glTF gives znear and zfar in the camera node's units (§3.10.3).
    let scale = forward.length();
    let clip = Clip {
        camera: cam.index(),
        near: f64::from(p.znear()) * scale,
        far: p.zfar().map(|f| f64::from(f) * scale),
        aspect: p.aspect_ratio(),
    };
    Ok(Some((
        (position, forward.normalize(), up.normalize(), yfov),
        clip,
    )))
}

/// The planes in world units.
#[derive(Clone, Copy, Debug)]
pub struct Clip {
    /// The glTF camera's index.
    pub camera: usize,
    pub near: f64,
    pub far: Option<f64>,
    /// `aspectRatio`, where given.
    pub aspect: Option<f32>,
}

/// The widest film the view cone below allows for: 2:1. A vertex outside the cone of a
/// film's corner cannot be in view.
const MAX_ASPECT: f64 = 2.0;

impl Clip {
    /// A warning where the planes are invalid or may cut the scene's triangles in front of
    /// a camera at `position` looking along unit `forward` with vertical field of view
    /// `yfov`, else None: a vertex in view (of a film up to 2:1) closer than `near` or
    /// farther than `far`. Occlusion is not looked at (hence "may"), nor triangles whose
    /// vertices all lie outside the view.
    pub fn unapplied(
        &self,
        name: &str,
        position: DVec3,
        forward: DVec3,
        yfov: f32,
        triangles: &[[DVec3; 3]],
    ) -> Option<String> {
        let c = self.camera;
        let near = self.near as f32;
        if let Some(far) = self.far {
            if far <= self.near {
                return Some(format!("'{name}': camera {c} has zfar {} ≤ znear {near}, which glTF does not allow; both are ignored (lightlearn does not clip camera rays)", far as f32));
            }
        }
        let t = (f64::from(yfov) * 0.5).tan();
        let cos_cone = 1.0 / (1.0 + t * t * (1.0 + MAX_ASPECT * MAX_ASPECT)).sqrt();
        let mut nearest_in_view = f64::INFINITY;
        let mut farthest = 0.0f64;
        for v in triangles.iter().flatten() {
            let d = *v - position;
            let depth = d.dot(forward);
            if depth <= 0.0 {
                continue;
            }
            if depth >= cos_cone * d.length() {
                nearest_in_view = nearest_in_view.min(depth);
                farthest = farthest.max(depth);
            }
        }
        let mut cut = Vec::new();
        if nearest_in_view < self.near {
            cut.push(format!(
                "its znear {near} may hide geometry {} in front of it",
                nearest_in_view as f32
            ));
        }
        if let Some(far) = self.far.filter(|f| farthest > *f) {
            cut.push(format!(
                "its zfar {} may hide geometry up to {} away",
                far as f32, farthest as f32
            ));
        }
        (!cut.is_empty()).then(|| {
            format!(
                "'{name}': camera {c}: {}; lightlearn does not clip camera rays and renders it (set znear/zfar to match, or ignore this)",
                cut.join(", and ")
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64, half: f64) -> Vec<[DVec3; 3]> {
        let p = |x: f64, y: f64| DVec3::new(x, y, z);
        vec![
            [p(-half, -half), p(half, -half), p(half, half)],
            [p(-half, -half), p(half, half), p(-half, half)],
        ]
    }

    fn warns(clip: Clip, tris: &[[DVec3; 3]]) -> Option<String> {
        // A camera at the origin looking down −z, 60° vertical field of view.
        clip.unapplied("s", DVec3::ZERO, DVec3::NEG_Z, 1.047, tris)
    }

    #[test]
    fn planes_that_cut_nothing_in_view_say_nothing() {
        let wall = square(-3.0, 1.0);
        let clip = |near, far| Clip {
            camera: 0,
            near,
            far,
            aspect: None,
        };
        assert_eq!(warns(clip(0.1, Some(100.0)), &wall), None);
        assert_eq!(warns(clip(0.1, None), &wall), None);
        // A floor under the camera reaches behind it: its vertices are far or out of view.
        let floor = vec![[
            DVec3::new(-5.0, -0.01, 5.0),
            DVec3::new(5.0, -0.01, 5.0),
            DVec3::new(0.0, -0.01, -5.0),
        ]];
        assert_eq!(warns(clip(0.1, Some(100.0)), &floor), None);
    }

    #[test]
    fn planes_that_would_hide_geometry_are_named() {
        let wall = square(-3.0, 1.0);
        let near = |near| Clip {
            camera: 2,
            near,
            far: None,
            aspect: None,
        };
        let w = warns(near(5.0), &wall).unwrap();
        assert!(w.contains("camera 2") && w.contains("znear 5"), "{w}");
        let far = Clip {
            camera: 0,
            near: 0.1,
            far: Some(2.0),
            aspect: None,
        };
        let w = warns(far, &wall).unwrap();
        assert!(w.contains("zfar 2") && w.contains("up to 3"), "{w}");
        let inverted = Clip {
            camera: 0,
            near: 1.0,
            far: Some(0.5),
            aspect: None,
        };
        assert!(warns(inverted, &wall)
            .unwrap()
            .contains("zfar 0.5 ≤ znear 1"));
    }
}
