//! The render session: one object per (scene, device) that `render`, `compare` and
//! `reference` drive (and the preview, animation and farm are to drive), holding three
//! lifetimes (docs: architecture in the README):
//!
//! - the **scene** (`GpuScene`, borrowed: uploaded once);
//! - the **learned state**: grid, region index, cuts, statistics and window sums, and the
//!   learning pass counter [`Session::passes`], which never goes back;
//! - the **film**: accumulators and counters, and its sample count, reset by
//!   [`Session::reset_film`], [`Session::set_camera`] and [`Session::resize`].
//!
//! The camera is an input: [`Session::set_camera`] replaces it and resets the film, the
//! learning stays (regions live in world space).
//!
//! Random numbers: every pass draws from the stream of its *learning* pass index, never of
//! the film's sample count. A film reset therefore never replays a stream the statistics
//! were learned from (the weights of a pass would then depend on its own random numbers:
//! a bias), and a `--load-stats` continuation goes on exactly where the saved render
//! stopped (tested bit for bit in tests/learning/files.rs).

mod film;
mod growth;
mod inspect;

use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Result};

use super::coverage;
use super::cuts::{check_region_index_fits, stats_header};
use super::learned_state::LearnedState;
use super::passes::PassKernels;
use super::timeline::Event;
use super::{camera_vectors, GpuScene, Learned, RegionStats, RenderResult, RenderSettings};
use crate::gpu::layout::{PixelAccum, RenderParams, SlotDelta, SlotStats};
use crate::gpu::Context;
use crate::learning::stats_file::{SavedStats, StatsHeader};
use crate::learning::LearningClock;
use crate::scene::{Camera, Scene};

use film::Film;
pub use film::{filled_before, max_film_pixels, MAX_FILM_SPP};
use growth::next_growth_point;
pub use growth::{growth_point, POOL_AGE_MAX};

/// One scene on one device with its learned state and film; see the module comment.
pub struct Session<'a> {
    ctx: Arc<Context>,
    scene: &'a Scene,
    gpu: &'a GpuScene,
    settings: RenderSettings,
    camera: Camera,
    learned: LearnedState,
    film: Film,
    kernels: PassKernels,
    /// The camera or size changed since the session began (cuts grow on the film's schedule
    /// too).
    moved: bool,
    /// The last pass did not end a learning window: observations wait in the window's sums.
    /// Kept apart from the clock, whose age restarts with a move while a window may be open.
    window_open: bool,
    /// A growth point has passed and the cuts grow at the next fold boundary.
    growth_due: bool,
    /// Passes skipped before the first (a farm chunk, [`Session::skip_passes`]).
    skipped: u32,
    /// Growth waits (the preview while the camera moves: a cut build every frame halved
    /// the frame rate); due growth happens once it is resumed.
    growth_paused: bool,
    /// Direct light covers only the pixels that can see the scene ([`Session::set_pixel_culling`]).
    cull_pixels: bool,
    /// Each dispatch, fold and growth point timed on its own ([`Session::record_timeline`]).
    pub(super) timeline: Option<Vec<Event>>,
}

