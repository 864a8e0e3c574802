//! GPU renders against the CPU reference integrator on small scenes: every pixel's mean must
//! agree within a tolerance derived from both estimates' sample variances, and no pixel may be
//! NaN or Inf.

mod common;

use glam::Vec3;
use lightlearn::accel::Bvh;
use lightlearn::reference::{self, ReferenceImage};
use lightlearn::render::{
    self, Budget, GpuScene, LightPoint, LightSampler, RenderResult, RenderSettings,
};
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::Scene;

const W: u32 = 40;
const H: u32 = 32;
const SPP: u32 = 512;

fn room(g: &mut GltfBuilder) {
    let floor = g.material("floor", Vec3::new(0.8, 0.7, 0.6), Vec3::ZERO, false);
    let wall = g.material("wall", Vec3::new(0.5, 0.6, 0.8), Vec3::ZERO, false);
    let block = g.material("block", Vec3::new(0.9, 0.3, 0.2), Vec3::ZERO, false);
    g.quad(
        "floor",
        [
            Vec3::new(-3.0, 0.0, -2.0),
            Vec3::new(-3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, -2.0),
        ],
        floor,
    );
    g.cuboid(
        "back",
        Vec3::new(-3.0, 0.0, -2.2),
        Vec3::new(3.0, 2.5, -2.0),
        wall,
    );
    // The occluder: casts shadows from every light below.
    g.cuboid(
        "block",
        Vec3::new(-0.4, 0.0, -0.4),
        Vec3::new(0.4, 0.9, 0.4),
        block,
    );
    g.camera(
        Vec3::new(0.3, 2.6, 4.0),
        Vec3::new(0.0, 0.4, 0.0),
        55f32.to_radians(),
    );
}

/// Point and spot lights only (the reference sums them exactly).
fn punctual_scene() -> Scene {
    let mut g = GltfBuilder::new();
    room(&mut g);
    g.point_light(
        "p0",
        Vec3::new(-1.2, 1.5, 0.8),
        Vec3::new(1.0, 0.8, 0.6),
        3.0,
    );
    g.point_light(
        "p1",
        Vec3::new(1.5, 0.6, -1.0),
        Vec3::new(0.3, 0.6, 1.0),
        1.5,
    );
    g.point_light(
        "p2",
        Vec3::new(0.0, 2.2, -1.5),
        Vec3::new(1.0, 1.0, 1.0),
        0.5,
    );
    g.spot_light(
        "spot",
        Vec3::new(1.0, 2.0, 1.0),
        Vec3::new(-1.0, -2.0, -1.0),
        Vec3::new(1.0, 0.9, 0.7),
        8.0,
        0.25,
        0.45,
    );
    common::load(&g, "punctual")
}

/// Emissive triangles (one-sided quad facing down, a two-sided triangle seen by the camera)
/// and a point light.
fn area_scene() -> Scene {
    let mut g = GltfBuilder::new();
    room(&mut g);
    let panel = g.material("panel", Vec3::splat(0.5), Vec3::new(4.0, 3.5, 3.0), false);
    let sheet = g.material("sheet", Vec3::splat(0.5), Vec3::new(0.5, 2.0, 1.0), true);
    g.quad(
        "panel",
        [
            Vec3::new(-1.0, 2.0, -1.0),
            Vec3::new(0.0, 2.0, -1.0),
            Vec3::new(0.0, 2.0, 0.5),
            Vec3::new(-1.0, 2.0, 0.5),
        ],
        panel,
    );
    g.mesh(
        "sheet",
        &[
            Vec3::new(1.2, 0.0, 0.5),
            Vec3::new(2.2, 0.0, -0.5),
            Vec3::new(1.7, 1.2, 0.0),
        ],
        &[0, 1, 2],
        sheet,
    );
    g.point_light(
        "p0",
        Vec3::new(-1.5, 1.0, 1.5),
        Vec3::new(1.0, 0.9, 0.8),
        1.0,
    );
    common::load(&g, "area")
}

fn gpu_render(scene: &Scene, sampler: LightSampler, light_point: LightPoint) -> RenderResult {
    let ctx = common::ctx();
    let bvh = Bvh::build(&scene.triangles);
    let gpu = GpuScene::upload(&ctx, scene, &bvh).unwrap();
    let settings = RenderSettings {
        width: W,
        height: H,
        budget: Budget::Samples(SPP),
        seed: 7,
        sampler,
        regions: lightlearn::lights::regions::RegionSettings::default(),
        learn: Default::default(),
        resume: None,
        stratify: lightlearn::render::Stratify::Off,
        max_depth: 1,
        light_point,
        indirect_light_samples: 1,
        first_light_samples: 1,
    };
    render::render(&ctx, scene, &gpu, &settings, &mut |_, _| {}).unwrap()
}

