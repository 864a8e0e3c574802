//! A glTF file as a sequence of frames: frame k is the scene posed at t0 + k / fps (t0: the
//! animations' first key), flattened in one coordinate frame and one region-grid box for the
//! whole animation, so that what one frame learned about a place is where the next frame
//! looks for it.

use std::path::Path;

use anyhow::{bail, Result};
use glam::{DVec3, Vec3};

use super::gltf_load::{self, Document, Frame};
use super::Scene;

/// Poses sampled over the animation's span for its bounds (ends included): enough for the
/// committed scenes' paths (straight walks, car loops) to be inside the union.
const BOUND_SAMPLES: usize = 33;

/// Most frames one animation may have (a typo in --fps must not start a million renders).
pub const MAX_FRAMES: u32 = 100_000;

pub struct AnimatedScene {
    pub doc: Document,
    /// The animations' time span (seconds); (0, 0) for a file without animations.
    pub span: (f32, f32),
    /// The coordinate frame of every frame.
    pub frame: Frame,
    /// The region grid's box (in that frame): the union of the bounds over the span.
    pub grid_box: (Vec3, Vec3),
}

impl AnimatedScene {
    /// Opens the file (None: the built-in default scene) and bounds its animation.
    pub fn open(path: Option<&Path>, warn: &mut dyn FnMut(String)) -> Result<AnimatedScene> {
        let doc = match path {
            Some(p) => gltf_load::open(p, warn)?,
            None => gltf_load::open_bytes(
                crate::DEFAULT_SCENE,
                crate::DEFAULT_SCENE_NAME,
                Path::new("."),
                warn,
            )?,
        };
        let span = doc.animations.span().unwrap_or((0.0, 0.0));
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        // The smallest pose's extent, and the time of the pose that reaches farthest.
        let (mut smallest, mut farthest) = (f64::INFINITY, (0.0, f64::NEG_INFINITY));
        for i in 0..BOUND_SAMPLES {
            let s = i as f64 / (BOUND_SAMPLES - 1) as f64;
            let t = span.0 as f64 + s * (span.1 as f64 - span.0 as f64);
            let (a, b) = doc.pose_bounds(&doc.animations.pose(t))?;
            lo = lo.min(a);
            hi = hi.max(b);
            let extent = (b - a).max_element();
            if extent.is_finite() {
                smallest = smallest.min(extent);
                if extent > farthest.1 {
                    farthest = (t, extent);
                }
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            bail!(
                "'{}' has no geometry or lights to bound in any pose; check the file",
                doc.name()
            );
        }
        let mut frame = Frame::of(lo, hi);
        // Every frame is flattened in the frame of all poses, so one pose keyed far out of
        // scale shrinks every other frame's geometry below f32's resolution; where triangles
        // are lost so, the message names the time of the pose that reaches farthest.
        if (hi - lo).max_element() > 1.5 * smallest {
            frame.far_pose = Some(farthest.0);
        }
        let grid_box = (frame.to_local(lo), frame.to_local(hi));
        Ok(AnimatedScene {
            doc,
            span,
            frame,
            grid_box,
        })
    }

    pub fn is_animated(&self) -> bool {
        !self.doc.animations.is_empty()
    }

    /// The time of frame `k` at `fps`.
    pub fn time(&self, k: u32, fps: f64) -> f64 {
        self.span.0 as f64 + k as f64 / fps
    }

    /// Frames in the whole span at `fps`, both ends included. The keys are f32, so an end a
    /// whole number of frames away can round below it (1.8 s is 1.7999999523: at 25 fps
    /// frame 45, the last key, was left out, an audit of 2026-12-07 found one end in three
    /// so): each end counts half its f32 step outward (at most a quarter frame), as
    /// `reached` does for the keys.
    pub fn frame_count(&self, fps: f64) -> Result<u32> {
        let half_step = |x: f32| {
            let step = (f32::from_bits(x.abs().to_bits() + 1) - x.abs()) as f64;
            (0.5 * step).min(0.25 / fps)
        };
        let (a, b) = (self.span.0, self.span.1);
        let span = (b as f64 + half_step(b)) - (a as f64 - half_step(a));
        let n = (span * fps + 1e-6).floor() + 1.0;
        if n > MAX_FRAMES as f64 {
            bail!(
                "'{}' spans {n} frames at {fps} fps, more than the {MAX_FRAMES} one run renders; give --frames A..B or a lower --fps",
                self.doc.name()
            );
        }
        Ok(n as u32)
    }

    /// The scene at time `t`, in the animation's frame and grid box. Warnings go to `warn`.
    pub fn scene_at(&self, t: f64, warn: &mut dyn FnMut(String)) -> Result<Scene> {
        let pose = self.doc.animations.pose(t);
        let mut scene = self.doc.scene(&pose, Some(self.frame), warn)?;
        scene.grid_box = Some(self.grid_box);
        Ok(scene)
    }
}

/// What changed from one frame to the next.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Changes {
    pub camera: bool,
    pub lights: bool,
    pub geometry: bool,
}

impl Changes {
    pub fn between(a: &Scene, b: &Scene) -> Changes {
        Changes {
            camera: a.camera != b.camera,
            lights: a.lights != b.lights || a.directional != b.directional,
            geometry: a.triangles != b.triangles,
        }
    }

    /// Lights or geometry moved: what was learned about visibility may be stale.
    pub fn scene_moved(&self) -> bool {
        self.lights || self.geometry
    }
}
