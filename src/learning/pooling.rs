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
//! recomputes them at every growth point (src/render/session/mod.rs).
//!
//! The priors are a pure function of the totals, so a continuation of a render saved at a
//! growth point pools what the uninterrupted render pooled there, and they never touch the
//! totals themselves: statistics files and merges hold observations only. Unbiased: the
//! pseudo-observations only move the posterior, whose weights stay positive (fold.comp).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use crate::abi::SlotStats;
use crate::lights::regions::Grid;

/// A multiplicative hash of the u64 keys below. With the standard SipHash and tuple keys a
/// growth point's pooling took 2.7–4.6 ms on city (47k slots, 128×96; reading the totals
/// and uploading the result included), with this 1.5–2.3 ms.
#[derive(Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        // hashbrown takes its buckets from the low bits: fold the well-mixed high half in.
        self.0 ^ (self.0 >> 32)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }
    fn write_u64(&mut self, k: u64) {
        self.0 = (k ^ (k >> 29)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

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
    // Each block's totals per node, summed in region order (deterministic), in f64; the cold
    // slots with their keys, to be served after.
    let mut pooled: HashMap<u64, [f64; 4], BuildHasherDefault<KeyHasher>> = HashMap::default();
    let mut cold = Vec::new();
    // A cut that regions share (a block without lights) counts once, for its first region.
    let mut seen = vec![false; cuts.len()];
    for (r, &o) in index.iter().enumerate() {
        if o == 0 || std::mem::replace(&mut seen[o as usize], true) {
            continue;
        }
        let o = o as usize;
        // A slot's key: its region's pooling block and normal bin, then its node.
        let block = grid.block_key(r as u32, COARSE) << 32;
        for (i, &node) in cuts.iter().enumerate().skip(o + 1).take(cuts[o] as usize) {
            let s = &stats[i];
            let k = block | node as u64;
            if s.n_zero + s.n_nonzero > 0.0 {
                let e = pooled.entry(k).or_insert([0.0; 4]);
                e[0] += s.n_zero as f64;
                e[1] += s.n_nonzero as f64;
                e[2] += s.sum as f64;
                e[3] += s.sum_sq as f64;
            } else {
                cold.push((i, k));
            }
        }
    }
    for (i, k) in cold {
        // A cold slot added nothing to its block's totals: they are all the others'.
        // Damaged or lying totals (inf, NaN) lend nothing: the coefficients must stay finite.
        if let Some(e) = pooled.get(&k).filter(|e| e.iter().all(|v| v.is_finite())) {
            let f = (budget as f64 / (e[0] + e[1])).min(1.0);
            priors[i] = e.map(|v| (f * v.max(0.0)).min(f32::MAX as f64) as f32);
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
}
