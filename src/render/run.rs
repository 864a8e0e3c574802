//! The pass loop: runs a session's passes in batches until a sample count or a time budget
//! is reached, handing the running image to checkpoints on the way.

use std::sync::Arc;

use anyhow::Result;

use super::{
    Budget, GpuScene, RenderResult, RenderSettings, Session, MAX_FILM_SPP, MAX_PASSES_PER_BATCH,
    PASS_BATCH_SECONDS,
};
use crate::gpu::Context;
use crate::scene::Scene;

/// Where to stop and look at the image during a render (for convergence curves).
#[derive(Clone, Debug, Default)]
pub enum Checkpoints {
    #[default]
    None,
    /// After these many seconds of rendering (the first batch end at or past each).
    Seconds(Vec<f64>),
    /// After exactly these sample counts.
    Samples(Vec<u32>),
}

/// The image at a checkpoint.
pub struct Checkpoint {
    pub spp: u32,
    /// Render time so far (checkpoint work excluded).
    pub seconds: f64,
    pub mean: Vec<[f32; 3]>,
}

/// Renders `scene`; `progress(spp_done, fraction)` is called after every batch of passes.
pub fn render(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    render_with_checkpoints(
        ctx,
        scene,
        gpu,
        settings,
        &Checkpoints::None,
        &mut |_| Ok(()),
        progress,
    )
}

/// [`render`] that also hands the running image to `on_checkpoint` at the given points.
///
/// The render clock only runs while passes execute: reading the image back and whatever
/// `on_checkpoint` does are outside it, so checkpoints do not change the measured time or
/// how many samples a time budget buys (only the wall clock grows).
#[allow(clippy::too_many_arguments)]
pub fn render_with_checkpoints(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    checkpoints: &Checkpoints,
    on_checkpoint: &mut dyn FnMut(Checkpoint) -> Result<()>,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    let mut session = Session::new(ctx, scene, gpu, settings)?;
    run_session(
        &mut session,
        settings.budget,
        checkpoints,
        on_checkpoint,
        progress,
    )
}

/// Runs passes of `session` until `budget` (samples or seconds of its film) is reached or a
/// stop is asked for (Ctrl-C: the batch in flight finishes, and the result says
/// `interrupted`); checkpoints as [`render_with_checkpoints`].
pub fn run_session(
    session: &mut Session,
    budget: Budget,
    checkpoints: &Checkpoints,
    on_checkpoint: &mut dyn FnMut(Checkpoint) -> Result<()>,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    run_session_until(
        session,
        budget,
        f64::INFINITY,
        checkpoints,
        on_checkpoint,
        progress,
    )
}

/// [`run_session`] that also returns (not interrupted) once the film's render clock reaches
/// `until` seconds, its batches aimed not to pass it, so that the caller can write the image
/// so far and call again (`render --checkpoint`). The passes are those of one call: growth
/// points and learning windows follow the pass counter, not the batches.
pub fn run_session_until(
    session: &mut Session,
    budget: Budget,
    until: f64,
    checkpoints: &Checkpoints,
    on_checkpoint: &mut dyn FnMut(Checkpoint) -> Result<()>,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<RenderResult> {
    // The CLI checks --time; a library caller's NaN never ended (an audit, 2026-12-07).
    if let Budget::Seconds(s) = budget {
        if !(s.is_finite() && s > 0.0) {
            anyhow::bail!("a time budget of {s} seconds: give a finite number of seconds above 0");
        }
    }
    if let Budget::Samples(n) = budget {
        if n > MAX_FILM_SPP {
            anyhow::bail!("a budget of {n} samples a pixel is more than the {MAX_FILM_SPP} a film's float sums add without loss; render parts of other seeds and merge them (`lightlearn merge`)");
        }
    }
    let _active = crate::interrupt::Active::begin();
    // Checkpoints still ahead, as (seconds, spp) limits; one of the two is infinite.
    let mut pending: std::collections::VecDeque<(f64, u32)> = match checkpoints {
        Checkpoints::None => Default::default(),
        Checkpoints::Seconds(t) => t.iter().map(|&t| (t, u32::MAX)).collect(),
        Checkpoints::Samples(n) => n.iter().map(|&n| (f64::INFINITY, n)).collect(),
    };
    let mut batch = 1u32;
    let mut interrupted = false;
    // The spp of the last checkpoint given (a full film's last image is not given twice).
    let mut last_checkpoint: Option<u32> = None;
    loop {
        let (done, elapsed) = (session.spp(), session.film_seconds());
        let mut k = match budget {
            // A film that already holds the budget (a second call with a smaller one) runs
            // no pass; `n - done` wrapped and ran one more batch.
            Budget::Samples(n) => batch.min(n.saturating_sub(done)),
            // A time budget ends where the film is full ([`MAX_FILM_SPP`]).
            Budget::Seconds(_) => batch.min(MAX_FILM_SPP.saturating_sub(done)),
        };
        if let Some(&(_, n)) = pending.front() {
            if n > done {
                k = k.min(n - done);
            }
        }
        if k == 0 {
            // A time budget's film filled: the checkpoints still ahead get the image as it
            // ends, once (compare's convergence.csv lost its last points: a review,
            // 2026-12-07).
            if matches!(budget, Budget::Seconds(_))
                && !pending.is_empty()
                && done > 0
                && last_checkpoint != Some(done)
            {
                pending.clear();
                on_checkpoint(Checkpoint {
                    spp: done,
                    seconds: elapsed,
                    mean: session.image()?,
                })?;
            }
            break;
        }
        let dt = session.run_passes(k)?;
        let (done, elapsed) = (session.spp(), elapsed + dt);
        let fraction = match budget {
            Budget::Samples(n) => done as f64 / n as f64,
            Budget::Seconds(s) => (elapsed / s).min(1.0),
        };
        progress(done, fraction);
        // Every checkpoint this batch passed, given once: several that fell inside one
        // batch (the first, on a cold shader cache) were each written, the same point up to
        // six times in compare's convergence.csv (an audit, 2026-12-06).
        let mut passed = false;
        while let Some(&(t, n)) = pending.front() {
            if elapsed < t && done < n {
                break;
            }
            pending.pop_front();
            passed = true;
        }
        if passed {
            last_checkpoint = Some(done);
            on_checkpoint(Checkpoint {
                spp: done,
                seconds: elapsed,
                mean: session.image()?,
            })?;
        }
        // A budget met is a finished render, whatever was asked meanwhile: a stop during
        // the last batch of `--spp` was reported as an interruption and a complete
        // reference thrown away (an audit, 2026-12-06).
        let met = match budget {
            Budget::Seconds(s) => elapsed >= s,
            Budget::Samples(n) => done >= n,
        };
        if met {
            break;
        }
        if crate::interrupt::requested() {
            interrupted = true;
            break;
        }
        if elapsed >= until {
            break;
        }
        // Aim the next batch at PASS_BATCH_SECONDS, and never past the next time checkpoint
        // or a time budget's end.
        let per_pass = dt / k as f64;
        let mut target = PASS_BATCH_SECONDS.min(until - elapsed);
        if let Budget::Seconds(s) = budget {
            target = target.min(s - elapsed);
        }
        if let Some(&(t, _)) = pending.front() {
            target = target.min(t - elapsed);
        }
        batch = ((target / per_pass.max(1e-9)) as u32).clamp(1, MAX_PASSES_PER_BATCH);
    }
    let mut result = session.result()?;
    result.interrupted = interrupted;
    Ok(result)
}
