//! `hall`: one open hall, 5 m high, with a square-ish grid of 1 m × 0.5 m ceiling panels every
//! 3 m (each panel = 2 triangle lights; an odd budget adds one bulb), tables and a few
//! partitions. Simple occlusion and little to learn: a baseline must not lose here.

use glam::Vec3;

use super::{ceiling_quad, floor_material, floor_quad, FamilyParams, MeshAccum};
use crate::rng::SplitMix64;
use crate::scene::gltf_write::GltfBuilder;

const SPACING: f32 = 3.0;
const HEIGHT: f32 = 5.0;

pub fn build(p: &FamilyParams) -> GltfBuilder {
    let mut rng = SplitMix64(p.seed);
    let mut g = GltfBuilder::new();
    let floor_m = floor_material(&mut g, p, "floor", Vec3::new(0.5, 0.5, 0.5));
    let wall_m = g.material("wall", Vec3::new(0.75, 0.72, 0.68), Vec3::ZERO, false);
    let table_m = g.material("table", Vec3::new(0.6, 0.45, 0.3), Vec3::ZERO, false);
    let part_m = g.material("partition", Vec3::new(0.35, 0.45, 0.6), Vec3::ZERO, false);
    let panel_m = g.material("panel", Vec3::splat(0.8), Vec3::new(5.0, 4.8, 4.4), false);

    let quads = p.lights / 2;
    let nx = ((quads as f64).sqrt().ceil() as usize).max(1);
    let nz = quads.div_ceil(nx).max(1);
    let (w, d) = (nx as f32 * SPACING, nz as f32 * SPACING);

    let mut panels = MeshAccum::default();
    for q in 0..quads {
        let (i, j) = (q % nx, q / nx);
        let (cx, cz) = ((i as f32 + 0.5) * SPACING, (j as f32 + 0.5) * SPACING);
        panels.quad(ceiling_quad(
            cx - 0.5,
            cx + 0.5,
            cz - 0.25,
            cz + 0.25,
            HEIGHT - 0.02,
        ));
    }
    if p.lights % 2 == 1 {
        g.point_light(
            "bulb",
            Vec3::new(0.5 * w, HEIGHT - 1.0, 0.5 * d),
            Vec3::ONE,
            2.0,
        );
    }

    let mut shell = MeshAccum::default();
    shell.quad(floor_quad(0.0, w, 0.0, d, 0.0));
    shell.emit(&mut g, "floor", floor_m);
    let mut walls = MeshAccum::default();
    walls.quad(ceiling_quad(0.0, w, 0.0, d, HEIGHT));
    walls.cuboid(Vec3::new(-0.2, 0.0, -0.2), Vec3::new(w + 0.2, HEIGHT, 0.0));
    walls.cuboid(Vec3::new(-0.2, 0.0, d), Vec3::new(w + 0.2, HEIGHT, d + 0.2));
    walls.cuboid(Vec3::new(-0.2, 0.0, 0.0), Vec3::new(0.0, HEIGHT, d));
    walls.cuboid(Vec3::new(w, 0.0, 0.0), Vec3::new(w + 0.2, HEIGHT, d));
    walls.emit(&mut g, "walls", wall_m);

    // About one table per panel cell, and one partition per four cells.
    let mut tables = MeshAccum::default();
    let mut parts = MeshAccum::default();
    let cells = nx * nz;
    for _ in 0..cells {
        let c = Vec3::new(rng.range(0.8, w - 0.8), 0.375, rng.range(0.8, d - 0.8));
        tables.turned_box(
            c,
            Vec3::new(0.7, 0.375, 0.4),
            rng.range(0.0, std::f32::consts::PI),
        );
    }
    let eye = Vec3::new(0.6, 1.7, 0.6);
    let half = Vec3::new(1.5, 1.0, 0.05);
    for _ in 0..cells.div_ceil(4) {
        let c = Vec3::new(rng.range(1.0, w - 1.0), 1.0, rng.range(1.0, d - 1.0));
        let angle = rng.range(0.0, std::f32::consts::PI);
        // Not one around the camera: in a hall of 1–3 lights (3 m) one closed over it and
        // the image was black (an audit, 2026-12-06). Drawn all the same, so that the
        // halls without one keep their bytes.
        let local = glam::Quat::from_rotation_y(-angle) * (eye - c);
        if local.abs().cmple(half + 0.1).all() {
            continue;
        }
        parts.turned_box(c, half, angle);
    }
    panels.emit(&mut g, "panels", panel_m);
    tables.emit(&mut g, "tables", table_m);
    parts.emit(&mut g, "partitions", part_m);

    g.camera(eye, Vec3::new(0.5 * w, 1.2, 0.5 * d), 60f32.to_radians());
    g
}
