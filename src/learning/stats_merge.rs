//! `merge-stats`: the statistics of several renders of one scene (farm chunks, other seeds,
//! other machines) added into one [`SavedStats`].

use std::path::Path;

use anyhow::{bail, Context, Result};

use super::stats_file::{possible_totals, SavedStats};
use crate::abi::SlotStats;

impl SavedStats {
    /// The statistics learned by `parts` together (renders of one scene with the same
    /// settings: other seeds, other machines, other cameras). Every region with a cut in any
    /// part gets that cut (a pure function of the region, the light tree and the settings, so
    /// parts that share a region have the same cut, which is checked) and the sum of the
    /// parts' totals: counts and sums add (in f64, rounded once), the window scale becomes
    /// the merged root mean square as `fold.comp` sets it, and the weight coefficients are
    /// recomputed when the file is loaded. `samples_done` is the parts' total. Parts of
    /// another scene or other settings are refused naming the field.
    pub fn merge(parts: &[(SavedStats, String)]) -> Result<SavedStats> {
        Self::merge_keyed(&by_checksum(parts))
    }

    /// [`Self::merge`] of parts in [`by_checksum`]'s order, with their checksums.
    fn merge_keyed(keyed: &[(String, &(SavedStats, String))]) -> Result<SavedStats> {
        let parts: Vec<&(SavedStats, String)> = keyed.iter().map(|(_, p)| *p).collect();
        let parts = parts.as_slice();
        let Some(((first, first_name), rest)) = parts.split_first() else {
            bail!("nothing to merge: give at least one statistics file");
        };
        for (p, name) in rest {
            p.check_merges_with(&first.header, Path::new(name), &format!("'{first_name}'"))
                .with_context(|| format!("cannot merge '{name}' with '{first_name}'"))?;
            if p.index.len() != first.index.len() {
                bail!("'{name}' has {} regions but '{first_name}' has {}; they were saved for other region grids", p.index.len(), first.index.len());
            }
        }
        for (p, name) in parts {
            p.check_totals(Path::new(name))?;
        }
        let cut_of = |s: &SavedStats, o: u32| {
            let o = o as usize;
            s.cuts[o..o + 1 + s.cuts[o] as usize].to_vec()
        };
        for (p, name) in rest {
            if cut_of(p, 0) != cut_of(first, 0) {
                bail!("'{name}' has another fallback cut than '{first_name}': other settings or lights; save both with the same version and settings");
            }
        }
        let mut cuts = cut_of(first, 0);
        let mut stats = first.stats[..cuts.len()].to_vec();
        let mut index = vec![0u32; first.index.len()];
        // Regions that share one cut and its statistics in a part (a block without lights
        // under --coarse-blocks) share them in the merge: each part's statistics of a block
        // count once. Merging regions one by one gave every region of a block its own copy
        // of the block's totals (a file merged with nothing held 3.2× its observations: an
        // audit, 2026-12-07).
        for group in shared_cut_groups(parts) {
            let r = group[0];
            // Each part's offsets for the group, each once: one where the part shares the
            // group's cut, several where it holds a block split by an earlier merge (parts
            // that reached different regions of one block, nothing joining them there: their
            // statistics stay apart, unbiased, and join here).
            let mut held: Vec<(&SavedStats, &str, u32)> = Vec::new();
            for (p, name) in parts {
                let mut offsets: Vec<u32> = group
                    .iter()
                    .map(|&m| p.index[m as usize])
                    .filter(|&o| o != 0)
                    .collect();
                offsets.sort_unstable();
                offsets.dedup();
                held.extend(offsets.into_iter().map(|o| (p, name.as_str(), o)));
            }
            let (h, holder, ho) = held[0];
            let cut = cut_of(h, ho);
            for &(p, name, o) in &held[1..] {
                if cut_of(p, o) != cut {
                    bail!("'{name}' has another cut for region {r} than '{holder}': other cut settings (--coarse-blocks, --tau, --k-max), or cuts refined apart (--refine-cuts); they cannot be merged");
                }
            }
            let o = cuts.len() as u32;
            for &m in &group {
                index[m as usize] = o;
            }
            for k in 0..cut.len() {
                let slots: Vec<&SlotStats> = held
                    .iter()
                    .map(|&(p, _, po)| &p.stats[po as usize + k])
                    .collect();
                let sum = if k == 0 { *slots[0] } else { sum_slots(&slots) };
                if k > 0 && !possible_totals(&sum) {
                    bail!("the parts' statistics for region {r}'s cut add up past what a statistics file holds ({sum:?}); merge fewer files");
                }
                stats.push(sum);
            }
            cuts.extend_from_slice(&cut);
        }
        let mut header = first.header.clone();
        // Fields that files before 2026-12-07 lack: any part's record, all records alike.
        let recorded = |f: fn(&SavedStats) -> Option<bool>, flag: &str| -> Result<Option<bool>> {
            let mut seen: Option<(bool, &str)> = None;
            for (p, name) in parts {
                match (f(p), seen) {
                    (Some(v), None) => seen = Some((v, name)),
                    (Some(v), Some((w, other))) if v != w => bail!("'{name}' and '{other}' were saved with other {flag} settings; merge only statistics saved with the same settings"),
                    _ => {}
                }
            }
            Ok(seen.map(|(v, _)| v))
        };
        header.coarse_blocks = recorded(|p| p.header.coarse_blocks, "--coarse-blocks")?;
        header.in_cluster_importance =
            recorded(|p| p.header.in_cluster_importance, "--in-cluster")?;
        // The passes learned from together (a chunk's skipped passes are not its own), and
        // never below the last pass any part drew: a continuation must start after both.
        let learned = parts
            .iter()
            .try_fold(0u32, |a, (p, _)| {
                a.checked_add(p.header.samples_done - p.header.skipped_passes.unwrap_or(0))
            })
            .ok_or_else(|| anyhow::anyhow!("the parts have learned from more passes together than a statistics file counts (2^32)"))?;
        let last = parts
            .iter()
            .map(|(p, _)| p.header.samples_done)
            .max()
            .unwrap_or(0);
        header.samples_done = learned.max(last);
        header.skipped_passes = None;
        // One frame's chunks end that frame; parts of several frames end none of them.
        if parts
            .iter()
            .any(|(p, _)| p.header.animation_frame != first.header.animation_frame)
        {
            header.animation_frame = None;
        }
        // The time where every part that records one agrees (files of builds before it
        // record none: a review, 2026-12-07).
        let times: Vec<f64> = parts
            .iter()
            .filter_map(|(p, _)| p.header.animation_time)
            .collect();
        header.animation_time = match times.first() {
            Some(&t) if header.animation_frame.is_some() && times.iter().all(|&u| u == t) => {
                Some(t)
            }
            _ => None,
        };
        header.regions = index.len() as u32;
        header.cuts_len = cuts.len() as u32;
        // The merge is made from its parts (sorted already).
        let mut holds: Vec<String> = keyed.iter().map(|(k, _)| k.clone()).collect();
        holds.dedup();
        header.holds = Some(holds);
        Ok(SavedStats {
            header,
            index,
            cuts,
            stats,
        })
    }

