//! The unoccluded importance Ĩ_C(x) exists twice: in GLSL (sampling on the GPU) and in Rust
//! (the host's cut builder and the CPU samplers). Both must agree on random inputs.

mod common;

use glam::Vec3;
use lightlearn::gpu::layout::{LightNode, LightQuery, LIGHT_NODE_AREA, LIGHT_NODE_TWO_SIDED};
use lightlearn::gpu::{kernels, Buffer, ComputePipeline};
use lightlearn::lights::bounds::{gpu_node, importance};
use lightlearn::rng::SplitMix64;

#[test]
fn glsl_and_rust_importance_agree_on_random_inputs() {
    let ctx = common::ctx();
    let mut r = SplitMix64(123);
    let count = 20_000;
    let mut nodes = Vec::with_capacity(count);
    let mut queries = Vec::with_capacity(count);
    for i in 0..count {
        let c = Vec3::new(r.range(-5.0, 5.0), r.range(-5.0, 5.0), r.range(-5.0, 5.0));
        // Points, thin boxes and big boxes.
        let h = match i % 3 {
            0 => Vec3::ZERO,
            1 => Vec3::new(r.range(0.0, 0.2), r.range(0.0, 0.01), r.range(0.0, 0.2)),
            _ => Vec3::new(r.range(0.0, 3.0), r.range(0.0, 3.0), r.range(0.0, 3.0)),
        };
        let axis = Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
            .normalize_or(Vec3::Y);
        nodes.push(LightNode {
            bmin: (c - h).to_array(),
            phi: r.range(0.01, 100.0),
            bmax: (c + h).to_array(),
            cos_o: [1.0, -1.0, r.range(-1.0, 1.0)][i % 3],
            axis: axis.to_array(),
            cos_e: [0.0, r.range(0.0, 1.0)][i % 2],
            right: 0,
            begin: 0,
            count: 2,
            // Both distance clamps (bounds.rs d2_floor): point lights alone, an area light inside.
            flags: (if i % 5 == 0 { LIGHT_NODE_TWO_SIDED } else { 0 })
                | (if i % 4 < 2 { LIGHT_NODE_AREA } else { 0 }),
        });
        // Points near, far and inside the box; every seventh without a receiver normal.
        let p = c + Vec3::new(r.range(-8.0, 8.0), r.range(-8.0, 8.0), r.range(-8.0, 8.0))
            * [0.1, 1.0, 3.0][i % 3];
        let n = if i % 7 == 0 {
            Vec3::ZERO
        } else {
            Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
                .normalize_or(Vec3::X)
        };
        queries.push(LightQuery {
            p: p.to_array(),
            u: 0.0,
            n: n.to_array(),
            light: u32::MAX,
        });
    }
    let gpu = gpu_importance(&ctx, &nodes, &queries);

    let (mut zeros, mut mismatches, mut max_rel) = (0, 0, 0.0f32);
    for i in 0..count {
        let cpu = cpu_importance(&nodes[i], &queries[i]);
        let g = gpu[i];
        assert!(g.is_finite() && g >= 0.0, "input {i}: GPU importance {g}");
        zeros += (cpu == 0.0) as usize;
        if g > 0.0 && cpu > 0.0 {
            max_rel = max_rel.max((g - cpu).abs() / g.max(cpu));
        }
        // Within float rounding: sqrt/acos-free formulas, but the GPU may fuse multiply-adds,
        // and near the clamps of cos_sub_clamped a one-ulp difference in a cosine grows:
        // the largest relative difference over these inputs is printed below.
        if (g - cpu).abs() > 2e-3 * g.max(cpu) {
            mismatches += 1;
            // Only inputs at a threshold (cone edge, horizon) may round to the other side.
            assert!(g == 0.0 || cpu == 0.0, "input {i}: GPU {g} vs CPU {cpu}");
        }
    }
    eprintln!("largest relative GPU/CPU difference where both are non-zero: {max_rel:e}");
    assert!(
        mismatches * 1000 <= count,
        "{mismatches} of {count} disagree"
    );
    assert!(
        zeros > count / 20 && zeros < count * 19 / 20,
        "inputs should mix zero and non-zero importance ({zeros} zeros)"
    );
}

