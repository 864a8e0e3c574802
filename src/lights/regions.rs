//! Cuts (docs/method.md §2): every region ([`super::grid`]) that shading points reach gets a
//! cut of the light tree. The `wang` sampler (Wang & Åkerlund 2009) picks a cluster of the
//! region's cut ∝ Ĩ_C(x), then a light inside by power.
//!
//! Mirrored in `shaders/shared/regions.glsl`; tests/regions.rs checks GPU against CPU.

use std::collections::{BinaryHeap, HashMap};

use glam::Vec3;

pub use super::grid::{largest_grid, Grid, RegionSettings, MAX_GRID, MAX_K};
use super::{bounds::LightBounds, tree::LightTree};
use crate::abi::{LightNode, LIGHT_NODE_AREA, LIGHT_NODE_TWO_SIDED};

fn node_bounds(n: &LightNode) -> LightBounds {
    LightBounds {
        lo: Vec3::from(n.bmin),
        hi: Vec3::from(n.bmax),
        phi: n.phi,
        axis: Vec3::from(n.axis),
        cos_o: n.cos_o,
        cos_e: n.cos_e,
        two_sided: n.flags & LIGHT_NODE_TWO_SIDED != 0,
        area: n.flags & LIGHT_NODE_AREA != 0,
    }
}

/// A region-conservative importance for building cuts: the node's bounds grown by the
/// cell's half-size, seen from the cell's centre, with no receiver term (any normal). It only
/// steers which nodes get refined; sampling uses the point-wise Ĩ_C(x). Its distance clamp is
/// the point-wise one's (bounds.rs d2_floor): with pbrt-v4's clamp kept here, strings' cuts
/// grouped near bulbs less finely and `bayes` had 1.7× the variance it has with it (eight
/// seeds, 256 spp), for 2 % less on city10k and 4 % on cornell40 (docs/results.md, tenth
/// session).
fn region_importance(node: &LightNode, centre: Vec3, half: Vec3) -> f32 {
    let mut b = node_bounds(node);
    b.lo -= half;
    b.hi += half;
    b.importance(centre, Vec3::ZERO)
}

#[derive(PartialEq)]
struct Ranked(f32, u32);
impl Eq for Ranked {}
impl PartialOrd for Ranked {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Ranked {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0).then(o.1.cmp(&self.1))
    }
}

/// Whether the box (centre c, half-size h) meets the bounding box of a light of `tree`
/// (touching counts): a descent of the tree that skips the nodes whose boxes miss it.
pub fn light_in_box(tree: &LightTree, c: Vec3, h: Vec3) -> bool {
    let (lo, hi) = (c - h, c + h);
    let mut stack = vec![0u32];
    while let Some(i) = stack.pop() {
        let Some(nd) = tree.nodes.get(i as usize) else {
            continue;
        };
        if Vec3::from(nd.bmin).cmpgt(hi).any() || Vec3::from(nd.bmax).cmplt(lo).any() {
            continue;
        }
        if nd.count <= 1 {
            return true;
        }
        stack.push(i + 1);
        stack.push(nd.right);
    }
    false
}

/// The cut of a region: node indices covering every light exactly once, sorted by the start
/// of their light range. Refines the largest splittable node until it is ≤ τ × the total or
/// the cut has `k_max` nodes.
pub fn build_cut(tree: &LightTree, centre: Vec3, half: Vec3, s: &RegionSettings) -> Vec<u32> {
    let imp = |i: u32| region_importance(&tree.nodes[i as usize], centre, half);
    let mut done: Vec<u32> = Vec::new(); // leaves: cannot be split
    let mut open = BinaryHeap::new();
    let root_imp = imp(0);
    let mut total = root_imp;
    if tree.nodes[0].count == 1 {
        done.push(0);
    } else {
        open.push(Ranked(root_imp, 0));
    }
    while let Some(Ranked(top, i)) = open.peek().map(|r| Ranked(r.0, r.1)) {
        if (done.len() + open.len()) as u32 >= s.k_max
            || top <= s.tau * total && top >= 0.0 && total > 0.0
        {
            break;
        }
        open.pop();
        total -= top;
        let node = &tree.nodes[i as usize];
        for child in [i + 1, node.right] {
            let ci = imp(child);
            total += ci;
            if tree.nodes[child as usize].count == 1 {
                done.push(child);
            } else {
                open.push(Ranked(ci, child));
            }
        }
    }
    let mut cut: Vec<u32> = done
        .into_iter()
        .chain(open.into_iter().map(|r| r.1))
        .collect();
    cut.sort_by_key(|&i| tree.nodes[i as usize].begin);
    cut
}

