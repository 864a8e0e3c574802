//! glTF alphaMode MASK: a surface is there where its alpha (baseColorFactor's × the
//! base-colour texture's) is at least alphaCutoff (0.5 by default), and every ray (camera,
//! path and shadow) passes it elsewhere. Rendered opaque with a warning before 2026-12-07.
//! The mutations that drop the test from shadow rays or from the closest hit, read the
//! texture's red for its alpha, or test alpha > cutoff each fail a test below.

mod common;

use glam::Vec3;
use lightlearn::render::LightSampler;
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::Scene;

/// The blocker: a quad at height 1 over z in ±1 and x from `x0` to 1 (albedo 0.2), above a
/// grey floor, under a sun from straight above and a dim bulb.
enum Blocker {
    None,
    /// Opaque from x0 to 1.
    Opaque(f32),
    /// Over x in ±1, alphaMode MASK of this factor alpha and cutoff (None: glTF's default);
    /// with `halves`, a NEAREST texture of white texels whose alpha is 0 on the left half
    /// (x < 0) and 255 on the right.
    Masked {
        alpha: f32,
        cutoff: Option<f32>,
        halves: bool,
    },
}

fn scene(blocker: Blocker, side: bool) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let grey = g.material("grey", Vec3::splat(0.5), Vec3::ZERO, false);
    g.quad(
        "floor",
        [
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, -2.0),
        ],
        grey,
    );
    let x0 = match blocker {
        Blocker::None => None,
        Blocker::Opaque(x0) => Some(x0),
        Blocker::Masked { .. } => Some(-1.0),
    };
    if let Some(x0) = x0 {
        let dark = g.material("blocker", Vec3::splat(0.2), Vec3::ZERO, false);
        let c = [
            Vec3::new(x0, 1.0, -1.0),
            Vec3::new(x0, 1.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(1.0, 1.0, -1.0),
        ];
        if let Blocker::Masked {
            alpha,
            cutoff,
            halves,
        } = blocker
        {
            g.set_alpha_mask(dark, alpha, cutoff);
            if halves {
                let png = common::png_rgba(2, 1, &[[255, 255, 255, 0], [255, 255, 255, 255]]);
                let t = g.texture_png_filtered(&png, [33071, 33071], Some(9728));
                g.set_base_color_texture(dark, t);
            }
        }
        let uv = c.map(|p| [(p.x + 1.0) / 2.0, (p.z + 1.0) / 2.0]);
        g.mesh_uv("blocker", &c, Some(&uv), &[0, 1, 2, 0, 2, 3], dark);
    }
    g.point_light("dim", Vec3::new(0.5, 3.0, 0.3), Vec3::ONE, 0.5);
    g.directional_light("sun", Vec3::NEG_Y, Vec3::ONE, 3.0);
    if side {
        // Low, from the front: the floor under the blocker, in its shadow or not.
        g.camera(Vec3::new(0.0, 0.9, 2.6), Vec3::new(0.0, 0.0, -0.3), 1.1);
    } else {
        g.camera(
            Vec3::new(0.0, 40.0, 1e-3),
            Vec3::ZERO,
            2.0 * (2.0f32 / 40.0).atan(),
        );
    }
    g
}

fn render(s: &Scene, sampler: LightSampler, depth: u32) -> Vec<[f32; 3]> {
    common::render_mean(s, sampler, (32, 32), depth, 4, 5)
}

fn assert_same(a: &[[f32; 3]], b: &[[f32; 3]], what: &str) {
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        assert!(
            (p[0] - q[0]).abs() <= 1e-3 * q[0].max(1e-2),
            "{what} pixel {i}: masked {p:?}, geometry {q:?}"
        );
    }
}

/// A blocker whose texture cuts away its left half renders as a blocker of its right half
/// alone: seen from above (the camera's rays pass the cut; the floor below it is in the
/// sun) and from the side (the floor under the cut half lit, under the other in shadow),
/// in direct light and along paths.
#[test]
fn a_texture_cut_renders_as_the_geometry_that_is_left() {
    for side in [false, true] {
        let masked = common::load(
            &scene(
                Blocker::Masked {
                    alpha: 1.0,
                    cutoff: None,
                    halves: true,
                },
                side,
            ),
            "masked",
        );
        let half = common::load(&scene(Blocker::Opaque(0.0), side), "half");
        let whole = common::load(&scene(Blocker::Opaque(-1.0), side), "whole");
        for (sampler, depth) in [
            (LightSampler::Power, 1),
            (LightSampler::Power, 3),
            (LightSampler::Bayes, 3),
        ] {
            let what = format!("side {side} {sampler:?} depth {depth}");
            let (a, b) = (
                render(&masked, sampler, depth),
                render(&half, sampler, depth),
            );
            assert_same(&a, &b, &what);
            // The cut shows: the whole blocker's image differs.
            let c = render(&whole, sampler, depth);
            let differ = a
                .iter()
                .zip(&c)
                .filter(|(p, q)| (p[0] - q[0]).abs() > 0.05 * q[0].max(1e-2))
                .count();
            assert!(
                differ > 50,
                "{what}: {differ} pixels differ from the whole blocker"
            );
        }
    }
}

/// The factor's alpha alone (no texture): below the cutoff the blocker is not there; at the
/// cutoff (glTF: "greater than or equal") and above the default 0.5 it is whole.
#[test]
fn the_factor_alpha_against_the_cutoff() {
    let none = common::load(&scene(Blocker::None, true), "none");
    let whole = common::load(&scene(Blocker::Opaque(-1.0), true), "whole");
    for (alpha, cutoff, want) in [
        (0.3, Some(0.5), &none),
        (0.5, Some(0.5), &whole),
        (0.6, None, &whole),
        (0.4, None, &none),
    ] {
        let s = common::load(
            &scene(
                Blocker::Masked {
                    alpha,
                    cutoff,
                    halves: false,
                },
                true,
            ),
            "factor",
        );
        for depth in [1, 3] {
            assert_same(
                &render(&s, LightSampler::Power, depth),
                &render(want, LightSampler::Power, depth),
                &format!("alpha {alpha} cutoff {cutoff:?} depth {depth}"),
            );
        }
    }
}
