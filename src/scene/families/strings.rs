//! `strings`: strands of small bulbs (decorations) wound around objects: a cone "tree" and
//! spheres on a floor in front of a wall. Each object gets a helical strand 3 cm off its
//! surface; the lights are shared out evenly between strands. `--resolution` sets the
//! segments of the curved meshes.

use glam::Vec3;

use super::{floor_material, floor_quad, shares, FamilyParams, MeshAccum};
use crate::rng::SplitMix64;
use crate::scene::gltf_write::GltfBuilder;

/// A palette of decoration colours.
const PALETTE: [Vec3; 5] = [
    Vec3::new(1.0, 0.25, 0.2),
    Vec3::new(1.0, 0.8, 0.3),
    Vec3::new(0.3, 0.9, 0.35),
    Vec3::new(0.35, 0.5, 1.0),
    Vec3::new(1.0, 1.0, 0.9),
];

/// A closed cone (apex up) with `seg` sides.
fn cone(m: &mut MeshAccum, base: Vec3, radius: f32, height: f32, seg: u32) {
    let b = m.positions.len() as u32;
    let apex = base + Vec3::Y * height;
    m.positions.push(apex);
    m.positions.push(base);
    for k in 0..seg {
        let a = k as f32 / seg as f32 * std::f32::consts::TAU;
        m.positions
            .push(base + Vec3::new(a.cos(), 0.0, a.sin()) * radius);
    }
    for k in 0..seg {
        let (i, j) = (b + 2 + k, b + 2 + (k + 1) % seg);
        m.indices.extend_from_slice(&[b, j, i, b + 1, i, j]);
    }
}

/// A UV sphere with `seg` segments around and `seg / 2` rings.
fn sphere(m: &mut MeshAccum, c: Vec3, r: f32, seg: u32) {
    let rings = (seg / 2).max(2);
    let b = m.positions.len() as u32;
    for i in 0..=rings {
        let phi = i as f32 / rings as f32 * std::f32::consts::PI;
        for k in 0..seg {
            let th = k as f32 / seg as f32 * std::f32::consts::TAU;
            m.positions
                .push(c + r * Vec3::new(phi.sin() * th.cos(), phi.cos(), phi.sin() * th.sin()));
        }
    }
    for i in 0..rings {
        for k in 0..seg {
            let a = b + i * seg + k;
            let bb = b + i * seg + (k + 1) % seg;
            let (c0, d) = (a + seg, bb + seg);
            m.indices.extend_from_slice(&[a, bb, d, a, d, c0]);
        }
    }
}

pub fn build(p: &FamilyParams) -> GltfBuilder {
    let mut rng = SplitMix64(p.seed);
    let mut g = GltfBuilder::new();
    let floor_m = floor_material(&mut g, p, "floor", Vec3::new(0.45, 0.4, 0.35));
    let wall_m = g.material("wall", Vec3::new(0.7, 0.7, 0.72), Vec3::ZERO, false);
    let tree_m = g.material("tree", Vec3::new(0.1, 0.35, 0.12), Vec3::ZERO, false);
    let ball_m = g.material("ball", Vec3::new(0.6, 0.6, 0.65), Vec3::ZERO, false);
    let seg = p.resolution;

    let mut room = MeshAccum::default();
    room.quad(floor_quad(-4.0, 4.0, -3.0, 3.0, 0.0));
    room.emit(&mut g, "floor", floor_m);
    let mut wall = MeshAccum::default();
    wall.cuboid(Vec3::new(-4.0, 0.0, -3.2), Vec3::new(4.0, 3.5, -3.0));
    wall.emit(&mut g, "wall", wall_m);
    let mut tree = MeshAccum::default();
    let (tree_base, tree_r, tree_h) = (Vec3::new(0.0, 0.0, -0.5), 1.0, 2.6);
    cone(&mut tree, tree_base, tree_r, tree_h, seg);
    tree.emit(&mut g, "tree", tree_m);
    let balls = [
        (Vec3::new(-2.2, 0.45, 0.4), 0.45),
        (Vec3::new(2.1, 0.6, 0.2), 0.6),
        (Vec3::new(1.2, 0.3, 1.4), 0.3),
    ];
    let mut spheres = MeshAccum::default();
    for (c, r) in balls {
        sphere(&mut spheres, c, r, seg);
    }
    spheres.emit(&mut g, "balls", ball_m);

    // Strand 0 (the tree) gets half of the lights, the balls share the rest.
    let tree_lights = p.lights.div_ceil(2);
    let per_ball: Vec<usize> = shares(p.lights - tree_lights, balls.len()).collect();
    let mut id = 0usize;
    let off = 0.03;
    for k in 0..tree_lights {
        let s = (k as f32 + 0.5) / tree_lights as f32;
        let th = s * 9.0 * std::f32::consts::TAU;
        let r = tree_r * (1.0 - s) + off;
        let pos = tree_base + Vec3::new(r * th.cos(), s * tree_h, r * th.sin());
        let colour = PALETTE[(rng.next_u64() % 5) as usize];
        g.point_light(&format!("b{id}"), pos, colour, rng.range(0.002, 0.01));
        id += 1;
    }
    for ((c, r), n) in balls.into_iter().zip(per_ball) {
        for k in 0..n {
            let s = (k as f32 + 0.5) / n as f32;
            let phi = s * std::f32::consts::PI;
            let th = s * 6.0 * std::f32::consts::TAU;
            let pos =
                c + (r + off) * Vec3::new(phi.sin() * th.cos(), phi.cos(), phi.sin() * th.sin());
            let colour = PALETTE[(rng.next_u64() % 5) as usize];
            g.point_light(&format!("b{id}"), pos, colour, rng.range(0.002, 0.01));
            id += 1;
        }
    }
    g.camera(
        Vec3::new(0.3, 1.5, 4.6),
        Vec3::new(0.0, 1.0, -0.5),
        55f32.to_radians(),
    );
    g
}