/// Per pixel and channel: |gpu − ref| ≤ z·sqrt(var_gpu + var_ref) + abs_tol, and the image
/// means agree within z standard errors. Returns the worst offence on failure.
fn compare(gpu: &RenderResult, r: &ReferenceImage, z: f64) -> Result<(), String> {
    let mean = gpu.mean();
    let var = gpu.variance_of_mean();
    let peak = r.mean.iter().flatten().fold(0f64, |m, v| m.max(*v));
    let abs_tol = 1e-5 * peak;
    let (mut sum_g, mut sum_r, mut var_sum) = (0f64, 0f64, 0f64);
    for p in 0..mean.len() {
        for k in 0..3 {
            let g = mean[p][k] as f64;
            if !g.is_finite() {
                return Err(format!("pixel {p} channel {k} is {g}"));
            }
            let rr = r.mean[p][k];
            let sigma = (var[p][k] as f64 + r.variance_of_mean[p][k]).sqrt();
            if (g - rr).abs() > z * sigma + abs_tol {
                return Err(format!(
                    "pixel ({}, {}) channel {k}: GPU {g:.5} vs reference {rr:.5} (σ {sigma:.5})",
                    p as u32 % gpu.width,
                    p as u32 / gpu.width
                ));
            }
            sum_g += g;
            sum_r += rr;
            var_sum += var[p][k] as f64 + r.variance_of_mean[p][k];
        }
    }
    if (sum_g - sum_r).abs() > z * var_sum.sqrt() + abs_tol {
        return Err(format!(
            "image sums differ: GPU {sum_g:.4} vs reference {sum_r:.4} (σ {:.4})",
            var_sum.sqrt()
        ));
    }
    Ok(())
}

fn check(scene: &Scene, sampler: LightSampler) {
    check_with(scene, sampler, LightPoint::Area)
}

fn check_with(scene: &Scene, sampler: LightSampler, light_point: LightPoint) {
    let bvh = Bvh::build(&scene.triangles);
    let reference = reference::render(scene, &bvh, W, H, 256, 8, 99);
    let gpu = gpu_render(scene, sampler, light_point);
    assert_eq!(gpu.spp, SPP);
    assert_eq!(gpu.invalid_samples, 0, "NaN/Inf samples were produced");
    let lit = gpu
        .mean()
        .iter()
        .filter(|p| p.iter().any(|v| *v > 1e-3))
        .count();
    assert!(
        lit * 2 > (W * H) as usize,
        "most of the image should be lit ({lit} px)"
    );
    if let Err(e) = compare(&gpu, &reference, 5.0) {
        panic!("{} with {sampler:?}: {e}", scene.source);
    }
    // The comparison must be able to fail: a reference 5% too bright is rejected.
    let mut wrong = ReferenceImage {
        mean: reference.mean.clone(),
        variance_of_mean: reference.variance_of_mean.clone(),
        ..reference
    };
    wrong.mean.iter_mut().flatten().for_each(|v| *v *= 1.05);
    assert!(
        compare(&gpu, &wrong, 5.0).is_err(),
        "a 5% error must be detected"
    );
}

#[test]
fn punctual_lights_uniform() {
    check(&punctual_scene(), LightSampler::Uniform);
}

#[test]
fn punctual_lights_power() {
    check(&punctual_scene(), LightSampler::Power);
}

#[test]
fn area_lights_uniform() {
    check(&area_scene(), LightSampler::Uniform);
}

/// Triangle lights drawn by solid angle (`--light-point solid-angle`): the one-sided panel
/// and the two-sided sheet, seen from both sides, match the CPU reference (which samples by
/// area) pixel by pixel; with a learned sampler too.
#[test]
fn area_lights_by_solid_angle_uniform() {
    check_with(&area_scene(), LightSampler::Uniform, LightPoint::SolidAngle);
}

#[test]
fn area_lights_by_solid_angle_bayes() {
    check_with(&area_scene(), LightSampler::Bayes, LightPoint::SolidAngle);
}

#[test]
fn area_lights_power() {
    check(&area_scene(), LightSampler::Power);
}

#[test]
fn punctual_lights_lightbvh() {
    check(&punctual_scene(), LightSampler::Lightbvh);
}

#[test]
fn area_lights_lightbvh() {
    check(&area_scene(), LightSampler::Lightbvh);
}

#[test]
fn punctual_lights_wang() {
    check(&punctual_scene(), LightSampler::Wang);
}

#[test]
fn area_lights_wang() {
    check(&area_scene(), LightSampler::Wang);
}
