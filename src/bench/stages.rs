//! Stage profile of a render pass: where a pass of `render.comp` spends its time. One kernel
//! does a whole path, so its stages cannot be timed apart with timestamp queries; instead the
//! same passes are timed with one stage knocked out at a time (the `KNOCK_OUT` specialization
//! constant of `render.comp`), and a stage's cost is what its removal saves. The knocked-out
//! kernels compute wrong images; the attribution is approximate where a stage changes the work
//! of the others (uniform picks shadow other lights, so their shadow rays differ).

use std::sync::Arc;

use anyhow::Result;

use crate::gpu::Context;
use crate::learning::{LearnDiagnostics, UpdateEvery};
use crate::render::timeline::Event;
use crate::render::{GpuScene, LightSampler, RenderSettings, Session};
use crate::scene::Scene;

/// `render.comp` KNOCK_OUT bits.
pub const KNOCK_SELECT: u32 = 1;
pub const KNOCK_SHADOW: u32 = 2;
pub const KNOCK_MIS_PMF: u32 = 4;
pub const KNOCK_OBSERVE: u32 = 8;
pub const KNOCK_SHADING: u32 = 16;
pub const KNOCK_IMPORTANCE: u32 = 32;

const ALL: &str = "all of the above";
const BUT_CAMERA: &str = "everything but the camera rays";

/// One timed variant.
pub struct StageTime {
    /// What the variant leaves out ("nothing" for the real kernel).
    pub name: &'static str,
    /// The fastest of the repeats, seconds for the passes.
    pub seconds: f64,
}

/// The variants that mean something for these settings: (name, KNOCK_OUT bits, folds).
fn variants(settings: &RenderSettings) -> Vec<(&'static str, u32, bool)> {
    let learning = settings.sampler.learned();
    let mut v = vec![("nothing (the real kernel)", 0, true)];
    // `uniform` knocked out is `uniform`: the row timed the same kernel twice and printed
    // the noise as a stage (32 % at 4×4: an audit, 2026-12-07).
    if settings.sampler != LightSampler::Uniform {
        v.push(("light selection (uniform picks)", KNOCK_SELECT, true));
    }
    v.push(("shadow rays (all visible)", KNOCK_SHADOW, true));
    if settings.sampler.uses_importance() {
        // Part of light selection: on the default render 4-13 % of a `bayes` pass in single
        // profiles, ~10 % over six interleaved rounds, against 5-7 % for the texel fetches of
        // the cut's loop (docs/results.md, thirteenth session).
        v.push((
            "the importance's cone and cosine bounds (Φ/d² instead)",
            KNOCK_IMPORTANCE,
            true,
        ));
    }
    if settings.max_depth > 1 {
        v.push(("MIS light pmf of BSDF hits", KNOCK_MIS_PMF, true));
    }
    if learning {
        v.push(("statistics atomics", KNOCK_OBSERVE, true));
        v.push(("folds and region growth between passes", 0, false));
    }
    // (KNOCK_IMPORTANCE need not be in it: with uniform picks no importance is evaluated.)
    let all = KNOCK_SELECT | KNOCK_SHADOW | KNOCK_MIS_PMF | KNOCK_OBSERVE;
    v.push((ALL, all, false));
    // What is left is the camera rays (their hits) and the film: on lavapipe with `uniform`
    // direct light 48 % of a pass on rooms and 57 % on city (docs/results.md, ninth session).
    v.push((BUT_CAMERA, all | KNOCK_SHADING, false));
    v
}

