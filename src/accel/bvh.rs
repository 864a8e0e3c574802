//! Geometry BVH: a binned-SAH binary BVH built on the host, flattened into [`BvhNode`]s that
//! hold both children's boxes (one fetch tests two boxes), plus the CPU traversal of exactly
//! those nodes that the tests and the ray-throughput benchmark compare the GPU kernel with.

use glam::Vec3;

use crate::gpu::layout::{BvhNode, BvhTri, BVH_LEAF_BIT};

/// Leaves hold at most this many triangles unless the depth limit forces more.
const MAX_LEAF: usize = 4;
/// The traversal stack in `shaders/shared/bvh.glsl` holds `STACK_SIZE` entries; a binary tree
/// of depth D needs at most D - 1, so the builder stops splitting at this depth.
pub const MAX_DEPTH: usize = 48;
const BINS: usize = 16;

#[derive(Clone, Debug)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub tris: Vec<BvhTri>,
}

#[derive(Clone, Copy)]
struct Aabb {
    lo: Vec3,
    hi: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, p: Vec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    fn union(&mut self, o: &Aabb) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
    }
    fn area(&self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// Node of the binary build tree before flattening.
struct BuildNode {
    bounds: Aabb,
    /// Children for an interior node.
    kids: Option<(usize, usize)>,
    first: usize,
    count: usize,
}

impl Bvh {
    /// Builds the BVH over world-space triangles (`prim` = index into `triangles`).
    pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
        assert!(
            !triangles.is_empty(),
            "the loader refuses scenes without triangles"
        );
        let boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| {
                let mut b = Aabb::EMPTY;
                t.iter().for_each(|v| b.grow(*v));
                b
            })
            .collect();
        let centroids: Vec<Vec3> = boxes.iter().map(|b| 0.5 * (b.lo + b.hi)).collect();
        let mut ids: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes: Vec<BuildNode> = Vec::with_capacity(2 * triangles.len() / MAX_LEAF + 1);

        let bounds_of = |ids: &[u32]| {
            let mut b = Aabb::EMPTY;
            ids.iter().for_each(|&i| b.union(&boxes[i as usize]));
            b
        };
        nodes.push(BuildNode {
            bounds: bounds_of(&ids),
            kids: None,
            first: 0,
            count: ids.len(),
        });
        let mut work = vec![(0usize, 1usize)]; // (node, depth)
        while let Some((n, depth)) = work.pop() {
            let (first, count) = (nodes[n].first, nodes[n].count);
            if count <= 1 || depth >= MAX_DEPTH {
                continue;
            }
            let slice = &mut ids[first..first + count];
            let Some(mid) = split(slice, &boxes, &centroids, &nodes[n].bounds) else {
                continue; // a leaf is cheaper
            };
            let (l, r) = slice.split_at(mid);
            let (lb, rb) = (bounds_of(l), bounds_of(r));
            let li = nodes.len();
            nodes.push(BuildNode {
                bounds: lb,
                kids: None,
                first,
                count: mid,
            });
            nodes.push(BuildNode {
                bounds: rb,
                kids: None,
                first: first + mid,
                count: count - mid,
            });
            nodes[n].kids = Some((li, li + 1));
            work.push((li + 1, depth + 1));
            work.push((li, depth + 1));
        }
        flatten(&nodes, &ids, triangles)
    }

    /// Closest hit along `o + t d`, t in (tmin, tmax): (t, prim) or None.
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, u32)> {
        self.traverse(o, d, tmin, tmax, false)
    }

    /// Whether anything is hit with t in (tmin, tmax) (shadow rays).
    pub fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        self.traverse(o, d, tmin, tmax, true).is_some()
    }

    /// The same loop as `trace_ray` in `shaders/shared/bvh.glsl`.
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
        let mut best_t = tmax;
        let mut best = u32::MAX;
        let mut stack = [(0u32, 0f32); MAX_DEPTH];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let ta = slab(n.a_min, n.a_max, oi, inv, tmin, best_t);
            let tb = slab(n.b_min, n.b_max, oi, inv, tmin, best_t);
            let mut hit_a = ta.is_some();
            let mut hit_b = tb.is_some();
            if hit_a && n.a_ref & BVH_LEAF_BIT != 0 {
                hit_a = false;
                if self.leaf(n.a_ref, n.a_count, o, d, tmin, &mut best_t, &mut best) && any {
                    return Some((best_t, best));
                }
            }
            if hit_b && n.b_ref & BVH_LEAF_BIT != 0 {
                hit_b = false;
                if self.leaf(n.b_ref, n.b_count, o, d, tmin, &mut best_t, &mut best) && any {
                    return Some((best_t, best));
                }
            }
            if hit_a && hit_b {
                let (near, far) = if ta <= tb {
                    (n.a_ref, (n.b_ref, tb.unwrap()))
                } else {
                    (n.b_ref, (n.a_ref, ta.unwrap()))
                };
                stack[sp] = far;
                sp += 1;
                node = near;
            } else if hit_a {
                node = n.a_ref;
            } else if hit_b {
                node = n.b_ref;
            } else {
                // Pop the next child that can still hold a closer hit.
                let mut found = false;
                while sp > 0 && !found {
                    sp -= 1;
                    found = stack[sp].1 <= best_t;
                    node = stack[sp].0;
                }
                if !found {
                    break;
                }
            }
        }
        (best != u32::MAX).then_some((best_t, best))
    }

    #[allow(clippy::too_many_arguments)]
    fn leaf(
        &self,
        r: u32,
        count: u32,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        best_t: &mut f32,
        best: &mut u32,
    ) -> bool {
        let first = (r & !BVH_LEAF_BIT) as usize;
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

/// Ray/box slab test (`oi` = o · inv); the entry distance if the box is hit within
/// [tmin, tmax].
#[inline]
fn slab(lo: [f32; 3], hi: [f32; 3], oi: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
    let t0 = Vec3::from(lo) * inv - oi;
    let t1 = Vec3::from(hi) * inv - oi;
    let near = t0.min(t1).max_element().max(tmin);
    let far = t0.max(t1).min_element().min(tmax);
    (near <= far).then_some(near)
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

/// Chooses a split of `ids` by binned SAH over all three axes and partitions `ids` in place;
/// returns the size of the left part, or None when a leaf is cheaper.
fn split(ids: &mut [u32], boxes: &[Aabb], centroids: &[Vec3], bounds: &Aabb) -> Option<usize> {
    let mut cb = Aabb::EMPTY;
    ids.iter().for_each(|&i| cb.grow(centroids[i as usize]));
    let extent = cb.hi - cb.lo;
    // Costs relative to one triangle test; a node visit (two box tests) costs about one.
    let leaf_cost = ids.len() as f32;
    let mut best: Option<(f32, usize, f32)> = None; // (cost, axis, split position)
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent[axis];
        let mut bin_box = [Aabb::EMPTY; BINS];
        let mut bin_n = [0usize; BINS];
        for &i in ids.iter() {
            let b = (((centroids[i as usize][axis] - cb.lo[axis]) * scale) as usize).min(BINS - 1);
            bin_n[b] += 1;
            bin_box[b].union(&boxes[i as usize]);
        }
        // Sweep from the right to get suffix areas, then from the left.
        let mut right_area = [0f32; BINS];
        let mut right_n = [0usize; BINS];
        let mut acc = Aabb::EMPTY;
        let mut n = 0;
        for b in (1..BINS).rev() {
            acc.union(&bin_box[b]);
            n += bin_n[b];
            right_area[b] = acc.area();
            right_n[b] = n;
        }
        let mut acc = Aabb::EMPTY;
        let mut n = 0;
        for b in 0..BINS - 1 {
            acc.union(&bin_box[b]);
            n += bin_n[b];
            if n == 0 || right_n[b + 1] == 0 {
                continue;
            }
            let cost = 1.0
                + (acc.area() * n as f32 + right_area[b + 1] * right_n[b + 1] as f32)
                    / bounds.area().max(f32::MIN_POSITIVE);
            if best.is_none_or(|(c, _, _)| cost < c) {
                let pos = cb.lo[axis] + (b + 1) as f32 / scale;
                best = Some((cost, axis, pos));
            }
        }
    }
    match best {
        Some((cost, axis, pos)) if cost < leaf_cost || ids.len() > MAX_LEAF => {
            let mid = partition(ids, |i| centroids[i as usize][axis] < pos);
            if mid == 0 || mid == ids.len() {
                Some(ids.len() / 2) // rounding put all on one side: split by count
            } else {
                Some(mid)
            }
        }
        // All centroids coincide: split by count so leaves stay small.
        None if ids.len() > MAX_LEAF => Some(ids.len() / 2),
        _ => None,
    }
}

fn partition(ids: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..ids.len() {
        if left(ids[j]) {
            ids.swap(i, j);
            i += 1;
        }
    }
    i
}

/// Lays out interior nodes depth-first (parent, left subtree, right subtree) and triangles in
/// leaf order.
fn flatten(nodes: &[BuildNode], ids: &[u32], triangles: &[[Vec3; 3]]) -> Bvh {
    let tris = ids
        .iter()
        .map(|&i| {
            let [a, b, c] = triangles[i as usize];
            BvhTri {
                v0: a.to_array(),
                prim: i,
                e1: (b - a).to_array(),
                e2: (c - a).to_array(),
                ..Default::default()
            }
        })
        .collect();
    let mut out: Vec<BvhNode> = Vec::new();
    let root = &nodes[0];
    if root.kids.is_none() {
        // A single leaf: one node with the leaf as child A and an empty leaf as child B.
        out.push(BvhNode {
            a_min: root.bounds.lo.to_array(),
            a_max: root.bounds.hi.to_array(),
            a_ref: BVH_LEAF_BIT | root.first as u32,
            a_count: root.count as u32,
            b_min: [1e30; 3],
            b_max: [1e30; 3],
            b_ref: BVH_LEAF_BIT,
            b_count: 0,
        });
        return Bvh { nodes: out, tris };
    }
    // Each interior node gets its slot before its children (pre-order).
    let mut stack = vec![(0usize, usize::MAX, false)]; // (build node, parent slot, is B child)
    while let Some((n, parent, is_b)) = stack.pop() {
        let node = &nodes[n];
        let (child_ref, count) = match node.kids {
            Some(_) => (out.len() as u32, 0),
            None => (BVH_LEAF_BIT | node.first as u32, node.count as u32),
        };
        if parent != usize::MAX {
            let p = &mut out[parent];
            if is_b {
                p.b_min = node.bounds.lo.to_array();
                p.b_max = node.bounds.hi.to_array();
                p.b_ref = child_ref;
                p.b_count = count;
            } else {
                p.a_min = node.bounds.lo.to_array();
                p.a_max = node.bounds.hi.to_array();
                p.a_ref = child_ref;
                p.a_count = count;
            }
        }
        if let Some((l, r)) = node.kids {
            let slot = out.len();
            out.push(BvhNode::default());
            stack.push((r, slot, true));
            stack.push((l, slot, false));
        }
    }
    Bvh { nodes: out, tris }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn random_soup(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
        let mut r = SplitMix64(seed);
        (0..n)
            .map(|_| {
                let c = Vec3::new(r.range(-5.0, 5.0), r.range(-5.0, 5.0), r.range(-5.0, 5.0));
                let mut v =
                    || c + Vec3::new(r.range(-0.3, 0.3), r.range(-0.3, 0.3), r.range(-0.3, 0.3));
                [v(), v(), v()]
            })
            .collect()
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
