//! A stop asked for while a render's last batch runs: the render met its budget, so it is
//! complete, not interrupted (its own process: the stop is process-wide). Before, `--spp`
//! renders were reported as interrupted and `reference` threw a complete image away (an
//! audit, 2026-12-06).

mod common;

use lightlearn::accel::Bvh;
use lightlearn::render::{self, Budget, GpuScene, LightSampler, RenderSettings};

#[test]
fn a_stop_during_the_last_batch_leaves_a_complete_render() {
    let mut g = lightlearn::scene::gltf_write::GltfBuilder::new();
    let m = g.material("grey", glam::Vec3::splat(0.5), glam::Vec3::ZERO, false);
    g.cuboid("box", glam::Vec3::ZERO, glam::Vec3::ONE, m);
    g.point_light("bulb", glam::Vec3::new(0.5, 2.0, 0.5), glam::Vec3::ONE, 1.0);
    g.camera(glam::Vec3::new(0.5, 1.5, 3.0), glam::Vec3::splat(0.5), 0.8);
    let scene = common::load(&g, "box.glb");
    let ctx = common::ctx();
    let gpu = GpuScene::upload(&ctx, &scene, &Bvh::build(&scene.triangles)).unwrap();
    let settings = RenderSettings {
        width: 8,
        height: 8,
        budget: Budget::Samples(1),
        seed: 1,
        sampler: LightSampler::Uniform,
        regions: Default::default(),
        learn: Default::default(),
        resume: None,
        stratify: render::Stratify::Off,
        max_depth: 1,
        light_point: Default::default(),
        indirect_light_samples: 1,
        first_light_samples: 1,
    };
    // Asked before the loop starts: its first batch (of one pass) is its last.
    lightlearn::interrupt::request();
    let r = render::render(&ctx, &scene, &gpu, &settings, &mut |_, _| {}).unwrap();
    assert_eq!(r.spp, 1);
    assert!(!r.interrupted, "a render that met its budget is complete");
    // A time budget not met is still stopped after its batch.
    let timed = RenderSettings {
        budget: Budget::Seconds(1e6),
        ..settings
    };
    let r = render::render(&ctx, &scene, &gpu, &timed, &mut |_, _| {}).unwrap();
    assert!(r.interrupted && r.spp >= 1);
}