    /// The statistics of farm chunks that each started from `base` (tempered by the factor
    /// each part records, `start_forget`) and learned apart: the base once plus every part's
    /// own learning, Σ (part − start), so N chunks do not count the base N times.
    /// `samples_done` is the largest part's (the chunks' sample ranges follow each other).
    pub fn merge_onto(base: &SavedStats, parts: &[(SavedStats, String)]) -> Result<SavedStats> {
        // Subtracted below: a NaN or huge total would be clamped to 0 in silence.
        base.check_totals(Path::new("the --base file"))?;
        for (p, name) in parts {
            p.check_merges_with(&base.header, Path::new(name), "the --base file")
                .with_context(|| format!("'{name}' did not start from the --base file"))?;
            if p.header.samples_done <= base.header.samples_done
                || p.index.len() != base.index.len()
            {
                bail!("'{name}' did not start from the --base file (it has learned no more passes than the base, or over another region grid)");
            }
        }
        // In merge's order (by checksum), so that the order given changes no byte.
        let keyed = by_checksum(parts);
        let mut merged = SavedStats::merge_keyed(&keyed)?;
        let sorted: Vec<&(SavedStats, String)> = keyed.iter().map(|(_, p)| *p).collect();
        let cut_len = |s: &SavedStats, o: u32| 1 + s.cuts[o as usize] as usize;
        // Regions with a cut in the base (the fallback cut, offset 0, is the first part's in
        // `merge`, as for any merge).
        // A cut shared by a block's regions is taken out once (the audit of 2026-12-07), and
        // a merged cut stands for one base cut (parts that started from the base keep its
        // offsets apart; a merged cut over two would keep one's extra copies: a review).
        let mut done = std::collections::HashMap::new();
        for (r, &bo) in base.index.iter().enumerate() {
            if bo == 0 {
                continue;
            }
            let mo = merged.index[r];
            if mo == 0 {
                bail!("region {r} has a cut in the --base file but in none of the parts: they did not start from it");
            }
            match done.insert(mo, bo) {
                None => {}
                Some(b) if b == bo => continue,
                Some(_) => bail!("region {r}'s cut joins two cuts of the --base file in the parts: they did not start from it (give the statistics the chunks loaded)"),
            }
            fn cut(s: &SavedStats, o: u32) -> &[u32] {
                &s.cuts[o as usize..o as usize + 1 + s.cuts[o as usize] as usize]
            }
            if cut(base, bo) != cut(&merged, mo) {
                bail!("region {r} has another cut in the --base file than in the parts: they did not start from it (give the statistics the chunks loaded)");
            }
            let (bo, mo) = (bo as usize, mo as usize);
            for k in 1..cut_len(base, bo as u32) {
                // Every part started from the tempered base: take out all but one copy.
                let mut start_total = SlotStats::default();
                for (p, _) in &sorted {
                    let g = p.header.start_forget.unwrap_or(1.0);
                    let b = &base.stats[bo + k];
                    start_total.n_zero += g * b.n_zero;
                    start_total.n_nonzero += g * b.n_nonzero;
                    start_total.sum += g * b.sum;
                    start_total.sum_sq += g * b.sum_sq;
                }
                let g0 = sorted[0].0.header.start_forget.unwrap_or(1.0);
                let b = base.stats[bo + k];
                let m = &mut merged.stats[mo + k];
                let sub = |total: f32, all: f32, once: f32| (total - all + once).max(0.0);
                m.n_zero = sub(m.n_zero, start_total.n_zero, g0 * b.n_zero);
                m.n_nonzero = sub(m.n_nonzero, start_total.n_nonzero, g0 * b.n_nonzero);
                m.sum = sub(m.sum, start_total.sum, g0 * b.sum);
                m.sum_sq = sub(m.sum_sq, start_total.sum_sq, g0 * b.sum_sq);
                if m.n_nonzero == 0.0 {
                    (m.sum, m.sum_sq) = (0.0, 0.0);
                }
                if m.sum_sq > 0.0 && m.n_nonzero > 0.0 {
                    m.scale = (m.sum_sq / m.n_nonzero).sqrt();
                }
            }
        }
        merged.header.samples_done = parts
            .iter()
            .map(|(p, _)| p.header.samples_done)
            .max()
            .unwrap_or(0);
        merged.header.start_forget = None;
        let mut holds = merged.header.holds.take().unwrap_or_default();
        holds.push(base.checksum());
        holds.sort_unstable();
        holds.dedup();
        merged.header.holds = Some(holds);
        Ok(merged)
    }
}