/// Times `passes` passes of each variant on fresh sessions, the fastest of `repeats`; with the
/// learning's diagnostics after the real kernel's passes (learned samplers). Where slots see
/// few observations each, the statistics atomics and the folds cost per observation: each
/// one meets a slot of its own, far apart in memory, and each slot gets a fold of its own
/// (docs/results.md, seventh session: cornell40 at 128×96, 256 spp, 12 observations a slot,
/// `bayes` took 1.48× `wang`'s time; with `--grid 16`, 4× fewer slots, 1.25×).
pub fn profile(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    passes: u32,
    repeats: u32,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<StageTime>, Option<LearnDiagnostics>)> {
    let variants = variants(settings);
    let mut best = vec![f64::INFINITY; variants.len()];
    let mut learned = None;
    let repeats = repeats.max(1);
    // Round by round over the variants, not each variant's repeats in a row: this machine's
    // speed drifts by 10-15 % within minutes, and a drift between two variants' turns reads
    // as a stage's cost (rows of -9 % and -13 % in row-by-row profiles). Rounds spread the
    // drift over every variant; they do not remove the noise (3 rounds still gave a -21 %
    // row once, 5 gave none: docs/results.md, thirteenth session).
    for rep in 0..repeats {
        if rep + 1 < repeats {
            progress(&format!("round {} of {repeats}", rep + 1));
        }
        for (v, &(name, mask, folds)) in variants.iter().enumerate() {
            let mut s = settings.clone();
            if !folds {
                // No fold inside the timed passes (the coefficients are set once, untimed), and
                // so no region growth either: it waits for a fold boundary. With direct light
                // the passes then share dispatches too (one learning window), so what this
                // saves is everything a fold costs, its breaking of the dispatch included.
                s.learn.update_every = UpdateEvery::Passes(passes + 2);
            }
            let mut session = Session::new(ctx, scene, gpu, &s)?;
            session.knock_out(mask)?;
            // One untimed pass first: lavapipe compiles a kernel at its first dispatch, not
            // when the pipeline is made, and with a cold shader cache that compile (0.73 s
            // at 16×12) was timed as the variant's passes: rows of -5105 % with exit 0 (an
            // audit, 2026-12-06).
            session.run_passes(1)?;
            best[v] = best[v].min(session.run_passes(passes)?);
            // Once, after the real kernel's last repeat (untimed: it reads the film back).
            if mask == 0 && folds && rep + 1 == repeats {
                learned = session.result()?.learned.map(|l| l.diagnostics);
            }
            if rep + 1 == repeats {
                progress(&format!("without {name}: {:.3} s", best[v]));
            }
        }
    }
    let out = variants
        .iter()
        .zip(best)
        .map(|(&(name, _, _), seconds)| StageTime { name, seconds })
        .collect();
    Ok((out, learned))
}

/// `profile --timeline`: one more render of `passes` passes of the real kernel on a fresh
/// session, each dispatch, fold and growth point submitted and timed on its own
/// (src/render/timeline.rs).
pub fn timeline(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    passes: u32,
) -> Result<Vec<Event>> {
    let mut session = Session::new(ctx, scene, gpu, settings)?;
    session.record_timeline();
    session.run_passes(passes)?;
    Ok(session.timeline().unwrap_or_default().to_vec())
}

/// A markdown table: each variant, its time, and what leaving the stage out saved.
pub fn table(times: &[StageTime]) -> String {
    let full = times.first().map_or(1.0, |t| t.seconds);
    let mut s =
        String::from("| left out | seconds | saved | share of the pass |\n|---|---|---|---|\n");
    for t in times {
        let saved = full - t.seconds;
        s.push_str(&format!(
            "| {} | {:.4} | {:+.4} | {:.0} % |\n",
            t.name,
            t.seconds,
            saved,
            100.0 * saved / full
        ));
    }
    // A variant that took longer than the full pass (a row printed below 0 %) is noise, not
    // a stage: `--repeats 1`
    // at 16×12 printed "statistics atomics −69 %" with no word (an audit, 2026-12-06).
    // So is a stage that saved more than every stage together ("all of the above"): at 1×1
    // the folds alone saved 81 % and all of them 71 %, the rows summing to 309 % (an audit,
    // 2026-12-07).
    let all = times
        .iter()
        .find(|t| t.name == ALL)
        .map_or(f64::INFINITY, |t| full - t.seconds);
    let part_over_all = times
        .iter()
        .filter(|t| t.name != ALL && t.name != BUT_CAMERA)
        .any(|t| (full - t.seconds) - all > 0.05 * full);
    if part_over_all || times.iter().any(|t| (full - t.seconds) / full < -0.005) {
        s.push_str("
warning: a row below 0 %, or one that saved more than all of the above, is this machine's noise, not the stage: the times are too short or too few to resolve it; use more --repeats, --spp or pixels\n");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(saved: &[(&'static str, f64)]) -> Vec<StageTime> {
        let mut v = vec![StageTime {
            name: "nothing (the real kernel)",
            seconds: 1.0,
        }];
        v.extend(saved.iter().map(|&(name, s)| StageTime {
            name,
            seconds: 1.0 - s,
        }));
        v
    }

    /// A stage that saved more than all of them together is noise and says so (at 1×1 the
    /// folds alone saved 81 %, all of them 71 %: an audit, 2026-12-07); shares that add up
    /// are printed without a word.
    #[test]
    fn a_part_over_the_whole_is_called_noise() {
        let noise = "is this machine's noise";
        let fine = table(&rows(&[("shadow rays", 0.3), ("folds", 0.2), (ALL, 0.6)]));
        assert!(!fine.contains(noise), "{fine}");
        let over = table(&rows(&[("shadow rays", 0.3), ("folds", 0.81), (ALL, 0.71)]));
        assert!(over.contains(noise), "{over}");
        let below = table(&rows(&[("shadow rays", -0.1), (ALL, 0.5)]));
        assert!(below.contains(noise), "{below}");
    }
}
