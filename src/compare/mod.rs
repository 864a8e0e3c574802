//! `lightlearn compare`: renders one scene with several samplers at equal time and/or equal
//! samples, measures each against a reference, and keeps convergence checkpoints.

pub mod reference;
pub mod report;

use std::sync::Arc;

use anyhow::{bail, Result};
use serde::Serialize;

use crate::gpu::Context;
use crate::render::{self, Budget, Checkpoints, GpuScene, LightSampler, RenderSettings};
use crate::scene::Scene;

/// Image error against a reference, averaged over pixels and the three channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Metrics {
    pub mse: f64,
    /// mean of (x − ref)² / (ref² + 0.01)
    pub rel_mse: f64,
    pub rmse: f64,
}

/// Errors of `image` against `reference` (same size).
pub fn metrics(image: &[[f32; 3]], reference: &[[f32; 3]]) -> Metrics {
    assert_eq!(
        image.len(),
        reference.len(),
        "image sizes are checked before rendering"
    );
    let (mut se, mut rel) = (0f64, 0f64);
    for (x, r) in image.iter().zip(reference) {
        for k in 0..3 {
            let d = x[k] as f64 - r[k] as f64;
            se += d * d;
            rel += d * d / ((r[k] as f64).powi(2) + 0.01);
        }
    }
    let n = (3 * image.len().max(1)) as f64;
    Metrics {
        mse: se / n,
        rel_mse: rel / n,
        rmse: (se / n).sqrt(),
    }
}

/// Per-pixel relative squared error (mean over channels), for the false-colour maps.
pub fn rel_error_map(image: &[[f32; 3]], reference: &[[f32; 3]]) -> Vec<f32> {
    image
        .iter()
        .zip(reference)
        .map(|(x, r)| {
            (0..3)
                .map(|k| {
                    let d = x[k] as f64 - r[k] as f64;
                    d * d / ((r[k] as f64).powi(2) + 0.01)
                })
                .sum::<f64>() as f32
                / 3.0
        })
        .collect()
}

#[derive(Clone, Debug, Serialize)]
pub struct ConvergencePoint {
    pub spp: u32,
    pub seconds: f64,
    #[serde(flatten)]
    pub metrics: Metrics,
}

/// One sampler's run in one comparison.
#[derive(Clone, Debug, Serialize)]
pub struct SamplerRun {
    pub sampler: LightSampler,
    pub spp: u32,
    pub seconds: f64,
    #[serde(flatten)]
    pub metrics: Metrics,
    /// MSE(baseline) / MSE(this): the equal-time speed-up (at equal spp: the MSE ratio).
    pub speedup: f64,
    /// The errors with the reference's own noise taken out: E[(x − ref)²] = error(x) +
    /// Var(ref) for an independent reference, so its estimated variance is subtracted (None
    /// when the reference's noise is unknown, or not below this run's error: then only the
    /// raw numbers mean something, and the comparison's warning says so).
    pub corrected: Option<Metrics>,
    /// The speed-up from the corrected MSEs (None unless both are > 0).
    pub speedup_corrected: Option<f64>,
    /// The fraction of light samples that came out zero (occluded, facing away, a dead end
    /// in a cluster): what learning exists to cut.
    pub zero_sample_fraction: f64,
    /// Samples that came out NaN/Inf and were dropped (should be 0; a warning says so).
    pub invalid_samples: u32,
    pub convergence: Vec<ConvergencePoint>,
    /// Per pixel, the fraction of its light samples that came out zero.
    #[serde(skip)]
    pub zero_map: Vec<f32>,
    #[serde(skip)]
    pub image: Vec<[f32; 3]>,
}

/// The samplers run back to back under one budget.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// "equal time" or "equal samples".
    pub kind: &'static str,
    pub budget_seconds: Option<f64>,
    pub budget_spp: Option<u32>,
    pub runs: Vec<SamplerRun>,
    /// Why the comparison is not what its kind says ([`over_budget`]), also printed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// Checkpoint schedule: 9 points halving back from the budget (T/256 … T or 1 … N spp).
fn schedule(budget: Budget) -> Checkpoints {
    match budget {
        Budget::Seconds(t) => {
            Checkpoints::Seconds((0..9).rev().map(|k| t / f64::powi(2.0, k)).collect())
        }
        Budget::Samples(n) => {
            let mut v: Vec<u32> = (0..32).map(|k| 1u32 << k).take_while(|&s| s < n).collect();
            v.push(n);
            Checkpoints::Samples(v)
        }
    }
}

