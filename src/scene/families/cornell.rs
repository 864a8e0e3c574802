//! `cornell`: the classic box (red left, green right wall, open front) with a short and a tall
//! block. Lights: a downward ceiling panel (2 triangle lights) and N − 2 small bulbs in the
//! upper half; with N = 1 a single bulb under the ceiling.

use glam::Vec3;

use super::{ceiling_quad, floor_quad, light_colour, FamilyParams, MeshAccum};
use crate::rng::SplitMix64;
use crate::scene::gltf_write::GltfBuilder;

pub fn build(p: &FamilyParams) -> GltfBuilder {
    let mut rng = SplitMix64(p.seed);
    let mut g = GltfBuilder::new();
    let white = g.material("white", Vec3::new(0.73, 0.73, 0.73), Vec3::ZERO, false);
    let red = g.material("red", Vec3::new(0.63, 0.065, 0.05), Vec3::ZERO, false);
    let green = g.material("green", Vec3::new(0.14, 0.45, 0.091), Vec3::ZERO, false);

    // Inside faces of the box [-1, 1] × [0, 2] × [-1, 1].
    let mut w = MeshAccum::default();
    w.quad(floor_quad(-1.0, 1.0, -1.0, 1.0, 0.0));
    w.quad(ceiling_quad(-1.0, 1.0, -1.0, 1.0, 2.0));
    w.quad([
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 2.0, -1.0),
        Vec3::new(-1.0, 2.0, -1.0),
    ]);
    w.turned_box(Vec3::new(0.33, 0.3, 0.37), Vec3::splat(0.3), -0.3);
    // The tall box: white like the walls, or with --glossy a white metal (Fresnel 1 in glTF's
    // Schlick form: exactly Mitsuba's roughconductor with material "none", tests/mitsuba.rs).
    let metal = p
        .glossy
        .map(|r| g.glossy_material("metal", Vec3::ONE, 1.0, r));
    let mut tall = MeshAccum::default();
    let tall_mesh = if metal.is_some() { &mut tall } else { &mut w };
    tall_mesh.turned_box(Vec3::new(-0.35, 0.6, -0.3), Vec3::new(0.3, 0.6, 0.3), 0.3);
    w.emit(&mut g, "walls", white);
    if let Some(metal) = metal {
        tall.emit(&mut g, "tall box", metal);
    }
    let mut left = MeshAccum::default();
    left.quad([
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(-1.0, 2.0, -1.0),
        Vec3::new(-1.0, 2.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
    ]);
    left.emit(&mut g, "left", red);
    let mut right = MeshAccum::default();
    right.quad([
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 2.0, 1.0),
        Vec3::new(1.0, 2.0, -1.0),
    ]);
    right.emit(&mut g, "right", green);

    let bulbs = if p.lights >= 2 {
        let panel = g.material("panel", Vec3::splat(0.78), Vec3::new(12.0, 9.5, 6.0), false);
        let mut q = MeshAccum::default();
        q.quad(ceiling_quad(-0.25, 0.25, -0.2, 0.2, 1.99));
        q.emit(&mut g, "panel", panel);
        p.lights - 2
    } else {
        p.lights
    };
    for i in 0..bulbs {
        let pos = Vec3::new(
            rng.range(-0.85, 0.85),
            rng.range(1.2, 1.85),
            rng.range(-0.85, 0.6),
        );
        let colour = light_colour(&mut rng);
        g.point_light(&format!("bulb{i}"), pos, colour, rng.range(0.1, 0.4));
    }
    g.camera(
        Vec3::new(0.0, 1.0, 3.9),
        Vec3::new(0.0, 1.0, 0.0),
        40f32.to_radians(),
    );
    g
}
