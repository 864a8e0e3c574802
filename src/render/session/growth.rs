//! Region growth: cuts for the regions that samples reached without one, built at growth
//! points between learning windows, and the pooled priors of cold slots refreshed there.

use std::time::Instant;

use anyhow::Result;

use super::Session;
use crate::gpu::Transfers;
use crate::render::timeline::Event;
use crate::render::LightSampler;

impl Session<'_> {
    /// Whether cold slots borrow observations now: `bayes` learning with `--pool-priors` > 0
    /// while the learning is young ([`POOL_AGE_MAX`]).
    pub(super) fn pools_now(&self) -> bool {
        self.pools_priors() && self.clock().age <= POOL_AGE_MAX
    }

    /// Whether cold slots borrow observations at all (`bayes` learning with `--pool-priors` > 0).
    pub(super) fn pools_priors(&self) -> bool {
        self.is_learning()
            && self.settings.sampler == LightSampler::Bayes
            && self.settings.learn.pool_priors > 0.0
    }

    /// Builds cuts (and, for the learned samplers, starting statistics) for the regions
    /// that samples reached without one since the last frame, appends them and rebinds:
    /// the regions a moved camera reaches then learn instead of using the shared fallback
    /// cut. Only at a fold boundary (the window is empty), so the statistics grow by
    /// appending totals alone; the new slots get their coefficients. Returns how many
    /// regions got a cut.
    pub(super) fn grow_regions(&mut self) -> Result<usize> {
        if !self.settings.sampler.uses_cuts() || !self.at_fold_boundary() {
            return Ok(0);
        }
        // Two submissions a growth point: one read-back (the missing regions' bits, and the
        // totals when pooling), then the uploads with the folds after them
        // (src/gpu/transfer.rs says why). --refine-cuts reads and writes on its own.
        let before = self.learned.slots;
        let t0 = Instant::now();
        let pools = self.pools_now();
        // Past the young age the borrowed observations are dropped, once.
        let drops = !pools && self.pools_priors() && self.learned.borrowing();
        let refining = self.settings.learn.refine_cuts > 0;
        let (words, stats) = self
            .learned
            .read_growth_inputs(&self.ctx, pools && !refining)?;
        let t_read = t0.elapsed().as_secs_f64();
        let mut up = Transfers::new();
        let added =
            self.learned
                .grow(&self.ctx, &self.gpu.tree, &self.settings, &words, &mut up)?;
        let t_cuts = t0.elapsed().as_secs_f64();
        let mut refined = 0;
        if refining {
            std::mem::take(&mut up).submit(&self.ctx, |_| {})?;
            refined = self
                .learned
                .refine(&self.ctx, &self.gpu.tree, &self.settings)?;
        }
        if added + refined > 0 {
            self.bind_learned()?;
        }
        let mut listed = 0;
        if drops {
            // Budget 0: nothing borrowed; the slots that borrowed get their coefficients again.
            listed = self
                .learned
                .pool_priors_into(0.0, before, Vec::new(), &mut up)?;
        } else if pools {
            // Every slot's borrowed observations anew from the totals; the old slots whose
            // borrowed observations changed get their coefficients again.
            let stats = if refining {
                self.learned.read_stats()?
            } else {
                stats
            };
            listed = self.learned.pool_priors_into(
                self.settings.learn.pool_priors,
                before,
                stats,
                &mut up,
            )?;
        }
        // The new slots' coefficients (the others' totals did not change): over all slots
        // this fold was 4-5 ms of a growth's 6-9 ms (city, 128x96).
        let fold_new = (added + refined > 0 && self.is_learning()).then_some(before);
        let t_pool = t0.elapsed().as_secs_f64();
        if !up.is_empty() || listed > 0 || fold_new.is_some() {
            self.kernels
                .submit_growth(&self.ctx, up, listed > 0, fold_new, &self.learned)?;
        }
        if let Some(events) = &mut self.timeline {
            events.push(Event::Growth {
                added,
                read: t_read,
                cuts: t_cuts - t_read,
                pool: t_pool - t_cuts,
                submit: t0.elapsed().as_secs_f64() - t_pool,
            });
        }
        Ok(added)
    }
}

/// Cold slots borrow their neighbours' observations (`--pool-priors`) at the growth points of
/// the learning's first passes, up to this age (the film's passes after a camera move, else
/// the learned passes, as `--update-every auto` counts them); at the first growth point past
/// it every slot's borrowed observations are dropped. Why: pooling paid at 64–256 passes
/// (city 1.29× less variance at 64 spp, 1.14× at 256), while each pooling reads the totals
/// back and uploads the priors: on an NVIDIA H200 it took bayes from 0.14 to 0.21 s for
/// 1024 passes at 512×384 (city; docs/results.md, 2026-12-04, fifth session). A pure function
/// of the clock, so a `--load-stats` continuation pools (or not) as the render it continues.
pub const POOL_AGE_MAX: u32 = 256;

/// Whether regions reached without a cut get one after `n` passes: 1, 2, 4, 8, 16, 32,
/// then every 64th (soon after the start or a camera move, rarely once settled).
pub fn growth_point(n: u32) -> bool {
    n > 0 && (n <= 32 && n.is_power_of_two() || n.is_multiple_of(64))
}

/// The first growth point after `spp`.
pub(super) fn next_growth_point(spp: u32) -> u32 {
    if spp < 32 {
        (spp + 1).next_power_of_two()
    } else {
        (spp / 64 + 1).saturating_mul(64)
    }
}