/// Runs every sampler under `budget`, back to back in this process on this device (the first
/// sampler is the baseline of the speed-ups).
#[allow(clippy::too_many_arguments)]
pub fn compare(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    samplers: &[LightSampler],
    regions: &crate::lights::regions::RegionSettings,
    learn: &crate::learning::LearnSettings,
    budget: Budget,
    width: u32,
    height: u32,
    seed: u32,
    max_depth: u32,
    light_point: crate::lights::LightPoint,
    reference: &[[f32; 3]],
    reference_noise: Option<Metrics>,
    progress: &mut dyn FnMut(LightSampler, u32, f64),
) -> Result<Comparison> {
    // A black reference makes every MSE 0 and every speed-up ∞ (an audit, 2026-12-06:
    // "relMSE 0, speed-up inf" and exit 0 for a scene whose light never reached the camera).
    if !reference.iter().flatten().any(|v| *v > 0.0) {
        bail!("the reference image is black: no light reaches the camera (check that the camera looks at the scene and that its lights are not hidden or facing away); there is nothing to compare");
    }
    let mut runs = Vec::new();
    for &sampler in samplers {
        let settings = RenderSettings {
            width,
            height,
            budget,
            seed,
            sampler,
            regions: *regions,
            learn: *learn,
            resume: None,
            stratify: crate::render::Stratify::Sobol,
            max_depth,
            light_point,
            indirect_light_samples: 1,
            first_light_samples: 1,
        };
        // One untimed pass first (thrown away): lavapipe compiles a kernel at its first
        // dispatch, which on a cold shader cache took 0.4–0.6 s of a 1-s budget, bayes 1234
        // spp where a warm cache gave 3013 (an audit, 2026-12-06). As `profile`. At equal
        // spp too: the first sampler's convergence.csv seconds held the compile (its 1-spp
        // point at 0.56 s against 0.011 s for the next: an audit, 2026-12-07).
        let warm = RenderSettings {
            budget: Budget::Samples(1),
            ..settings.clone()
        };
        render::render(ctx, scene, gpu, &warm, &mut |_, _| {})?;
        let mut convergence = Vec::new();
        let result = render::render_with_checkpoints(
            ctx,
            scene,
            gpu,
            &settings,
            &schedule(budget),
            &mut |c| {
                convergence.push(ConvergencePoint {
                    spp: c.spp,
                    seconds: c.seconds,
                    metrics: metrics(&c.mean, reference),
                });
                Ok(())
            },
            &mut |spp, f| progress(sampler, spp, f),
        )?;
        if result.interrupted {
            bail!(
                "interrupted (Ctrl-C or a stop signal) while rendering {}; the comparison wrote nothing",
                sampler.name()
            );
        }
        let image = result.mean();
        let m = metrics(&image, reference);
        runs.push(SamplerRun {
            sampler,
            spp: result.spp,
            seconds: result.render_seconds,
            metrics: m,
            speedup: 1.0,
            // None where the reference's own error is not below this run's: the difference
            // was written as a negative MSE, and its speed-up left out without a word (an
            // audit, 2026-12-06); `unresolved` says so.
            corrected: reference_noise
                .filter(|n| m.mse > n.mse && m.rel_mse > n.rel_mse)
                .map(|n| Metrics {
                    mse: m.mse - n.mse,
                    rel_mse: m.rel_mse - n.rel_mse,
                    rmse: (m.mse - n.mse).sqrt(),
                }),
            speedup_corrected: None,
            zero_sample_fraction: result.zero_sample_fraction(),
            invalid_samples: result.invalid_samples,
            zero_map: result.zero_sample_map(),
            convergence,
            image,
        });
    }
    let base = runs[0].metrics.mse;
    let base_corrected = runs[0].corrected.map(|c| c.mse);
    for r in &mut runs {
        r.speedup = if r.metrics.mse > 0.0 {
            base / r.metrics.mse
        } else {
            f64::INFINITY
        };
        r.speedup_corrected = match (base_corrected, r.corrected) {
            (Some(b), Some(c)) if b > 0.0 && c.mse > 0.0 => Some(b / c.mse),
            _ => None,
        };
    }
    let (kind, budget_seconds, budget_spp) = match budget {
        Budget::Seconds(s) => ("equal time", Some(s), None),
        Budget::Samples(n) => ("equal samples", None, Some(n)),
    };
    let mut c = Comparison {
        kind,
        budget_seconds,
        budget_spp,
        runs,
        warning: None,
    };
    let warnings: Vec<String> = [
        over_budget(&c),
        film_full(&c),
        invalid_samples(&c),
        unresolved(&c, reference_noise),
    ]
    .into_iter()
    .flatten()
    .collect();
    c.warning = (!warnings.is_empty()).then(|| warnings.join("; "));
    Ok(c)
}

/// A warning where an equal-time comparison is not one: a render stops at a pass's end, so
/// a `--time` below a sampler's first pass (or a dispatch of them) lets it run over, and
/// the speed-ups then compare unequal times with no word (`compare --time 0.0005` at 32×24:
/// 1.5 and 1.8 ms against 0.5, exit 0; an audit, 2026-12-06). Half the budget again is
/// allowed: a pass's end does not meet the budget exactly.
fn over_budget(c: &Comparison) -> Option<String> {
    let t = c.budget_seconds?;
    let over: Vec<String> = c
        .runs
        .iter()
        .filter(|r| r.seconds > 1.5 * t)
        .map(|r| format!("{} {:.3} s ({} spp)", r.sampler.name(), r.seconds, r.spp))
        .collect();
    if over.is_empty() {
        return None;
    }
    Some(format!(
        "equal time is not equal here: {} against --time {} s (a render stops at the end of a pass, and on a cold shader cache its first pass holds lavapipe's kernel compile), so their speed-ups compare longer renders; give a longer --time",
        over.join(", "),
        seconds(t)
    ))
}

