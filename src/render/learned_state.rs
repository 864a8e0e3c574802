//! The learned state of a render session: the region grid's index, the cuts, the
//! statistics and window sums, the bitset of regions reached without a cut, and the
//! learning pass counter; and how it grows between frames (src/render/session/growth.rs).

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;

use super::cuts::{build_cuts, fill_initial, initial_stats};
use super::{GpuScene, RenderSettings};
use crate::gpu::layout::{LearnParams, SlotDelta, SlotStats};
use crate::gpu::transfer::{pod_vec, read_many};
use crate::gpu::{Buffer, Context, Transfers};
use crate::learning::pooling::SlotPrior;
use crate::learning::LearnSettings;
use crate::lights::regions::{Cuts, Grid};
use crate::lights::tree::LightTree;
use crate::scene::{Camera, Scene};

/// The learned state: regions, cuts and statistics (GPU buffers and the host's copy of the
/// cuts), and the learning pass counter.
pub struct LearnedState {
    pub cuts: Cuts,
    pub grid: Buffer,
    pub index: Buffer,
    pub cuts_buf: Buffer,
    pub stats: Buffer,
    pub delta: Buffer,
    /// The slots the open window touched, for the fold ([`touched_list`]).
    pub touched: Buffer,
    /// Each slot's borrowed pseudo-observations (`--pool-priors`, fold.comp `Prior`), as
    /// long as `stats`.
    pub prior: Buffer,
    /// Each slot's observations by the side of its node they came through (`--refine-cuts`,
    /// render.comp `side_counts`: counts and sums of y²), as long as `stats`;
    /// summed over the render.
    pub sides: Buffer,
    /// The host's copy of what `prior` holds for the slots in use.
    borrowed: Vec<SlotPrior>,
    /// The learning's parameters (render.comp `Learn`) and the same values for fold.comp,
    /// which takes them as push constants.
    pub params: Buffer,
    pub learn: LearnParams,
    /// Regions without a cut that samples reached (render.comp `missing_regions`): a count
    /// of newly set bits, then one bit per region.
    pub missing: Buffer,
    pub slots: u32,
    /// Slots that `stats`, `delta` and `touched` have room for (≥ `slots`): growth appends
    /// in place until it runs out, then doubles it ([`LearnedState::append_slots`]).
    pub capacity: u32,
    /// Regions whose cuts were built between frames (not before the first pass).
    pub regions_added: usize,
    /// Cut refinements done (`--refine-cuts`: one per region per growth point that split).
    pub regions_refined: usize,
    /// Growing stopped: more cuts would not fit the device's storage buffers.
    pub full: bool,
    /// Passes learned from, including a loaded file's (the next pass's sample index).
    pub passes: u32,
    pub cut_seconds: f64,
}

/// The cost of one host-side reduction of the statistics ([`super::Session::measure_host_reduction`]).
#[derive(Clone, Copy, Debug)]
pub struct HostReduction {
    pub slots: usize,
    /// Read back (totals and window sums) plus uploaded (totals).
    pub bytes: usize,
    pub read_seconds: f64,
    pub reduce_seconds: f64,
    pub upload_seconds: f64,
}

