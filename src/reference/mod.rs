//! A small, obviously correct CPU integrator for tests: the same image as `render.comp`
//! (box-filtered direct illumination, Lambertian, two-sided reflection), computed with an
//! exact sum over point and spot lights and many area samples per triangle light. It shares
//! only the scene and the CPU BVH traversal with the GPU path, and its own random numbers.

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::Bvh;
use crate::render::{camera_params, hit_epsilon, surface_epsilon};
use crate::rng::SplitMix64;
use crate::scene::{spot_falloff, Light, Scene};

pub struct ReferenceImage {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<[f64; 3]>,
    /// Variance of each pixel's mean (sample variance over pixel samples / their number).
    pub variance_of_mean: Vec<[f64; 3]>,
}

/// `pixel_samples` jittered camera rays per pixel; at each hit every point/spot light is
/// summed exactly and every triangle light with `area_samples` uniform area samples.
pub fn render(
    scene: &Scene,
    bvh: &Bvh,
    width: u32,
    height: u32,
    pixel_samples: u32,
    area_samples: u32,
    seed: u64,
) -> ReferenceImage {
    let cam = camera_params(scene, width, height);
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let (pos, cu, cv, cw) = (v(cam.cam_pos), v(cam.cam_u), v(cam.cam_v), v(cam.cam_w));
    let results: Vec<([f64; 3], [f64; 3])> = (0..width * height)
        .into_par_iter()
        .map(|p| {
            let (px, py) = (p % width, p / width);
            let mut rng = SplitMix64(seed ^ (p as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
            let mut sum = [0f64; 3];
            let mut sum_sq = [0f64; 3];
            for _ in 0..pixel_samples {
                let nx = (px as f32 + rng.f32()) / width as f32 * 2.0 - 1.0;
                let ny = 1.0 - (py as f32 + rng.f32()) / height as f32 * 2.0;
                let dir = (cw + nx * cu + ny * cv).normalize();
                let l = radiance(scene, bvh, pos, dir, area_samples, &mut rng);
                for k in 0..3 {
                    sum[k] += l[k] as f64;
                    sum_sq[k] += (l[k] as f64).powi(2);
                }
            }
            let n = pixel_samples as f64;
            let mut mean = [0f64; 3];
            let mut var = [0f64; 3];
            for k in 0..3 {
                mean[k] = sum[k] / n;
                var[k] =
                    ((sum_sq[k] / n - mean[k] * mean[k]) * n / (n - 1.0).max(1.0)).max(0.0) / n;
            }
            (mean, var)
        })
        .collect();
    ReferenceImage {
        width,
        height,
        mean: results.iter().map(|r| r.0).collect(),
        variance_of_mean: results.iter().map(|r| r.1).collect(),
    }
}

fn radiance(
    scene: &Scene,
    bvh: &Bvh,
    o: Vec3,
    d: Vec3,
    area_samples: u32,
    rng: &mut SplitMix64,
) -> Vec3 {
    let Some(hit) = first_hit(scene, bvh, o, d) else {
        return Vec3::ZERO;
    };
    let mut l = hit.emission;
    for light in 0..scene.lights.len() {
        let s = light_samples(scene, bvh, &hit, light, area_samples, rng);
        l += hit.brdf * s.sum / s.count as f32;
    }
    l
}

/// The first surface a camera ray meets, shaded as render.comp shades it: Lambertian,
/// two-sided (the normal faces the ray), emission only on an emitter's front unless the
/// material is double-sided.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub x: Vec3,
    /// The geometric normal turned towards the ray.
    pub n: Vec3,
    /// albedo / π.
    pub brdf: Vec3,
    /// The radiance the camera sees emitted at x.
    pub emission: Vec3,
    /// How far rays leave x ([`hit_epsilon`], render.comp's `eps`).
    pub eps: f32,
}

pub fn first_hit(scene: &Scene, bvh: &Bvh, o: Vec3, d: Vec3) -> Option<Hit> {
    let (t, prim) = bvh.intersect(o, d, 0.0, f32::INFINITY)?;
    let [a, b, c] = scene.triangles[prim as usize];
    let ng = (b - a).cross(c - a).normalize();
    let front = ng.dot(d) < 0.0;
    let m = &scene.materials[scene.triangle_material[prim as usize] as usize];
    let x = o + t * d;
    Some(Hit {
        x,
        eps: hit_epsilon(x, o, t, [a, b, c]),
        n: if front { ng } else { -ng },
        brdf: m.base_color / std::f32::consts::PI,
        emission: if front || m.double_sided {
            m.emission
        } else {
            Vec3::ZERO
        },
    })
}

/// The one-sample next-event estimates of one light at a hit, without the BRDF and the
/// light-selection pmf: L_e G V / p(y) (radiance × cosθ_x × cosθ_y / r² / p(y)), each of
/// `count` samples (1, exact, for point and spot lights; `area_samples` uniform area
/// samples for a triangle, two random numbers each) summed, with the sum of the squared
/// luminances of BRDF × sample and how many samples were 0.
pub struct LightSamples {
    pub sum: Vec3,
    pub sum_sq_lum: f64,
    pub zeros: u32,
    pub count: u32,
}

pub fn light_samples(
    scene: &Scene,
    bvh: &Bvh,
    hit: &Hit,
    light: usize,
    area_samples: u32,
    rng: &mut SplitMix64,
) -> LightSamples {
    let (x, n, eps) = (hit.x, hit.n, hit.eps);
    // Unoccluded contribution of a point y with "intensity" term `e` (already / r²);
    // `area`: for an area light, the largest magnitude of its corners (how far to stop
    // short of its surface).
    let visible = |y: Vec3, area: Option<f32>| -> Option<(Vec3, f32, f32)> {
        let to = y - x;
        let dist = to.length();
        let wi = to / dist;
        let cos_x = n.dot(wi);
        if cos_x <= 0.0 {
            return None;
        }
        // From just off the surface straight to y (see render.comp for why).
        let so = x + n * eps;
        let to_light = y - so;
        let sdist = to_light.length();
        let tmax = match area {
            Some(corners) => sdist - eps.max(surface_epsilon(y.abs().max_element(), corners)),
            None => sdist,
        };
        if bvh.occluded(so, to_light / sdist, 0.0, tmax) {
            return None;
        }
        Some((wi, dist, cos_x))
    };
    let mut out = LightSamples {
        sum: Vec3::ZERO,
        sum_sq_lum: 0.0,
        zeros: 0,
        count: 0,
    };
    let add = |v: Vec3, out: &mut LightSamples| {
        let lum = crate::scene::luminance(hit.brdf * v) as f64;
        out.sum += v;
        out.sum_sq_lum += lum * lum;
        out.zeros += (lum <= 0.0) as u32;
        out.count += 1;
    };
    match scene.lights[light] {
        Light::Point {
            position,
            intensity,
        } => {
            let v = match visible(position, None) {
                Some((_, dist, cos_x)) => intensity * cos_x / (dist * dist),
                None => Vec3::ZERO,
            };
            add(v, &mut out);
        }
        Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
        } => {
            let v = match visible(position, None) {
                Some((wi, dist, cos_x)) => {
                    let f = spot_falloff(direction.dot(-wi), cos_inner, cos_outer);
                    intensity * f * cos_x / (dist * dist)
                }
                None => Vec3::ZERO,
            };
            add(v, &mut out);
        }
        Light::Triangle { triangle } => {
            let [p0, p1, p2] = scene.triangles[triangle as usize];
            let cross = (p1 - p0).cross(p2 - p0);
            let area = 0.5 * cross.length();
            let ny = cross.normalize();
            let (emission, two) = scene.triangle_emission(triangle);
            let corners = p0.abs().max(p1.abs()).max(p2.abs()).max_element();
            for _ in 0..area_samples {
                let su = rng.f32().sqrt();
                let (b0, b1) = (1.0 - su, rng.f32() * su);
                let y = b0 * p0 + b1 * p1 + (1.0 - b0 - b1) * p2;
                let mut v = Vec3::ZERO;
                if let Some((wi, dist, cos_x)) = visible(y, Some(corners)) {
                    let mut cos_y = ny.dot(-wi);
                    if two {
                        cos_y = cos_y.abs();
                    }
                    if cos_y > 0.0 {
                        v = emission * cos_x * cos_y * area / (dist * dist);
                    }
                }
                add(v, &mut out);
            }
        }
    }
    out
}
