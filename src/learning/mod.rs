//! Online learning of cluster selection (docs/method.md §3–§8): the Bayesian posterior of one
//! (region, cut slot) and the sampling weights built from it; the settings of the `bayes` and
//! `donikian` samplers (settings.rs), their windows (schedule.rs), borrowed evidence for cold
//! slots (pooling.rs) and the saved-statistics file (stats_file.rs).
//!
//! Where the work happens: the render kernel adds every observation to the slot's window sums
//! with integer atomics (`shaders/shared/learning.glsl`), and between passes `fold.comp` folds
//! the window into the frozen totals on the GPU. The posterior itself is never stored: the
//! kernel evaluates it from the totals at each shading point, because the prior mean depends
//! on x (below). This module is the CPU mirror the tests check the kernels against.
//!
//! One deviation from docs/method.md §3, and why: the prior mean μ0 is the unoccluded estimate at
//! the shading point x (Ĩ_C(x) · d_C(x)² / π), not at the region centre. With it the `bayes`
//! pmf before any data is exactly ∝ Ĩ_C(x), i.e. learning starts exactly where `wang` is
//! (the test), and no region-centre estimate can be zero for a slot that lights x.

pub mod pooling;
mod schedule;
mod settings;
pub mod stats_file;
mod stats_merge;

pub use schedule::{LearningClock, UpdateEvery};
pub use settings::*;

use crate::abi::{SlotDelta, SlotStats};

/// The posterior of one slot (docs/method.md §3), in f64: Beta(a, b) on p0 and
/// Normal-inverse-gamma (μ, κ, α, β) on (k, h).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Posterior {
    pub a: f64,
    pub b: f64,
    pub kappa: f64,
    pub mu: f64,
    pub alpha: f64,
    pub beta: f64,
    /// Without priors: 1 − p̂0 is kept ≥ 1/(n + 1) (a slot never seen lit keeps a chance).
    pub priors: bool,
}

impl Posterior {
    /// From the totals of a slot and the prior mean μ0 of y at the shading point.
    pub fn new(s: &SlotStats, mu0: f64, l: &LearnSettings) -> Posterior {
        let (nz, nv) = (s.n_zero as f64, s.n_nonzero as f64);
        let (s1, s2) = (s.sum as f64, s.sum_sq as f64);
        let p = l.priors;
        let pick = |v: f32| if p { v as f64 } else { 0.0 };
        let (a0, b0, nbar, abar) = (
            pick(l.prior_zero),
            pick(l.prior_nonzero),
            pick(l.prior_n),
            pick(l.prior_alpha),
        );
        let beta0 = if p {
            abar * (l.prior_cv as f64 * mu0).powi(2)
        } else {
            0.0
        };
        let kappa = nbar + nv;
        let mu = if kappa > 0.0 {
            (nbar * mu0 + s1) / kappa
        } else {
            mu0
        };
        // Without priors a slot whose observations all rounded to 0 would starve (biased):
        // it falls back to the unoccluded estimate (the same guard as learning.glsl).
        let mu = if !p && mu <= 0.0 { mu0 } else { mu };
        let ybar = if nv > 0.0 { s1 / nv } else { 0.0 };
        let ss = (s2 - s1 * ybar).max(0.0);
        let shrink = if kappa > 0.0 {
            nbar * nv * (ybar - mu0).powi(2) / (2.0 * kappa)
        } else {
            0.0
        };
        Posterior {
            a: a0 + nz,
            b: b0 + nv,
            kappa,
            mu,
            alpha: abar + 0.5 * nv,
            beta: beta0 + 0.5 * ss + shrink,
            priors: p,
        }
    }

    /// 1 − p̂0: the posterior mean of the chance of a non-zero observation.
    pub fn nonzero_chance(&self) -> f64 {
        let n = self.a + self.b;
        if self.priors {
            self.b / n
        } else if n > 0.0 {
            (self.b / n).max(1.0 / (n + 1.0))
        } else {
            1.0
        }
    }

