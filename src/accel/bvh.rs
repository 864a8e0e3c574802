//! Geometry BVH: a binned-SAH binary BVH built on the host, collapsed into 4-wide
//! [`BvhNode`]s (each node holds the boxes of a binary node's grandchildren, or of a child
//! that is a leaf: one fetch tests up to four boxes, and a path from the root is half as many
//! dependent fetches). The CPU traversal of those nodes is in `traverse.rs`.

use glam::Vec3;

use crate::gpu::layout::{
    BvhNode, BvhTri, BVH_LEAF_BIT, BVH_LEAF_COUNT_SHIFT, BVH_LEAF_FIRST_MASK,
};

/// Leaves hold at most this many triangles unless the depth limit forces more.
const MAX_LEAF: usize = 4;
/// The builder stops choosing splits by SAH at this binary depth, which bounds the traversal
/// stack; a deeper node is a leaf where it holds at most `MAX_LEAF_COUNT` triangles, else it
/// is halved by count, at most `COUNT_SPLIT_LEVELS` times.
pub const MAX_DEPTH: usize = 48;
/// The most triangles a leaf holds: its reference has 8 bits for the count (src/abi.rs).
const MAX_LEAF_COUNT: usize = 255;
/// The most triangles a BVH holds: a leaf reference has 23 bits for its first triangle.
pub const MAX_TRIANGLES: usize = BVH_LEAF_FIRST_MASK as usize + 1;
/// Halvings below MAX_DEPTH that bring any node's triangles down to a leaf's.
const COUNT_SPLIT_LEVELS: usize = 16;
const _: () = assert!(MAX_TRIANGLES.div_ceil(1 << COUNT_SPLIT_LEVELS) <= MAX_LEAF_COUNT);
/// Entries of the traversal stack (`BVH_STACK_SIZE` in `shaders/shared/types.glsl`): a 4-wide
/// node spans two binary levels wherever it has interior children, so a path has at most
/// (MAX_DEPTH + COUNT_SPLIT_LEVELS) / 2 = 32 nodes; each node on it with two or more interior
/// children leaves one entry of siblings to visit (the latest in registers, the others
/// stacked), and the last node has none: at most 32 − 2 = 30 on the stack.
pub const STACK_SIZE: usize = (MAX_DEPTH + COUNT_SPLIT_LEVELS) / 2;
/// The most nodes a BVH may have: the kernel's stack entry packs a slot below 2^24 into its
/// high bits (shaders/shared/bvh.glsl). At seven texels a node that is 117 M texels, within
/// the 2^27 a texel buffer holds on the devices that allow the most.
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
        Bvh::build_to(triangles, MAX_DEPTH)
    }

    /// As `build`, with SAH splits down to binary depth `sah_depth` (≤ MAX_DEPTH; the tests
    /// take less to reach the forced leaves with few triangles).
    fn build_to(triangles: &[[Vec3; 3]], sah_depth: usize) -> Bvh {
        debug_assert!(sah_depth <= MAX_DEPTH, "the stack bound rests on MAX_DEPTH");
        assert!(
            !triangles.is_empty(),
            "the loader refuses scenes without triangles"
        );
        assert!(
            triangles.len() <= MAX_TRIANGLES,
            "the loader refuses scenes of more than gltf_mesh::MAX_TRIANGLES triangles"
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
            let forced = depth >= sah_depth;
            if count <= 1 || (forced && count <= MAX_LEAF_COUNT) {
                continue;
            }
            let slice = &mut ids[first..first + count];
            let mid = if forced {
                // Past the SAH's depth: halve at the median centroid along the widest axis
                // until a leaf's reference holds the count.
                let mut cb = Aabb::EMPTY;
                slice.iter().for_each(|&i| cb.grow(centroids[i as usize]));
                let e = cb.hi - cb.lo;
                let axis = if e.x >= e.y && e.x >= e.z {
                    0
                } else if e.y >= e.z {
                    1
                } else {
                    2
                };
                slice.select_nth_unstable_by(count / 2, |&a, &b| {
                    centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
                });
                Some(count / 2)
            } else {
                split(slice, &boxes, &centroids, &nodes[n].bounds)
            };
            let Some(mid) = mid else {
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

/// A child slot of a node: (box min, box max, reference, leaf triangle count), the reference
/// of a leaf `BVH_LEAF_BIT | first triangle` (its count unpacked into the fourth member).
pub type Child = ([f32; 3], [f32; 3], u32, u32);

/// A leaf reference's first triangle and triangle count (`BvhNode::refs`, src/abi.rs).
pub fn leaf_range(r: u32) -> (u32, u32) {
    (
        r & BVH_LEAF_FIRST_MASK,
        (r & !BVH_LEAF_BIT) >> BVH_LEAF_COUNT_SHIFT,
    )
}

/// A node's four child slots in order.
pub fn children(n: &BvhNode) -> [Child; 4] {
    std::array::from_fn(|i| {
        let r = n.refs[i];
        let (r, count) = if r & BVH_LEAF_BIT != 0 {
            let (first, count) = leaf_range(r);
            (BVH_LEAF_BIT | first, count)
        } else {
            (r, 0)
        };
        (
            [n.lo_x[i], n.lo_y[i], n.lo_z[i]],
            [n.hi_x[i], n.hi_y[i], n.hi_z[i]],
            r,
            count,
        )
    })
}

fn set_child(n: &mut BvhNode, i: usize, (lo, hi, r, count): Child) {
    [n.lo_x[i], n.lo_y[i], n.lo_z[i]] = lo;
    [n.hi_x[i], n.hi_y[i], n.hi_z[i]] = hi;
    n.refs[i] = if r & BVH_LEAF_BIT != 0 {
        let first = r & !BVH_LEAF_BIT;
        assert!(
            first <= BVH_LEAF_FIRST_MASK && count as usize <= MAX_LEAF_COUNT,
            "a leaf of {count} triangles from triangle {first} does not fit its reference"
        );
        BVH_LEAF_BIT | count << BVH_LEAF_COUNT_SHIFT | first
    } else {
        r
    };
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
pub(crate) mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// Random small triangles in a 10-unit cube (the traversal's tests use them too).
    pub(crate) fn random_soup(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
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
            let mut inner: Vec<u32> = n
                .refs
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

    /// The most sibling entries a traversal can hold at and below `node` (registers and
    /// stack together), and the depth in nodes: descending from a node with two or more
    /// interior children leaves one entry of its others.
    fn stack_need(bvh: &Bvh, node: u32) -> (usize, usize) {
        let n = &bvh.nodes[node as usize];
        let inner: Vec<u32> = n
            .refs
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
        // The bound STACK_SIZE rests on, for a tree the SAH builds alone (no node past
        // MAX_DEPTH holds more than a leaf may): at most MAX_DEPTH / 2 levels, one entry a
        // level but the last, one of them in registers (STACK_SIZE allows for the count
        // halvings past MAX_DEPTH besides: forced_leaves_fit_their_references).
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

    /// Past the SAH's depth a node holding more triangles than a leaf reference can count
    /// (255) is halved until it fits, within the levels STACK_SIZE allows for; the tree then
    /// finds every hit a brute-force test finds.
    #[test]
    fn forced_leaves_fit_their_references() {
        let tris = random_soup(3000, 9);
        let bvh = Bvh::build_to(&tris, 2);
        let mut leaves: Vec<(u32, u32)> = bvh
            .nodes
            .iter()
            .flat_map(children)
            .filter(|c| c.2 & BVH_LEAF_BIT != 0 && c.3 > 0)
            .map(|c| (c.2 & !BVH_LEAF_BIT, c.3))
            .collect();
        leaves.sort_unstable();
        // The leaves' ranges tile the triangles: each in exactly one leaf.
        let end = leaves.iter().fold(0, |next, &(first, count)| {
            assert_eq!(first, next, "leaves {leaves:?} overlap or leave a gap");
            first + count
        });
        assert_eq!(end, 3000);
        let most = leaves.iter().map(|l| l.1).max().unwrap();
        eprintln!("{} leaves, the largest {most} triangles", leaves.len());
        assert!(
            most > 64,
            "no large forced leaf ({most}): the test tests nothing"
        );
        // The halvings stay within the levels STACK_SIZE allows past the SAH's depth.
        let (entries, depth) = stack_need(&bvh, 0);
        assert!(
            depth <= (2 + COUNT_SPLIT_LEVELS) / 2 && entries <= STACK_SIZE,
            "4-wide depth {depth}, entries {entries}"
        );
        let mut r = SplitMix64(4);
        let mut hits = 0;
        for _ in 0..300 {
            let o = Vec3::new(r.range(-6.0, 6.0), r.range(-6.0, 6.0), -8.0);
            let d = (Vec3::new(r.range(-4.0, 4.0), r.range(-4.0, 4.0), 0.0) - o).normalize();
            let want = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| {
                    let tri = BvhTri {
                        v0: t[0].to_array(),
                        e1: (t[1] - t[0]).to_array(),
                        e2: (t[2] - t[0]).to_array(),
                        prim: i as u32,
                        ..Default::default()
                    };
                    super::super::traverse::intersect_tri(&tri, o, d, 0.0, f32::INFINITY)
                        .map(|t| (t, i as u32))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            assert_eq!(bvh.intersect(o, d, 0.0, f32::INFINITY), want);
            assert_eq!(bvh.occluded(o, d, 0.0, f32::INFINITY), want.is_some());
            hits += want.is_some() as usize;
        }
        assert!(hits > 100, "only {hits} of 300 rays hit");
    }
}
