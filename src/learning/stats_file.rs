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
    /// `--coarse-blocks` (on: a block without lights shares one cut) and `--in-cluster`
    /// (importance or power) the cuts and statistics were learned with (absent in files
    /// saved before 2026-12-07, which were loaded under either without a word: an audit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarse_blocks: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub in_cluster_importance: Option<bool>,
    /// The factor the statistics this render started from were tempered by (`animate
    /// --forget`), so `merge-stats --base` can take out the shared start exactly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_forget: Option<f32>,
    /// Passes a farm chunk skipped before its own (`--chunk`): `samples_done` counts them,
    /// its learning does not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skipped_passes: Option<u32>,
    /// The frame of an `animate` run these statistics end (learned in the animation's own
    /// coordinate frame): what `render --load-stats` and `animate --frame K --load-stats`
    /// say when given them (an audit, 2026-12-06: the one was told "other lights", the
    /// other took any frame's file without a word).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub animation_frame: Option<u32>,
    /// The time (seconds) of that frame's pose: `animate --frame K --load-stats` compares
    /// the pose the statistics were learned at with frame K's to decide whether they are
    /// tempered; it compared frame K−1's, whatever frame or frame rate the file came from
    /// (an audit, 2026-12-07: statistics 6 units of light travel old were carried
    /// untempered).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub animation_time: Option<f64>,
    /// The checksums ([`SavedStats::checksum`]) of the statistics files this one was made
    /// from, and so whose observations it holds: the file a render or an animation's frame
    /// continued from (`--load-stats`, the frame before), or a merge's parts and `--base`.
    /// The direct sources only, so the list stays as short as a merge's parts over a long
    /// animation. `merge-stats` refuses a part another part holds and warns of a start two
    /// parts share that is not the `--base` file: a file merged with its own continuation
    /// counted its observations twice with exit 0 (a note of 2026-12-07). Absent in files
    /// made from nothing, and in files saved before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub holds: Option<Vec<String>>,
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
    ///
    /// What falls below [`FORGOTTEN`] of one observation is forgotten outright: halved at
    /// every frame that moved, a slot's count underflowed to 0 after ~150 frames while its
    /// sums were still a subnormal above it, and the next frame refused those totals as
    /// impossible (an audit, 2026-12-07: a 60-fps city-cars run ended at frame 157 of 241).
    pub fn temper(&mut self, g: f32) {
        temper_slots(&mut self.stats, g);
    }
}

/// [`SavedStats::temper`] of `stats`.
fn temper_slots(stats: &mut [SlotStats], g: f32) {
    for s in stats {
        s.n_zero *= g;
        s.n_nonzero *= g;
        s.sum *= g;
        s.sum_sq *= g;
        if s.n_zero < FORGOTTEN {
            s.n_zero = 0.0;
        }
        if s.n_nonzero < FORGOTTEN {
            (s.n_nonzero, s.sum, s.sum_sq) = (0.0, 0.0, 0.0);
        }
    }
}