    /// ĥ = β' / (α − ½): finite before any data, the unbiased sample variance once data
    /// dominate (0 where there is no estimate: no priors and fewer than two samples).
    pub fn h_hat(&self) -> f64 {
        if self.alpha > 0.5 {
            self.beta / (self.alpha - 0.5)
        } else {
            0.0
        }
    }

    /// The weight before the 1/d² factor: sqrt((1 − p̂0)(k̂² + ĥ)), or (1 − p̂0) k̂ for
    /// `target = mean`.
    pub fn weight(&self, target_mean: bool) -> f64 {
        let q = self.nonzero_chance();
        if target_mean {
            q * self.mu
        } else {
            (q * (self.mu * self.mu + self.h_hat())).sqrt()
        }
    }
}

/// The prior mean of y at a shading point from the cluster's unoccluded importance Ĩ and
/// regression distance² d2 (1 without regression): Ĩ · d2 · brdf · prior_scale, and by
/// importance (d2 = 1/Ĩ) brdf · prior_scale, without the round trip through Ĩ.
pub fn prior_mean(importance: f32, d2: f32, brdf: f32, l: &LearnSettings) -> f32 {
    if l.regression == Regression::Importance {
        return brdf * l.prior_scale;
    }
    importance * d2 * brdf * l.prior_scale
}

/// Window sums of the kernel's fixed point: 24 fraction bits of y / scale.
pub const FIX_ONE: f64 = 16_777_216.0;

/// The value of one of the kernel's 64-bit fixed-point sums (its low and high words), in
/// units of the slot's scale (learning.glsl record_observation, render.comp record_side).
pub fn fixed_sum(lo: u32, hi: u32) -> f64 {
    ((hi as u64) << 32 | lo as u64) as f64 / FIX_ONE
}

/// The CPU mirror of `fold.comp` for a slot without borrowed observations ([`fold_with_prior`]).
pub fn fold(s: &SlotStats, d: &SlotDelta, l: &LearnSettings) -> SlotStats {
    fold_with_prior(s, d, &[0.0; 4], l)
}

/// The CPU mirror of `fold.comp`: the window's sums folded into the totals, then the weight
/// coefficients recomputed from the totals plus the slot's borrowed pseudo-observations
/// (`prior`, src/learning/pooling.rs), which the totals never hold (f64 sums here, f32 on the
/// GPU; tests compare within rounding).
pub fn fold_with_prior(
    s: &SlotStats,
    d: &SlotDelta,
    prior: &pooling::SlotPrior,
    l: &LearnSettings,
) -> SlotStats {
    let mut out = *s;
    if out.scale.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        out.scale = 1.0;
    }
    if d.n_zero + d.n_nonzero > 0 {
        let scale = out.scale as f64;
        out.n_zero += d.n_zero as f32;
        out.n_nonzero += d.n_nonzero as f32;
        out.sum = (s.sum as f64 + fixed_sum(d.sum_lo, d.sum_hi) * scale) as f32;
        out.sum_sq = (s.sum_sq as f64 + fixed_sum(d.sq_lo, d.sq_hi) * scale * scale) as f32;
        if out.sum_sq > 0.0 && out.n_nonzero > 0.0 {
            out.scale = (out.sum_sq / out.n_nonzero).sqrt();
        }
    }
    [out.coef_a, out.coef_b, out.coef_c] = coefficients(&with_prior(&out, prior), l);
    out
}

/// The totals the posterior is computed from: the slot's own plus its borrowed ones.
pub fn with_prior(s: &SlotStats, p: &pooling::SlotPrior) -> SlotStats {
    SlotStats {
        n_zero: s.n_zero + p[0],
        n_nonzero: s.n_nonzero + p[1],
        sum: s.sum + p[2],
        sum_sq: s.sum_sq + p[3],
        ..*s
    }
}

