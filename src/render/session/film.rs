//! The session's film: per-pixel sums and counters since the last reset (the third
//! lifetime of [`super::Session`]).

use std::sync::Arc;

use anyhow::{bail, Result};

use crate::gpu::layout::PixelAccum;
use crate::gpu::{Buffer, Context};

/// The film: per-pixel sums and counters since the last reset.
pub(super) struct Film {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) accum: Buffer,
    /// [0]: samples dropped as NaN/Inf; [1]: learned samples in regions without a cut.
    pub(super) counters: Buffer,
    pub(super) spp: u32,
    /// Seconds spent in passes since the reset.
    pub(super) seconds: f64,
}

/// The most samples a pixel of a film takes. Its sums are float32, added to sample by
/// sample (direct light: a dispatch's passes at a time), and a sample below half an ulp of
/// the sum is lost: sums of 2^k samples, float32 against float64 (numpy, sequential adds),
/// lost 9e-5 (exponential samples) to 1e-3 (lognormal σ 2) of the total at 2^20, 1.5e-3 to
/// 8e-3 at 2^22 and 2 to 4 % at 2^24 (docs/results.md, thirtieth session), a darker image
/// with exit 0. So 2^20 at most (Blender Cycles stops at 2^24); more samples come from
/// renders of other seeds added by `lightlearn merge`, which sums in float64.
pub const MAX_FILM_SPP: u32 = 1 << 20;

/// Whether a render of `spp` samples in `seconds` stopped short of a time budget of `t`
/// seconds because its film was full ([`MAX_FILM_SPP`]).
pub fn filled_before(t: f64, spp: u32, seconds: f64) -> bool {
    spp >= MAX_FILM_SPP && seconds < t
}

/// The most pixels a film may have on this device: its accumulators are one storage buffer
/// of 32 bytes a pixel, read as two texels a pixel.
pub fn max_film_pixels(ctx: &Context) -> u64 {
    let limits = &ctx.properties.limits;
    (limits.max_storage_buffer_range as u64 / std::mem::size_of::<PixelAccum>() as u64)
        .min(limits.max_texel_buffer_elements as u64 / 2)
}

impl Film {
    pub(super) fn new(ctx: &Arc<Context>, width: u32, height: u32) -> Result<Film> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            bail!("image size {width}×{height} is out of range; use 1..=16384 for --width and --height");
        }
        let pixels = width as u64 * height as u64;
        // Both of the device's limits on the accumulators ([`max_film_pixels`], which the
        // preview sizes its film by): the storage buffer's was met only in Buffer::new, with
        // a message that named a buffer, not the film.
        let most = max_film_pixels(ctx);
        if pixels > most {
            bail!(
                "a {width}×{height} film has {pixels} pixels but this device's film holds at most {most} (its accumulators' buffer); use a smaller --width/--height"
            );
        }
        Ok(Film {
            width,
            height,
            accum: Buffer::scratch_texels(
                ctx,
                "pixel accumulators",
                pixels * std::mem::size_of::<PixelAccum>() as u64,
            )?,
            counters: Buffer::zeroed(ctx, "counters", 16)?,
            spp: 0,
            seconds: 0.0,
        })
    }

    pub(super) fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}