impl<'a> Session<'a> {
    /// A session with the scene's own camera; `settings.resume` starts from loaded
    /// statistics (their cuts and sample count), else the cuts are built for the regions
    /// the camera's rays reach. `settings.budget` is not used (the caller's loop decides).
    pub fn new(
        ctx: &Arc<Context>,
        scene: &'a Scene,
        gpu: &'a GpuScene,
        settings: &RenderSettings,
    ) -> Result<Session<'a>> {
        settings.regions.check()?;
        settings.learn.check()?;
        settings.check_paths()?;
        scene.camera.check()?;
        // A GpuScene uploaded from another scene indexed past this one's lights (a panic in
        // build_cuts) or rendered black with `Ok` (an audit of the library, 2026-12-07).
        if gpu.uploaded_from != (scene.triangles.len(), scene.lights.len()) {
            bail!(
                "the GpuScene was uploaded from another scene ({} triangles, {} lights) than this session's ({} triangles, {} lights); upload the scene the session renders",
                gpu.uploaded_from.0,
                gpu.uploaded_from.1,
                scene.triangles.len(),
                scene.lights.len()
            );
        }
        let film = Film::new(ctx, settings.width, settings.height)?;
        if settings.sampler.uses_cuts() {
            check_region_index_fits(ctx, scene, &settings.regions)?;
        }
        if let Some(saved) = &settings.resume {
            super::check_resume(
                scene,
                gpu,
                settings,
                saved,
                std::path::Path::new("the statistics this render starts from"),
            )?;
        }
        let learned = LearnedState::new(ctx, scene, gpu, settings, &scene.camera)?;
        let kernels = PassKernels::new(ctx, gpu, settings)?;
        let mut session = Session {
            ctx: ctx.clone(),
            scene,
            gpu,
            settings: settings.clone(),
            camera: scene.camera,
            learned,
            film,
            kernels,
            moved: false,
            window_open: false,
            growth_due: false,
            growth_paused: false,
            skipped: 0,
            cull_pixels: true,
            timeline: None,
        };
        session.bind_scene()?;
        session.bind_learned()?;
        session.bind_film()?;
        if session.pools_now() && settings.resume.is_some() {
            // What the render that saved them pooled at its last growth point (pooling.rs).
            // Every slot's coefficients follow from the fold below.
            session
                .learned
                .pool_priors(&session.ctx, settings.learn.pool_priors, 0)?;
        }
        if session.is_learning() {
            // The weight coefficients of fresh or loaded statistics (under these settings).
            session.fold_from(0)?;
        }
        Ok(session)
    }

    /// Knocks stages out of every following pass (`render.comp` KNOCK_OUT: the bits of
    /// [`crate::bench::stages`]): the images are then wrong, only the pass time means
    /// something. 0 restores the real kernel.
    pub fn knock_out(&mut self, mask: u32) -> Result<()> {
        self.kernels
            .knock_out(&self.ctx, self.gpu, &self.settings, mask)?;
        self.bind_scene()?;
        self.bind_learned()?;
        self.bind_film()
    }

    fn is_learning(&self) -> bool {
        self.settings.sampler.learned()
    }

    fn bind_scene(&self) -> Result<()> {
        self.kernels.bind_scene(self.gpu)
    }

    fn bind_learned(&self) -> Result<()> {
        self.kernels.bind_learned(&self.learned)
    }

    fn bind_film(&mut self) -> Result<()> {
        let rows = self.live_rows(&self.camera, self.film.width, self.film.height);
        self.kernels.bind_film(
            &self.ctx,
            &self.film.accum,
            &self.film.counters,
            self.film.width,
            self.film.height,
            &rows,
        )
    }

    /// The rows of 8 pixels the direct-light kernel covers for `camera` on a
    /// `width`×`height` film: those that can see the scene, or all of them with culling off
    /// ([`coverage`]).
    fn live_rows(&self, camera: &Camera, width: u32, height: u32) -> Vec<u32> {
        let params = camera_vectors(camera, width, height);
        if !self.kernels.direct_light() {
            // Paths start from every pixel (their bounces are queued).
            Vec::new()
        } else if self.cull_pixels {
            coverage::dispatch_order(&coverage::live_rows(
                &self.gpu.bvh,
                &params,
                self.gpu.ray_eps,
            ))
        } else {
            coverage::dispatch_order(&coverage::all_rows(width, height))
        }
    }

    /// The direct-light kernel leaves out the rows of 8 pixels whose camera rays cannot meet
    /// the scene (`true`, the default; the image is the same bit for bit, the time less) or
    /// covers every pixel (`false`: for the test that compares the two).
    pub fn set_pixel_culling(&mut self, on: bool) -> Result<()> {
        let old = std::mem::replace(&mut self.cull_pixels, on);
        let camera = self.camera;
        self.rebind_live_rows(&camera)
            .inspect_err(|_| self.cull_pixels = old)
    }

    /// Binds the rows `camera` sees on the film (the binding stays as it was on an error).
    fn rebind_live_rows(&mut self, camera: &Camera) -> Result<()> {
        let rows = self.live_rows(camera, self.film.width, self.film.height);
        self.kernels
            .set_live_rows(&self.ctx, &self.film.accum, &self.film.counters, &rows)
    }

    /// Sets the coefficients of the slots from `first` on from their totals.
    fn fold_from(&self, first: u32) -> Result<()> {
        self.kernels.fold_from(&self.ctx, first, &self.learned)
    }

    /// The push constants of the next pass.
    fn pass_params(&self) -> RenderParams {
        let mut p = camera_vectors(&self.camera, self.film.width, self.film.height);
        p.seed = self.settings.seed;
        p.light_count = self.gpu.light_count;
        p.ray_eps = self.gpu.ray_eps;
        p.max_depth = self.settings.max_depth;
        p.sample_index = self.learned.passes;
        p
    }

    /// Runs `k` passes (one sample per pixel each); returns their seconds, including the
    /// cuts built between them. The posteriors stay frozen within a learning window and are
    /// folded at its end (`--update-every`, counted on the session's clock): each pass's
    /// samples depend only on earlier passes, so the average of passes is unbiased. Regions
    /// reached without a cut get one after learning pass 1, 2, 4, …, 32 and every 64th
    /// ([`growth_point`]), and after a camera move or resize also after the film's passes
    /// 1, 2, 4, …, 32: a fixed schedule, so the image does not depend on how passes are
    /// batched, and a `--load-stats` continuation of a render saved at a growth point grows
    /// where the uninterrupted render grew.
    /// Frees what only a run of passes needs (the wavefront's path queues: up to 64 MB at
    /// depth > 1) until the next [`Self::run_passes`] makes it again; the film, the camera
    /// and the learned state stay, and the images are the same bit for bit. The preview
    /// keeps a session for every sampler and depth shown: 707 MB after six samplers at
    /// both depths at 640×480 (an audit, 2026-12-07).
    pub fn release_scratch(&mut self) {
        self.kernels.release_queues();
    }

    pub fn run_passes(&mut self, k: u32) -> Result<f64> {
        if !self.kernels.has_queues() {
            self.bind_film()?;
        }
        if self.film.spp.saturating_add(k) > MAX_FILM_SPP {
            bail!(
                "the film holds {} samples a pixel and {k} more would pass the {MAX_FILM_SPP} its float sums add without loss; reset it, or render more in another session of another seed and merge the images (`lightlearn merge`)",
                self.film.spp
            );
        }
        if self
            .learned
            .passes
            .checked_add(k)
            .is_none_or(|p| p > MAX_PASSES)
        {
            bail!(
                "{} passes learned already: at most {MAX_PASSES} fit the random streams; start from fresh statistics",
                self.learned.passes
            );
        }
        let mut seconds = 0.0;
        let mut left = k;
        while left > 0 {
            let (passes, spp) = (self.learned.passes, self.film.spp);
            let mut n = left.min(next_growth_point(passes) - passes);
            if self.moved && spp < 32 {
                n = n.min(next_growth_point(spp) - spp);
            }
            if self.growth_due {
                // Growth waits for the next fold boundary (--update-every): stop there.
                n = n.min(self.settings.learn.update_every.to_window_end(self.clock()));
            }
            debug_assert!(n > 0);
            seconds += self.submit_passes(n)?;
            left -= n;
            // After the chunk, so a render saved at a growth point has grown what its last
            // passes reached, as the uninterrupted render has at that point.
            let (passes, spp) = (self.learned.passes, self.film.spp);
            if growth_point(passes) || self.moved && spp <= 32 && growth_point(spp) {
                self.growth_due = true;
            }
            if self.growth_due && !self.growth_paused && self.at_fold_boundary() {
                let t0 = Instant::now();
                self.grow_regions()?;
                self.growth_due = false;
                seconds += t0.elapsed().as_secs_f64();
            }
        }
        self.film.seconds += seconds;
        Ok(seconds)
    }

    /// `k` passes in one submission; their seconds.
    fn submit_passes(&mut self, k: u32) -> Result<f64> {
        let fold = self
            .is_learning()
            .then_some((self.settings.learn.update_every, self.clock()));
        let dt = self.kernels.submit(
            &self.ctx,
            self.pass_params(),
            k,
            fold,
            &self.learned,
            self.timeline.as_mut(),
        )?;
        self.learned.passes += k;
        self.film.spp += k;
        self.window_open = fold.is_some_and(|(every, _)| !every.ends_at(self.clock()));
        Ok(dt)
    }

    /// The learning's clock for its windows: the learned passes, and as its age the film's
    /// passes once the camera, size or chunk changed (`moved`), else the learned passes.
    fn clock(&self) -> LearningClock {
        LearningClock {
            passes: self.learned.passes,
            age: if self.moved {
                self.film.spp
            } else {
                self.learned.passes
            },
        }
    }

    /// Whether the window is empty (samplers that do not learn: always).
    fn at_fold_boundary(&self) -> bool {
        !self.window_open
    }

    /// Moves the learning pass counter on by `k` passes without rendering them, before the
    /// first pass: a farm chunk `c` of `n` samples draws the random streams of passes
    /// [c·n, (c+1)·n) after what it loaded, so chunks never share samples and, for the
    /// samplers that learn nothing, the merged chunks are the one-machine render. Regions
    /// then grow on the film's schedule (as after a camera move), not the counter's.
    pub fn skip_passes(&mut self, k: u32) -> Result<()> {
        if self.film.spp > 0 {
            bail!("passes can be skipped only before the first pass");
        }
        if k == 0 {
            return Ok(());
        }
        match self.learned.passes.checked_add(k) {
            Some(p) if p <= MAX_PASSES / 2 => {
                self.learned.passes = p;
                self.skipped = k;
            }
            _ => bail!("--chunk starts past the {} passes the random streams hold; use fewer or smaller chunks", MAX_PASSES / 2),
        }
        self.moved = true;
        Ok(())
    }

    /// Holds region growth back (`true`) or lets it go on (`false`); what fell due meanwhile
    /// grows at the next fold boundary. Regions reached meanwhile use the shared fallback
    /// cut, which is unbiased.
    pub fn pause_growth(&mut self, paused: bool) {
        self.growth_paused = paused;
    }

    /// Clears the film (image, counters, its sample count); the learning stays.
    pub fn reset_film(&mut self) -> Result<()> {
        self.film.accum.clear()?;
        self.film.counters.clear()?;
        self.film.spp = 0;
        self.film.seconds = 0.0;
        Ok(())
    }

    /// A new camera: the film is reset, the learning stays.
    pub fn set_camera(&mut self, camera: Camera) -> Result<()> {
        camera.check()?;
        // The rows first: if they cannot be bound, nothing has changed.
        self.rebind_live_rows(&camera)?;
        self.camera = camera;
        self.moved = true;
        self.reset_film()
    }

    /// The most memory the path tracer's queues may take (by default
    /// [`super::passes::QUEUE_BYTES`]): with less, a film's paths start in more bands of
    /// rows, and the image is bit for bit the same. An error if 8 rows do not fit (the
    /// limit then stays as it was).
    pub fn set_path_queue_bytes(&mut self, bytes: u64) -> Result<()> {
        let old = self.kernels.set_queue_bytes(bytes);
        self.bind_film().inspect_err(|_| {
            self.kernels.set_queue_bytes(old);
        })
    }

    /// A new image size: a new, empty film; the learning stays.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        // Bound before the old film is dropped: on an error the session keeps its film and
        // its bindings.
        let film = Film::new(&self.ctx, width, height)?;
        let rows = self.live_rows(&self.camera, width, height);
        self.kernels
            .bind_film(&self.ctx, &film.accum, &film.counters, width, height, &rows)?;
        self.film = film;
        self.moved = true;
        self.settings.width = width;
        self.settings.height = height;
        Ok(())
    }

    /// The learned statistics with their regions and cuts, as a file would hold them
    /// (learned samplers only). Folds what is left of the current window first, so the
    /// totals hold every sample.
    pub fn snapshot(&self) -> Result<Option<SavedStats>> {
        if !self.is_learning() {
            return Ok(None);
        }
        let mut stats: Vec<SlotStats> = self.learned.read_stats()?;
        if !self.at_fold_boundary() {
            // What is left of the window, folded here on the host (the CPU mirror of
            // fold.comp): the GPU's state, and so what later passes sample by, stays as it is.
            let delta: Vec<SlotDelta> = self.learned.read_delta()?;
            let borrowed = self.learned.borrowed();
            for (i, (s, d)) in stats.iter_mut().zip(&delta).enumerate() {
                if d.n_zero + d.n_nonzero > 0 {
                    let p = borrowed.get(i).unwrap_or(&[0.0; 4]);
                    *s = crate::learning::fold_with_prior(s, d, p, &self.settings.learn);
                }
            }
        }
        let cuts = &self.learned.cuts;
        Ok(Some(SavedStats {
            header: StatsHeader {
                samples_done: self.learned.passes,
                regions: cuts.index.len() as u32,
                cuts_len: cuts.cuts.len() as u32,
                skipped_passes: (self.skipped > 0).then_some(self.skipped),
                ..stats_header(self.scene, self.gpu, &self.settings)
            },
            index: cuts.index.clone(),
            cuts: cuts.cuts.clone(),
            stats,
        }))
    }

    /// What the film holds, with the learned state's diagnostics (the render result).
    pub fn result(&self) -> Result<RenderResult> {
        let accum: Vec<PixelAccum> = self.film.accum.read()?;
        let counters = self.film.counters.read::<u32>()?;
        let learned = match self.snapshot()? {
            Some(saved) => Some(Learned {
                diagnostics: crate::learning::diagnostics(
                    &saved.cuts,
                    &self.learned.cuts.offsets,
                    self.learned.cuts.built(),
                    &saved.stats,
                    &self.settings.learn,
                    counters[1] as u64,
                ),
                saved,
            }),
            None => None,
        };
        let cuts = &self.learned.cuts;
        Ok(RenderResult {
            width: self.film.width,
            height: self.film.height,
            spp: self.film.spp,
            first_sample_index: self.learned.passes - self.film.spp,
            accum: accum[..self.film.pixels()].to_vec(),
            radiance_scale: self.gpu.radiance_scale,
            render_seconds: self.film.seconds,
            invalid_samples: counters[0],
            interrupted: false,
            regions: RegionStats {
                regions_with_cuts: cuts.built(),
                cut_seconds: self.learned.cut_seconds,
                regions_added_between_frames: self.learned.regions_added,
                cut_refinements: self.learned.regions_refined,
                cut_bytes: 4 * (cuts.index.len() + cuts.cuts.len()),
            },
            learned,
        })
    }
}

/// Most passes a session takes (learned ones included): the random streams are indexed by
/// a u32 and must never repeat.
pub const MAX_PASSES: u32 = 1 << 31;
