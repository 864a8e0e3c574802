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