/// The kernels' `light_importance` (importance.comp) of each node at its query.
fn gpu_importance(
    ctx: &std::sync::Arc<lightlearn::gpu::Context>,
    nodes: &[LightNode],
    queries: &[LightQuery],
) -> Vec<f32> {
    let gpu_nodes: Vec<_> = nodes.iter().map(gpu_node).collect();
    let nb = Buffer::texels(ctx, "nodes", &gpu_nodes).unwrap();
    let ob = Buffer::from_slice(ctx, "order", &[0u32]).unwrap();
    let qb = Buffer::from_slice(ctx, "queries", queries).unwrap();
    let vb = Buffer::zeroed(ctx, "values", (queries.len() * 4) as u64).unwrap();
    let k = ComputePipeline::new(ctx, "importance", kernels::IMPORTANCE, 4, 4, &[]).unwrap();
    k.bind(&[&nb, &ob, &qb, &vb]).unwrap();
    let n = queries.len() as u32;
    ctx.submit(|cmd| k.dispatch(cmd, bytemuck::bytes_of(&n), [n.div_ceil(64), 1, 1]))
        .unwrap();
    vb.read().unwrap()
}

/// The host's mirror of the same.
fn cpu_importance(nd: &LightNode, q: &LightQuery) -> f32 {
    importance(
        Vec3::from(nd.bmin),
        Vec3::from(nd.bmax),
        nd.phi,
        Vec3::from(nd.axis),
        nd.cos_o,
        nd.cos_e,
        nd.flags,
        Vec3::from(q.p),
        Vec3::from(q.n),
    )
}

/// A spot with innerConeAngle = outerConeAngle (legal glTF: a hard edge) has no falloff
/// ramp. Its bounds (bounds.rs LightBounds::of) had cos θ_e = 1, and inside its cone cos θ_p is
/// 1: the importance returned 0 where cos θ_p ≤ cos θ_e, so every sampler that reads Ĩ
/// (bayes, the default, wang, donikian, lightbvh) never chose the light, a black image where
/// `uniform` lit the floor (found by an audit, 2026-12-06; the old comparison fails the
/// first case, tried). A ramp of 1e-4 rad, whose cos θ_e also rounds to 1, must light its
/// band between the cones too (it passes with the old bounds as well: f32 rounds cos θ_p to
/// 1 there at these angles). Both implementations, on the node the tree builds.
#[test]
fn a_hard_edged_spot_lights_its_cone_and_nothing_outside() {
    let ctx = common::ctx();
    for (inner, outer) in [(0.5f32, 0.5f32), (0.4999, 0.5)] {
        let mut g = lightlearn::scene::gltf_write::GltfBuilder::new();
        let m = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
        g.cuboid("box", Vec3::ZERO, Vec3::ONE, m);
        g.spot_light(
            "spot",
            Vec3::new(0.5, 3.0, 0.5),
            Vec3::NEG_Y,
            Vec3::ONE,
            10.0,
            inner,
            outer,
        );
        let scene = common::load(&g, "spot");
        let light = scene.lights[0];
        let lightlearn::scene::Light::Spot { position, .. } = light else {
            panic!("the spot is not the first light: {light:?}");
        };
        // The leaf the tree builds for it (LightBounds::of, then the node's flags).
        let tree = lightlearn::lights::tree::LightTree::build(&scene);
        let spot = *tree
            .nodes
            .iter()
            .find(|n| n.count == 1 && n.begin == tree.position[0])
            .expect("a leaf for the spot");
        let query = |a: f32| LightQuery {
            p: (position + Vec3::new(2.0 * a.tan(), -2.0, 0.0)).to_array(),
            u: 0.0,
            n: [0.0, 1.0, 0.0],
            light: u32::MAX,
        };
        // On the axis, inside the inner cone, between the cones (lit by the falloff) and
        // outside the outer one.
        let angles = [0.0, 0.45, 0.49995, 0.55];
        let queries: Vec<_> = angles.iter().map(|&a| query(a)).collect();
        let gpu = gpu_importance(&ctx, &[spot; 4], &queries);
        for (i, q) in queries.iter().enumerate() {
            let cpu = cpu_importance(&spot, q);
            let lit = angles[i] < outer;
            assert_eq!(
                (cpu > 0.0, gpu[i] > 0.0),
                (lit, lit),
                "cones {inner}/{outer}, {} rad off the axis: CPU {cpu}, GPU {}",
                angles[i],
                gpu[i]
            );
        }
    }
}