/// R = 1 − p̂0 and the regression constant's posterior mean μ = P μ0 + Q · scale: the part
/// the weight and the predicted mean share (`posterior_rpq` in posterior.glsl).
fn posterior_rpq(s: &SlotStats, l: &LearnSettings) -> (f32, f32, f32) {
    let p = l.priors;
    let pick = |v: f32| if p { v } else { 0.0 };
    let (a0, b0, nbar) = (pick(l.prior_zero), pick(l.prior_nonzero), pick(l.prior_n));
    let (nz, nv) = (s.n_zero, s.n_nonzero);
    let n_all = nz + nv;
    let r = if p {
        (b0 + nv) / (a0 + b0 + n_all)
    } else if n_all > 0.0 {
        (nv / n_all).max(1.0 / (n_all + 1.0))
    } else {
        1.0
    };
    let s1 = s.sum / s.scale;
    let kappa = nbar + nv;
    let (mut pp, mut q) = if kappa > 0.0 {
        (nbar / kappa, s1 / kappa)
    } else {
        (1.0, 0.0)
    };
    if !p && q <= 0.0 {
        (pp, q) = (1.0, 0.0);
    }
    (r, pp, q)
}

/// The posterior's predicted mean of y as coefficients of the prior mean:
/// E[y] = (1 − p̂0) μ = c0 μ0 + c1 · scale (`mean_coefficients` in posterior.glsl).
pub fn mean_coefficients(s: &SlotStats, l: &LearnSettings) -> [f32; 2] {
    let (r, pp, q) = posterior_rpq(s, l);
    [r * pp, r * q]
}

/// The control variate of docs/method.md §6 (`predicted_mean` in learning.glsl): the predicted
/// mean of the observation Î_C = y / d² at prior mean mu0, regression distance² di (1
/// without regression) and BRDF factor brdf (1 unless --brdf-aware; 0 gives 0).
pub fn predicted_mean(s: &SlotStats, mu0: f32, di: f32, brdf: f32, l: &LearnSettings) -> f32 {
    if brdf.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return 0.0;
    }
    let c = mean_coefficients(s, l);
    (c[0] * mu0 + c[1] * s.scale).max(0.0) / (di * brdf)
}

/// The bayes weight of a slot as coefficients of its prior mean (posterior.glsl has the
/// derivation): with t = μ0 / scale, w = scale · sqrt(a t² + b t + c), or scale · (a t + b)
/// for `target = mean`. The same f32 arithmetic as the GLSL.
pub fn coefficients(s: &SlotStats, l: &LearnSettings) -> [f32; 3] {
    let pick = |v: f32| if l.priors { v } else { 0.0 };
    let (nbar, abar) = (pick(l.prior_n), pick(l.prior_alpha));
    let nv = s.n_nonzero;
    let (r, pp, q) = posterior_rpq(s, l);
    let sc = s.scale;
    let (s1, s2) = (s.sum / sc, s.sum_sq / (sc * sc));
    let ybar = if nv > 0.0 { s1 / nv } else { 0.0 };
    let kappa = nbar + nv;
    let den = abar + 0.5 * nv - 0.5;
    let (mut h2, mut h0, mut h1) = (0.0, 0.0, 0.0);
    if den > 0.0 {
        h2 = abar * l.prior_cv * l.prior_cv / den;
        h0 = 0.5 * (s2 - s1 * ybar).max(0.0) / den;
        h1 = if kappa > 0.0 {
            nbar * nv / (2.0 * kappa * den)
        } else {
            0.0
        };
    }
    if l.target_mean {
        return [r * pp, r * q, 0.0];
    }
    [
        r * (pp * pp + h2 + h1),
        r * (2.0 * pp * q - 2.0 * h1 * ybar),
        r * (q * q + h0 + h1 * ybar * ybar),
    ]
}