/// The weight below which tempered observations are forgotten (about 20 halvings of one
/// observation: nothing next to the next frame's, each of weight 1).
pub const FORGOTTEN: f32 = 1e-6;

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
    /// The file's identity: the checksum it ends with (FNV-1a 64 of the bytes before it, as
    /// [`Self::to_bytes`] writes them: the same for a file and for what loading it gives),
    /// in hex. Hashed piece by piece, without building the file.
    pub fn checksum(&self) -> String {
        let header = self.header_json();
        let len = (header.len() as u32).to_le_bytes();
        let mut h = crate::fnv::Fnv1a::default();
        for piece in self.pieces(&header, &len) {
            h.add(piece);
        }
        format!("{:016x}", h.0)
    }

    /// [`Self::checksum`] of a file's bytes as [`Self::to_bytes`] wrote them: its last 8
    /// (crate-only: a library caller's shorter slice panicked, an audit, 2026-12-07; what
    /// to_bytes writes always ends with them).
    pub(crate) fn checksum_of_bytes(bytes: &[u8]) -> String {
        let tail: [u8; 8] = bytes[bytes.len() - 8..]
            .try_into()
            .expect("to_bytes ends with its 8-byte checksum");
        format!("{:016x}", u64::from_le_bytes(tail))
    }

    /// The file's bytes with a header that says it holds `holds` (empty: nothing); no copy
    /// of the statistics where that is what the header says already.
    pub fn to_bytes_holding(&self, holds: &[String]) -> Vec<u8> {
        let want = (!holds.is_empty()).then(|| holds.to_vec());
        if self.header.holds == want {
            return self.to_bytes();
        }
        let mut s = self.clone();
        s.header.holds = want;
        s.to_bytes()
    }

    fn header_json(&self) -> Vec<u8> {
        serde_json::to_vec(&self.header).expect("a header always serialises")
    }

    /// The file's bytes before its checksum, in order (`header` is [`Self::header_json`],
    /// `len` its length as a little-endian u32).
    fn pieces<'a>(&'a self, header: &'a [u8], len: &'a [u8; 4]) -> [&'a [u8]; 7] {
        const VERSION_BYTES: [u8; 4] = VERSION.to_le_bytes();
        [
            MAGIC,
            &VERSION_BYTES,
            len,
            header,
            bytemuck::cast_slice(&self.index),
            bytemuck::cast_slice(&self.cuts),
            bytemuck::cast_slice(&self.stats),
        ]
    }

    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let header = self.header_json();
        let len = (header.len() as u32).to_le_bytes();
        let mut out = Vec::with_capacity(
            24 + header.len() + 4 * (self.index.len() + self.cuts.len()) + 32 * self.stats.len(),
        );
        for piece in self.pieces(&header, &len) {
            out.extend_from_slice(piece);
        }
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
        // A chunk's skipped passes are part of its samples_done; more of them than that
        // wrapped `merge-stats`'s count of learned passes to 294967304 with exit 0 (an edited
        // header with its checksum made again: an audit, 2026-12-06).
        if let Some(skipped) = header.skipped_passes.filter(|&k| k > header.samples_done) {
            bail!(
                "'{p}' is damaged: its header says {skipped} passes were skipped of {} done; save it again",
                header.samples_done
            );
        }
        // The factor an animation tempered the start by: merge-stats --base multiplies by it
        // (an edited −1 or 1e30 merged with exit 0 into other counts: an audit, 2026-12-07).
        if let Some(g) = header.start_forget.filter(|g| !(*g > 0.0 && *g <= 1.0)) {
            bail!(
                "'{p}' is damaged: its header's start_forget {g} is outside (0, 1]; save it again"
            );
        }
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
        for o in self.used_offsets() {
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
        }
        self.check_totals(path)
    }

    /// The offsets of the cuts the regions use and of the fallback cut (0), each once.
    fn used_offsets(&self) -> Vec<u32> {
        let mut offsets: Vec<u32> = self.index.clone();
        offsets.push(0);
        offsets.sort_unstable();
        offsets.dedup();
        offsets
    }

    /// Errors unless every total of every cut the regions use (and the fallback's) is a
    /// possible one (see [`SavedStats::check_cuts`]); needs no light tree, so `merge-stats`
    /// checks its parts and its sum with it (it wrote a sum that overflowed to inf, or a
    /// part's NaN, with exit 0, for `--load-stats` to call damaged: an audit, 2026-12-07).
    pub fn check_totals(&self, path: &Path) -> Result<()> {
        for o in self.used_offsets() {
            let o = o as usize;
            for i in o + 1..o + 1 + self.cuts[o] as usize {
                if !possible_totals(&self.stats[i]) {
                    bail!(
                        "'{}' is damaged: statistics entry {i} holds impossible totals ({:?}); save it again",
                        path.display(),
                        self.stats[i]
                    );
                }
            }
        }
        Ok(())
    }

    /// Errors unless these statistics can be used by a render with `want` (every field but the
    /// sample count and sizes must match), naming the field and the fix.
    pub fn check_matches(&self, want: &StatsHeader, path: &Path) -> Result<()> {
        self.check_against(want, path, None)
    }

    /// [`SavedStats::check_matches`] for `merge-stats`: `want` is the header of `other` (a
    /// quoted file name, or "the --base file"), and the messages say so (they spoke of "this render" and `--load-stats`: an audit,
    /// 2026-12-06).
    pub fn check_merges_with(&self, want: &StatsHeader, path: &Path, other: &str) -> Result<()> {
        self.check_against(want, path, Some(other))
    }

    fn check_against(&self, want: &StatsHeader, path: &Path, part: Option<&str>) -> Result<()> {
        let h = &self.header;
        let p = path.display();
        let (them, scene_fix) = match part {
            None => (
                "this render uses".to_string(),
                "load it only with the scene it was saved from",
            ),
            Some(o) => (format!("{o} has"), "merge only statistics of one scene"),
        };
        if h.scene != want.scene {
            let fix = match (part, h.animation_frame) {
                (None, Some(k)) => format!(
                    ": it holds the statistics of frame {k} of an `animate` run, learned in that animation's own coordinate frame; if it is this scene's animation, continue it with `lightlearn animate … --frame {} --load-stats {p}`, else {scene_fix}",
                    k.saturating_add(1)
                ),
                _ => format!("; {scene_fix}"),
            };
            bail!(
                "'{p}' was learned on other lights (scene fingerprint {} vs {}){fix}",
                h.scene,
                want.scene
            );
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
        if let (Some(a), Some(b)) = (h.coarse_blocks, want.coarse_blocks) {
            fields.push(("--coarse-blocks", on_off(a), on_off(b)));
        }
        if let (Some(a), Some(b)) = (h.in_cluster_importance, want.in_cluster_importance) {
            let name = |i: bool| if i { "importance" } else { "power" }.to_string();
            fields.push(("--in-cluster", name(a), name(b)));
        }
        for (flag, saved, now) in fields {
            if saved != now {
                let fix = match part {
                    // --brdf-aware is a plain switch: "render with --brdf-aware on" was told,
                    // which the command line refuses (an audit, 2026-12-07).
                    None if flag == "--brdf-aware" => format!(
                        "{} --brdf-aware or drop --load-stats",
                        if saved == "on" { "add" } else { "remove" }
                    ),
                    None => format!("render with {flag} {saved} or drop --load-stats"),
                    Some(_) => "merge only statistics saved with the same settings".to_string(),
                };
                bail!("'{p}' was saved with {flag} {saved} but {them} {flag} {now}; {fix}");
            }
        }
        if (h.grid_params, h.grid_dims) != (want.grid_params, want.grid_dims) {
            bail!("'{p}' was saved for other scene bounds (region grid differs); {scene_fix}");
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

/// Totals a render can have made: non-negative counts (fractional once an animation has
/// tempered them, `animate --forget`), finite non-negative sums with
/// no sum without data, and a positive scale that keeps y / scale and (y / scale)² f32
/// numbers (the kernels work with those; a tiny scale made the weights Inf). (Σy)² ≤ n Σy²
/// is not required: the window's 24-bit fixed point rounds (y / scale)² ≪ 2^-24 to 0.
pub(crate) fn possible_totals(s: &SlotStats) -> bool {
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

    /// Tempered frame after frame (`animate`, something moving in every frame), a slot's
    /// count underflowed to 0 before its sums and the next frame refused the totals as
    /// impossible (an audit, 2026-12-07: frame 157 of 241). Every tempering now leaves
    /// possible totals, and what fell below one millionth of an observation is gone.
    #[test]
    fn tempering_frame_after_frame_keeps_possible_totals() {
        let slot = SlotStats {
            n_zero: 3.0,
            n_nonzero: 1.0,
            sum: 1000.0,
            sum_sq: 1e6,
            scale: 1.0,
            ..Default::default()
        };
        let mut stats = [slot];
        for frame in 0..300 {
            temper_slots(&mut stats, 0.5);
            assert!(possible_totals(&stats[0]), "frame {frame}: {:?}", stats[0]);
        }
        let s = stats[0];
        assert_eq!(
            (s.n_zero, s.n_nonzero, s.sum, s.sum_sq),
            (0.0, 0.0, 0.0, 0.0)
        );
        // Ten halvings keep what they should.
        let mut stats = [slot];
        for _ in 0..10 {
            temper_slots(&mut stats, 0.5);
        }
        assert_eq!(stats[0].n_nonzero, 1.0 / 1024.0);
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
            coarse_blocks: None,
            in_cluster_importance: None,
            start_forget: None,
            skipped_passes: None,
            animation_frame: None,
            animation_time: None,
            holds: None,
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