/// The parts in the order of their checksums, each with its checksum (each file hashed
/// once). The order given does not matter then: the first part's slot fields that a sum does
/// not make (the coefficients, recomputed on load) and the f64 sums' rounding made `merge a b`
/// and `merge b a` other bytes, so a merge of those two was not refused as the same
/// statistics twice and counted every observation twice (an audit, 2026-12-07).
fn by_checksum(parts: &[(SavedStats, String)]) -> Vec<(String, &(SavedStats, String))> {
    let mut keyed: Vec<_> = parts.iter().map(|p| (p.0.checksum(), p)).collect();
    keyed.sort_by(|a, b| a.0.cmp(&b.0));
    keyed
}

/// The regions with a cut in some part, in groups that share one cut: two regions that share
/// a cut in any part are in one group (transitively). Regions of one block without lights
/// share a cut in every part that reached two of them or more; a block whose regions no part
/// reached together (each part one region of it) stays split in the merge, its statistics
/// apart as they were learned (merging needs the scene's lights to tell a light-free block
/// from cells that happen to have equal cuts). Groups in the order of their first region,
/// each in region order.
fn shared_cut_groups(parts: &[&(SavedStats, String)]) -> Vec<Vec<u32>> {
    let n = parts[0].0.index.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut r: u32) -> u32 {
        while parent[r as usize] != r {
            let up = parent[parent[r as usize] as usize];
            parent[r as usize] = up;
            r = up;
        }
        r
    }
    for (p, _) in parts {
        let mut first_with = std::collections::HashMap::new();
        for (r, &o) in p.index.iter().enumerate() {
            if o == 0 {
                continue;
            }
            let f = *first_with.entry(o).or_insert(r as u32);
            let (a, b) = (root(&mut parent, f), root(&mut parent, r as u32));
            // The smaller region is the root, so a group is met first at its root.
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let mut groups: Vec<Vec<u32>> = Vec::new();
    let mut slot_of_root = std::collections::HashMap::new();
    for r in 0..n {
        if parts.iter().all(|(p, _)| p.index[r] == 0) {
            continue;
        }
        let g = root(&mut parent, r as u32);
        let i = *slot_of_root.entry(g).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[i].push(r as u32);
    }
    groups
}

/// The totals of several parts' copies of one slot, added.
fn sum_slots(slots: &[&SlotStats]) -> SlotStats {
    // A slot one part alone holds is that part's, bit for bit: the scale below in f32 on the
    // CPU differs by an ulp from the one fold.comp took on an NVIDIA H200 (its sqrt and
    // division are not correctly rounded), which made a merged region differ from its only
    // part there (tests/session.rs, 2026-12-04).
    if let [one] = slots {
        return **one;
    }
    let add = |f: fn(&SlotStats) -> f32| slots.iter().map(|s| f(s) as f64).sum::<f64>() as f32;
    let mut s = SlotStats {
        n_zero: add(|s| s.n_zero),
        n_nonzero: add(|s| s.n_nonzero),
        sum: add(|s| s.sum),
        sum_sq: add(|s| s.sum_sq),
        ..*slots[0]
    };
    if s.sum_sq > 0.0 && s.n_nonzero > 0.0 {
        s.scale = (s.sum_sq / s.n_nonzero).sqrt();
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_slot_is_taken_as_it_is_and_two_add() {
        // A scale one ulp off sqrt(sum_sq / n_nonzero), as a GPU's fold may leave it.
        let scale = f32::from_bits(2.0f32.to_bits() + 1);
        let a = SlotStats {
            n_zero: 1.0,
            n_nonzero: 2.0,
            sum: 4.0,
            sum_sq: 8.0,
            scale,
            coef_a: 0.5,
            coef_b: 0.0,
            coef_c: 0.25,
        };
        assert_eq!(sum_slots(&[&a]), a);
        let two = sum_slots(&[&a, &a]);
        assert_eq!(
            (two.n_zero, two.n_nonzero, two.sum, two.sum_sq),
            (2.0, 4.0, 8.0, 16.0)
        );
        assert_eq!(two.scale, 2.0);
    }
}
