//! The CPU traversal of the 4-wide BVH: the same steps as the kernel's `trace_ray`
//! (`shaders/shared/bvh.glsl`), which the tests and the ray-throughput benchmark compare it
//! with, and which the cut build and the preview's coverage use on the host.

use glam::{Vec3, Vec4};

use super::bvh::{leaf_range, Bvh, STACK_SIZE};
use crate::gpu::layout::{BvhNode, BvhTri, BVH_LEAF_BIT};

impl Bvh {
    /// Closest hit along `o + t d`, t in (tmin, tmax): (t, prim) or None.
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, u32)> {
        self.traverse(o, d, tmin, tmax, false)
    }

    /// Whether anything is hit with t in (tmin, tmax) (shadow rays).
    pub fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        self.traverse(o, d, tmin, tmax, true).is_some()
    }

    /// The same steps as `trace_ray` in `shaders/shared/bvh.glsl`, test for test and in the
    /// same order (a node's hit leaves tested after the next node is chosen, as the kernel's
    /// lanes step from node to node until they hold leaves), so both find the same closest
    /// triangle, also where two are hit at the same distance (tests/gpu_bvh.rs checks every
    /// ray). For any hit the kernel stops at the first triangle hit and this loop at the end
    /// of that leaf: the same answer, maybe another triangle.
    fn traverse(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, any: bool) -> Option<(f32, u32)> {
        // A zero direction component would make o * inv = 0 * inf = NaN: nudge it to ±1e-20.
        let nudge = |c: f32| {
            if c.abs() < 1e-20 {
                1e-20f32.copysign(c)
            } else {
                c
            }
        };
        let inv = Vec3::new(nudge(d.x), nudge(d.y), nudge(d.z)).recip();
        let oi = o * inv;
        // A box entered at t = ∞ (an origin near f32's limit: a camera at 3e38 reached this
        // from build_cuts) must not pass for an interior child: it sorts among the empty
        // slots, and one of those was then taken for a node (an out-of-range index, a panic).
        // The kernel clamps its distance the same way.
        let mut best_t = tmax.min(f32::MAX);
        let mut best = u32::MAX;
        let mut stack = [Siblings::default(); STACK_SIZE];
        let mut sp = 0usize;
        let mut node = 0u32;
        // The kernel's sibling entry: the interior children still to visit of the last node
        // that had two or more, in registers; the next such node stacks it.
        let mut sib = Siblings::default();
        let mut done = false;
        loop {
            let n = &self.nodes[node as usize];
            // All four boxes against the distance known on arrival (-1: missed). The hit
            // leaves are tested once the next node is chosen, as the kernel's lanes step from
            // node to node until they hold leaves and then test them.
            let mut key = slab4(n, oi, inv, tmin, best_t).to_array();
            // The kernel's references as they are: a leaf's carries BVH_LEAF_BIT, its count
            // and its first triangle.
            let mut refs = n.refs;
            let leaves = std::array::from_fn::<_, 4, _>(|i| {
                (key[i] >= 0.0 && refs[i] & BVH_LEAF_BIT != 0).then(|| leaf_range(refs[i]))
            });
            // Interior children that can still hold a closer hit, nearest first (the same
            // five compare-exchanges as the kernel; the others sort last with key ∞).
            let mut m = 0;
            for i in 0..4 {
                let inner = key[i] >= 0.0 && refs[i] & BVH_LEAF_BIT == 0 && key[i] <= best_t;
                key[i] = if inner { key[i] } else { f32::INFINITY };
                m += inner as u32;
            }
            for (i, j) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                if key[j] < key[i] {
                    key.swap(i, j);
                    refs.swap(i, j);
                }
            }
            if m > 0 {
                if m > 1 {
                    if sib.count > 0 {
                        stack[sp] = sib;
                        sp += 1;
                    }
                    // Leaf refs carry BVH_LEAF_BIT: the least ref is the block's first slot.
                    let base = refs.iter().copied().min().unwrap_or(0);
                    sib = Siblings {
                        base,
                        offsets: (1..4).fold(0, |o, j| {
                            o | ((refs[j].wrapping_sub(base) & 3) << (2 * (j - 1)))
                        }),
                        count: m - 1,
                        key: key[1],
                    };
                }
                node = refs[0];
            } else {
                // The nearest sibling left that can still hold a closer hit.
                let mut found = false;
                while !found && (sib.count > 0 || sp > 0) {
                    if sib.count == 0 {
                        sp -= 1;
                        sib = stack[sp];
                    }
                    if sib.key <= best_t {
                        found = true;
                        node = sib.base + (sib.offsets & 3);
                        sib.offsets >>= 2;
                        sib.count -= 1;
                    } else {
                        sib.count = 0; // sorted: the rest are farther still
                    }
                }
                done = !found;
            }
            for &(first, count) in leaves.iter().flatten() {
                if self.leaf(first, count, o, d, tmin, &mut best_t, &mut best) && any {
                    return Some((best_t, best));
                }
            }
            if done {
                break;
            }
        }
        (best != u32::MAX).then_some((best_t, best))
    }

    #[allow(clippy::too_many_arguments)]
    fn leaf(
        &self,
        first: u32,
        count: u32,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        best_t: &mut f32,
        best: &mut u32,
    ) -> bool {
        let first = first as usize;
        let mut hit = false;
        for tri in &self.tris[first..first + count as usize] {
            if let Some(t) = intersect_tri(tri, o, d, tmin, *best_t) {
                *best_t = t;
                *best = tri.prim;
                hit = true;
            }
        }
        hit
    }
}