/// The mirror of `bayes_weight` (learning.glsl): the weight before 1/d² at prior mean mu0.
pub fn coefficient_weight(s: &SlotStats, c: [f32; 3], mu0: f32, l: &LearnSettings) -> f32 {
    let t = (mu0 / s.scale).clamp(1e-15, 1e15);
    if l.target_mean {
        return s.scale * (c[0] * t + c[1]).max(0.0);
    }
    let v = (c[0] * t + c[1]) * t + c[2];
    s.scale * if v > 0.0 { v.sqrt() } else { t * c[0].sqrt() }
}

/// What the learning did, for the JSON sidecar.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct LearnDiagnostics {
    /// Regions with their own cut that received at least one observation.
    pub regions_touched: usize,
    /// Regions with a cut (their own, or the one their block shares).
    pub regions_with_cuts: usize,
    /// Distinct cuts (the regions of a block without lights share one).
    pub cuts: usize,
    /// Cut slots (over all regions with a cut) and the fraction that have any observation.
    pub slots: usize,
    pub fraction_slots_with_data: f64,
    /// Mean posterior p̂0 over slots with data (prior pseudo-counts included).
    pub mean_p0: f64,
    /// Observations folded in, and how many samples fell in regions without a cut (those
    /// sample as `wang` from the shared fallback cut and do not learn).
    pub observations: f64,
    pub samples_in_fallback: u64,
    /// GPU memory of the statistics (totals + window sums).
    pub stats_bytes: usize,
}

/// Summarises the totals of every built cut (`cuts[o]` = count, then the slots; `offsets`:
/// the distinct cuts, of `regions` regions).
pub fn diagnostics(
    cuts: &[u32],
    offsets: &[u32],
    regions: usize,
    stats: &[SlotStats],
    l: &LearnSettings,
    samples_in_fallback: u64,
) -> LearnDiagnostics {
    let mut d = LearnDiagnostics {
        regions_with_cuts: regions,
        cuts: offsets.len(),
        samples_in_fallback,
        stats_bytes: stats.len() * 2 * std::mem::size_of::<SlotStats>(),
        ..Default::default()
    };
    let (mut with_data, mut p0_sum) = (0usize, 0f64);
    for &o in offsets {
        let o = o as usize;
        let mut touched = false;
        for s in &stats[o + 1..o + 1 + cuts[o] as usize] {
            d.slots += 1;
            let n = s.n_zero as f64 + s.n_nonzero as f64;
            if n > 0.0 {
                touched = true;
                with_data += 1;
                d.observations += n;
                let (a, b) = if l.priors {
                    (l.prior_zero as f64, l.prior_nonzero as f64)
                } else {
                    (0.0, 0.0)
                };
                p0_sum += (a + s.n_zero as f64) / (a + b + n);
            }
        }
        d.regions_touched += touched as usize;
    }
    d.fraction_slots_with_data = with_data as f64 / d.slots.max(1) as f64;
    d.mean_p0 = if with_data > 0 {
        p0_sum / with_data as f64
    } else {
        f64::NAN
    };
    d
}

