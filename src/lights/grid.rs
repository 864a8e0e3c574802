//! The regions (docs/method.md §2): the scene bounds split into a uniform grid of cubic cells
//! (`grid` cells along the longest axis), each cell split into 6 normal bins (dominant axis
//! and sign of the shading normal) so both sides of a wall keep apart; and the region
//! settings (`--grid`, `--normal-bins`, `--tau`, `--k-max`, …). Their cuts are in
//! [`super::regions`].
//!
//! Mirrored in `shaders/shared/regions.glsl`; tests/regions.rs checks GPU against CPU.

use glam::Vec3;

use crate::abi::GridParams;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionSettings {
    /// Cells along the longest axis of the scene bounds.
    pub grid: u32,
    /// Split each cell by the dominant axis and sign of the normal (6 bins).
    pub normal_bins: bool,
    /// Stop refining a cut when its largest node's importance ≤ τ × the cut's total.
    pub tau: f32,
    /// At most this many clusters per cut.
    pub k_max: u32,
    /// Inside a chosen cluster pick the light by importance at the shading point (a
    /// lightbvh-style descent of the cluster's subtree) instead of by power.
    pub in_cluster_importance: bool,
    /// The regions of a block of 2×2×2 cells (one normal bin) whose box holds no light share
    /// one cut, built for the block, and one set of statistics ([`Cuts::append`]).
    pub coarse_blocks: bool,
}

/// Largest `--grid`: with 6 normal bins a cubic scene has 6·grid³ regions, which must stay
/// a u32 (grid 895 overflowed it and panicked). Whether the region index also fits the
/// device's storage buffers depends on the scene's shape: [`largest_grid`].
pub const MAX_GRID: u32 = 512;

/// Largest `k_max`: the GPU keeps a cut's weights in a local array of this size
/// (`MAX_CUT` in shaders/shared/regions.glsl).
pub const MAX_K: u32 = 64;

impl RegionSettings {
    pub fn check(&self) -> anyhow::Result<()> {
        if !(1..=MAX_GRID).contains(&self.grid) {
            anyhow::bail!("--grid {} is out of range: use 1..={MAX_GRID}", self.grid);
        }
        if !(1..=MAX_K).contains(&self.k_max) {
            anyhow::bail!("--k-max {} is out of range: use 1..={MAX_K}", self.k_max);
        }
        if !(self.tau >= 0.0 && self.tau <= 1.0) {
            anyhow::bail!("--tau {} is out of range: use 0..=1", self.tau);
        }
        Ok(())
    }
}

impl Default for RegionSettings {
    /// docs/method.md §2 defaults.
    fn default() -> Self {
        RegionSettings {
            grid: 32,
            normal_bins: true,
            tau: 0.02,
            k_max: 32,
            // Measured (rooms16 128×96 256 spp, city 256×192 64 spp, noise-corrected MSE):
            // wang 1.48e-4 → 1.32e-4 and 6.65e-3 → 3.06e-3, bayes 6.0e-5 → 5.1e-5 and
            // 1.99e-3 → 7.4e-4 with importance instead of power inside the cluster.
            in_cluster_importance: true,
            // Measured (docs/results.md, seventh session): variance over seeds 0.96–1.04×
            // on ten scenes (strings 1.00×, where a coarser grid everywhere was 1.9× worse),
            // time 0.84× on cornell40 (3.7× fewer slots), elsewhere within the timing noise
            // (0.98–1.06×, interleaved best of 3).
            coarse_blocks: true,
        }
    }
}

/// The grid: which region a shading point (p, n) falls in.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    pub params: GridParams,
}

impl Grid {
    pub fn new(lo: Vec3, hi: Vec3, s: &RegionSettings) -> Grid {
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        let cell = extent.max_element() / s.grid as f32;
        let dims = (extent / cell).ceil().max(Vec3::ONE);
        Grid {
            params: GridParams {
                lo: lo.to_array(),
                cell,
                dims: [dims.x as u32, dims.y as u32, dims.z as u32],
                bins: if s.normal_bins { 6 } else { 1 },
            },
        }
    }

    pub fn region_count(&self) -> u32 {
        u32::try_from(self.region_count_u64()).expect("RegionSettings::check bounds the grid")
    }

