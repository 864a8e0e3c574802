//! `rooms`: a building floor. Rows of 4 m × 4 m rooms face corridors (rows 2k and 2k+1 share
//! the corridor between them; an odd last row gets one of its own). Every room has a door to
//! its corridor; side-by-side rooms are joined by a door half of the time. Lights: ceiling
//! panels in the corridors (a tenth of the budget), and in each room up to two ceiling panels,
//! a spot over the table and bulbs. From any point most lights are hidden.

use anyhow::{bail, Result};
use glam::Vec3;

use super::{
    ceiling_quad, floor_material, floor_quad, light_colour, shares, wall_with_door, FamilyParams,
    MeshAccum,
};
use crate::rng::SplitMix64;
use crate::scene::gltf_write::GltfBuilder;

const ROOM: f32 = 4.0;
const CORRIDOR: f32 = 2.0;
const HEIGHT: f32 = 3.0;
const WALL: f32 = 0.1;
const DOOR: (f32, f32) = (1.0, 2.2);
/// Rooms per light when the grid is not given: about 25 lights per room.
const LIGHTS_PER_ROOM: usize = 25;
pub const MAX_ROOMS: usize = 10_000;

pub fn build(p: &FamilyParams) -> Result<GltfBuilder> {
    let (rx, rz) = match p.rooms {
        Some((x, z)) => (x, z),
        None => {
            // At most MAX_ROOMS: `--lights 1000000` alone asked for a 200x200 grid and was
            // refused as "--rooms 200x200", a flag not given (an audit, 2026-12-06).
            let n = p.lights.div_ceil(LIGHTS_PER_ROOM).clamp(1, MAX_ROOMS);
            let x = (n as f64).sqrt().ceil() as usize;
            (x, n.div_ceil(x))
        }
    };
    // Checked: a product that wraps passed the limit (an audit, 2026-12-07).
    if rx == 0 || rz == 0 || rx.checked_mul(rz).is_none_or(|n| n > MAX_ROOMS) {
        bail!("--rooms {rx}x{rz}: use at least 1x1 and at most {MAX_ROOMS} rooms");
    }
    let mut rng = SplitMix64(p.seed);
    let mut g = GltfBuilder::new();
    let floor_m = floor_material(&mut g, p, "floor", Vec3::new(0.6, 0.58, 0.55));
    let ceiling_m = g.material("ceiling", Vec3::splat(0.7), Vec3::ZERO, false);
    let wall_m = g.material("wall", Vec3::new(0.7, 0.68, 0.62), Vec3::ZERO, false);
    let table_m = g.material("table", Vec3::new(0.55, 0.4, 0.3), Vec3::ZERO, false);
    let panel_m = g.material("panel", Vec3::splat(0.8), Vec3::new(6.0, 5.4, 4.6), false);

    // z-extent of each row of rooms and of each corridor.
    let mut row_z = Vec::with_capacity(rz);
    let mut corridors = Vec::new();
    let mut z = 0.0;
    for r in 0..rz {
        if r % 2 == 1 {
            corridors.push(z);
            z += CORRIDOR;
        }
        row_z.push(z);
        z += ROOM;
        if r % 2 == 0 && r == rz - 1 {
            corridors.push(z);
            z += CORRIDOR;
        }
    }
    let (width, depth) = (rx as f32 * ROOM, z);

    let mut walls = MeshAccum::default();
    let mut tables = MeshAccum::default();
    let mut panels = MeshAccum::default();
    let along_x = |zc: f32| {
        move |a: f32, b: f32, y0: f32, y1: f32| {
            (
                Vec3::new(a, y0, zc - 0.5 * WALL),
                Vec3::new(b, y1, zc + 0.5 * WALL),
            )
        }
    };
    let along_z = |xc: f32| {
        move |a: f32, b: f32, y0: f32, y1: f32| {
            (
                Vec3::new(xc - 0.5 * WALL, y0, a),
                Vec3::new(xc + 0.5 * WALL, y1, b),
            )
        }
    };
    for (r, &z0) in row_z.iter().enumerate() {
        let z1 = z0 + ROOM;
        // Row 2k has its corridor on +z, row 2k+1 on −z.
        let corridor_plus_z = r % 2 == 0;
        for i in 0..rx {
            let (x0, x1) = (i as f32 * ROOM, (i + 1) as f32 * ROOM);
            // Walls toward −z and +z: the corridor side has a door. A wall shared with the
            // next row (row 2k+1's +z) is built once, by the lower row.
            let (minus, plus) = if corridor_plus_z {
                (None, Some(DOOR))
            } else {
                (Some(DOOR), None)
            };
            if r == 0 || !corridor_plus_z {
                wall_with_door(&mut walls, x0, x1, HEIGHT, minus, along_x(z0));
            }
            wall_with_door(&mut walls, x0, x1, HEIGHT, plus, along_x(z1));
            // Walls toward −x (outer only) and +x (door to the neighbour half of the time).
            if i == 0 {
                wall_with_door(&mut walls, z0, z1, HEIGHT, None, along_z(x0));
            }
            let door = (i + 1 < rx && rng.f32() < 0.5).then_some(DOOR);
            wall_with_door(&mut walls, z0, z1, HEIGHT, door, along_z(x1));
            let c = Vec3::new(x0 + rng.range(1.3, 2.7), 0.0, z0 + rng.range(1.3, 2.7));
            tables.cuboid(
                c + Vec3::new(-0.6, 0.0, -0.4),
                c + Vec3::new(0.6, 0.75, 0.4),
            );
        }
    }
    // The far side of a trailing corridor (odd row count), and the corridor end walls.
    if rz % 2 == 1 {
        wall_with_door(&mut walls, 0.0, width, HEIGHT, None, along_x(depth));
    }
    for &cz in &corridors {
        for x in [0.0, width] {
            wall_with_door(&mut walls, cz, cz + CORRIDOR, HEIGHT, None, along_z(x));
        }
    }

    // Light budget: a tenth to corridor panels (2 triangle lights each), the rest to rooms.
    let corridor_panels = if corridors.is_empty() {
        0
    } else {
        p.lights / 20
    };
    let room_budget = p.lights - 2 * corridor_panels;
    for (k, n) in shares(corridor_panels, corridors.len().max(1)).enumerate() {
        if n == 0 {
            continue;
        }
        let cz = corridors[k];
        let step = width / n as f32;
        for j in 0..n {
            let x = (j as f32 + 0.5) * step;
            let half = (0.3f32).min(0.4 * step);
            panels.quad(ceiling_quad(
                x - half,
                x + half,
                cz + 0.7,
                cz + CORRIDOR - 0.7,
                HEIGHT - 0.02,
            ));
        }
    }
    let rooms: Vec<(f32, f32)> = row_z
        .iter()
        .flat_map(|&z0| (0..rx).map(move |i| (i as f32 * ROOM, z0)))
        .collect();
    let mut bulb = 0usize;
    for (&(x0, z0), n) in rooms.iter().zip(shares(room_budget, rooms.len())) {
        let panel_quads = (n / 4).min(2);
        for q in 0..panel_quads {
            let px = x0 + 1.0 + 1.5 * q as f32;
            panels.quad(ceiling_quad(
                px,
                px + 0.5,
                z0 + 1.5,
                z0 + 2.5,
                HEIGHT - 0.02,
            ));
        }
        let mut rest = n - 2 * panel_quads;
        if rest > 0 {
            let top = Vec3::new(
                x0 + rng.range(1.0, 3.0),
                HEIGHT - 0.05,
                z0 + rng.range(1.0, 3.0),
            );
            let aim = Vec3::new(x0 + rng.range(1.0, 3.0), 0.0, z0 + rng.range(1.0, 3.0));
            g.spot_light(
                &format!("spot{bulb}"),
                top,
                aim - top,
                Vec3::new(1.0, 0.9, 0.75),
                6.0,
                25f32.to_radians(),
                35f32.to_radians(),
            );
            bulb += 1;
            rest -= 1;
        }
        for _ in 0..rest {
            let pos = Vec3::new(
                x0 + rng.range(0.3, ROOM - 0.3),
                rng.range(0.3, HEIGHT - 0.3),
                z0 + rng.range(0.3, ROOM - 0.3),
            );
            let colour = light_colour(&mut rng);
            g.point_light(&format!("bulb{bulb}"), pos, colour, rng.range(0.05, 0.4));
            bulb += 1;
        }
    }

    let mut shell = MeshAccum::default();
    shell.quad(floor_quad(0.0, width, 0.0, depth, 0.0));
    shell.emit(&mut g, "floor", floor_m);
    let mut ceiling = MeshAccum::default();
    ceiling.quad(ceiling_quad(0.0, width, 0.0, depth, HEIGHT));
    ceiling.emit(&mut g, "ceiling", ceiling_m);
    walls.emit(&mut g, "walls", wall_m);
    tables.emit(&mut g, "tables", table_m);
    panels.emit(&mut g, "panels", panel_m);

    let cz = corridors[0] + 0.5 * CORRIDOR;
    if p.animate {
        // A walk (4 s): from inside the first room through its door (centred in the wall
        // at z = 4), along the corridor past up to two rooms, and through the door of the
        // room across the corridor (row 1) when there is one.
        let door_x = 0.5 * ROOM;
        let xj = door_x + ROOM * (rx.min(3) - 1) as f32;
        let (z_door, eye) = (row_z[0] + ROOM, 1.6);
        let mut keys = vec![
            (0.0, Vec3::new(door_x, eye, 1.2), Vec3::new(door_x, 1.5, cz)),
            (
                1.0,
                Vec3::new(door_x, eye, z_door),
                Vec3::new(door_x + 0.5, 1.5, cz + 1.0),
            ),
            (
                1.5,
                Vec3::new(door_x + 0.3, eye, cz),
                Vec3::new(xj + 2.0, 1.5, cz),
            ),
        ];
        if rz >= 2 {
            let z1 = row_z[1];
            keys.push((
                3.0,
                Vec3::new(xj, eye, cz),
                Vec3::new(xj + 0.3, 1.5, z1 + 1.0),
            ));
            keys.push((
                4.0,
                Vec3::new(xj, eye, z1 + 2.0),
                Vec3::new(xj, 1.2, z1 + ROOM),
            ));
        } else {
            keys.push((4.0, Vec3::new(xj, eye, cz), Vec3::new(xj + 4.0, 1.5, cz)));
        }
        g.camera_path(&keys, 60f32.to_radians());
    } else {
        // From the start of the first corridor, looking down it.
        g.camera(
            Vec3::new(0.4, 1.6, cz - 0.3),
            Vec3::new(width.min(4.0 * ROOM), 1.2, cz + 0.2),
            60f32.to_radians(),
        );
    }
    Ok(g)
}