/// Cuts for the regions reached, in the GPU layout: `index[region]` is the offset in `cuts`
/// of `[count, node, node, …]` (offset 0: the fallback cut of the whole scene, used by
/// regions no cut was built for — unbiased, just less adapted).
pub struct Cuts {
    pub grid: Grid,
    pub index: Vec<u32>,
    pub cuts: Vec<u32>,
    /// Offsets of the cuts built for reached regions (the fallback at 0 is not listed).
    pub offsets: Vec<u32>,
    /// Lights inside a cluster by importance (else by power).
    pub in_cluster_importance: bool,
    /// Blocks of 2×2×2 cells met so far ([`Grid::block_of`] keys; `coarse_blocks` only): the
    /// offset of the cut their regions share, or 0 for a block that holds a light, whose
    /// regions get cuts of their own.
    blocks: HashMap<u64, u32>,
    /// Whether blocks without lights share one cut ([`RegionSettings::coarse_blocks`]).
    coarse_blocks: bool,
}

impl Cuts {
    pub fn build(
        tree: &LightTree,
        grid: Grid,
        reached: impl IntoIterator<Item = u32>,
        scene_lo: Vec3,
        scene_hi: Vec3,
        s: &RegionSettings,
    ) -> Cuts {
        let mut cuts = Vec::new();
        let whole = build_cut(
            tree,
            0.5 * (scene_lo + scene_hi),
            0.5 * (scene_hi - scene_lo),
            s,
        );
        cuts.push(whole.len() as u32);
        cuts.extend(&whole);
        let mut built = Cuts {
            index: vec![0u32; grid.region_count() as usize],
            grid,
            cuts,
            offsets: Vec::new(),
            in_cluster_importance: s.in_cluster_importance,
            blocks: HashMap::new(),
            coarse_blocks: s.coarse_blocks,
        };
        // In the order given (the same cuts at the same offsets on every run); a region
        // listed twice keeps its first cut.
        let reached: Vec<u32> = reached.into_iter().collect();
        built.append(tree, &reached, s);
        built
    }

    /// Gives the `regions` that have no cut yet (regions a moved camera or a later sample
    /// reached) theirs, in the order given: a new cut of their own, or, in a block without
    /// lights, the block's shared cut (built by the block's first region); returns (region,
    /// offset) of each region given a cut, joined or new. A cut is a pure function of its
    /// region (or its block), the tree and the settings, so where the new cuts are appended
    /// changes no sample.
    pub fn append(
        &mut self,
        tree: &LightTree,
        regions: &[u32],
        s: &RegionSettings,
    ) -> Vec<(u32, u32)> {
        let mut added = Vec::new();
        for &r in regions {
            if self.index[r as usize] != 0 {
                continue;
            }
            // A block without a light: its regions share one cut, built for the block, and
            // its statistics. With every light outside the block, what a point sees changes
            // more slowly across it than next to a light, so finer regions there mostly
            // divide the same observations between more slots; near lights (strings' bulbs on their
            // objects) regions stay fine: a coarser grid everywhere made strings 1.9×
            // worse (docs/results.md, seventh session).
            let shared = if self.coarse_blocks {
                let (key, c, h) = self.grid.block_of(r);
                match self.blocks.get(&key) {
                    Some(&o) => Some(o),
                    None => {
                        let o = if light_in_box(tree, c, h) {
                            0
                        } else {
                            self.push_cut(&build_cut(tree, c, h, s))
                        };
                        self.blocks.insert(key, o);
                        Some(o)
                    }
                }
            } else {
                None
            };
            let offset = match shared {
                Some(o) if o != 0 => o,
                _ => {
                    let (c, h) = self.grid.cell_box(r);
                    self.push_cut(&build_cut(tree, c, h, s))
                }
            };
            self.index[r as usize] = offset;
            added.push((r, offset));
        }
        added
    }

