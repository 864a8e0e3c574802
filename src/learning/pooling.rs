//! Pooled priors for cold slots (`--pool-priors N`, issue #17): a `bayes` slot that has not
//! seen one observation of its own borrows up to N pseudo-observations from the slots of
//! the same light-tree node in the neighbouring regions.
//!
//! Why: learning from scratch was well behind the same sampler with converged statistics
//! (direct light, 128×96, variance over seeds: city 3.2× at 64 spp, 1.75× at 256; city
//! path traced 2.6× at 64 spp), while a coarser `--grid` learned city faster but made
//! strings 2.2× worse: its cuts need small regions. Pooling keeps the fine regions and their
//! cuts and shares only evidence. Because y = Î d² is regressed on the distance (Î / Ĩ by
//! importance, the default), a node's observations from nearby regions are in the same
//! units.
//!
//! The neighbourhood: the fine regions whose grid cells fall in the same block of
//! [`COARSE`]³ cells, with the same normal bin. Borrowed data go only to slots with no
//! observation of their own: pooling into every slot (N = 4) made strings 1.2–1.8× worse at
//! 64 spp (tiny bulbs wound around objects: what a neighbour sees of a cluster is not what a
//! region sees); cold slots alone cost it 7–9 % (without each run's ten worst pixels) while
//! city gained 1.14× at 256 spp and 1.29× at 64 (docs/results.md, 2026-12-04). A slot's own
//! data replace the borrowed ones at the next pooling (until then both count): the host
//! recomputes them at every growth point (src/render/session/growth.rs).
//!
//! The priors are a pure function of the totals, so a continuation of a render saved at a
//! growth point pools what the uninterrupted render pooled there, and they never touch the
//! totals themselves: statistics files and merges hold observations only. Unbiased: the
//! pseudo-observations only move the posterior, whose weights stay positive (fold.comp).

use crate::abi::SlotStats;
use crate::lights::regions::Grid;

/// Grid cells per axis of a pooling block: 4³ = 64 fine cells. Measured against 2 and 8
/// (budget 4, 64 spp, eight seeds): city 5.2e-4 / 4.4e-4 / 4.4e-4 (4 is the best or even),
/// cornell40 3.9e-4 / 3.8e-4 / 3.8e-4, strings within its heavy-tailed noise.
pub const COARSE: u32 = 4;

/// A slot's borrowed pseudo-observations, in the units of its totals: counts of zero and
/// non-zero observations, Σy, Σy² (fold.comp adds them to the totals it computes the
/// posterior of).
pub type SlotPrior = [f32; 4];

