//! Learned cut refinement (`--refine-cuts N`, issue #17): between passes a region's cut
//! replaces a cluster by its two children where drawing the children apart would pay for
//! the longer cut.
//!
//! `lightlearn variance` found most of converged `bayes`'s remaining variance inside the
//! clusters on strings (66 %) and rooms16 (43 %), and a fixed larger cut (`--k-max 64 --tau
//! 0.005`) cut that term 3.2× on strings but cost 1.3–1.5× per sample everywhere
//! (docs/results.md, "Where the variance is"). Inside a cluster the light is drawn by the
//! children's unoccluded importance, so a split pays only where the children's observations
//! differ (one hidden, one lit; one near, one far), not where each child's observations
//! spread alike. The kernel counts each observation by the side it came through
//! (render.comp `side_counts`), and [`split_gain`] prices the split from those sums.
//!
//! Until 2026-12-05 the choice was the slot's own cv² = E[y²]/E[y]² − 1 > 1, which cannot
//! tell the two apart: `--refine-cuts 8` then cost rooms16 7 % at equal time (1.10× less
//! variance for 1.19× the time a sample). With the side sums and a split only where its gain
//! beats [`SLOT_COST`] (direct light, 128×96, 256 spp, eight seeds, variance × time against
//! off; docs/results.md, tenth session): rooms16 1.01×, rooms36 1.05× (strings 1.92× until
//! the importance's distance clamp took its fireflies away, 0.97× since); where little
//! splits, the counting and the read-backs cost 1–7 % a sample (cornell40 1.03× the time,
//! best of 5), so it is off by default.
//!
//! Unbiased: the cut changes only at a fold boundary, between passes, and the new cut tiles
//! the same lights. Deterministic: the decision reads integer sums. The children inherit
//! the parent's statistics as a prior split by power share f (counts halved, so the data
//! soon outweigh it; mean × f, second moment × f²; f = 1 under `--regression importance`,
//! where y is a share of Ĩ, which splits with the power): their weights start summing to
//! about the parent's, where fresh priors would forget what the region learned about
//! occlusion.

use crate::abi::SlotStats;
use crate::learning::{fixed_sum, Regression};
use crate::lights::regions::Cuts;
use crate::lights::tree::LightTree;

/// Observations a cluster needs (counted by side) before its children's sums count.
pub const MIN_OBSERVATIONS: u32 = 64;
/// What one more slot costs a sample, as a share of the sample's time when the cut holds
/// one slot: a sample's time in the light choice is about linear in the cut's length and
/// `lightlearn profile` put the choice at 41–60 % of a `bayes` pass (the default scene at
/// depth 8 41 %, city at depth 8 48 %, cornell40 direct 60 %; docs/results.md), so one slot
/// more in a cut of `count` costs about `SLOT_COST / count` of a sample.
pub const SLOT_COST: f64 = 0.5;

/// One slot's observations by side, from render.comp `side_counts`: for the left and the
/// right child, how many and Σ (y / scale)², each y in the slot's scale when it was observed
/// (the folds move the scale towards y's root mean square; both sides alike, so their
/// ratio, which is all [`split_gain`] reads, keeps its meaning).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sides {
    pub n: [f64; 2],
    pub sq: [f64; 2],
}

impl Sides {
    /// From the kernel's six words (`sq` in the 2^24 fixed point of the window sums).
    pub fn from_words(w: [u32; 6]) -> Sides {
        Sides {
            n: [w[0] as f64, w[1] as f64],
            sq: [fixed_sum(w[2], w[3]), fixed_sum(w[4], w[5])],
        }
    }
}

/// How much a split of one cluster would cut the second moment of its region's estimate,
/// as a share of it, from its observations by side and `share`, the slot's part of its
/// cut's observations (how often the region draws it). Inside the cluster the light is
/// drawn ∝ Ĩ, so the sides' shares πc of the draws are the children's parts of Ĩ (averaged
/// over the region), and y = Î / Ĩ has the second moment mc on side c: the cluster's
/// estimate has the second moment ∝ Σ πc mc now and (Σ πc √mc)² with its children drawn
/// apart (each ∝ Ĩc √mc, as `bayes` draws clusters), a factor g = Σ πc mc / (Σ πc √mc)² ≥ 1,
/// 1 where both children give alike: the slot's own totals (its cv²) cannot tell that from
/// a spread inside each child, which a split leaves where it is. The region's √(second
/// moment) is about the sum of its slots' weights, of which this one's share is how often
/// it is drawn, so the split shrinks it by share · (1 − 1/√g).
pub fn split_gain(s: &Sides, share: f64) -> Option<f64> {
    let n = s.n[0] + s.n[1];
    if n < MIN_OBSERVATIONS as f64 || s.sq[0] + s.sq[1] <= 0.0 {
        return None;
    }
    // Each side's mean of y² drawn towards the two sides' together by PSEUDO observations,
    // so a side with few draws is not taken as certainly dark or bright.
    let pooled = (s.sq[0] + s.sq[1]) / n;
    let m = |c: usize| (s.sq[c] + PSEUDO * pooled) / (s.n[c] + PSEUDO);
    let (a0, a1) = (s.n[0] / n, s.n[1] / n);
    let root = a0 * m(0).sqrt() + a1 * m(1).sqrt();
    let g = (a0 * m(0) + a1 * m(1)) / (root * root);
    let shrink = share.clamp(0.0, 1.0) * (1.0 - 1.0 / g.sqrt());
    Some(1.0 - (1.0 - shrink) * (1.0 - shrink))
}

/// Pseudo-observations of the pooled second moment in each side's ([`split_gain`]).
const PSEUDO: f64 = 2.0;

