//! The committed default scene (`scenes/default.glb`): a 3 × 3 grid of rooms joined by doors,
//! 225 lights (emissive ceiling panels, small point lights, one spot per room). The camera
//! looks from the first room through two doors, so most lights are hidden from most points.
//!
//! Regenerate with `cargo run --release --example make_default_scene`; a test checks that the
//! committed file equals what this code writes.

use glam::Vec3;

use super::gltf_write::GltfBuilder;
use crate::rng::SplitMix64;

pub const ROOMS_X: usize = 3;
pub const ROOMS_Z: usize = 3;
const ROOM: f32 = 4.0; // room size (m)
const HEIGHT: f32 = 3.0;
const WALL: f32 = 0.1; // wall thickness
const DOOR_W: f32 = 1.0;
const DOOR_H: f32 = 2.2;
pub const POINTS_PER_ROOM: usize = 20;

/// Builds the default scene. Lights: per room 2 emissive panels (4 triangles), 20 point
/// lights and 1 spot: 9 × 25 = 225.
pub fn build(seed: u64) -> GltfBuilder {
    let mut rng = SplitMix64(seed);
    let mut g = GltfBuilder::new();
    let (w, d) = (ROOMS_X as f32 * ROOM, ROOMS_Z as f32 * ROOM);
    let floor = g.material("floor", Vec3::new(0.6, 0.58, 0.55), Vec3::ZERO, false);
    let ceiling = g.material("ceiling", Vec3::splat(0.7), Vec3::ZERO, false);
    let wall = g.material("wall", Vec3::new(0.7, 0.68, 0.62), Vec3::ZERO, false);
    let panel = g.material("panel", Vec3::splat(0.8), Vec3::new(6.0, 5.4, 4.6), false);

    g.quad(
        "floor",
        [
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, d),
            Vec3::new(w, 0.0, d),
            Vec3::new(w, 0.0, 0.0),
        ],
        floor,
    );
    g.quad(
        "ceiling",
        [
            Vec3::new(0.0, HEIGHT, 0.0),
            Vec3::new(w, HEIGHT, 0.0),
            Vec3::new(w, HEIGHT, d),
            Vec3::new(0.0, HEIGHT, d),
        ],
        ceiling,
    );

    // Walls of constant z (running along x) and of constant x (running along z); inner walls
    // have a door in the middle of each room's segment.
    for k in 0..=ROOMS_Z {
        let z = k as f32 * ROOM;
        let inner = k > 0 && k < ROOMS_Z;
        for i in 0..ROOMS_X {
            let x0 = i as f32 * ROOM;
            wall_segment(&mut g, wall, inner, x0, x0 + ROOM, |a, b, y0, y1| {
                (
                    Vec3::new(a, y0, z - 0.5 * WALL),
                    Vec3::new(b, y1, z + 0.5 * WALL),
                )
            });
        }
    }
    for k in 0..=ROOMS_X {
        let x = k as f32 * ROOM;
        let inner = k > 0 && k < ROOMS_X;
        for j in 0..ROOMS_Z {
            let z0 = j as f32 * ROOM;
            wall_segment(&mut g, wall, inner, z0, z0 + ROOM, |a, b, y0, y1| {
                (
                    Vec3::new(x - 0.5 * WALL, y0, a),
                    Vec3::new(x + 0.5 * WALL, y1, b),
                )
            });
        }
    }

    for j in 0..ROOMS_Z {
        for i in 0..ROOMS_X {
            let o = Vec3::new(i as f32 * ROOM, 0.0, j as f32 * ROOM);
            let tint = Vec3::new(
                rng.range(0.3, 0.8),
                rng.range(0.3, 0.8),
                rng.range(0.3, 0.8),
            );
            let table = g.material(&format!("table_{i}_{j}"), tint, Vec3::ZERO, false);
            let c = o + Vec3::new(rng.range(1.2, 2.8), 0.0, rng.range(1.2, 2.8));
            g.cuboid(
                &format!("table_{i}_{j}"),
                c + Vec3::new(-0.6, 0.0, -0.4),
                c + Vec3::new(0.6, 0.75, 0.4),
                table,
            );
            // Two ceiling panels facing down (CCW seen from below).
            for p in 0..2 {
                let px = o.x + 1.0 + 1.5 * p as f32;
                let pz = o.z + 1.5;
                let y = HEIGHT - 0.02;
                g.quad(
                    &format!("panel_{i}_{j}_{p}"),
                    [
                        Vec3::new(px, y, pz),
                        Vec3::new(px + 0.5, y, pz),
                        Vec3::new(px + 0.5, y, pz + 1.0),
                        Vec3::new(px, y, pz + 1.0),
                    ],
                    panel,
                );
            }
            for n in 0..POINTS_PER_ROOM {
                let pos = o + Vec3::new(
                    rng.range(0.3, ROOM - 0.3),
                    rng.range(0.3, HEIGHT - 0.3),
                    rng.range(0.3, ROOM - 0.3),
                );
                let col = Vec3::new(
                    rng.range(0.4, 1.0),
                    rng.range(0.4, 1.0),
                    rng.range(0.4, 1.0),
                );
                g.point_light(&format!("bulb_{i}_{j}_{n}"), pos, col, rng.range(0.05, 0.4));
            }
            let top = o + Vec3::new(rng.range(1.0, 3.0), HEIGHT - 0.05, rng.range(1.0, 3.0));
            let aim = o + Vec3::new(rng.range(1.0, 3.0), 0.0, rng.range(1.0, 3.0));
            g.spot_light(
                &format!("spot_{i}_{j}"),
                top,
                aim - top,
                Vec3::new(1.0, 0.9, 0.75),
                6.0,
                25f32.to_radians(),
                35f32.to_radians(),
            );
        }
    }
    // From the first room, through the doors of the x-row of rooms.
    g.camera(
        Vec3::new(0.6, 1.6, 1.2),
        Vec3::new(ROOMS_X as f32 * ROOM, 1.1, 2.4),
        60f32.to_radians(),
    );
    g
}

/// One wall segment from `a` to `b` along its length; `make(a, b, y0, y1)` gives the box.
fn wall_segment(
    g: &mut GltfBuilder,
    material: usize,
    door: bool,
    a: f32,
    b: f32,
    make: impl Fn(f32, f32, f32, f32) -> (Vec3, Vec3),
) {
    let mut push = |a: f32, b: f32, y0: f32, y1: f32| {
        let (lo, hi) = make(a, b, y0, y1);
        g.cuboid("wall", lo, hi, material);
    };
    if door {
        let m = 0.5 * (a + b);
        push(a, m - 0.5 * DOOR_W, 0.0, HEIGHT);
        push(m + 0.5 * DOOR_W, b, 0.0, HEIGHT);
        push(m - 0.5 * DOOR_W, m + 0.5 * DOOR_W, DOOR_H, HEIGHT);
    } else {
        push(a, b, 0.0, HEIGHT);
    }
}
