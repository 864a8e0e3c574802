//! Ray-throughput benchmark: the GPU kernel (`trace.comp`) against a plain multithreaded Rust
//! traversal of the same BVH, side by side in one run, for coherent (camera) and incoherent
//! (random direction from surface points) rays.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use rayon::prelude::*;

use crate::accel::{gpu_trace, Bvh};
use crate::gpu::layout::GpuRay;
use crate::gpu::{Buffer, Context};
use crate::rng::SplitMix64;
use crate::scene::Camera;

/// A procedural test mesh of about `triangles` triangles: a bumpy heightfield (2/3 of the
/// triangles) with a field of randomly placed boxes standing on it.
pub fn bench_mesh(triangles: usize, seed: u64) -> Vec<[Vec3; 3]> {
    let mut rng = SplitMix64(seed);
    let grid = ((triangles as f64 * 2.0 / 3.0 / 2.0).sqrt() as usize).max(2);
    let size = 100.0f32;
    let height = |x: f32, z: f32| {
        2.0 * (x * 0.15).sin() * (z * 0.11).cos() + 0.7 * (x * 0.9 + z * 0.7).sin()
    };
    let mut tris = Vec::with_capacity(triangles);
    let p = |i: usize, j: usize| {
        let (x, z) = (
            i as f32 / grid as f32 * size - 50.0,
            j as f32 / grid as f32 * size - 50.0,
        );
        Vec3::new(x, height(x, z), z)
    };
    for j in 0..grid {
        for i in 0..grid {
            tris.push([p(i, j), p(i, j + 1), p(i + 1, j + 1)]);
            tris.push([p(i, j), p(i + 1, j + 1), p(i + 1, j)]);
        }
    }
    while tris.len() + 12 <= triangles {
        let c = Vec3::new(rng.range(-48.0, 48.0), 0.0, rng.range(-48.0, 48.0));
        let half = Vec3::new(
            rng.range(0.2, 1.5),
            rng.range(0.5, 4.0),
            rng.range(0.2, 1.5),
        );
        let base = Vec3::new(c.x, height(c.x, c.z) - 0.5, c.z);
        let (pts, idx) = crate::scene::gltf_write::box_mesh(
            base - half * Vec3::new(1.0, 0.0, 1.0),
            base + half * Vec3::new(1.0, 2.0, 1.0),
        );
        for t in idx.chunks(3) {
            tris.push([pts[t[0] as usize], pts[t[1] as usize], pts[t[2] as usize]]);
        }
    }
    tris
}

/// Camera rays over a `w`×`h` image (pixel centres), looking down onto the mesh.
pub fn primary_rays(w: u32, h: u32) -> Vec<GpuRay> {
    let cam = Camera::look_at(
        Vec3::new(-40.0, 25.0, -40.0),
        Vec3::new(10.0, 0.0, 10.0),
        Vec3::Y,
        60f32.to_radians(),
    );
    let tan = (0.5 * cam.yfov).tan();
    let right = cam.forward.cross(cam.up).normalize() * tan * (w as f32 / h as f32);
    let up = cam.up * tan;
    (0..w * h)
        .map(|p| {
            let x = ((p % w) as f32 + 0.5) / w as f32 * 2.0 - 1.0;
            let y = 1.0 - ((p / w) as f32 + 0.5) / h as f32 * 2.0;
            GpuRay {
                origin: cam.position.to_array(),
                tmin: 0.0,
                dir: (cam.forward + x * right + y * up).normalize().to_array(),
                tmax: f32::INFINITY,
            }
        })
        .collect()
}

/// Incoherent rays: from the hit points of `primary` (slightly lifted), in uniformly random
/// directions over the sphere; primary misses start at random points above the mesh.
pub fn incoherent_rays(bvh: &Bvh, primary: &[GpuRay], seed: u64) -> Vec<GpuRay> {
    primary
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            let mut rng = SplitMix64(seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let (o, d) = (Vec3::from(r.origin), Vec3::from(r.dir));
            let origin = match bvh.intersect(o, d, 0.0, f32::INFINITY) {
                Some((t, _)) => o + d * (t - 1e-3),
                None => Vec3::new(
                    rng.range(-50.0, 50.0),
                    rng.range(0.0, 10.0),
                    rng.range(-50.0, 50.0),
                ),
            };
            let z = rng.range(-1.0, 1.0);
            let phi = rng.range(0.0, std::f32::consts::TAU);
            let s = (1.0 - z * z).max(0.0).sqrt();
            GpuRay {
                origin: origin.to_array(),
                tmin: 0.0,
                dir: [s * phi.cos(), z, s * phi.sin()],
                tmax: f32::INFINITY,
            }
        })
        .collect()
}