impl LearnedState {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Scene,
        gpu: &GpuScene,
        settings: &RenderSettings,
        camera: &Camera,
    ) -> Result<LearnedState> {
        let t0 = Instant::now();
        let cuts = match &settings.resume {
            Some(saved) => {
                let (lo, hi) = scene.grid_bounds();
                Cuts::from_parts(
                    &gpu.tree,
                    Grid::new(lo, hi, &settings.regions),
                    saved.index.clone(),
                    saved.cuts.clone(),
                    &settings.regions,
                )
            }
            None => build_cuts(scene, gpu, settings, camera),
        };
        let cut_seconds = t0.elapsed().as_secs_f64();
        // One entry per cuts entry (1 dummy entry for the samplers that do not learn).
        let stats: Vec<SlotStats> = match (&settings.resume, settings.sampler.learned()) {
            (Some(saved), true) => saved.stats.clone(),
            (None, true) => initial_stats(&gpu.tree, &cuts, settings.observed_regression()),
            (_, false) => vec![SlotStats::default()],
        };
        let slots = stats.len() as u32;
        // Past it the fold's dispatch asks more workgroups than the device takes (a device
        // of a 65535 x-limit and a larger storage range loading another machine's
        // statistics: a review, 2026-12-07).
        if settings.sampler.learned() && slots as u64 > most_slots(ctx) {
            anyhow::bail!(
                "the learned state has {slots} cluster slots, more than this device holds ({}); use a coarser --grid or a smaller --k-max, or statistics saved with them",
                most_slots(ctx)
            );
        }
        // Room for growth from the start: the first growth point's reallocation, with its
        // copies, was 6.1-6.2 ms of a 64-spp render's 0.18-0.22 s on city10k and cornell40
        // (128x96; city10k had 46.7k slots after it, 58.3k after 64 passes;
        // docs/results.md, seventeenth session).
        let capacity = slot_capacity(ctx, slots as u64);
        let mut padded = stats;
        padded.resize(capacity as usize, SlotStats::default());
        let words = 1 + cuts.index.len().div_ceil(32);
        Ok(LearnedState {
            missing: Buffer::zeroed(ctx, "missing regions", 4 * words as u64)?,
            regions_added: 0,
            regions_refined: 0,
            full: false,
            grid: Buffer::texels(ctx, "region grid", &[cuts.grid.params])?,
            index: Buffer::words(ctx, "region index", &cuts.index)?,
            cuts_buf: Buffer::words(ctx, "cuts", &cuts.cuts)?,
            stats: Buffer::texels(ctx, "learned statistics", &padded)?,
            delta: Buffer::zeroed_texels(
                ctx,
                "learning window sums",
                capacity * std::mem::size_of::<SlotDelta>() as u64,
            )?,
            touched: Buffer::indirect(ctx, "touched slots", &touched_list(capacity as u32))?,
            prior: Buffer::zeroed_texels(ctx, "borrowed observations", capacity * PRIOR_BYTES)?,
            sides: Buffer::zeroed(ctx, "observations by side", capacity * SIDE_BYTES)?,
            borrowed: Vec::new(),
            params: Buffer::from_slice(ctx, "learning parameters", &[settings.learn.gpu_params()])?,
            learn: settings.learn.gpu_params(),
            slots,
            capacity: capacity as u32,
            passes: settings
                .resume
                .as_ref()
                .map_or(0, |s| s.header.samples_done),
            cuts,
            cut_seconds,
        })
    }

    /// What a growth point reads back, in one submission: the bits of the regions reached
    /// without a cut (`missing`: a count, then the bits), and with `stats` the totals of the
    /// slots in use (for pooling, [`LearnedState::pool_priors_into`]; empty without).
    pub fn read_growth_inputs(
        &self,
        ctx: &Arc<Context>,
        stats: bool,
    ) -> Result<(Vec<u32>, Vec<SlotStats>)> {
        let stat_bytes = if stats {
            self.slots as u64 * std::mem::size_of::<SlotStats>() as u64
        } else {
            0
        };
        let got = read_many(
            ctx,
            &[
                (&self.missing, self.missing.size),
                (&self.stats, stat_bytes),
            ],
        )?;
        Ok((pod_vec(&got[0]), pod_vec(&got[1])))
    }

    /// Builds and appends the cuts (and, for the learned samplers, the starting statistics)
    /// of the regions flagged in `words` (the `missing` bits as read at this point,
    /// [`LearnedState::read_growth_inputs`]), at a fold boundary (the window is empty, so the
    /// statistics grow by appending totals alone). Its uploads (the bits cleared, the index,
    /// the cuts, the new slots' totals) go into `up`, for the caller to submit before the
    /// next pass; only a statistics buffer that must grow is copied at once. Stops growing,
    /// unbiased (the fallback cut serves the rest), before the cuts or statistics would
    /// outgrow one storage buffer. Returns how many regions got a cut; the caller rebinds.
    pub fn grow(
        &mut self,
        ctx: &Arc<Context>,
        tree: &LightTree,
        settings: &RenderSettings,
        words: &[u32],
        up: &mut Transfers,
    ) -> Result<usize> {
        let learning = settings.sampler.learned();
        if self.full {
            return Ok(0);
        }
        let l = self;
        if words.first().is_none_or(|&n| n == 0) {
            return Ok(0);
        }
        let t0 = Instant::now();
        up.clear(&l.missing);
        let mut regions = Vec::new();
        for (w, &bits) in words[1..].iter().enumerate() {
            let mut b = bits;
            while b != 0 {
                regions.push(w as u32 * 32 + b.trailing_zeros());
                b &= b - 1;
            }
        }
        regions.retain(|&r| (r as usize) < l.cuts.index.len());
        // Stop growing (the fallback cut serves the rest, unbiased) before the cuts or the
        // statistics would outgrow one storage buffer of this device.
        let max_bytes = ctx.properties.limits.max_storage_buffer_range as usize;
        let most_new = regions.len() * (settings.regions.k_max as usize + 1);
        let slot_bytes = if learning {
            std::mem::size_of::<SlotStats>()
        } else {
            4
        };
        let words = l.cuts.cuts.len() + most_new;
        if words * slot_bytes > max_bytes || (learning && words as u64 > most_slots(ctx)) {
            l.full = true;
            return Ok(0);
        }
        // Ascending region order: the same cuts at the same offsets on every run.
        let added = l.cuts.append(tree, &regions, &settings.regions);
        if added.is_empty() {
            return Ok(0);
        }
        up.write(&l.index, 0, bytemuck::cast_slice(&l.cuts.index));
        l.cuts_buf = Buffer::words_unfilled(ctx, "cuts", l.cuts.cuts.len())?;
        up.write(&l.cuts_buf, 0, bytemuck::cast_slice(&l.cuts.cuts));
        if learning {
            let (old, new) = (l.slots as usize, l.cuts.cuts.len());
            let mut fresh = vec![SlotStats::default(); new];
            // Regions that joined a block's shared cut made no new slots.
            for &(r, o) in added.iter().filter(|&&(_, o)| o as usize >= old) {
                fill_initial(
                    &mut fresh,
                    tree,
                    &l.cuts,
                    o,
                    Some(r),
                    settings.observed_regression(),
                );
            }
            l.append_slots(ctx, &fresh[old..], up)?;
        }
        l.regions_added += added.len();
        l.cut_seconds += t0.elapsed().as_secs_f64();
        Ok(added.len())
    }

    /// Grows the statistics and window-sum buffers by `tail` (the totals of the slots
    /// appended to `cuts`; their window sums start empty), keeping every existing slot.
    /// Within the capacity the tail is written in place (an upload into `up`); beyond it the three
    /// buffers are made anew with twice the room (up to what the device allows): of the 10
    /// growths of a 256-pass render on city (128x96) only the first reallocates now, and a
    /// reallocation with its copies was 1-3.5 ms of a growth.
    fn append_slots(
        &mut self,
        ctx: &Arc<Context>,
        tail: &[SlotStats],
        up: &mut Transfers,
    ) -> Result<()> {
        let (old, new) = (self.slots as u64, self.slots as u64 + tail.len() as u64);
        let slot = std::mem::size_of::<SlotStats>() as u64;
        if new > self.capacity as u64 {
            let capacity = slot_capacity(ctx, new);
            let stats = Buffer::zeroed_texels(ctx, "learned statistics", capacity * slot)?;
            stats.copy_from(&self.stats)?;
            let delta = Buffer::zeroed_texels(
                ctx,
                "learning window sums",
                capacity * std::mem::size_of::<SlotDelta>() as u64,
            )?;
            // At a fold boundary every window sum is 0 (as in `delta`, which is not copied)
            // and the list is empty (every slot's `touched` flag 0): a new, empty one with
            // room for every slot of the capacity.
            let touched = Buffer::indirect(ctx, "touched slots", &touched_list(capacity as u32))?;
            let prior =
                Buffer::zeroed_texels(ctx, "borrowed observations", capacity * PRIOR_BYTES)?;
            prior.copy_from(&self.prior)?;
            let sides = Buffer::zeroed(ctx, "observations by side", capacity * SIDE_BYTES)?;
            sides.copy_from(&self.sides)?;
            (self.stats, self.delta, self.touched, self.prior) = (stats, delta, touched, prior);
            self.sides = sides;
            self.capacity = capacity as u32;
        }
        // The window sums of the slots past `slots` were never touched: zero, as fresh ones.
        up.write(&self.stats, old * slot, bytemuck::cast_slice(tail));
        self.slots = new as u32;
        Ok(())
    }

    /// Recomputes every slot's borrowed pseudo-observations from the totals
    /// (src/learning/pooling.rs), at a fold boundary, and lists the slots below `below` whose
    /// borrowed observations changed in the (empty) touched list, for a fold of their
    /// coefficients ([`super::passes::PassKernels::submit_growth`]; the slots from `below` on
    /// are the caller's to fold). Returns how many it listed. Folding only those, not every
    /// slot, halved the fold's part (cornell40, 128×96: 170k slots, 42–90k borrowing at passes
    /// 1–8, 3.5k at 256; docs/results.md 2026-12-04).
    pub fn pool_priors(&mut self, ctx: &Arc<Context>, budget: f32, below: u32) -> Result<u32> {
        let stats = self.read_stats()?;
        let mut up = Transfers::new();
        let listed = self.pool_priors_into(budget, below, stats, &mut up)?;
        up.submit(ctx, |_| {})?;
        Ok(listed)
    }

    /// [`LearnedState::pool_priors`] from `stats`, the totals of the first slots as read
    /// (the slots past them are taken as fresh: no observations, which lend nothing and
    /// borrow, as a growth's new slots), its uploads into `up` for the caller to submit.
    pub fn pool_priors_into(
        &mut self,
        budget: f32,
        below: u32,
        mut stats: Vec<SlotStats>,
        up: &mut Transfers,
    ) -> Result<u32> {
        let t0 = Instant::now();
        stats.resize(self.slots as usize, SlotStats::default());
        let c = &self.cuts;
        let priors =
            crate::learning::pooling::pooled_priors(&c.grid, &c.index, &c.cuts, &stats, budget);
        let before = |i: usize| self.borrowed.get(i).copied().unwrap_or([0.0; 4]);
        let changed: Vec<u32> = (0..(below as usize).min(priors.len()))
            .filter(|&i| priors[i] != before(i))
            .map(|i| i as u32)
            .collect();
        up.write(&self.prior, 0, bytemuck::cast_slice(&priors));
        if !changed.is_empty() {
            let n = changed.len() as u32;
            let mut list = vec![n.div_ceil(64), 1, 1, n];
            list.extend(&changed);
            up.write(&self.touched, 0, bytemuck::cast_slice(&list));
        }
        self.borrowed = priors;
        self.cut_seconds += t0.elapsed().as_secs_f64();
        Ok(changed.len() as u32)
    }

    /// Whether any slot borrows observations now.
    pub fn borrowing(&self) -> bool {
        self.borrowed.iter().any(|p| p.iter().any(|&v| v != 0.0))
    }

    /// Each slot's borrowed pseudo-observations as last pooled (empty before the first
    /// pooling; slots past its end borrow nothing).
    pub fn borrowed(&self) -> &[SlotPrior] {
        &self.borrowed
    }

    /// The totals and coefficients of the slots in use (the buffer may have room for more).
    pub fn read_stats(&self) -> Result<Vec<SlotStats>> {
        self.stats.read_first(self.slots as usize)
    }

    /// The open window's sums of the slots in use.
    pub fn read_delta(&self) -> Result<Vec<SlotDelta>> {
        self.delta.read_first(self.slots as usize)
    }

    /// The touched-slot list as long as `touched_list(slots)` makes it.
    pub fn read_touched(&self) -> Result<Vec<u32>> {
        self.touched
            .read_first(4 + self.slots.div_ceil(64) as usize * 64)
    }

    /// Learned cut refinement (src/render/refine.rs), at a fold boundary: every region whose
    /// cut has clusters to split gets its new cut and statistics appended and its index
    /// pointed at them (the old slots stay, unused). Returns how many regions changed; the
    /// caller rebinds.
    pub fn refine(
        &mut self,
        ctx: &Arc<Context>,
        tree: &LightTree,
        settings: &RenderSettings,
    ) -> Result<usize> {
        let splits = settings.learn.refine_cuts as usize;
        if splits == 0 || self.full || !settings.sampler.learned() {
            return Ok(0);
        }
        let t0 = Instant::now();
        // The totals and the side sums in one submission (src/gpu/transfer.rs says why).
        let n = self.slots as u64;
        let got = read_many(
            ctx,
            &[
                (&self.stats, n * std::mem::size_of::<SlotStats>() as u64),
                (&self.sides, n * SIDE_BYTES),
            ],
        )?;
        let (stats, sides): (Vec<SlotStats>, Vec<[u32; 6]>) = (pod_vec(&got[0]), pod_vec(&got[1]));
        // --k-max caps the cut as built; refinement may grow it to what the kernel holds.
        let k_max = crate::lights::regions::MAX_K as usize;
        let mut plans = Vec::new();
        // Once per cut: the regions of a block share theirs.
        for &o in &self.cuts.offsets {
            if let Some(p) = super::refine::refined_cut(
                tree,
                &self.cuts,
                &stats,
                &sides,
                o as usize,
                splits,
                k_max,
                settings.observed_regression(),
            ) {
                plans.push((o, p));
            }
        }
        if plans.is_empty() {
            return Ok(0);
        }
        let grown: usize = plans.iter().map(|(_, (c, _))| c.len() + 1).sum();
        if (self.cuts.cuts.len() + grown) as u64 > most_slots(ctx) {
            self.full = true;
            return Ok(0);
        }
        let mut fresh = Vec::with_capacity(grown);
        let mut moved = std::collections::HashMap::new();
        for (o, (cut, st)) in &plans {
            let offset = self.cuts.cuts.len() as u32;
            self.cuts.cuts.push(cut.len() as u32);
            self.cuts.cuts.extend(cut);
            fresh.push(SlotStats::default());
            fresh.extend(st);
            moved.insert(*o, offset);
        }
        self.cuts.replace(&moved);
        self.index.write(bytemuck::cast_slice(&self.cuts.index))?;
        self.cuts_buf = Buffer::words(ctx, "cuts", &self.cuts.cuts)?;
        let mut up = Transfers::new();
        self.append_slots(ctx, &fresh, &mut up)?;
        up.submit(ctx, |_| {})?;
        self.regions_refined += plans.len();
        self.cut_seconds += t0.elapsed().as_secs_f64();
        Ok(plans.len())
    }

    /// What reducing the statistics on the host between frames would cost now, measured by
    /// doing it: read the totals and window sums back, fold every slot with the CPU mirror
    /// of `fold.comp` (`learning::fold`, coefficients included) and upload the totals again
    /// (the same values, so the state does not change). The GPU fold stays the one in use
    /// (docs/features.md has the measurement).
    pub fn measure_host_reduction(&self, learn: &LearnSettings) -> Result<HostReduction> {
        let t0 = Instant::now();
        let stats: Vec<SlotStats> = self.read_stats()?;
        let delta: Vec<SlotDelta> = self.read_delta()?;
        let read = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let folded: Vec<SlotStats> = stats
            .iter()
            .zip(&delta)
            .map(|(s, d)| crate::learning::fold(s, d, learn))
            .collect();
        let reduce = t1.elapsed().as_secs_f64();
        std::hint::black_box(&folded);
        let t2 = Instant::now();
        self.stats.write(bytemuck::cast_slice(&stats))?;
        let upload = t2.elapsed().as_secs_f64();
        Ok(HostReduction {
            slots: stats.len(),
            bytes: stats.len()
                * (std::mem::size_of::<SlotStats>() * 2 + std::mem::size_of::<SlotDelta>()),
            read_seconds: read,
            reduce_seconds: reduce,
            upload_seconds: upload,
        })
    }
}