/// The CPU mirror of `sample_learned`'s weights (learning.glsl) over the cut at offset `o`:
/// `bayes` (posterior weight / d², × Ĩ by importance, 0 where Ĩ = 0; with `--defensive` the
/// mixture's weights) or `donikian` (its own defensive mixture).
#[allow(clippy::too_many_arguments)]
pub fn learned_weights(
    tree: &crate::lights::tree::LightTree,
    cuts: &[u32],
    o: usize,
    stats: &[SlotStats],
    p: glam::Vec3,
    n: glam::Vec3,
    donikian: bool,
    l: &LearnSettings,
    brdf: f32,
) -> Vec<f32> {
    let cut = &cuts[o + 1..o + 1 + cuts[o] as usize];
    let slots = &stats[o + 1..o + 1 + cut.len()];
    let imp = crate::lights::regions::Cuts::importances(tree, cut, p, n);
    if donikian && o != 0 {
        let count = |s: &SlotStats| s.n_zero + s.n_nonzero;
        let mean = |s: &SlotStats| {
            if count(s) > 0.0 {
                s.sum / count(s)
            } else {
                0.0
            }
        };
        let seen: f32 = slots.iter().map(count).sum();
        let sum_mean: f32 = slots.iter().map(mean).sum();
        let sum_imp: f32 = imp.iter().sum();
        if seen >= cut.len() as f32 && sum_mean > 0.0 && sum_imp > 0.0 {
            return imp
                .iter()
                .zip(slots)
                .map(|(&i, s)| {
                    if i > 0.0 {
                        (1.0 - l.lambda) * mean(s) / sum_mean + l.lambda * i / sum_imp
                    } else {
                        0.0
                    }
                })
                .collect();
        }
        return imp;
    }
    let mut w = per_bayes_slot(tree, cut, slots, &imp, p, l, |s, i, d2| {
        let c = [s.coef_a, s.coef_b, s.coef_c];
        let w = coefficient_weight(s, c, prior_mean(i, d2, brdf, l), l);
        // The weight of y times 1/d2 (learning.glsl: a product by importance).
        if l.regression == Regression::Importance {
            w * i
        } else {
            w / d2
        }
    });
    if l.defensive > 0.0 {
        // The defensive mixture as learning.glsl forms it: w + λ Ĩ, λ = ε/(1 − ε) · W / I
        // (the totals summed in the kernel's order).
        let total: f32 = w.iter().sum();
        let imp_total: f32 = imp.iter().sum();
        if total > 0.0 && imp_total > 0.0 {
            let lambda = l.defensive / (1.0 - l.defensive) * (total / imp_total);
            for (w, &i) in w.iter_mut().zip(&imp) {
                *w += lambda * i;
            }
        }
    }
    w
}

/// `f(slot as fold.comp leaves it, Ĩ, regression d²)` for every slot of a cut whose Ĩ > 0,
/// 0 for the others: the loop the bayes weights and the control variates share.
fn per_bayes_slot(
    tree: &crate::lights::tree::LightTree,
    cut: &[u32],
    slots: &[SlotStats],
    imp: &[f32],
    p: glam::Vec3,
    l: &LearnSettings,
    f: impl Fn(&SlotStats, f32, f32) -> f32,
) -> Vec<f32> {
    cut.iter()
        .zip(imp)
        .zip(slots)
        .map(|((&node, &i), s)| {
            if i <= 0.0 {
                return 0.0;
            }
            let d2 = l.regression.d2(&tree.nodes[node as usize], i, p);
            // What fold.comp leaves in the slot: its coefficients (and a scale of 1 if unset).
            f(&fold(s, &SlotDelta::default(), l), i, d2)
        })
        .collect()
}

/// The CPU mirror of the control variates in `sample_learned` (learning.glsl): every slot's
/// predicted mean g_C of the observation Î_C at (p, n) over the cut at offset `o`, 0 where
/// the bayes weight is 0 (Ĩ = 0: the slot lights nothing here).
#[allow(clippy::too_many_arguments)]
pub fn predicted_means(
    tree: &crate::lights::tree::LightTree,
    cuts: &[u32],
    o: usize,
    stats: &[SlotStats],
    p: glam::Vec3,
    n: glam::Vec3,
    l: &LearnSettings,
    brdf: f32,
) -> Vec<f32> {
    let cut = &cuts[o + 1..o + 1 + cuts[o] as usize];
    let slots = &stats[o + 1..o + 1 + cut.len()];
    let imp = crate::lights::regions::Cuts::importances(tree, cut, p, n);
    per_bayes_slot(tree, cut, slots, &imp, p, l, |s, i, d2| {
        predicted_mean(s, prior_mean(i, d2, brdf, l), d2, brdf, l)
    })
}

/// The regression distance² of a node (the same clamp as the importance's).
pub fn node_d2(nd: &crate::abi::LightNode, p: glam::Vec3) -> f32 {
    crate::lights::bounds::clamped_d2(nd.bmin.into(), nd.bmax.into(), nd.flags, p)
}