/// Interior children of one node still to visit, nearest first: they sit in consecutive slots
/// from `base` (flatten), and `offsets` holds each one's slot − base in two bits, the next in
/// the low bits; `key` is the next one's entry distance, a lower bound for the others'. The
/// kernel stacks it as one word, base · 256 | offsets · 4 | count, and that distance.
#[derive(Clone, Copy, Default)]
struct Siblings {
    base: u32,
    offsets: u32,
    count: u32,
    key: f32,
}

/// The ray/box slab test of the four children at once (`oi` = o · inv; SIMD lanes =
/// children): each child's entry distance if its box is hit within [tmin, tmax], else -1
/// (tmin ≥ 0). The same tests per lane as `slab4` in the kernel (whose compiler may fuse the
/// multiply-add: a distance can differ in its last bit, which can only reorder a near tie).
#[inline]
fn slab4(n: &BvhNode, oi: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> Vec4 {
    let axis = |lo: [f32; 4], hi: [f32; 4], oi: f32, inv: f32| {
        let t0 = Vec4::from(lo) * inv - Vec4::splat(oi);
        let t1 = Vec4::from(hi) * inv - Vec4::splat(oi);
        (t0.min(t1), t0.max(t1))
    };
    let (nx, fx) = axis(n.lo_x, n.hi_x, oi.x, inv.x);
    let (ny, fy) = axis(n.lo_y, n.hi_y, oi.y, inv.y);
    let (nz, fz) = axis(n.lo_z, n.hi_z, oi.z, inv.z);
    let near = nx.max(ny).max(nz).max(Vec4::splat(tmin));
    let far = fx.min(fy).min(fz).min(Vec4::splat(tmax));
    Vec4::select(near.cmple(far), near, Vec4::splat(-1.0))
}

/// Möller–Trumbore, both faces; Some(t) for a hit with t in (tmin, tmax).
#[inline]
pub fn intersect_tri(tri: &BvhTri, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
    let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = o - Vec3::from(tri.v0);
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv_det;
    (t > tmin && t < tmax).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::tests::random_soup;
    use crate::rng::SplitMix64;

    /// A ray from near f32's limit (a glTF camera at 3e38) meets boxes at t = ∞: it must
    /// miss or hit, never take an empty child slot for a node (it panicked in build_cuts).
    #[test]
    fn rays_from_near_the_float_limit_do_not_panic() {
        let bvh = Bvh::build(&random_soup(64, 5));
        for o in [
            Vec3::splat(3e38),
            Vec3::new(3e38, -3e38, 3e38),
            Vec3::splat(-3.4e38),
        ] {
            let d = (-o).normalize();
            let _ = bvh.intersect(o, d, 0.0, f32::INFINITY);
            let _ = bvh.occluded(o, d, 0.0, f32::INFINITY);
        }
    }

    /// The BVH must find exactly what testing every triangle finds.
    #[test]
    fn bvh_matches_brute_force() {
        for &n in &[1usize, 3, 7, 2000] {
            let tris = random_soup(n, n as u64);
            let bvh = Bvh::build(&tris);
            let flat: Vec<BvhTri> = tris
                .iter()
                .enumerate()
                .map(|(i, &[a, b, c])| BvhTri {
                    v0: a.to_array(),
                    prim: i as u32,
                    e1: (b - a).to_array(),
                    e2: (c - a).to_array(),
                    ..Default::default()
                })
                .collect();
            let mut r = SplitMix64(99);
            let mut hits = 0;
            let axes = [
                Vec3::X,
                Vec3::NEG_X,
                Vec3::Y,
                Vec3::NEG_Y,
                Vec3::Z,
                Vec3::NEG_Z,
            ];
            for i in 0..3000 {
                let o = Vec3::new(r.range(-8.0, 8.0), r.range(-8.0, 8.0), r.range(-8.0, 8.0));
                let d = if i % 5 == 0 {
                    axes[i % 6] // exact zero components
                } else {
                    (Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
                        - o * 0.1)
                        .normalize()
                };
                let mut best = (f32::INFINITY, u32::MAX);
                for t in &flat {
                    if let Some(tt) = intersect_tri(t, o, d, 0.0, best.0) {
                        best = (tt, t.prim);
                    }
                }
                let got = bvh.intersect(o, d, 0.0, f32::INFINITY);
                match got {
                    Some((t, p)) => {
                        hits += 1;
                        assert_eq!(p, best.1, "n={n}: different triangle");
                        assert_eq!(t, best.0);
                        assert!(bvh.occluded(o, d, 0.0, f32::INFINITY));
                    }
                    None => {
                        assert_eq!(best.1, u32::MAX, "n={n}: BVH missed a hit");
                        assert!(!bvh.occluded(o, d, 0.0, f32::INFINITY));
                    }
                }
            }
            if n >= 2000 {
                assert!(hits > 300, "too few hits ({hits}) for a meaningful test");
            }
        }
    }
}