    /// Appends a cut; its offset.
    fn push_cut(&mut self, cut: &[u32]) -> u32 {
        let offset = self.cuts.len() as u32;
        self.cuts.push(cut.len() as u32);
        self.cuts.extend(cut);
        self.offsets.push(offset);
        offset
    }

    /// Points every region (and block) whose cut was at an old offset of `moved` to its new
    /// one (cut refinement replaced those cuts by cuts appended at the new offsets): one pass
    /// over the index, whatever the number of cuts replaced.
    pub fn replace(&mut self, moved: &HashMap<u32, u32>) {
        let all = self.index.iter_mut().chain(self.blocks.values_mut());
        for o in all.chain(self.offsets.iter_mut()) {
            if let Some(&new) = moved.get(o) {
                *o = new;
            }
        }
        self.offsets.sort_unstable();
    }

    /// Cuts read back from a statistics file (`--load-stats`). With `coarse_blocks` the
    /// shared cut of each block without lights is found again from the regions that have it
    /// (the first in region order), so that regions reached later join it as they would
    /// have in the render that saved the file.
    pub fn from_parts(
        tree: &LightTree,
        grid: Grid,
        index: Vec<u32>,
        cuts: Vec<u32>,
        s: &RegionSettings,
    ) -> Cuts {
        let mut offsets: Vec<u32> = index.iter().copied().filter(|&o| o != 0).collect();
        offsets.sort_unstable();
        offsets.dedup();
        let mut blocks = HashMap::new();
        if s.coarse_blocks {
            for (r, &o) in index.iter().enumerate() {
                if o != 0 {
                    let (key, c, h) = grid.block_of(r as u32);
                    blocks
                        .entry(key)
                        .or_insert_with(|| if light_in_box(tree, c, h) { 0 } else { o });
                }
            }
        }
        Cuts {
            grid,
            index,
            cuts,
            offsets,
            in_cluster_importance: s.in_cluster_importance,
            blocks,
            coarse_blocks: s.coarse_blocks,
        }
    }

    /// Regions with a cut of their own or a shared one.
    pub fn built(&self) -> usize {
        self.index.iter().filter(|&&o| o != 0).count()
    }

    /// Distinct cuts built (a block's shared cut counts once).
    pub fn distinct(&self) -> usize {
        self.offsets.len()
    }

    /// The cut (node indices) used at (p, n).
    pub fn cut_at(&self, p: Vec3, n: Vec3) -> &[u32] {
        let o = self.index[self.grid.region(p, n) as usize] as usize;
        &self.cuts[o + 1..o + 1 + self.cuts[o] as usize]
    }

    /// Offset in `cuts` of the cut used at (p, n) (0: the fallback).
    pub fn offset_at(&self, p: Vec3, n: Vec3) -> usize {
        self.index[self.grid.region(p, n) as usize] as usize
    }

    /// Ĩ_C(p) of every node of a cut (the `wang` weights).
    pub fn importances(tree: &LightTree, cut: &[u32], p: Vec3, n: Vec3) -> Vec<f32> {
        cut.iter()
            .map(|&i| node_bounds(&tree.nodes[i as usize]).importance(p, n))
            .collect()
    }

    /// `wang`: cluster ∝ Ĩ_C(x) over the cut, then a light by power. The light and its pmf,
    /// or None when no cluster can light the front of n at p.
    pub fn sample(&self, tree: &LightTree, p: Vec3, n: Vec3, u: f32) -> Option<(u32, f32)> {
        let cut = self.cut_at(p, n);
        let w = Self::importances(tree, cut, p, n);
        let inside = self.inside(p, n);
        pick_in_cut(tree, cut, &w, u, inside).map(|(l, pmf, _)| (l, pmf))
    }

    /// The probability that `sample` returns `light` at (p, n).
    pub fn pmf(&self, tree: &LightTree, p: Vec3, n: Vec3, light: u32) -> f32 {
        let cut = self.cut_at(p, n);
        pmf_in_cut(
            tree,
            cut,
            &Self::importances(tree, cut, p, n),
            light,
            self.inside(p, n),
        )
    }

    /// How this cut picks a light inside a cluster at (p, n).
    pub fn inside(&self, p: Vec3, n: Vec3) -> Inside {
        if self.in_cluster_importance {
            Inside::Importance(p, n)
        } else {
            Inside::Power
        }
    }
}