    /// The region count without overflow, for checking a grid before building it.
    pub fn region_count_u64(&self) -> u64 {
        let d = self.params.dims.map(u64::from);
        d[0] * d[1] * d[2] * self.params.bins as u64
    }

    /// Region index of (p, n); points outside the bounds clamp to the border cells.
    pub fn region(&self, p: Vec3, n: Vec3) -> u32 {
        let g = &self.params;
        let c = ((p - Vec3::from(g.lo)) / g.cell).floor();
        let cell = |k: usize| (c[k].max(0.0) as u32).min(g.dims[k] - 1);
        let flat = (cell(2) * g.dims[1] + cell(1)) * g.dims[0] + cell(0);
        let bin = if g.bins == 6 {
            let a = n.abs();
            let axis = if a.x >= a.y && a.x >= a.z {
                0
            } else if a.y >= a.z {
                1
            } else {
                2
            };
            2 * axis as u32 + (n[axis] < 0.0) as u32
        } else {
            0
        };
        flat * g.bins + bin
    }

    /// A region's grid cell (x, y, z) and normal bin: [`Grid::region`] undone.
    pub fn cell_of(&self, region: u32) -> ([u32; 3], u32) {
        let g = &self.params;
        let flat = region / g.bins;
        let cell = [
            flat % g.dims[0],
            flat / g.dims[0] % g.dims[1],
            flat / (g.dims[0] * g.dims[1]),
        ];
        (cell, region % g.bins)
    }

    /// The block of 2×2×2 cells (with the region's normal bin) that holds a region: a key
    /// unique to the block and bin, and the block's centre and half-size (clamped to the
    /// grid at its far edges).
    pub fn block_of(&self, region: u32) -> (u64, Vec3, Vec3) {
        let g = &self.params;
        let ([x, y, z], _) = self.cell_of(region);
        let b = [x / 2, y / 2, z / 2];
        let key = self.block_key(region, 2);
        let lo = Vec3::from(g.lo);
        let cells = Vec3::new(g.dims[0] as f32, g.dims[1] as f32, g.dims[2] as f32);
        let b_lo = lo + Vec3::new(b[0] as f32, b[1] as f32, b[2] as f32) * 2.0 * g.cell;
        let b_hi = (b_lo + Vec3::splat(2.0 * g.cell)).min(lo + cells * g.cell);
        (key, 0.5 * (b_lo + b_hi), 0.5 * (b_hi - b_lo))
    }

    /// A key unique to the block of `size`³ cells and the normal bin that hold a region
    /// (blocks shared by their regions here, pooling blocks in src/learning/pooling.rs).
    pub fn block_key(&self, region: u32, size: u32) -> u64 {
        let g = &self.params;
        let ([x, y, z], bin) = self.cell_of(region);
        let b = g.dims.map(|d| d.div_ceil(size) as u64);
        let block = ((z / size) as u64 * b[1] + (y / size) as u64) * b[0] + (x / size) as u64;
        block * g.bins as u64 + bin as u64
    }

    /// Centre and half-size of a region's cell.
    pub fn cell_box(&self, region: u32) -> (Vec3, Vec3) {
        let g = &self.params;
        let ([x, y, z], _) = self.cell_of(region);
        let lo = Vec3::from(g.lo) + Vec3::new(x as f32, y as f32, z as f32) * g.cell;
        (lo + Vec3::splat(0.5 * g.cell), Vec3::splat(0.5 * g.cell))
    }
}

/// The largest `--grid` (≤ [`MAX_GRID`]) whose region count over [lo, hi] is at most
/// `max_regions`, or 0 if not even grid 1 fits.
pub fn largest_grid(lo: Vec3, hi: Vec3, s: &RegionSettings, max_regions: u64) -> u32 {
    let fits = |g: u32| {
        let s = RegionSettings { grid: g, ..*s };
        Grid::new(lo, hi, &s).region_count_u64() <= max_regions
    };
    // The region count grows with the grid: binary search the last grid that fits.
    let (mut ok, mut bad) = (0u32, MAX_GRID + 1);
    while bad - ok > 1 {
        let mid = (ok + bad) / 2;
        if fits(mid) {
            ok = mid;
        } else {
            bad = mid;
        }
    }
    ok
}
