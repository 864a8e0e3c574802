//! `--save-stats` / `--load-stats`: the learned statistics of a render with the regions and
//! cuts they belong to, so a later render (a continuation, the next animation frame, another
//! machine) starts from what was learned.
//!
//! Format (version 1, little-endian): the 8 bytes `LLSTATS\0`, a u32 version, a u32 length
//! and that many bytes of JSON header (what must match to reuse the statistics), then the
//! region index (u32 per region), the cuts array (u32) and the totals (`SlotStats`, 32 bytes,
//! one per cuts entry).

use std::path::Path;

use anyhow::{bail, Context, Result};

use crate::gpu::layout::{GridParams, SlotStats};
use crate::lights::tree::LightTree;

const MAGIC: &[u8; 8] = b"LLSTATS\0";
pub const VERSION: u32 = 1;

/// What must match between the render that saved and the one that loads.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StatsHeader {
    /// Fingerprint of the scene's lights (the light tree's nodes).
    pub scene: String,
    pub sampler: String,
    pub grid: u32,
    pub normal_bins: bool,
    pub regression: bool,
    pub brdf_aware: bool,
    /// Passes already taken: a continuation starts its sample indices here.
    pub samples_done: u32,
    pub grid_params: [f32; 4],
    pub grid_dims: [u32; 4],
    pub regions: u32,
    pub cuts_len: u32,
}

#[derive(Clone, Debug)]
pub struct SavedStats {
    pub header: StatsHeader,
    pub index: Vec<u32>,
    pub cuts: Vec<u32>,
    pub stats: Vec<SlotStats>,
}

/// FNV-1a over the light tree's bytes: equal for the same lights in the same order.
pub fn scene_fingerprint(tree: &LightTree) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytemuck::cast_slice::<_, u8>(&tree.nodes) {
        h ^= *b as u64;
        h = h.wrapping_mul(0x100_0000_01b3);
    }
    format!("{h:016x}-{}", tree.order.len())
}

pub fn grid_fields(g: &GridParams) -> ([f32; 4], [u32; 4]) {
    (
        [g.lo[0], g.lo[1], g.lo[2], g.cell],
        [g.dims[0], g.dims[1], g.dims[2], g.bins],
    )
}

impl SavedStats {
    pub fn save(&self, path: &Path) -> Result<()> {
        let header = serde_json::to_vec(&self.header)?;
        let mut out = Vec::with_capacity(
            16 + header.len() + 4 * (self.index.len() + self.cuts.len()) + 32 * self.stats.len(),
        );
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(header.len() as u32).to_le_bytes());
        out.extend_from_slice(&header);
        out.extend_from_slice(bytemuck::cast_slice(&self.index));
        out.extend_from_slice(bytemuck::cast_slice(&self.cuts));
        out.extend_from_slice(bytemuck::cast_slice(&self.stats));
        crate::io::write_atomic(path, &out)
            .with_context(|| format!("cannot write the statistics file '{}'", path.display()))
    }

    pub fn load(path: &Path) -> Result<SavedStats> {
        let p = path.display();
        let bytes = std::fs::read(path)
            .with_context(|| format!("cannot read the statistics file '{p}'"))?;
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            bail!("'{p}' is not a lightlearn statistics file (written by --save-stats)");
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
        if version != VERSION {
            bail!("'{p}' is a version {version} statistics file; this lightlearn reads version {VERSION}: save it again with this version");
        }
        let hlen = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let truncated = || anyhow::anyhow!("'{p}' is truncated or damaged; save it again");
        let hbytes = bytes.get(16..16 + hlen).ok_or_else(truncated)?;
        let header: StatsHeader = serde_json::from_slice(hbytes)
            .with_context(|| format!("'{p}' has a damaged header; save it again"))?;
        let mut at = 16 + hlen;
        let mut take = |n: usize| -> Result<&[u8]> {
            let s = bytes.get(at..at + n).ok_or_else(truncated)?;
            at += n;
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
        // The cuts must be well formed before a kernel walks them.
        if let Some(&o) = index.iter().find(|&&o| o as usize >= c) {
            bail!("'{p}' is damaged: region offset {o} is past its cuts ({c} entries)");
        }
        Ok(SavedStats {
            header,
            index,
            cuts,
            stats,
        })
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
                "--regression",
                on_off(h.regression),
                on_off(want.regression),
            ),
            (
                "--brdf-aware",
                on_off(h.brdf_aware),
                on_off(want.brdf_aware),
            ),
        ];
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

fn on_off(b: bool) -> String {
    if b { "on" } else { "off" }.to_string()
}

/// Copies little-endian bytes into a vector of plain-old-data values (any alignment).
fn pod_vec<T: bytemuck::Pod>(bytes: &[u8]) -> Vec<T> {
    let mut v = vec![T::zeroed(); bytes.len() / std::mem::size_of::<T>()];
    bytemuck::cast_slice_mut::<T, u8>(&mut v).copy_from_slice(bytes);
    v
}
