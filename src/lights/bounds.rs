//! What a light or a set of lights can emit, and where to: bounds of positions, emission
//! directions (a cone: axis, θ_o, θ_e) and power, and the unoccluded importance Ĩ_C(x) of
//! docs/method.md §2 that a cluster of the light tree gets at a shading point, mirrored
//! exactly in `shaders/shared/light_tree.glsl`.

use std::f32::consts::PI;

use glam::Vec3;

use crate::abi::{GpuLightNode, LightNode, LIGHT_NODE_AREA, LIGHT_NODE_TWO_SIDED};
use crate::scene::{Light, Scene};

/// What a light (or a set of lights) can emit, and where to.
#[derive(Clone, Copy, Debug)]
pub struct LightBounds {
    pub lo: Vec3,
    pub hi: Vec3,
    /// Emitted power as luminance (the `power` sampler's weight).
    pub phi: f32,
    /// Unit axis of the emission cone.
    pub axis: Vec3,
    /// cos θ_o: every emission normal lies within θ_o of the axis.
    pub cos_o: f32,
    /// cos θ_e: emission spreads at most θ_e beyond a normal.
    pub cos_e: f32,
    pub two_sided: bool,
    /// Some light inside is a triangle (area) light (`LIGHT_NODE_AREA`).
    pub area: bool,
}

impl LightBounds {
    pub fn of(scene: &Scene, light: &Light) -> LightBounds {
        let phi = scene.light_power(light);
        match *light {
            Light::Point { position, .. } => LightBounds {
                lo: position,
                hi: position,
                phi,
                axis: Vec3::Z,
                cos_o: -1.0,
                cos_e: 0.0,
                two_sided: false,
                area: false,
            },
            Light::Spot {
                position,
                direction,
                cos_inner,
                cos_outer,
                ..
            } => {
                // Full intensity up to the inner cone, falling to zero at the outer one. A ramp
                // narrower than 1e-3 rad (inner = outer: a hard edge) is bounded as the whole
                // outer cone with no spread: its cos θ_e rounds to 1 in f32, and whether the
                // band between the cones, which `spot_falloff` lights, is then priced 0 would
                // hang on the rounding of cos θ_p there (a review, 2026-12-06).
                let (inner, outer) = (
                    cos_inner.clamp(-1.0, 1.0).acos(),
                    cos_outer.clamp(-1.0, 1.0).acos(),
                );
                let (cos_o, cos_e) = if outer - inner < 1e-3 {
                    (cos_outer, 1.0)
                } else {
                    (cos_inner, (outer - inner).cos())
                };
                LightBounds {
                    lo: position,
                    hi: position,
                    phi,
                    axis: direction,
                    cos_o,
                    cos_e,
                    two_sided: false,
                    area: false,
                }
            }
            Light::Triangle { triangle } => {
                let [a, b, c] = scene.triangles[triangle as usize];
                let (_, two) = scene.triangle_emission(triangle);
                LightBounds {
                    lo: a.min(b).min(c),
                    hi: a.max(b).max(c),
                    phi,
                    axis: (b - a).cross(c - a).normalize(),
                    cos_o: 1.0,
                    cos_e: 0.0, // a cosine lobe: up to 90° off the normal
                    two_sided: two,
                    area: true,
                }
            }
        }
    }

    /// The bounds of both (pbrt-v4's `Union` of LightBounds).
    pub fn union(&self, o: &LightBounds) -> LightBounds {
        if self.phi == 0.0 {
            return *o;
        }
        if o.phi == 0.0 {
            return *self;
        }
        let (axis, cos_o) = cone_union(self.axis, self.cos_o, o.axis, o.cos_o);
        LightBounds {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            phi: self.phi + o.phi,
            axis,
            cos_o,
            cos_e: self.cos_e.min(o.cos_e),
            two_sided: self.two_sided || o.two_sided,
            area: self.area || o.area,
        }
    }

    /// The node flags these bounds give (`LightNode::flags`).
    pub fn flags(&self) -> u32 {
        (if self.two_sided {
            LIGHT_NODE_TWO_SIDED
        } else {
            0
        }) | (if self.area { LIGHT_NODE_AREA } else { 0 })
    }

    /// Ĩ(p, n): power × bound on the emitter's cosine towards p × bound on the receiver's
    /// cosine / squared distance (clamped below: [`d2_floor`]). Zero only when no light
    /// inside can send anything to the front of n at p.
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        importance(
            self.lo,
            self.hi,
            self.phi,
            self.axis,
            self.cos_o,
            self.cos_e,
            self.flags(),
            p,
            n,
        )
    }
}

