//! `--save-stats` / `--load-stats`: the learned statistics of a render with the regions and
//! cuts they belong to, so a later render (a continuation, the next animation frame, another
//! machine) starts from what was learned.
//!
//! Format (version 2, little-endian): the 8 bytes `LLSTATS\0`, a u32 version, a u32 length
//! and that many bytes of JSON header (what must match to reuse the statistics), then the
//! region index (u32 per region), the cuts array (u32), the totals (`SlotStats`, 32 bytes,
//! one per cuts entry) and an FNV-1a 64 checksum of everything before it. Version 1 is the
//! same without the checksum (still read).
//!
//! A file is checked on load (the checksum, every offset and count) and against the scene
//! ([`SavedStats::check_cuts`]: every cut covers every light exactly once, every total is
//! finite and non-negative), so a damaged file is refused by name instead of reaching a
//! kernel: a flipped bit in a cut once panicked the host and a NaN total reached the image.

use std::path::Path;

use anyhow::{bail, Context, Result};

use crate::abi::{GridParams, SlotStats};
use crate::fnv::fnv1a;
use crate::lights::tree::LightTree;

const MAGIC: &[u8; 8] = b"LLSTATS\0";
pub const VERSION: u32 = 2;

/// What must match between the render that saved and the one that loads.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StatsHeader {
    /// Fingerprint of the scene's lights (the light tree's nodes).
    pub scene: String,
    pub sampler: String,
    pub grid: u32,
    pub normal_bins: bool,
    /// Any regression (`--regression distance` or `importance`).
    pub regression: bool,
    /// The regressor is the unoccluded importance (`--regression importance`; absent in
    /// files saved before it existed, which regress on distance).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub regression_importance: bool,
    pub brdf_aware: bool,
    /// Passes already taken: a continuation starts its sample indices here.
    pub samples_done: u32,
    pub grid_params: [f32; 4],
    pub grid_dims: [u32; 4],
    pub regions: u32,
    pub cuts_len: u32,
    /// The cut settings the cuts were built with (absent in files of older versions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_max: Option<u32>,
    /// The factor the statistics this render started from were tempered by (`animate
    /// --forget`), so `merge-stats --base` can take out the shared start exactly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_forget: Option<f32>,
    /// Passes a farm chunk skipped before its own (`--chunk`): `samples_done` counts them,
    /// its learning does not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skipped_passes: Option<u32>,
}

#[derive(Clone, Debug)]
pub struct SavedStats {
    pub header: StatsHeader,
    pub index: Vec<u32>,
    pub cuts: Vec<u32>,
    pub stats: Vec<SlotStats>,
}

impl SavedStats {
    /// Tempers old knowledge (`animate --forget G`): counts and sums × `g`, so the posterior
    /// keeps its means and loses confidence, and becomes the prior of the next frame (the
    /// scale, Σy² / n, is unchanged). Coefficients are recomputed when a session loads it.
    pub fn temper(&mut self, g: f32) {
        for s in &mut self.stats {
            s.n_zero *= g;
            s.n_nonzero *= g;
            s.sum *= g;
            s.sum_sq *= g;
        }
    }
}

/// FNV-1a over the light tree's bytes: equal for the same lights in the same order.
pub fn scene_fingerprint(tree: &LightTree) -> String {
    let h = fnv1a(bytemuck::cast_slice::<_, u8>(&tree.nodes));
    format!("{h:016x}-{}", tree.order.len())
}

/// FNV-1a over the light tree's shape alone (light order, node ranges and children), not
/// its bounds: an animation's frames refit one tree as lights move, and what was learned for
/// a node stays the node's. Marked `topology-` so it never equals a still scene's.
pub fn topology_fingerprint(tree: &LightTree) -> String {
    let shape: Vec<u32> = tree
        .nodes
        .iter()
        .flat_map(|n| [n.begin, n.count, n.right])
        .chain(tree.order.iter().copied())
        .collect();
    let h = fnv1a(bytemuck::cast_slice::<_, u8>(&shape));
    format!("topology-{h:016x}-{}", tree.order.len())
}