/// Closest-hit CPU traversal on all cores; the fastest of `repeats` runs in seconds.
pub fn trace_cpu(bvh: &Bvh, rays: &[GpuRay], repeats: u32) -> (Vec<Option<(f32, u32)>>, f64) {
    let mut best = f64::INFINITY;
    let mut out = Vec::new();
    for _ in 0..repeats.max(1) {
        let t0 = Instant::now();
        out = rays
            .par_iter()
            .map(|r| bvh.intersect(Vec3::from(r.origin), Vec3::from(r.dir), r.tmin, r.tmax))
            .collect();
        best = best.min(t0.elapsed().as_secs_f64());
    }
    (out, best)
}

pub struct RayBenchRow {
    pub kind: &'static str,
    pub rays: usize,
    pub gpu_mrays: f64,
    pub cpu_mrays: f64,
    /// Rays whose hit triangle agrees between GPU and CPU.
    pub agreement: f64,
}

/// The arguments `bench-rays` accepts, checked before any work. Measured before the bounds:
/// `--width 100000 --height 100000` aborted on a 45 GB allocation, `--triangles 1e8` ran to
/// 8.8 GB, `--repeats 0` printed rates from nothing. The mesh has the scenes' triangle
/// limit; 2048² rays of 32 B are lavapipe's 128 MiB storage-buffer limit.
pub fn check_args(triangles: usize, width: u32, height: u32, repeats: u32) -> Result<()> {
    use crate::scene::gltf_load::MAX_TRIANGLES;
    if !(1000..=MAX_TRIANGLES).contains(&triangles) {
        anyhow::bail!("--triangles {triangles} is out of range: use 1000..={MAX_TRIANGLES}");
    }
    if !(1..=2048).contains(&width) || !(1..=2048).contains(&height) {
        anyhow::bail!("--width/--height {width}×{height} is out of range: use 1..=2048 each");
    }
    if !(1..=100).contains(&repeats) {
        anyhow::bail!("--repeats {repeats} is out of range: use 1..=100");
    }
    Ok(())
}

/// Runs both ray kinds on GPU and CPU; `repeats` timed runs each, best taken.
pub fn run(
    ctx: &Arc<Context>,
    triangles: usize,
    width: u32,
    height: u32,
    repeats: u32,
    log: &mut dyn FnMut(String),
) -> Result<Vec<RayBenchRow>> {
    let mesh = bench_mesh(triangles, 7);
    let t0 = Instant::now();
    let bvh = Bvh::build(&mesh);
    log(format!(
        "mesh: {} triangles; BVH: {} nodes, built in {:.2} s",
        mesh.len(),
        bvh.nodes.len(),
        t0.elapsed().as_secs_f64()
    ));
    let nodes = Buffer::texels(ctx, "bvh nodes", &bvh.nodes)?;
    let tris = Buffer::texels(ctx, "bvh triangles", &bvh.tris)?;
    let primary = primary_rays(width, height);
    let incoherent = incoherent_rays(&bvh, &primary, 11);
    let mut rows = Vec::new();
    for (kind, rays) in [
        ("coherent (camera)", &primary),
        ("incoherent (random)", &incoherent),
    ] {
        let (gpu_hits, gpu_s) = gpu_trace::trace(ctx, &nodes, &tris, rays, false, repeats)?;
        let (cpu_hits, cpu_s) = trace_cpu(&bvh, rays, repeats);
        let agree = gpu_hits
            .iter()
            .zip(&cpu_hits)
            .filter(|(g, c)| g.prim == c.map_or(u32::MAX, |h| h.1))
            .count();
        let row = RayBenchRow {
            kind,
            rays: rays.len(),
            gpu_mrays: rays.len() as f64 / gpu_s / 1e6,
            cpu_mrays: rays.len() as f64 / cpu_s / 1e6,
            agreement: agree as f64 / rays.len() as f64,
        };
        log(format!(
            "{:<20} {:>9} rays  GPU {:>8.2} Mrays/s  CPU ({} threads) {:>8.2} Mrays/s  GPU/CPU {:.3}  same hit {:.4}%",
            row.kind,
            row.rays,
            row.gpu_mrays,
            rayon::current_num_threads(),
            row.cpu_mrays,
            row.gpu_mrays / row.cpu_mrays,
            100.0 * row.agreement
        ));
        rows.push(row);
    }
    Ok(rows)
}
