//! What a render session holds, read out for the commands, tests and diagnostics: the
//! film and its image, the learned state (statistics, borrowed priors, side sums, the open
//! window, cuts) and the settings, and the timeline of what a render did between its passes.
//! Nothing here changes what the session renders or learns.

use anyhow::Result;

use super::Session;
use crate::gpu::layout::{PixelAccum, SlotDelta, SlotStats};
use crate::gpu::Buffer;
use crate::render::learned_state::HostReduction;
use crate::render::result::mean_of;
use crate::render::timeline::Event;
use crate::render::RenderSettings;
use crate::scene::Camera;

impl Session<'_> {
    /// From now on, each dispatch (paths: each pass), fold and growth point is submitted and
    /// timed on its own, into [`Session::timeline`] (`profile --timeline`): the same commands
    /// and so the same image, each step plus one submission's wait.
    pub fn record_timeline(&mut self) {
        self.timeline.get_or_insert_with(Vec::new);
    }

    /// What [`Session::record_timeline`] has timed so far.
    pub fn timeline(&self) -> Option<&[Event]> {
        self.timeline.as_deref()
    }

    /// What reducing the statistics on the host between frames would cost now
    /// ([`crate::render::learned_state::LearnedState::measure_host_reduction`]).
    pub fn measure_host_reduction(&self) -> Result<HostReduction> {
        self.learned.measure_host_reduction(&self.settings.learn)
    }

    /// The film's accumulators and size (the preview's display pass reads them on the GPU).
    pub fn film(&self) -> (&Buffer, u32, u32) {
        (&self.film.accum, self.film.width, self.film.height)
    }

    /// What the film's sums are multiplied by to give radiance.
    pub fn radiance_scale(&self) -> f32 {
        self.gpu.radiance_scale
    }

    /// Cut refinements so far (`--refine-cuts`).
    pub fn regions_refined(&self) -> usize {
        self.learned.regions_refined
    }

    /// The regions' index and cuts as the kernel uses them now (the host's copy).
    pub fn cuts(&self) -> &crate::lights::regions::Cuts {
        &self.learned.cuts
    }

    /// The statistics the next pass samples by (learned samplers; empty otherwise): the
    /// totals as of the last fold, without the window that is still open (unlike
    /// [`Session::snapshot`], which folds it in).
    pub fn sampling_stats(&self) -> Result<Vec<SlotStats>> {
        if !self.is_learning() {
            return Ok(Vec::new());
        }
        self.learned.read_stats()
    }

    /// Each slot's borrowed pseudo-observations (`--pool-priors`; learned samplers; empty
    /// otherwise), as the last fold computed the coefficients with them.
    pub fn borrowed_priors(&self) -> Result<Vec<crate::learning::pooling::SlotPrior>> {
        if !self.is_learning() {
            return Ok(Vec::new());
        }
        self.learned.prior.read_first(self.learned.slots as usize)
    }

    /// Each slot's observations by the side of its node they came through (`--refine-cuts`,
    /// render.comp `side_counts`; all 0 without it). For tests and diagnostics; empty for
    /// the samplers that do not learn.
    pub fn side_sums(&self) -> Result<Vec<crate::render::refine::Sides>> {
        if !self.is_learning() {
            return Ok(Vec::new());
        }
        let words: Vec<[u32; 6]> = self.learned.sides.read_first(self.learned.slots as usize)?;
        Ok(words
            .into_iter()
            .map(crate::render::refine::Sides::from_words)
            .collect())
    }

    /// The open learning window as the GPU holds it: every slot's window sums, and the list
    /// of the slots it touched that the next fold visits (render.comp `mark_touched`:
    /// the fold's workgroup count, 1, 1, the count, then the slots and NO_SLOT after them).
    /// For tests and diagnostics; empty for the samplers that do not learn.
    pub fn open_window(&self) -> Result<(Vec<SlotDelta>, Vec<u32>)> {
        if !self.is_learning() {
            return Ok((Vec::new(), Vec::new()));
        }
        Ok((self.learned.read_delta()?, self.learned.read_touched()?))
    }

    /// How much the region of each (point, normal) has learned: the observations summed
    /// over its cut's slots, or None where the region has no cut of its own (it uses the
    /// shared fallback cut). Samplers that do not learn have no observations: Some(0).
    pub fn observations_at(&self, points: &[(glam::Vec3, glam::Vec3)]) -> Result<Vec<Option<f32>>> {
        let cuts = &self.learned.cuts;
        let stats: Vec<SlotStats> = if self.is_learning() {
            self.learned.read_stats()?
        } else {
            Vec::new()
        };
        Ok(points
            .iter()
            .map(|&(p, n)| {
                let o = cuts.offset_at(p, n);
                (o != 0).then(|| {
                    let len = cuts.cuts[o] as usize;
                    stats
                        .get(o + 1..o + 1 + len)
                        .map_or(0.0, |s| s.iter().map(|x| x.n_zero + x.n_nonzero).sum())
                })
            })
            .collect())
    }

    /// Regions that have a cut (their own or their block's) so far.
    pub fn regions_with_cuts(&self) -> usize {
        self.learned.cuts.built()
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Samples per pixel in the film.
    pub fn spp(&self) -> u32 {
        self.film.spp
    }

    /// Passes learned from, a loaded file's included; never goes back.
    pub fn passes(&self) -> u32 {
        self.learned.passes
    }

    /// Seconds spent in passes since the film was reset.
    pub fn film_seconds(&self) -> f64 {
        self.film.seconds
    }

    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// Direct light: the rows of 8 pixels a pass covers (those that can see the scene, or
    /// all with [`Session::set_pixel_culling`] off); 0 for paths.
    pub fn covered_rows(&self) -> u32 {
        self.kernels.live_rows()
    }

    /// The film's mean image (radiance), read back now.
    pub fn image(&self) -> Result<Vec<[f32; 3]>> {
        let data: Vec<PixelAccum> = self.film.accum.read()?;
        Ok(mean_of(
            &data[..self.film.pixels()],
            self.film.spp,
            self.gpu.radiance_scale,
        ))
    }
}