/// The smallest cone holding both cones (axis, cos of half-angle).
fn cone_union(a: Vec3, cos_a: f32, b: Vec3, cos_b: f32) -> (Vec3, f32) {
    let (theta_a, theta_b) = (cos_a.clamp(-1.0, 1.0).acos(), cos_b.clamp(-1.0, 1.0).acos());
    let theta_d = a.dot(b).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (a, cos_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (b, cos_b);
    }
    let theta_o = (theta_a + theta_d + theta_b) / 2.0;
    if theta_o >= PI {
        return (a, -1.0);
    }
    // Rotate a towards b by theta_o - theta_a.
    let theta_r = theta_o - theta_a;
    let w_r = a.cross(b);
    if w_r.length_squared() < 1e-12 {
        return (a, -1.0);
    }
    let axis = glam::Quat::from_axis_angle(w_r.normalize(), theta_r) * a;
    (axis.normalize(), theta_o.cos())
}

/// A box's centre and half its diagonal (the bounding sphere's radius): what the importance
/// and the regression distance need of it, computed once per node for the kernels
/// (`gpu_node`) and by this same function wherever the CPU mirrors them.
pub fn centre_radius(lo: Vec3, hi: Vec3) -> (Vec3, f32) {
    (0.5 * (lo + hi), 0.5 * (hi - lo).length())
}

/// sin θ from cos θ (θ in [0, π]).
pub fn sin_of_cos(c: f32) -> f32 {
    (1.0 - c * c).max(0.0).sqrt()
}

/// The node as the kernels read it (`GpuLightNode`).
pub fn gpu_node(n: &LightNode) -> GpuLightNode {
    let (centre, radius) = centre_radius(Vec3::from(n.bmin), Vec3::from(n.bmax));
    GpuLightNode {
        centre: centre.to_array(),
        phi: n.phi,
        axis: n.axis,
        cos_o: n.cos_o,
        radius,
        sin_o: sin_of_cos(n.cos_o),
        cos_e: n.cos_e,
        flags: n.flags,
        right: n.right,
        begin: n.begin,
        count: n.count,
        pad: 0,
    }
}

/// The least squared distance the importance divides by, for a node whose bounding sphere
/// has radius `radius` (half its box diagonal) and these `flags` (`d2_floor` in
/// light_tree.glsl). pbrt-v4 clamps d² at the radius itself, a length against a squared
/// distance, so the clamp depends on the scene's units: a 5 cm cluster of point lights is
/// priced as if no point were nearer than 22 cm, and a surface a centimetre from a bulb of
/// it got that cluster ~500× too rarely for what it gives: strings' fireflies. A point
/// light's 1/d² is real, so nodes of point lights alone clamp at (radius / 2)², the same in
/// any units; nodes holding an area light keep pbrt's clamp (their irradiance is bounded,
/// and (radius / 2)² there overpriced the ceiling panel near cornell40's ceiling: 0.80× the
/// variance). Measured (`bayes`, direct light, 256 spp, eight seeds; docs/results.md, tenth
/// session): strings 12.5× less variance, strings5k 79×, city10k 0.98×, cornell40 0.96×, the
/// other six 1.00×; `wang` on strings 25× less.
pub fn d2_floor(radius: f32, flags: u32) -> f32 {
    if flags & LIGHT_NODE_AREA != 0 {
        radius
    } else {
        0.25 * radius * radius
    }
}

/// The squared distance from p to a box's centre, at least [`d2_floor`]: the importance's
/// distance and the learned samplers' regression distance (`node_d2` in light_tree.glsl).
pub fn clamped_d2(lo: Vec3, hi: Vec3, flags: u32, p: Vec3) -> f32 {
    let (centre, radius) = centre_radius(lo, hi);
    (p - centre).length_squared().max(d2_floor(radius, flags))
}

/// The importance function, argument by argument as in the GLSL.
#[allow(clippy::too_many_arguments)]
pub fn importance(
    lo: Vec3,
    hi: Vec3,
    phi: f32,
    axis: Vec3,
    cos_o: f32,
    cos_e: f32,
    flags: u32,
    p: Vec3,
    n: Vec3,
) -> f32 {
    let (centre, radius) = centre_radius(lo, hi);
    let g = GpuLightNode {
        centre: centre.to_array(),
        phi,
        axis: axis.to_array(),
        cos_o,
        radius,
        sin_o: sin_of_cos(cos_o),
        cos_e,
        flags,
        ..Default::default()
    };
    node_importance(&g, p, n)
}