/// How a light is picked inside a chosen cluster.
#[derive(Clone, Copy, Debug)]
pub enum Inside {
    /// ∝ power (Wang & Åkerlund 2009; docs/method.md §4's default).
    Power,
    /// By descending the cluster's subtree ∝ importance at this shading point.
    Importance(Vec3, Vec3),
}

/// The probability of the left child at a node, or None at a dead end (no light below can
/// reach the shading point).
fn left_chance(tree: &LightTree, node: usize, inside: Inside) -> Option<f32> {
    let (l, r) = (
        &tree.nodes[node + 1],
        &tree.nodes[tree.nodes[node].right as usize],
    );
    match inside {
        Inside::Power => Some(l.phi / (l.phi + r.phi)),
        Inside::Importance(p, n) => {
            let (il, ir) = (
                node_bounds(l).importance(p, n),
                node_bounds(r).importance(p, n),
            );
            (il + ir > 0.0).then(|| il / (il + ir))
        }
    }
}

/// Picks a slot of `cut` ∝ `w`, then a light inside its node: (light, pmf, slot), or None
/// when every weight is 0 or the descent inside meets a dead end. The same loop as
/// `pick_in_cut` in regions.glsl.
pub fn pick_in_cut(
    tree: &LightTree,
    cut: &[u32],
    w: &[f32],
    u: f32,
    inside: Inside,
) -> Option<(u32, f32, usize)> {
    let total: f32 = w.iter().sum();
    if total <= 0.0 {
        return None;
    }
    // The first non-zero slot whose cumulative weight passes u × total (the last non-zero
    // one if rounding walks past the end).
    let target = u * total;
    let (mut acc, mut chosen, mut last) = (0.0f32, None, (0usize, 0.0f32));
    for (i, &wi) in w.iter().enumerate() {
        if wi > 0.0 {
            last = (i, acc);
            if target < acc + wi {
                chosen = Some((i, acc));
                break;
            }
            acc += wi;
        }
    }
    let (k, acc) = chosen.unwrap_or(last);
    let mut v = ((target - acc) / w[k]).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
    let mut node = cut[k] as usize;
    let mut pmf = w[k] / total;
    while tree.nodes[node].count > 1 {
        let (l, r) = (node + 1, tree.nodes[node].right as usize);
        let pl = left_chance(tree, node, inside)?;
        if v < pl {
            v = (v / pl).min(1.0 - f32::EPSILON / 2.0);
            pmf *= pl;
            node = l;
        } else {
            v = ((v - pl) / (1.0 - pl)).min(1.0 - f32::EPSILON / 2.0);
            pmf *= 1.0 - pl;
            node = r;
        }
    }
    Some((tree.order[tree.nodes[node].begin as usize], pmf, k))
}

/// The slot of `cut` whose light range holds `light` (binary search by range start).
pub fn slot_of(tree: &LightTree, cut: &[u32], light: u32) -> Option<usize> {
    let pos = tree.position[light as usize];
    let k = cut.partition_point(|&i| tree.nodes[i as usize].begin <= pos);
    let k = k.checked_sub(1)?;
    let nd = &tree.nodes[cut[k] as usize];
    (pos < nd.begin + nd.count).then_some(k)
}

/// The probability that [`pick_in_cut`] returns `light` with weights `w`.
pub fn pmf_in_cut(tree: &LightTree, cut: &[u32], w: &[f32], light: u32, inside: Inside) -> f32 {
    let total: f32 = w.iter().sum();
    if total <= 0.0 {
        return 0.0;
    }
    let Some(k) = slot_of(tree, cut, light) else {
        return 0.0;
    };
    let pos = tree.position[light as usize];
    let mut node = cut[k] as usize;
    let mut pmf = w[k] / total;
    while tree.nodes[node].count > 1 {
        let (l, r) = (node + 1, tree.nodes[node].right as usize);
        let Some(pl) = left_chance(tree, node, inside) else {
            return 0.0;
        };
        let nl = &tree.nodes[l];
        if pos < nl.begin + nl.count {
            pmf *= pl;
            node = l;
        } else {
            pmf *= 1.0 - pl;
            node = r;
        }
    }
    pmf
}