/// A number of seconds as given, in exponent form where Rust would write it out in hundreds
/// of digits (1e-300: an audit, 2026-12-06; the report's heading too, 2026-12-07).
pub fn seconds(t: f64) -> String {
    if (1e-6..1e9).contains(&t) {
        format!("{t}")
    } else {
        format!("{t:e}")
    }
}

/// A warning where a run stopped short of `--time` because its film was full (2^20 samples
/// a pixel, [`crate::render::MAX_FILM_SPP`]): the speed-ups then compare unequal times
/// (a 1×1 `--time 15` stopped at 6.2 and 4.9 s and reported "speed-up 1.00" without a
/// word: a review, 2026-12-07).
fn film_full(c: &Comparison) -> Option<String> {
    let t = c.budget_seconds?;
    let full: Vec<String> = (c.runs.iter())
        .filter(|r| crate::render::filled_before(t, r.spp, r.seconds))
        .map(|r| format!("{} {:.3} s", r.sampler.name(), r.seconds))
        .collect();
    (!full.is_empty()).then(|| {
        format!(
            "equal time is not equal here: {} stopped at a full film ({} samples a pixel) before --time {t} s; give a shorter --time or a larger image",
            full.join(", "),
            crate::render::MAX_FILM_SPP
        )
    })
}

/// A warning where the reference is too noisy to measure a run by: its own estimated MSE
/// is half that run's measured MSE or more, so the corrected numbers rest on the estimate
/// more than on the run (and where it is not below it, there are none).
fn unresolved(c: &Comparison, noise: Option<Metrics>) -> Option<String> {
    let n = noise?;
    let weak: Vec<String> = (c.runs.iter())
        .filter(|r| 2.0 * n.mse >= r.metrics.mse || r.corrected.is_none())
        .map(|r| {
            format!(
                "{} (MSE {:.2e}{})",
                r.sampler.name(),
                r.metrics.mse,
                if r.corrected.is_none() {
                    ", no corrected numbers"
                } else {
                    ""
                }
            )
        })
        .collect();
    (!weak.is_empty()).then(|| {
        format!(
            "the reference's own error (MSE {:.2e}) is half or more of {}: the comparison cannot resolve them; use a larger --reference-spp",
            n.mse,
            weak.join(", ")
        )
    })
}

/// A warning where a sampler's render dropped NaN/Inf samples: its MSE is then that of a
/// darker image, which `render` says and `compare` did not (an audit, 2026-12-06).
fn invalid_samples(c: &Comparison) -> Option<String> {
    let bad: Vec<String> = c
        .runs
        .iter()
        .filter(|r| r.invalid_samples > 0)
        .map(|r| format!("{} {}", r.sampler.name(), r.invalid_samples))
        .collect();
    (!bad.is_empty()).then(|| {
        format!(
            "samples came out NaN/Inf and were dropped ({}), so those errors are not the sampler's; please report this scene",
            bad.join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_match_their_definitions() {
        let r = [[1.0, 0.0, 0.5], [0.2, 0.2, 0.2]];
        let x = [[1.1, 0.1, 0.5], [0.2, 0.0, 0.2]];
        let m = metrics(&x, &r);
        // Expected values from the same f32 inputs, summed in f64.
        let (mut se, mut rel) = (0f64, 0f64);
        for p in 0..2 {
            for k in 0..3 {
                let d = x[p][k] as f64 - r[p][k] as f64;
                se += d * d;
                rel += d * d / ((r[p][k] as f64).powi(2) + 0.01);
            }
        }
        assert!((m.mse - se / 6.0).abs() < 1e-15);
        assert!((m.rel_mse - rel / 6.0).abs() < 1e-15);
        // And against the definition by hand: errors 0.1, 0.1, 0.2 (up to f32 rounding).
        assert!((m.mse - 0.06 / 6.0).abs() < 1e-7, "{}", m.mse);
        let by_hand = (0.01 / 1.01 + 0.01 / 0.01 + 0.04 / 0.05) / 6.0;
        assert!((m.rel_mse - by_hand).abs() < 1e-6, "{}", m.rel_mse);
        assert!((m.rmse - m.mse.sqrt()).abs() < 1e-12);
        assert_eq!(metrics(&r, &r), Metrics::default());
    }

    #[test]
    fn schedules_end_at_the_budget() {
        match schedule(Budget::Samples(100)) {
            Checkpoints::Samples(v) => assert_eq!(v, [1, 2, 4, 8, 16, 32, 64, 100]),
            _ => unreachable!(),
        }
        match schedule(Budget::Seconds(8.0)) {
            Checkpoints::Seconds(v) => {
                assert_eq!(v.len(), 9);
                assert_eq!(*v.last().unwrap(), 8.0);
                assert!((v[0] - 8.0 / 256.0).abs() < 1e-12);
            }
            _ => unreachable!(),
        }
    }
}