/// The new cut of the region at offset `o` and each new slot's statistics, or None when no
/// cluster qualifies or the cut is full. A cluster splits when [`split_gain`] exceeds what
/// one more slot costs ([`SLOT_COST`] / the cut's length); at most `splits` of them, the
/// largest gain first. `sides`: every slot's observations by side (render.comp
/// `side_counts`). `regression`: the units of y (by importance a child inherits the
/// parent's y as it is).
#[allow(clippy::too_many_arguments)]
pub fn refined_cut(
    tree: &LightTree,
    cuts: &Cuts,
    stats: &[SlotStats],
    sides: &[[u32; 6]],
    o: usize,
    splits: usize,
    k_max: usize,
    regression: Regression,
) -> Option<(Vec<u32>, Vec<SlotStats>)> {
    let count = cuts.cuts[o] as usize;
    let cut = &cuts.cuts[o + 1..o + 1 + count];
    let room = k_max.saturating_sub(count).min(splits);
    if room == 0 {
        return None;
    }
    let side = |k: usize| Sides::from_words(sides.get(o + 1 + k).copied().unwrap_or_default());
    // Observations through a single light are not counted by side: the cut's draws are the
    // totals (own observations; inherited ones are the parent's, drawn as often).
    let drawn = |k: usize| {
        let s = &stats[o + 1 + k];
        (s.n_zero + s.n_nonzero) as f64
    };
    let all: f64 = (0..count).map(drawn).sum();
    if all <= 0.0 {
        return None;
    }
    let cost = SLOT_COST / count as f64;
    let mut scored: Vec<(f64, usize)> = cut
        .iter()
        .enumerate()
        .filter_map(|(k, &node)| {
            if tree.nodes[node as usize].count < 2 {
                return None;
            }
            let gain = split_gain(&side(k), drawn(k) / all)?;
            (gain > cost).then_some((gain, k))
        })
        .collect();
    if scored.is_empty() {
        return None;
    }
    // Largest gain first; ties by slot, so the choice is the same on every run.
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let split: Vec<usize> = scored.iter().take(room).map(|&(_, k)| k).collect();
    let mut new_cut = Vec::with_capacity(count + split.len());
    let mut new_stats = Vec::with_capacity(count + split.len());
    for (k, &node) in cut.iter().enumerate() {
        let s = stats[o + 1 + k];
        if !split.contains(&k) {
            new_cut.push(node);
            new_stats.push(s);
            continue;
        }
        let nd = &tree.nodes[node as usize];
        // Children in tree order (left = node + 1 starts where the parent does), so the cut
        // stays sorted by range start.
        for child in [node + 1, nd.right] {
            // y's share of the parent by power; by importance (y = Î / Ĩ) a child's y is the
            // parent's, as Ĩ splits with the power.
            let f = if regression == Regression::Importance {
                1.0
            } else if nd.phi > 0.0 {
                tree.nodes[child as usize].phi / nd.phi
            } else {
                0.5
            };
            // Both children inherit the parent's statistics with half its counts, not the
            // part that came their way by the side counts: a child that its side's few
            // draws priced low was then drawn too rarely to learn otherwise, and strings
            // met fireflies (5.5x the variance, trimmed even, before the importance's clamp for
            // point lights; docs/results.md, tenth session).
            new_cut.push(child);
            new_stats.push(SlotStats {
                n_zero: 0.5 * s.n_zero,
                n_nonzero: 0.5 * s.n_nonzero,
                sum: 0.5 * f * s.sum,
                sum_sq: 0.5 * f * f * s.sum_sq,
                scale: (f * s.scale).max(1e-30),
                ..SlotStats::default()
            });
        }
    }
    Some((new_cut, new_stats))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sides(n: [f64; 2], mean_sq: [f64; 2]) -> Sides {
        Sides {
            n,
            sq: [n[0] * mean_sq[0], n[1] * mean_sq[1]],
        }
    }

    /// Children that give alike gain nothing from a split, however the spread inside each;
    /// one dark child gains most where the slot is drawn often; too few draws count nothing.
    #[test]
    fn split_gain_is_the_second_moment_a_split_saves() {
        let even = split_gain(&sides([500.0, 500.0], [3.0, 3.0]), 1.0).unwrap();
        assert!(even.abs() < 1e-12, "alike children gain {even}");
        // Half the draws into a child that gives nothing: g = 2, so the whole region's
        // √(second moment) shrinks by 1 − 1/√2 and its second moment to one half.
        let dark = split_gain(&sides([5000.0, 5000.0], [0.0, 1.0]), 1.0).unwrap();
        // (0.486: the pseudo-observations lend the dark side a little light)
        assert!((dark - 0.5).abs() < 0.02, "one dark child: {dark}");
        let rare = split_gain(&sides([5000.0, 5000.0], [0.0, 1.0]), 0.1).unwrap();
        assert!(
            rare > 0.0 && rare < 0.2 * dark,
            "a slot drawn a tenth as often: {rare}"
        );
        let skewed = split_gain(&sides([5000.0, 5000.0], [0.2, 1.0]), 1.0).unwrap();
        assert!(skewed > 0.0 && skewed < dark, "a dim child: {skewed}");
        assert_eq!(split_gain(&sides([30.0, 30.0], [0.0, 1.0]), 1.0), None);
    }

    /// The kernel's words: counts, then each side's Σ q² in 2^24 fixed point (low, high).
    #[test]
    fn sides_read_the_kernels_fixed_point() {
        let s = Sides::from_words([3, 4, 1 << 24, 0, 0, 2]);
        assert_eq!(s.n, [3.0, 4.0]);
        assert_eq!(s.sq, [1.0, 512.0]);
    }
}
