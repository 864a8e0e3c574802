//! The GPU traversal kernel finds the same triangle as the CPU traversal of the same BVH.

mod common;

use glam::Vec3;
use lightlearn::accel::{gpu_trace, Bvh};
use lightlearn::bench::rays::{bench_mesh, incoherent_rays, primary_rays};
use lightlearn::gpu::layout::GpuRay;
use lightlearn::gpu::Buffer;
use lightlearn::rng::SplitMix64;

#[test]
fn gpu_and_cpu_bvh_agree_on_every_ray() {
    let ctx = common::ctx();
    let mesh = bench_mesh(20_000, 3);
    let bvh = Bvh::build(&mesh);
    let nodes = Buffer::texels(&ctx, "nodes", &bvh.nodes).unwrap();
    let tris = Buffer::texels(&ctx, "tris", &bvh.tris).unwrap();

    let primary = primary_rays(64, 48);
    let incoherent = incoherent_rays(&bvh, &primary, 5);
    // Plus rays from outside in all directions, with finite tmin/tmax windows.
    let mut rng = SplitMix64(17);
    let outside: Vec<GpuRay> = (0..2000)
        .map(|_| {
            let o = Vec3::new(
                rng.range(-60.0, 60.0),
                rng.range(-5.0, 30.0),
                rng.range(-60.0, 60.0),
            );
            let target = Vec3::new(
                rng.range(-50.0, 50.0),
                rng.range(-2.0, 4.0),
                rng.range(-50.0, 50.0),
            );
            GpuRay {
                origin: o.to_array(),
                tmin: rng.range(0.0, 5.0),
                dir: (target - o).normalize().to_array(),
                tmax: rng.range(20.0, 200.0),
            }
        })
        .collect();

    // Axis-aligned rays (direction components exactly ±0), half from integer coordinates
    // that lie on box planes of the boxes standing on the mesh.
    let axes = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    let aligned: Vec<GpuRay> = (0..1200)
        .map(|i| {
            let o = Vec3::new(
                rng.range(-50.0, 50.0),
                rng.range(-1.0, 20.0),
                rng.range(-50.0, 50.0),
            );
            let o = if i % 2 == 0 { o.round() } else { o };
            GpuRay {
                origin: o.to_array(),
                tmin: 0.0,
                dir: axes[i % 6].to_array(),
                tmax: f32::INFINITY,
            }
        })
        .collect();

    for (kind, rays) in [
        ("primary", &primary),
        ("incoherent", &incoherent),
        ("outside", &outside),
        ("axis-aligned", &aligned),
    ] {
        let (hits, _) = gpu_trace::trace(&ctx, &nodes, &tris, rays, false, 1).unwrap();
        let (any, _) = gpu_trace::trace(&ctx, &nodes, &tris, rays, true, 1).unwrap();
        let mut n_hit = 0;
        let mut ties = 0;
        for (i, r) in rays.iter().enumerate() {
            let (o, d) = (Vec3::from(r.origin), Vec3::from(r.dir));
            let cpu = bvh.intersect(o, d, r.tmin, r.tmax);
            let gpu = hits[i];
            n_hit += cpu.is_some() as usize;
            match cpu {
                Some((t, prim)) if prim == gpu.prim => {
                    assert!(
                        (t - gpu.t).abs() <= 1e-4 * t.max(1.0),
                        "{kind} ray {i}: t {t} vs {}",
                        gpu.t
                    )
                }
                Some((t, prim)) => {
                    // Only a tie (the ray through a shared edge, equal t) may differ.
                    assert!(
                        gpu.prim != u32::MAX && (t - gpu.t).abs() <= 1e-4 * t.max(1.0),
                        "{kind} ray {i}: CPU hits {prim} at {t}, GPU hits {} at {}",
                        gpu.prim,
                        gpu.t
                    );
                    ties += 1;
                }
                None => assert_eq!(
                    gpu.prim,
                    u32::MAX,
                    "{kind} ray {i}: GPU hit where CPU missed"
                ),
            }
            assert_eq!(
                any[i].prim != u32::MAX,
                cpu.is_some(),
                "{kind} ray {i}: any-hit disagrees"
            );
        }
        assert!(
            ties * 1000 <= rays.len(),
            "{kind}: {ties} ties is too many to be edge hits"
        );
        assert!(
            n_hit * 10 >= rays.len(),
            "{kind}: only {n_hit} hits; the test would be too weak"
        );
        eprintln!("{kind}: {} rays, {n_hit} hits, {ties} ties", rays.len());
    }
}