/// The borrowed pseudo-observations of every slot (indexed like `stats` and the cuts array)
/// for the regions of `index` (cut offset per region, 0: none) and `cuts`: each slot with no
/// observation of its own gets the totals of the other slots of its node in its block,
/// scaled to at most `budget` observations; every other slot (and the fallback cut's) gets
/// none.
pub fn pooled_priors(
    grid: &Grid,
    index: &[u32],
    cuts: &[u32],
    stats: &[SlotStats],
    budget: f32,
) -> Vec<SlotPrior> {
    let mut priors = vec![[0.0; 4]; stats.len()];
    if budget.is_nan() || budget <= 0.0 {
        return priors;
    }
    // Each cut once, for its first region (regions of a block without lights share one), with
    // its key: the region's pooling block and normal bin. Grouped by key, region order kept
    // within a group (a stable sort), so each (key, node) total sums in region order
    // (deterministic) in f64.
    let mut seen = vec![false; cuts.len()];
    let mut order: Vec<(u64, usize)> = Vec::new();
    for (r, &o) in index.iter().enumerate() {
        if o != 0 && !std::mem::replace(&mut seen[o as usize], true) {
            order.push((grid.block_key(r as u32, COARSE), o as usize));
        }
    }
    order.sort_by_key(|&(key, _)| key);
    let slots_of = |o: usize| o + 1..o + 1 + cuts[o] as usize;
    let nodes = order
        .iter()
        .flat_map(|&(_, o)| cuts[slots_of(o)].iter())
        .max()
        .map_or(0, |&n| n as usize + 1);
    // A group's totals per node in dense arrays, valid where `stamp` holds the group's number:
    // with a hash map keyed by (block, node) a growth point's pooling took 1.3-2.6 ms on
    // city10k and cornell40 (128x96, 45-58k slots; docs/results.md, seventeenth session).
    let mut total = vec![[0.0f64; 4]; nodes];
    let mut stamp = vec![usize::MAX; nodes];
    let mut cold = Vec::new();
    for (g, group) in order.chunk_by(|a, b| a.0 == b.0).enumerate() {
        cold.clear();
        for &(_, o) in group {
            for i in slots_of(o) {
                let (s, node) = (&stats[i], cuts[i] as usize);
                if s.n_zero + s.n_nonzero > 0.0 {
                    let e = &mut total[node];
                    if stamp[node] != g {
                        stamp[node] = g;
                        *e = [0.0; 4];
                    }
                    e[0] += s.n_zero as f64;
                    e[1] += s.n_nonzero as f64;
                    e[2] += s.sum as f64;
                    e[3] += s.sum_sq as f64;
                } else {
                    cold.push((i, node));
                }
            }
        }
        for &(i, node) in &cold {
            // A cold slot added nothing to its group's totals: they are all the others'.
            // Damaged or lying totals (inf, NaN) lend nothing: the coefficients must stay
            // finite.
            let e = &total[node];
            if stamp[node] == g && e.iter().all(|v| v.is_finite()) {
                let f = (budget as f64 / (e[0] + e[1])).min(1.0);
                priors[i] = e.map(|v| (f * v.max(0.0)).min(f32::MAX as f64) as f32);
            }
        }
    }
    priors
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 8×4×4 grid with 6 normal bins (region = flat cell × 6 + bin).
    fn grid() -> Grid {
        Grid {
            params: crate::abi::GridParams {
                lo: [0.0; 3],
                cell: 1.0,
                dims: [8, 4, 4],
                bins: 6,
            },
        }
    }

    fn region(x: u32, y: u32, z: u32, bin: u32) -> u32 {
        ((z * 4 + y) * 8 + x) * 6 + bin
    }

    fn seen(n_zero: f32, n_nonzero: f32, sum: f32, sum_sq: f32) -> SlotStats {
        SlotStats {
            n_zero,
            n_nonzero,
            sum,
            sum_sq,
            scale: 1.0,
            ..Default::default()
        }
    }

    /// Regions a and b (same block and bin) share node 7; c is the next block over, d has
    /// another bin, e is cold. Only cold slots borrow, only from their own block and bin,
    /// only the same node, scaled to the budget.
    #[test]
    fn cold_slots_borrow_their_blocks_totals_of_the_same_node() {
        let g = grid();
        let mut index = vec![0u32; (8 * 4 * 4 * 6) as usize];
        // The fallback cut at 0 (one slot), then one cut per region: [count, nodes…].
        let mut cuts = vec![1u32, 0];
        let mut add = |r: u32, nodes: &[u32]| {
            index[r as usize] = cuts.len() as u32;
            cuts.push(nodes.len() as u32);
            cuts.extend(nodes);
            index[r as usize] as usize
        };
        let a = add(region(0, 0, 0, 2), &[7, 9]);
        let b = add(region(3, 3, 3, 2), &[7]);
        let c = add(region(4, 0, 0, 2), &[7]);
        let d = add(region(1, 0, 0, 3), &[7]);
        let e = add(region(2, 1, 0, 2), &[7, 9, 11]);
        let mut stats = vec![SlotStats::default(); cuts.len()];
        stats[a + 1] = seen(6.0, 2.0, 10.0, 60.0);
        stats[a + 2] = seen(1.0, 1.0, 3.0, 9.0);
        stats[b + 1] = seen(2.0, 2.0, 2.0, 2.0);
        stats[c + 1] = seen(100.0, 0.0, 0.0, 0.0);
        stats[d + 1] = seen(0.0, 50.0, 500.0, 5000.0);
        let p = pooled_priors(&g, &index, &cuts, &stats, 4.0);
        // e's node 7: a's and b's (12 observations) scaled to 4; node 9: a's alone (2 ≤ 4,
        // taken whole); node 11: nobody's.
        let third = |v: f32| v / 3.0;
        let want7 = [third(8.0), third(4.0), third(12.0), third(62.0)];
        for (got, want) in p[e + 1].iter().zip(want7) {
            assert!(
                (got - want).abs() < 1e-5,
                "node 7: {:?} vs {want7:?}",
                p[e + 1]
            );
        }
        assert_eq!(p[e + 2], [1.0, 1.0, 3.0, 9.0], "node 9");
        assert_eq!(p[e + 3], [0.0; 4], "node 11");
        // Slots with data of their own borrow nothing, nor does the fallback.
        for i in [0, 1, a + 1, a + 2, b + 1, c + 1, d + 1] {
            assert_eq!(p[i], [0.0; 4], "slot {i}");
        }
        assert!(
            pooled_priors(&g, &index, &cuts, &stats, 0.0)
                .iter()
                .all(|p| *p == [0.0; 4]),
            "budget 0 is off"
        );
        // A neighbour with an infinite sum lends nothing (its block's node 7); huge but
        // finite totals lend finite values.
        stats[b + 1] = seen(2.0, 2.0, f32::INFINITY, 2.0);
        stats[a + 2] = seen(0.0, 1.0, f32::MAX, f32::MAX);
        let p = pooled_priors(&g, &index, &cuts, &stats, 4.0);
        assert_eq!(p[e + 1], [0.0; 4], "node 7 with an infinite sum");
        assert!(
            p[e + 2].iter().all(|v| v.is_finite()),
            "node 9: {:?}",
            p[e + 2]
        );
    }

    /// The pooling as first written (one hash map keyed by block and node over every cut
    /// in region order): what the grouped, dense version must give bit for bit.
    fn pooled_priors_by_map(
        grid: &Grid,
        index: &[u32],
        cuts: &[u32],
        stats: &[SlotStats],
        budget: f32,
    ) -> Vec<SlotPrior> {
        let mut priors = vec![[0.0; 4]; stats.len()];
        let mut pooled = std::collections::HashMap::<u64, [f64; 4]>::new();
        let mut cold = Vec::new();
        let mut seen = vec![false; cuts.len()];
        for (r, &o) in index.iter().enumerate() {
            if o == 0 || std::mem::replace(&mut seen[o as usize], true) {
                continue;
            }
            let block = grid.block_key(r as u32, COARSE) << 32;
            for i in o as usize + 1..o as usize + 1 + cuts[o as usize] as usize {
                let (s, k) = (&stats[i], block | cuts[i] as u64);
                if s.n_zero + s.n_nonzero > 0.0 {
                    let e = pooled.entry(k).or_insert([0.0; 4]);
                    for (e, v) in e.iter_mut().zip([s.n_zero, s.n_nonzero, s.sum, s.sum_sq]) {
                        *e += v as f64;
                    }
                } else {
                    cold.push((i, k));
                }
            }
        }
        for (i, k) in cold {
            if let Some(e) = pooled.get(&k).filter(|e| e.iter().all(|v| v.is_finite())) {
                let f = (budget as f64 / (e[0] + e[1])).min(1.0);
                priors[i] = e.map(|v| (f * v.max(0.0)).min(f32::MAX as f64) as f32);
            }
        }
        priors
    }

    /// Many random cuts (some shared by several regions, as blocks without lights share
    /// one) over the 8×4×4×6 grid, a third of the slots cold: the same priors, bit for bit,
    /// as the hash map's. Fails if a group's totals are not cleared for the next group, or
    /// a shared cut counts once per region (checked by mutation, seventeenth session).
    #[test]
    fn grouped_pooling_is_the_hash_maps_bit_for_bit() {
        let g = grid();
        let mut rng = crate::rng::SplitMix64(17);
        let mut below = |n: u64| (rng.next_u64() % n) as u32;
        for round in 0..4 {
            let regions = 8 * 4 * 4 * 6;
            let mut index = vec![0u32; regions];
            let mut cuts = vec![1u32, 0];
            for r in 0..regions {
                match below(4) {
                    0 => {}
                    // Share an earlier region's cut.
                    1 if r > 0 && index[r - 1] != 0 => index[r] = index[r - 1],
                    _ => {
                        index[r] = cuts.len() as u32;
                        let n = 1 + below(6);
                        cuts.push(n);
                        for _ in 0..n {
                            cuts.push(below(12));
                        }
                    }
                }
            }
            let mut stats = vec![SlotStats::default(); cuts.len()];
            for s in stats.iter_mut().skip(2) {
                if below(3) != 0 {
                    let (z, v) = (below(50) as f32, below(50) as f32 + 0.5);
                    let y = below(1000) as f32 * 0.37;
                    *s = seen(z, v, y, y * y * 1.3 + 0.1);
                }
            }
            let budget = [4.0, 0.5, 1e6, 2.0][round];
            let got = pooled_priors(&g, &index, &cuts, &stats, budget);
            let want = pooled_priors_by_map(&g, &index, &cuts, &stats, budget);
            let lent = want.iter().filter(|p| **p != [0.0; 4]).count();
            assert!(lent > 20, "round {round}: only {lent} slots borrow");
            for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                assert!(
                    a.map(f32::to_bits) == b.map(f32::to_bits),
                    "round {round}, slot {i}: {a:?} against {b:?}"
                );
            }
        }
    }
}