/// Ĩ of a node at p for a receiver with normal n (0: none): the kernels' `light_importance`
/// on the same precomputed node, operation for operation.
pub fn node_importance(nd: &GpuLightNode, p: Vec3, n: Vec3) -> f32 {
    let to = p - Vec3::from(nd.centre);
    let dist2 = to.length_squared();
    let d2 = dist2.max(d2_floor(nd.radius, nd.flags));
    let inv_dist = if dist2 > 0.0 { 1.0 / dist2.sqrt() } else { 0.0 };
    let wi = to * inv_dist;
    let mut cos_w = Vec3::from(nd.axis).dot(wi);
    if nd.flags & LIGHT_NODE_TWO_SIDED != 0 {
        cos_w = cos_w.abs();
    }
    let sin_w = sin_of_cos(cos_w);
    // The half-angle the box subtends at p (a bounding sphere; the whole sphere if inside).
    let (cos_b, sin_b) = if dist2 <= nd.radius * nd.radius {
        (-1.0, 0.0)
    } else {
        let sin_b = nd.radius * inv_dist;
        (sin_of_cos(sin_b), sin_b)
    };
    // cos(max(0, θ_w − θ_o − θ_b)) by angle-difference identities.
    let cos_wo = cos_sub_clamped(sin_w, cos_w, nd.sin_o, nd.cos_o);
    let sin_wo = sin_sub_clamped(sin_w, cos_w, nd.sin_o, nd.cos_o);
    let cos_p = cos_sub_clamped(sin_wo, cos_wo, sin_b, cos_b);
    // Strictly outside the emission spread: a hard-edged spot (inner = outer cone, θ_e = 0,
    // cos θ_e = 1) has cos θ_p = 1 inside its cone, and `<=` had priced it 0 there
    // (tests/importance.rs). pbrt-v4's LightBounds::Importance compares with `<=`.
    if cos_p < nd.cos_e {
        return 0.0;
    }
    let mut imp = nd.phi * cos_p / d2;
    // The receiver: cos(max(0, θ_i − θ_b)), θ_i between n and the direction to the box.
    if n != Vec3::ZERO {
        let cos_i = n.dot(-wi);
        let c = cos_sub_clamped(sin_of_cos(cos_i), cos_i, sin_b, cos_b);
        imp *= c.max(0.0);
    }
    imp.max(0.0)
}

/// cos(max(0, a − b)) from sines and cosines.
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// sin(max(0, a − b)) from sines and cosines.
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cone_union_contains_both() {
        let (a, b) = (Vec3::X, Vec3::Y);
        let (axis, cos_o) = cone_union(a, 0.9, b, 0.9);
        for v in [a, b] {
            // Each input cone's axis ± its half-angle lies inside the union.
            let half = 0.9f32.acos();
            let ang = axis.dot(v).clamp(-1.0, 1.0).acos();
            assert!(
                ang + half <= cos_o.acos() + 1e-4,
                "{ang} + {half} > {}",
                cos_o.acos()
            );
        }
    }

    /// A node of point lights 0.1 apart (radius 0.05) seen from its centre and from just
    /// beside one of them: its importance is the same in any units (×1/s² when the scene
    /// is s times larger), and at the centre it divides by (radius / 2)². pbrt-v4's clamp
    /// (d² ≥ radius: 20 at the centre, not 1600) fails both. A node holding an area light
    /// keeps pbrt's clamp.
    #[test]
    fn point_light_nodes_clamp_their_distance_in_any_units() {
        let imp = |s: f32, p: Vec3, flags: u32| {
            let h = Vec3::new(0.05, 0.0, 0.0) * s;
            importance(-h, h, 1.0, Vec3::Z, -1.0, 0.0, flags, p * s, Vec3::ZERO)
        };
        let centre = imp(1.0, Vec3::ZERO, 0);
        assert!((centre - 1600.0).abs() < 1e-2, "at the centre: {centre}");
        let beside = Vec3::new(0.04, 0.0, 0.005);
        for s in [1e-3, 1e3] {
            for p in [Vec3::ZERO, beside] {
                let (a, b) = (imp(1.0, p, 0), imp(s, p, 0) * s * s);
                assert!((a - b).abs() < 1e-4 * a, "at {p} in units ×{s}: {a} vs {b}");
            }
        }
        let area = imp(1.0, Vec3::ZERO, LIGHT_NODE_AREA);
        assert!(
            (area - 20.0).abs() < 1e-4,
            "an area node at the centre: {area}"
        );
    }
}
