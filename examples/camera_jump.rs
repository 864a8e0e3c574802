//! What the preview's carried learning is worth after a camera jump (issue #13's benchmark):
//! rooms16, direct light, a session learns LEARN passes at the scene camera, the camera jumps,
//! and the MSE of the first 16 spp after the jump (against a lightbvh reference of the new
//! view) is compared with a fresh session's 16 spp there, averaged over seeds.
//!
//! cargo run --release --example camera_jump [-- WIDTH HEIGHT LEARN REFERENCE_SPP SEEDS]

use anyhow::Result;
use glam::Vec3;
use lightlearn::accel::Bvh;
use lightlearn::compare::metrics;
use lightlearn::gpu::{Context, ContextOptions};
use lightlearn::render::{self, Budget, GpuScene, LightSampler, RenderSettings, Session};
use lightlearn::scene::{gltf_load, Camera};

fn main() -> Result<()> {
    let a: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|s| s.parse().ok())
        .collect();
    let get = |i: usize, d: u32| a.get(i).copied().unwrap_or(d);
    let (w, h, learn, ref_spp, seeds) =
        (get(0, 96), get(1, 72), get(2, 256), get(3, 4096), get(4, 4));
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rooms16.glb");
    let scene = gltf_load::load(&path, &mut |_| {})?;
    let ctx = Context::new(&ContextOptions::default())?;
    let gpu = GpuScene::upload(&ctx, &scene, &Bvh::build(&scene.triangles))?;
    let settings = |sampler, seed, spp| RenderSettings {
        width: w,
        height: h,
        budget: Budget::Samples(spp),
        seed,
        sampler,
        regions: Default::default(),
        learn: Default::default(),
        resume: None,
        stratify: if sampler != LightSampler::Lightbvh {
            lightlearn::render::Stratify::Sobol
        } else {
            lightlearn::render::Stratify::Off
        },
        max_depth: 1,
        light_point: Default::default(),
        indirect_light_samples: 1,
        first_light_samples: 1,
    };
    // Jumps inside the first corridor and into the second (rooms16: corridors at z 4–6 and
    // 14–16, rooms 4 m wide along x).
    let jumps = [
        (
            "corridor, looking back",
            Camera::looking(
                Vec3::new(12.0, 1.6, 5.0),
                Vec3::new(-1.0, -0.1, 0.1),
                Vec3::Y,
                1.0,
            ),
        ),
        (
            "into a room",
            Camera::looking(
                Vec3::new(6.0, 1.6, 5.2),
                Vec3::new(0.1, -0.2, -1.0),
                Vec3::Y,
                1.0,
            ),
        ),
        (
            "second corridor",
            Camera::looking(
                Vec3::new(0.5, 1.6, 15.0),
                Vec3::new(1.0, -0.1, 0.0),
                Vec3::Y,
                1.0,
            ),
        ),
    ];
    println!("rooms16, direct light, {w}x{h}, learned {learn} passes at the scene camera, then 16 spp after the jump; {seeds} seeds; reference lightbvh {ref_spp} spp");
    for (name, cam) in jumps {
        let mut rs = scene.clone();
        rs.camera = cam;
        let reference = render::render(
            &ctx,
            &rs,
            &gpu,
            &settings(LightSampler::Lightbvh, 999, ref_spp),
            &mut |_, _| {},
        )?;
        let (_, ref_noise) = (0, reference.estimated_error().0);
        let reference = reference.mean();
        let mean = |im: &[[f32; 3]]| {
            im.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / (3 * im.len()) as f64
        };
        let ref_mean = mean(&reference);
        let (mut carried, mut fresh) = (0.0, 0.0);
        for seed in 0..seeds {
            let mut s = Session::new(&ctx, &scene, &gpu, &settings(LightSampler::Bayes, seed, 0))?;
            s.run_passes(learn)?;
            let before = s.passes();
            s.set_camera(cam)?;
            s.run_passes(16)?;
            assert!(
                s.passes() == before + 16,
                "the learned pass counter goes on after a move"
            );
            carried += metrics(&s.image()?, &reference).mse - ref_noise;
            let mut f = Session::new(&ctx, &rs, &gpu, &settings(LightSampler::Bayes, seed, 0))?;
            f.run_passes(16)?;
            fresh += metrics(&f.image()?, &reference).mse - ref_noise;
        }
        println!(
            "{name} (reference mean {ref_mean:.3e}): MSE carried {:.3e}, fresh {:.3e}: carried / fresh = {:.2}",
            carried / seeds as f64,
            fresh / seeds as f64,
            carried / fresh
        );
    }
    Ok(())
}
