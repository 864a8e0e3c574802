//! The preview's "regions learned" view: for each window pixel, the first surface the
//! camera's pixel-centre ray hits (CPU BVH), its region, and how many observations that
//! region's cut holds, as a colour: dark blue where the region has no cut of its own (the
//! shared fallback serves it), black → red → yellow → white for log(1 + observations) up
//! to the most any visible region has; the sky stays black.

use anyhow::Result;
use glam::Vec3;
use rayon::prelude::*;

use crate::render::{camera_vectors, GpuScene, Session};
use crate::scene::{Camera, Scene};

/// The direction of the ray through window pixel (x, y) (its centre at x + 0.5), as
/// `render.comp` makes it.
pub fn pixel_ray(camera: &Camera, width: u32, height: u32, x: f32, y: f32) -> Vec3 {
    let c = camera_vectors(camera, width, height);
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let ndc = (x / width as f32 * 2.0 - 1.0, 1.0 - y / height as f32 * 2.0);
    (v(c.cam_w) + ndc.0 * v(c.cam_u) + ndc.1 * v(c.cam_v)).normalize()
}

fn pack(rgb: [f32; 3], bgra: bool) -> u32 {
    let b = rgb.map(|c| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u32);
    if bgra {
        b[2] | b[1] << 8 | b[0] << 16 | 255 << 24
    } else {
        b[0] | b[1] << 8 | b[2] << 16 | 255 << 24
    }
}

/// The heat map at `width`×`height`, packed for the swapchain.
pub fn heat_map(
    scene: &Scene,
    gpu: &GpuScene,
    camera: &Camera,
    session: &Session,
    width: u32,
    height: u32,
    bgra: bool,
) -> Result<Vec<u32>> {
    let hits: Vec<Option<(Vec3, Vec3)>> = (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
            let d = pixel_ray(camera, width, height, x, y);
            let (t, prim) = gpu.bvh.intersect(camera.position, d, 0.0, f32::INFINITY)?;
            let [a, b, c] = scene.triangles[prim as usize];
            let n = (b - a).cross(c - a).normalize_or_zero();
            // The normal facing the camera, as the kernel's shading normal does.
            let n = if n.dot(d) > 0.0 { -n } else { n };
            Some((camera.position + t * d, n))
        })
        .collect();
    let points: Vec<(Vec3, Vec3)> = hits.iter().flatten().copied().collect();
    let learned = session.observations_at(&points)?;
    let most = learned.iter().flatten().fold(0f32, |a, &b| a.max(b));
    let scale = 1.0 / (1.0 + most).ln().max(1e-6);
    let mut learned = learned.into_iter();
    Ok(hits
        .iter()
        .map(|h| match h {
            None => pack([0.0; 3], bgra),
            Some(_) => match learned.next().flatten() {
                None => pack([0.05, 0.05, 0.35], bgra),
                Some(n) => {
                    let t = (1.0 + n).ln() * scale;
                    pack(
                        [
                            (3.0 * t).min(1.0),
                            (3.0 * t - 1.0).clamp(0.0, 1.0),
                            (3.0 * t - 2.0).clamp(0.0, 1.0),
                        ],
                        bgra,
                    )
                }
            },
        })
        .collect())
}