/// Whether the file at `path` starts like a statistics file of ours (so `--save-stats` may
/// replace it without `--force`).
pub fn is_stats_file(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    // Not a regular file (a FIFO would block the open): not ours.
    std::fs::metadata(path).is_ok_and(|m| m.is_file())
        && std::fs::File::open(path)
            .and_then(|mut f| f.read_exact(&mut magic))
            .is_ok()
        && &magic == MAGIC
}

pub fn grid_fields(g: &GridParams) -> ([f32; 4], [u32; 4]) {
    (
        [g.lo[0], g.lo[1], g.lo[2], g.cell],
        [g.dims[0], g.dims[1], g.dims[2], g.bins],
    )
}

/// Fails, before any rendering, unless `--save-stats p` may be written: `p` is none of the
/// run's inputs or other outputs, and a file already there is a statistics file of ours
/// (anything else only with `force`). Measured before: `--save-stats` onto the input scene
/// overwrote it, exit 0.
pub fn check_save_target(p: &Path, inputs: &[&Path], outputs: &[&Path], force: bool) -> Result<()> {
    let d = p.display();
    if inputs.iter().any(|i| crate::io::same_path(p, i)) {
        bail!("--save-stats '{d}' is the scene this render reads (or a file it names); name another file");
    }
    if outputs.iter().any(|o| crate::io::same_path(p, o)) {
        bail!(
            "--save-stats '{d}' is also one of this render's images or report; name another file"
        );
    }
    crate::io::check_not_special(p)?;
    if p.exists() && !p.is_dir() && !is_stats_file(p) && !force {
        bail!("--save-stats '{d}' exists and is not a lightlearn statistics file; name another file, or add --force to replace it");
    }
    crate::io::check_writable(p)
}

