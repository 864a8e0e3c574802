//! What a render produced: per-pixel sums and what they give (the image, its variance, the
//! zero-light-sample map), and the learned state at the end.

use crate::gpu::layout::PixelAccum;
use crate::learning::stats_file::SavedStats;
use crate::learning::LearnDiagnostics;

/// What a render produced: per-pixel sums over `spp` samples.
pub struct RenderResult {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// The pass index (random stream) of the film's first sample: its samples drew the
    /// streams [first_sample_index, first_sample_index + spp).
    pub first_sample_index: u32,
    /// Sums in the kernels' units: × `radiance_scale` gives radiance ([`GpuScene`]).
    pub accum: Vec<PixelAccum>,
    pub radiance_scale: f32,
    /// Seconds spent in passes (excludes scene upload).
    pub render_seconds: f64,
    /// Samples that came out NaN/Inf and were dropped (should be 0).
    pub invalid_samples: u32,
    /// Stopped early by Ctrl-C ([`crate::interrupt`]): `spp` is what was done.
    pub interrupted: bool,
    pub regions: RegionStats,
    /// The learned state at the end (learned samplers only).
    pub learned: Option<Learned>,
}

/// What a learned sampler knows at the end of a render.
pub struct Learned {
    pub saved: SavedStats,
    pub diagnostics: LearnDiagnostics,
}

/// What the regions and cuts of a render cost.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct RegionStats {
    /// Regions with their own cut (the camera reaches them); others use the scene's cut.
    pub regions_with_cuts: usize,
    /// Of those, the regions whose cuts were built between frames, because samples reached
    /// them without one (jitter, bounces, a moved camera).
    pub regions_added_between_frames: usize,
    /// Cut refinements (`--refine-cuts`): one per region per growth point that split
    /// clusters.
    pub cut_refinements: usize,
    /// Host time to find the regions and build their cuts.
    pub cut_seconds: f64,
    /// GPU memory of the region index and the cuts.
    pub cut_bytes: usize,
}

impl RenderResult {
    /// Per-pixel mean (the image).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        mean_of(&self.accum, self.spp, self.radiance_scale)
    }

    /// The fraction of the light samples (one per pixel sample that hit a surface) that came
    /// out zero: occluded, facing away, or a dead end inside a cluster. NaN with no samples.
    pub fn zero_sample_fraction(&self) -> f64 {
        let zero: f64 = self.accum.iter().map(|a| a.sum[3] as f64).sum();
        let all: f64 = self.accum.iter().map(|a| a.sum_sq[3] as f64).sum();
        zero / all
    }

    /// Per pixel, the same fraction (0 where the pixel saw no surface): a map of where the
    /// light samples are wasted.
    pub fn zero_sample_map(&self) -> Vec<f32> {
        self.accum
            .iter()
            .map(|a| {
                if a.sum_sq[3] > 0.0 {
                    a.sum[3] / a.sum_sq[3]
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// [`Self::estimated_error`] where the film has one: a variance needs two samples (at 1
    /// spp each pixel's "variance" is x²/4 from `spp.max(2)`, an invented number: an audit,
    /// 2026-12-07), so None below 2 spp. What reports write.
    pub fn known_error(&self) -> Option<(f64, f64)> {
        (self.spp >= 2).then(|| self.estimated_error())
    }

    /// The image's own estimated error: mean over pixels and channels of the variance of the
    /// mean, absolute (an MSE) and relative as relMSE (÷ (mean² + 0.01)).
    pub fn estimated_error(&self) -> (f64, f64) {
        let (mut mse, mut rel) = (0f64, 0f64);
        for (v, m) in self.variance_of_mean_f64().iter().zip(self.mean()) {
            for k in 0..3 {
                mse += v[k];
                rel += v[k] / ((m[k] as f64).powi(2) + 0.01);
            }
        }
        let n = (3 * self.accum.len().max(1)) as f64;
        (mse / n, rel / n)
    }

    /// Per-pixel variance of the mean (sample variance / spp).
    pub fn variance_of_mean(&self) -> Vec<[f32; 3]> {
        self.variance_of_mean_f64()
            .iter()
            .map(|v| v.map(|c| c as f32))
            .collect()
    }

    fn variance_of_mean_f64(&self) -> Vec<[f64; 3]> {
        let n = self.spp.max(2) as f64;
        let s2 = (self.radiance_scale as f64).powi(2);
        self.accum
            .iter()
            .map(|a| {
                std::array::from_fn(|k| {
                    let m = a.sum[k] as f64 / n;
                    let var = ((a.sum_sq[k] as f64 / n - m * m) * n / (n - 1.0)).max(0.0);
                    var / n * s2
                })
            })
            .collect()
    }
}

/// Per-pixel mean radiance of sums over `spp` samples in the kernels' units.
pub(crate) fn mean_of(accum: &[PixelAccum], spp: u32, radiance_scale: f32) -> Vec<[f32; 3]> {
    let inv = 1.0 / spp.max(1) as f32;
    accum
        .iter()
        .map(|a| [0, 1, 2].map(|k| a.sum[k] * inv * radiance_scale))
        .collect()
}
