//! Geometry BVH: a binned-SAH binary BVH built on the host, collapsed into 4-wide
//! [`BvhNode`]s (each node holds the boxes of a binary node's grandchildren, or of a child
//! that is a leaf: one fetch tests up to four boxes, and a path from the root is half as many
//! dependent fetches), plus the CPU traversal of exactly those nodes that the tests and the
//! ray-throughput benchmark compare the GPU kernel with.

use glam::{Vec3, Vec4};

use crate::gpu::layout::{BvhNode, BvhTri, BVH_LEAF_BIT};

/// Leaves hold at most this many triangles unless the depth limit forces more.
const MAX_LEAF: usize = 4;
/// The builder stops splitting at this binary depth, which bounds the traversal stack.
pub const MAX_DEPTH: usize = 48;
/// Entries of the traversal stack (`STACK_SIZE` in `shaders/shared/bvh.glsl`): a 4-wide node
/// spans two binary levels wherever it has interior children, so a path has at most
/// MAX_DEPTH / 2 = 24 nodes; each node on it with two or more interior children leaves one
/// entry of siblings to visit (the latest in registers, the others stacked), and the last
/// node has none: at most 24 − 2 = 22 on the stack.
pub const STACK_SIZE: usize = 24;
/// The most nodes a BVH may have: a stack entry packs a slot below 2^24 into its high bits
/// (`Siblings`). Devices whose texel buffers hold 2^27 texels cannot hold more anyway.
pub const MAX_NODES: usize = 1 << 24;
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

    /// The same loop as `trace_ray` in `shaders/shared/bvh.glsl`, test for test and in the same
    /// order, so both find the same triangle, also where two are hit at the same distance
    /// (tests/gpu_bvh.rs checks every ray).
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
        // The kernel's rays end at 3e38 (render.comp), so no key of theirs is ∞ either.
        let mut best_t = tmax.min(f32::MAX);
        let mut best = u32::MAX;
        let mut stack = [(0u32, 0f32); STACK_SIZE];
        let mut sp = 0usize;
        let mut node = 0u32;
        // The kernel's sibling entry: the interior children still to visit of the last node
        // that had two or more, in registers; the next such node stacks it.
        let mut sib = Siblings::default();
        let mut done = false;
        loop {
            let kids = children(&self.nodes[node as usize]);
            // All four boxes against the distance known on arrival (-1: missed). The hit
            // leaves are tested once the next node is chosen, as the kernel's lanes step from
            // node to node until they hold leaves and then test them.
            let mut key = slab4(&kids, oi, inv, tmin, best_t).to_array();
            let mut refs = kids.map(|k| k.2);
            let leaves = std::array::from_fn::<_, 4, _>(|i| {
                (key[i] >= 0.0 && refs[i] & BVH_LEAF_BIT != 0).then_some((refs[i], kids[i].3))
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
                        stack[sp] = (sib.pack(), sib.key);
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
                        sib = Siblings::unpack(stack[sp].0, stack[sp].1);
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
            for &(r, count) in leaves.iter().flatten() {
                if self.leaf(r, count, o, d, tmin, &mut best_t, &mut best) && any {
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

/// Interior children of one node still to visit, nearest first: they sit in consecutive slots
/// from `base` (flatten), and `offsets` holds each one's slot − base in two bits, the next in
/// the low bits. On the stack as one word, base · 256 | offsets · 4 | count (base below
/// MAX_NODES), and the next one's entry distance, a lower bound for the others'.
#[derive(Clone, Copy, Default)]
struct Siblings {
    base: u32,
    offsets: u32,
    count: u32,
    key: f32,
}

impl Siblings {
    fn pack(&self) -> u32 {
        (self.base << 8) | (self.offsets << 2) | self.count
    }

    fn unpack(word: u32, key: f32) -> Siblings {
        Siblings {
            base: word >> 8,
            offsets: (word >> 2) & 63,
            count: word & 3,
            key,
        }
    }
}

/// The ray/box slab test of the four children at once (`oi` = o · inv; SIMD lanes =
/// children): each child's entry distance if its box is hit within [tmin, tmax], else -1
/// (tmin ≥ 0). The same tests per lane as `slab` in the kernel (whose compiler may fuse the
/// multiply-add: a distance can differ in its last bit, which can only reorder a near tie).
#[inline]
fn slab4(kids: &[Child; 4], oi: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> Vec4 {
    let lane = |f: fn(&Child) -> f32| Vec4::new(f(&kids[0]), f(&kids[1]), f(&kids[2]), f(&kids[3]));
    let axis = |lo: Vec4, hi: Vec4, oi: f32, inv: f32| {
        let t0 = lo * inv - Vec4::splat(oi);
        let t1 = hi * inv - Vec4::splat(oi);
        (t0.min(t1), t0.max(t1))
    };
    let (nx, fx) = axis(lane(|k| k.0[0]), lane(|k| k.1[0]), oi.x, inv.x);
    let (ny, fy) = axis(lane(|k| k.0[1]), lane(|k| k.1[1]), oi.y, inv.y);
    let (nz, fz) = axis(lane(|k| k.0[2]), lane(|k| k.1[2]), oi.z, inv.z);
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

/// A child slot of a node: (box min, box max, reference, leaf triangle count).
pub type Child = ([f32; 3], [f32; 3], u32, u32);

/// A node's four child slots in order.
pub fn children(n: &BvhNode) -> [Child; 4] {
    [
        (n.a_min, n.a_max, n.a_ref, n.a_count),
        (n.b_min, n.b_max, n.b_ref, n.b_count),
        (n.c_min, n.c_max, n.c_ref, n.c_count),
        (n.d_min, n.d_max, n.d_ref, n.d_count),
    ]
}

fn set_child(n: &mut BvhNode, i: usize, (lo, hi, r, count): Child) {
    let (min, max, rf, c) = match i {
        0 => (&mut n.a_min, &mut n.a_max, &mut n.a_ref, &mut n.a_count),
        1 => (&mut n.b_min, &mut n.b_max, &mut n.b_ref, &mut n.b_count),
        2 => (&mut n.c_min, &mut n.c_max, &mut n.c_ref, &mut n.c_count),
        _ => (&mut n.d_min, &mut n.d_max, &mut n.d_ref, &mut n.d_count),
    };
    (*min, *max, *rf, *c) = (lo, hi, r, count);
}

/// An empty child: a leaf of no triangles (a point box far away; even where a ray meets it,
/// it adds no test).
const EMPTY_CHILD: Child = ([1e30; 3], [1e30; 3], BVH_LEAF_BIT, 0);

/// Lays out the 4-wide nodes with each node's interior children in one block of consecutive
/// slots (subtrees filled depth-first, a block allocated as its parent is filled) and the
/// triangles in leaf order. A node's children are its binary node's grandchildren, or the
/// child itself where that is a leaf.
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
    let empty = || {
        let mut n = BvhNode::default();
        (0..4).for_each(|i| set_child(&mut n, i, EMPTY_CHILD));
        n
    };
    let mut out: Vec<BvhNode> = Vec::new();
    let root = &nodes[0];
    if root.kids.is_none() {
        // A single leaf: one node with the leaf as child A and empty leaves for the others.
        let mut n = empty();
        let leaf = BVH_LEAF_BIT | root.first as u32;
        set_child(
            &mut n,
            0,
            (
                root.bounds.lo.to_array(),
                root.bounds.hi.to_array(),
                leaf,
                root.count as u32,
            ),
        );
        out.push(n);
        return Bvh { nodes: out, tris };
    }
    let wide_children = |n: usize| -> Vec<usize> {
        let (l, r) = nodes[n]
            .kids
            .expect("only interior build nodes become 4-wide nodes");
        [l, r]
            .iter()
            .flat_map(|&c| match nodes[c].kids {
                Some((a, b)) => vec![a, b],
                None => vec![c],
            })
            .collect()
    };
    // A node's interior children take consecutive slots (one block, allocated when the node
    // is filled), so the traversal names any of them by the block's first slot and an offset
    // below 4 (`Siblings`).
    out.push(empty());
    let mut work = vec![(0usize, 0usize)]; // (interior build node, its slot)
    while let Some((n, slot)) = work.pop() {
        let kids = wide_children(n);
        let mut next = out.len();
        let inner = kids.iter().filter(|&&c| nodes[c].kids.is_some()).count();
        out.extend((0..inner).map(|_| empty()));
        for (i, &c) in kids.iter().enumerate() {
            let node = &nodes[c];
            let (child_ref, count) = match node.kids {
                Some(_) => {
                    work.push((c, next));
                    next += 1;
                    ((next - 1) as u32, 0)
                }
                None => (BVH_LEAF_BIT | node.first as u32, node.count as u32),
            };
            let child = (
                node.bounds.lo.to_array(),
                node.bounds.hi.to_array(),
                child_ref,
                count,
            );
            set_child(&mut out[slot], i, child);
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

    /// The traversal names a node's interior children by the first one's slot and an offset
    /// below 4 (`Siblings`), so they must take consecutive slots, and every node but the root
    /// must be some node's child exactly once.
    #[test]
    fn interior_children_take_consecutive_slots() {
        let bvh = Bvh::build(&random_soup(3000, 11));
        let mut parents = vec![0u32; bvh.nodes.len()];
        for n in &bvh.nodes {
            let mut inner: Vec<u32> = [n.a_ref, n.b_ref, n.c_ref, n.d_ref]
                .into_iter()
                .filter(|r| r & BVH_LEAF_BIT == 0)
                .collect();
            inner.sort_unstable();
            for (i, &r) in inner.iter().enumerate() {
                assert_eq!(
                    r,
                    inner[0] + i as u32,
                    "children {inner:?} are not one block"
                );
                parents[r as usize] += 1;
            }
        }
        assert!(
            bvh.nodes.len() > 500,
            "too small a tree: {}",
            bvh.nodes.len()
        );
        assert_eq!(parents[0], 0, "the root is nobody's child");
        assert!(
            parents[1..].iter().all(|&p| p == 1),
            "a node with no or two parents"
        );
    }

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

    /// The most sibling entries a traversal can hold at and below `node` (registers and
    /// stack together), and the depth in nodes: descending from a node with two or more
    /// interior children leaves one entry of its others.
    fn stack_need(bvh: &Bvh, node: u32) -> (usize, usize) {
        let n = &bvh.nodes[node as usize];
        let inner: Vec<u32> = [n.a_ref, n.b_ref, n.c_ref, n.d_ref]
            .into_iter()
            .filter(|r| r & BVH_LEAF_BIT == 0)
            .collect();
        let below = inner.iter().map(|&c| stack_need(bvh, c));
        let need = below.clone().map(|(s, _)| s).max().unwrap_or(0) + (inner.len() > 1) as usize;
        (need, 1 + below.map(|(_, d)| d).max().unwrap_or(0))
    }

    /// A scene with a deep SAH tree (triangles at geometrically growing distances, split off a
    /// few at a time) must fit the traversal stack with the bound STACK_SIZE rests on, and
    /// still be traversed exactly.
    #[test]
    fn the_deepest_tree_fits_the_traversal_stack() {
        let tris: Vec<[Vec3; 3]> = (0..300)
            .map(|i| {
                let x = 1.3f32.powi(i);
                [
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                    Vec3::new(x, 0.0, 1.0),
                ]
            })
            .collect();
        let bvh = Bvh::build(&tris);
        let (entries, depth) = stack_need(&bvh, 0);
        // The latest entry is held in registers.
        let need = entries.saturating_sub(1);
        eprintln!("4-wide depth {depth}, stack need {need}");
        assert!(
            depth >= 16,
            "the tree is too shallow ({depth}) to test deep paths"
        );
        // The bound STACK_SIZE rests on: at most MAX_DEPTH / 2 levels, one entry a level but
        // the last, one of them in registers.
        assert!(
            depth <= MAX_DEPTH / 2 && need + 2 <= depth,
            "depth {depth}, need {need}"
        );
        assert!(need <= STACK_SIZE, "stack need {need} > {STACK_SIZE}");
        // A bushy tree, where nodes have two to four interior children and entries stack.
        let soup = Bvh::build(&random_soup(3000, 3));
        let (entries, soup_depth) = stack_need(&soup, 0);
        eprintln!(
            "soup: 4-wide depth {soup_depth}, stack need {}",
            entries - 1
        );
        assert!(entries >= 4 && entries - 1 + 2 <= soup_depth && entries - 1 <= STACK_SIZE);
        for i in [0, 7, 60] {
            let x = 1.3f32.powi(i);
            let o = Vec3::new(0.99 * x, 0.25, 0.25);
            assert_eq!(
                bvh.intersect(o, Vec3::X, 0.0, f32::INFINITY).map(|h| h.1),
                Some(i as u32)
            );
        }
    }
}