impl SavedStats {
    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let header = serde_json::to_vec(&self.header).expect("a header always serialises");
        let mut out = Vec::with_capacity(
            24 + header.len() + 4 * (self.index.len() + self.cuts.len()) + 32 * self.stats.len(),
        );
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(header.len() as u32).to_le_bytes());
        out.extend_from_slice(&header);
        out.extend_from_slice(bytemuck::cast_slice(&self.index));
        out.extend_from_slice(bytemuck::cast_slice(&self.cuts));
        out.extend_from_slice(bytemuck::cast_slice(&self.stats));
        let sum = fnv1a(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// Writes the file atomically (a temporary file, then a rename).
    pub fn save(&self, path: &Path) -> Result<()> {
        crate::io::write_atomic(path, &self.to_bytes())
            .with_context(|| format!("cannot write the statistics file '{}'", path.display()))
    }

    pub fn load(path: &Path) -> Result<SavedStats> {
        let bytes = crate::io::read_all(path)
            .with_context(|| format!("cannot read the statistics file '{}'", path.display()))?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }

    /// Parses and checks a file's bytes; `p` names it in errors.
    pub fn from_bytes(bytes: &[u8], p: &str) -> Result<SavedStats> {
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            bail!("'{p}' is not a lightlearn statistics file (written by --save-stats)");
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
        if version != VERSION && version != 1 {
            bail!("'{p}' is a version {version} statistics file; this lightlearn reads versions 1 and {VERSION}: save it again with this version");
        }
        let bytes = if version >= 2 {
            let Some(body) = bytes.len().checked_sub(8).map(|n| &bytes[..n]) else {
                bail!("'{p}' is truncated; save it again");
            };
            let stored = u64::from_le_bytes(bytes[body.len()..].try_into().unwrap());
            if body.len() < 16 || fnv1a(body) != stored {
                bail!("'{p}' is truncated or damaged (its checksum does not match its contents): save it again with --save-stats");
            }
            body
        } else {
            bytes
        };
        let hlen = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let truncated = || anyhow::anyhow!("'{p}' is truncated or damaged; save it again");
        let hbytes = bytes.get(16..16 + hlen).ok_or_else(truncated)?;
        let header: StatsHeader = serde_json::from_slice(hbytes)
            .with_context(|| format!("'{p}' has a damaged header; save it again"))?;
        let mut at = 16 + hlen;
        let mut take = |n: usize| -> Result<&[u8]> {
            let end = at.checked_add(n).ok_or_else(truncated)?;
            let s = bytes.get(at..end).ok_or_else(truncated)?;
            at = end;
            Ok(s)
        };
        let (r, c) = (header.regions as usize, header.cuts_len as usize);
        let index: Vec<u32> = pod_vec(take(4 * r)?);
        let cuts: Vec<u32> = pod_vec(take(4 * c)?);
        let stats: Vec<SlotStats> = pod_vec(take(32 * c)?);
        if at != bytes.len() {
            bail!(
                "'{p}' has {} bytes after its data; it is damaged: save it again",
                bytes.len() - at
            );
        }
        // The cuts must be well formed before anything walks them: every region's offset
        // points at a cut `[count, node…]` that lies inside the array.
        // At most MAX_K nodes: the kernels hold a cut's weights in an array of that size.
        let cut_fits = |o: u32| {
            let o = o as usize;
            o < c
                && (1..=crate::lights::regions::MAX_K).contains(&cuts[o])
                && (cuts[o] as usize) < c - o
        };
        if c == 0 || !cut_fits(0) {
            bail!("'{p}' is damaged: its fallback cut is malformed; save it again");
        }
        if let Some(&o) = index.iter().find(|&&o| !cut_fits(o)) {
            bail!("'{p}' is damaged: region offset {o} does not point at a cut inside its {c} entries; save it again");
        }
        Ok(SavedStats {
            header,
            index,
            cuts,
            stats,
        })
    }

    /// Errors unless every cut of the file is a cut of `tree` (nodes that cover every light
    /// exactly once, in range order) and every total is a possible one (finite, whole
    /// non-negative counts, non-negative sums, a positive scale that keeps y / scale finite):
    /// what a kernel needs to stay
    /// unbiased and finite. `regions` is the region count of the scene's grid.
    pub fn check_cuts(&self, tree: &LightTree, regions: u32, path: &Path) -> Result<()> {
        let p = path.display();
        let damaged = |what: String| anyhow::anyhow!("'{p}' is damaged: {what}; save it again");
        if self.index.len() != regions as usize {
            return Err(damaged(format!(
                "it has {} regions where the scene's grid has {regions}",
                self.index.len()
            )));
        }
        let lights = tree.order.len() as u32;
        let mut offsets: Vec<u32> = self.index.clone();
        offsets.push(0);
        offsets.sort_unstable();
        offsets.dedup();
        for o in offsets {
            let o = o as usize;
            let slots = o + 1..o + 1 + self.cuts[o] as usize;
            let mut next = 0u32;
            for &node in &self.cuts[slots.clone()] {
                let nd = tree.nodes.get(node as usize).ok_or_else(|| {
                    damaged(format!("the cut at {o} names light-tree node {node}"))
                })?;
                if nd.begin != next {
                    return Err(damaged(format!(
                        "the cut at {o} does not cover every light exactly once"
                    )));
                }
                next = nd.begin + nd.count;
            }
            if next != lights {
                return Err(damaged(format!(
                    "the cut at {o} does not cover every light exactly once"
                )));
            }
            for i in slots {
                if !possible_totals(&self.stats[i]) {
                    return Err(damaged(format!(
                        "statistics entry {i} holds impossible totals ({:?})",
                        self.stats[i]
                    )));
                }
            }
        }
        Ok(())
    }

    /// The statistics learned by `parts` together (renders of one scene with the same
    /// settings: other seeds, other machines, other cameras). Every region with a cut in any
    /// part gets that cut (a pure function of the region, the light tree and the settings, so
    /// parts that share a region have the same cut, which is checked) and the sum of the
    /// parts' totals: counts and sums add (in f64, rounded once), the window scale becomes
    /// the merged root mean square as `fold.comp` sets it, and the weight coefficients are
    /// recomputed when the file is loaded. `samples_done` is the parts' total. Parts of
    /// another scene or other settings are refused naming the field.
    pub fn merge(parts: &[(SavedStats, String)]) -> Result<SavedStats> {
        let Some(((first, first_name), rest)) = parts.split_first() else {
            bail!("nothing to merge: give at least one statistics file");
        };
        for (p, name) in rest {
            p.check_matches(&first.header, Path::new(name))
                .with_context(|| format!("cannot merge '{name}' with '{first_name}'"))?;
            if p.index.len() != first.index.len() {
                bail!("'{name}' has {} regions but '{first_name}' has {}; they were saved for other region grids", p.index.len(), first.index.len());
            }
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
        for (r, slot) in index.iter_mut().enumerate() {
            let holders: Vec<&(SavedStats, String)> =
                parts.iter().filter(|(p, _)| p.index[r] != 0).collect();
            let Some(((h, _), others)) = holders.split_first() else {
                continue;
            };
            let cut = cut_of(h, h.index[r]);
            let holder = &holders[0].1;
            for (p, name) in others {
                if cut_of(p, p.index[r]) != cut {
                    bail!("'{name}' has another cut for region {r} than '{holder}': other cut settings, or cuts refined apart (--refine-cuts); they cannot be merged");
                }
            }
            *slot = cuts.len() as u32;
            for k in 0..cut.len() {
                let slots: Vec<&SlotStats> = holders
                    .iter()
                    .map(|(p, _)| &p.stats[p.index[r] as usize + k])
                    .collect();
                stats.push(if k == 0 { *slots[0] } else { sum_slots(&slots) });
            }
            cuts.extend_from_slice(&cut);
        }
        let mut header = first.header.clone();
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
        header.regions = index.len() as u32;
        header.cuts_len = cuts.len() as u32;
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
        for (p, name) in parts {
            base.check_matches(&p.header, Path::new(name))
                .with_context(|| format!("'{name}' did not start from the --base file"))?;
            if p.header.samples_done <= base.header.samples_done
                || p.index.len() != base.index.len()
            {
                bail!("'{name}' did not start from the --base file (it has learned no more passes than the base, or over another region grid)");
            }
        }
        let mut merged = SavedStats::merge(parts)?;
        let cut_len = |s: &SavedStats, o: u32| 1 + s.cuts[o as usize] as usize;
        // Regions with a cut in the base (the fallback cut, offset 0, is the first part's in
        // `merge`, as for any merge).
        for (r, &bo) in base.index.iter().enumerate() {
            if bo == 0 {
                continue;
            }
            let mo = merged.index[r];
            if mo == 0 {
                bail!("region {r} has a cut in the --base file but in none of the parts: they did not start from it");
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
                for (p, _) in parts {
                    let g = p.header.start_forget.unwrap_or(1.0);
                    let b = &base.stats[bo + k];
                    start_total.n_zero += g * b.n_zero;
                    start_total.n_nonzero += g * b.n_nonzero;
                    start_total.sum += g * b.sum;
                    start_total.sum_sq += g * b.sum_sq;
                }
                let g0 = parts[0].0.header.start_forget.unwrap_or(1.0);
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
        Ok(merged)
    }

    /// Errors unless these statistics can be used by a render with `want` (every field but the
    /// sample count and sizes must match), naming the field and the fix.
    pub fn check_matches(&self, want: &StatsHeader, path: &Path) -> Result<()> {
        let h = &self.header;
        let p = path.display();
        if h.scene != want.scene {
            bail!("'{p}' was learned on other lights (scene fingerprint {} vs {}); load it only with the scene it was saved from", h.scene, want.scene);
        }
        let fields = [
            ("--sampler", h.sampler.clone(), want.sampler.clone()),
            ("--grid", h.grid.to_string(), want.grid.to_string()),
            (
                "--normal-bins",
                on_off(h.normal_bins),
                on_off(want.normal_bins),
            ),
            (
                "--brdf-aware",
                on_off(h.brdf_aware),
                on_off(want.brdf_aware),
            ),
        ];
        let mut fields = fields.to_vec();
        // Only bayes regresses (donikian records y = Î whatever --regression says).
        if h.sampler == "bayes" {
            fields.push((
                "--regression",
                regression_name(h).to_string(),
                regression_name(want).to_string(),
            ));
        }
        // The cut settings (files of version 1 do not record them).
        if let (Some(a), Some(b)) = (h.tau, want.tau) {
            fields.push(("--tau", a.to_string(), b.to_string()));
        }
        if let (Some(a), Some(b)) = (h.k_max, want.k_max) {
            fields.push(("--k-max", a.to_string(), b.to_string()));
        }
        for (flag, saved, now) in fields {
            if saved != now {
                bail!("'{p}' was saved with {flag} {saved} but this render uses {flag} {now}; render with {flag} {saved} or drop --load-stats");
            }
        }
        if (h.grid_params, h.grid_dims) != (want.grid_params, want.grid_dims) {
            bail!("'{p}' was saved for other scene bounds (region grid differs); load it only with the scene it was saved from");
        }
        Ok(())
    }
}

fn regression_name(h: &StatsHeader) -> &'static str {
    match (h.regression, h.regression_importance) {
        (false, _) => "off",
        (true, false) => "distance",
        (true, true) => "importance",
    }
}

fn on_off(b: bool) -> String {
    if b { "on" } else { "off" }.to_string()
}

/// Copies little-endian bytes into a vector of plain-old-data values (any alignment).
fn pod_vec<T: bytemuck::Pod>(bytes: &[u8]) -> Vec<T> {
    let mut v = vec![T::zeroed(); bytes.len() / std::mem::size_of::<T>()];
    bytemuck::cast_slice_mut::<T, u8>(&mut v).copy_from_slice(bytes);
    v
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

/// Totals a render can have made: non-negative counts (fractional once an animation has
/// tempered them, `animate --forget`), finite non-negative sums with
/// no sum without data, and a positive scale that keeps y / scale and (y / scale)² f32
/// numbers (the kernels work with those; a tiny scale made the weights Inf). (Σy)² ≤ n Σy²
/// is not required: the window's 24-bit fixed point rounds (y / scale)² ≪ 2^-24 to 0.
fn possible_totals(s: &SlotStats) -> bool {
    let count_ok = |n: f32| n >= 0.0 && n.is_finite();
    let (s1, s2) = (s.sum / s.scale, s.sum_sq / (s.scale * s.scale));
    count_ok(s.n_zero)
        && count_ok(s.n_nonzero)
        && s.sum >= 0.0
        && s.sum_sq >= 0.0
        && s.scale > 0.0
        && s.scale.is_finite()
        && s1.is_finite()
        && s2.is_finite()
        && (s.n_nonzero > 0.0 || s.sum == 0.0 && s.sum_sq == 0.0)
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

    /// A file saved before `--regression importance` existed regressed on distance: its
    /// header (no `regression_importance`) reads as that, and a render with the new default
    /// is refused with the flag that loads it.
    #[test]
    fn headers_without_the_regressor_regress_on_distance() {
        let new = StatsHeader {
            scene: "s".into(),
            sampler: "bayes".into(),
            grid: 32,
            normal_bins: true,
            regression: true,
            regression_importance: true,
            brdf_aware: false,
            samples_done: 0,
            grid_params: [0.0; 4],
            grid_dims: [1; 4],
            regions: 0,
            cuts_len: 0,
            tau: None,
            k_max: None,
            start_forget: None,
            skipped_passes: None,
        };
        let mut json = serde_json::to_value(&new).unwrap();
        json.as_object_mut()
            .unwrap()
            .remove("regression_importance");
        let old: StatsHeader = serde_json::from_value(json).unwrap();
        assert_eq!(regression_name(&old), "distance");
        assert_eq!(regression_name(&new), "importance");
        let saved = SavedStats {
            header: old,
            index: Vec::new(),
            cuts: Vec::new(),
            stats: Vec::new(),
        };
        let err = saved
            .check_matches(&new, Path::new("old.stats"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("--regression distance"),
            "the fix should be named: {err}"
        );
    }
}