/// Bytes of one slot's borrowed observations (a vec4 of fold.comp's `Prior`).
const PRIOR_BYTES: u64 = std::mem::size_of::<SlotPrior>() as u64;
/// One slot's `side_counts` (render.comp): six words.
const SIDE_BYTES: u64 = 24;

/// The slots to make room for when `want` are in use: twice as many, as far as the device
/// allows (one statistics buffer, two texels a slot: learned_texels.glsl), never fewer than
/// `want` (growth stops before that would not fit, [`LearnedState::grow`]).
fn slot_capacity(ctx: &Context, want: u64) -> u64 {
    (2 * want).min(most_slots(ctx)).max(want)
}

/// The most learned slots this device holds: one statistics buffer, two texels a slot, and
/// a fold over every slot in one dispatch of 64-wide workgroups (a device may take no more
/// than 65535 in x, as lavapipe: at its 4194304 slots of 128 MiB the fold asked 65536; an
/// audit, 2026-12-07).
pub(super) fn most_slots(ctx: &Context) -> u64 {
    let limits = &ctx.properties.limits;
    let slot = std::mem::size_of::<SlotStats>() as u64;
    (limits.max_storage_buffer_range as u64 / slot)
        .min(limits.max_texel_buffer_elements as u64 / 2)
        .min(64 * limits.max_compute_work_group_count[0] as u64)
}

/// The empty list of touched slots (render.comp `mark_touched`, fold.comp) for `slots`
/// slots: the fold's indirect workgroup counts (0, 1, 1), the count 0, then room for every
/// slot rounded up to whole 64-wide workgroups, all NO_SLOT.
pub fn touched_list(slots: u32) -> Vec<u32> {
    let mut list = vec![0, 1, 1, 0];
    list.resize(4 + slots.div_ceil(64) as usize * 64, u32::MAX);
    list
}
