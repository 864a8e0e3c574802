//! Learned cut refinement (`--refine-cuts N`, issue #17): between passes a region's cut
//! replaces the clusters whose observations vary the most by their two children.
//!
//! `lightlearn variance` found most of converged `bayes`'s remaining variance inside the
//! clusters on strings (66 %) and rooms16 (43 %), and a fixed larger cut (`--k-max 64 --tau
//! 0.005`) cut that term 3.2× on strings but cost 1.3–1.5× per sample everywhere
//! (docs/results.md, "Where the variance is"). A cluster whose lights are partly hidden
//! gives observations that are often 0 and sometimes large: a large squared coefficient of
//! variation cv² = E[y²]/E[y]² − 1 of y = Î_C d² (Î_C / Ĩ_C by importance, the default
//! since 2026-12-04: then the score below ranks by the spread share of that ratio, not by
//! the slot's weight, and dim clusters may split before bright ones; measured that way:
//! docs/results.md, sixth session). Splitting only those grows the cut where the choice
//! inside the cluster costs variance.
//!
//! Unbiased: the cut changes only at a fold boundary, between passes, and the new cut tiles
//! the same lights. Deterministic: the decision reads the totals, which are exact sums.
//! The children inherit the parent's statistics as a prior split by power share f (counts
//! halved, so the data soon outweigh it; mean × f, second moment × f²; f = 1 under
//! `--regression importance`, where y is a share of Ĩ, which splits with the power): their
//! weights start
//! summing to about the parent's, where fresh priors would forget what the region learned
//! about occlusion.
//!
//! Measured (`--refine-cuts 8`, direct light, 128×96, 256 spp; docs/results.md): by the
//! `variance` command at fixed pixel-centre hits, variance × render time 2.63× lower on
//! strings, equal on hall, 0.86× on rooms16 and 0.75× on city (longer cuts cost 20–27 % a
//! sample there for little); in rendered films over eight seeds (2026-12-04) strings had
//! 1.09× the variance of off. It is off by default.

use crate::abi::SlotStats;
use crate::learning::Regression;
use crate::lights::regions::Cuts;
use crate::lights::tree::LightTree;

/// Observations a cluster needs before its spread counts.
pub const MIN_OBSERVATIONS: f32 = 64.0;
/// Split only clusters whose cv² exceeds this.
pub const MIN_CV2: f64 = 1.0;

/// The new cut of the region at offset `o` and each new slot's statistics, or None when no
/// cluster qualifies or the cut is full. At most `splits` clusters split, the largest
/// sqrt(E[y²]) · cv²/(1 + cv²) (the slot's weight times the share of its second moment
/// that is spread) first. `regression`: the units of y (by importance a child inherits the
/// parent's y as it is).
pub fn refined_cut(
    tree: &LightTree,
    cuts: &Cuts,
    stats: &[SlotStats],
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
    let mut scored: Vec<(f64, usize)> = cut
        .iter()
        .enumerate()
        .filter_map(|(k, &node)| {
            let s = &stats[o + 1 + k];
            let n = s.n_zero + s.n_nonzero;
            if tree.nodes[node as usize].count < 2
                || n < MIN_OBSERVATIONS
                || s.sum <= 0.0
                || s.sum.is_nan()
            {
                return None;
            }
            let (n, sum, sq) = (n as f64, s.sum as f64, s.sum_sq as f64);
            let cv2 = n * sq / (sum * sum) - 1.0;
            (cv2 > MIN_CV2).then(|| ((sq / n).sqrt() * cv2 / (1.0 + cv2), k))
        })
        .collect();
    if scored.is_empty() {
        return None;
    }
    // Largest score first; ties by slot, so the choice is the same on every run.
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
