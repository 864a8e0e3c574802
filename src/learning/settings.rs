//! The learned samplers' settings (`--update-every`, the priors, `--regression`, …) with their
//! ranges, and the kernel's push-constant block built from them.

use anyhow::{bail, Result};

use super::{node_d2, UpdateEvery};
use crate::abi::{
    LearnParams, LEARN_BRDF, LEARN_BRDF_SELECT, LEARN_CONTROL_VARIATES, LEARN_DEFENSIVE,
    LEARN_PRIORS, LEARN_REFINE, LEARN_REGRESSION, LEARN_REGRESS_IMPORTANCE, LEARN_TARGET_MEAN,
};

/// Settings of the learned samplers; defaults are docs/method.md's [ours] values.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LearnSettings {
    /// When the observations are folded into the posteriors.
    pub update_every: UpdateEvery,
    /// What a cluster's contribution is regressed on (docs/method.md §3).
    pub regression: Regression,
    /// Sample ∝ the learned mean instead of sqrt(mean² + variance).
    pub target_mean: bool,
    /// Use the priors (off: all pseudo-counts 0, divisions guarded).
    pub priors: bool,
    /// The observation includes the BRDF (as luminance).
    pub brdf_aware: bool,
    /// `--brdf-select` (on by default): each slot's weight × the BRDF towards the slot's
    /// cluster (render kernel only; the CPU mirrors and `light_sample.comp` use factor 1).
    pub brdf_select: bool,
    /// `bayes`: the pixel estimate subtracts the model's predicted mean as a control variate
    /// (docs/method.md §6).
    pub control_variates: bool,
    /// Beta prior pseudo-counts of zero and non-zero observations (n̄_o, n̄_v).
    pub prior_zero: f32,
    pub prior_nonzero: f32,
    /// Pseudo-count of the Normal prior on k (n̄) and the Inv-Gamma shape (n̄_α).
    pub prior_n: f32,
    pub prior_alpha: f32,
    /// Prior coefficient of variation c_v: β = n̄_α (c_v μ0)².
    pub prior_cv: f32,
    /// `donikian`: weight λ of the unoccluded estimate in the defensive mixture.
    pub lambda: f32,
    /// The prior mean is μ0 = Ĩ_C(x) · d² · prior_scale: Ĩ counts power Φ, while the
    /// observation y = Î d² ≈ Φ/π for a one-sided area light and Φ/(4π) for a point light
    /// (by importance μ0 = prior_scale · brdf: y = Î / Ĩ is a share).
    pub prior_scale: f32,
    /// Learned cut refinement (`--refine-cuts N`, 0 = off): at each growth point a region
    /// splits up to N of its clusters whose observations vary the most into their two
    /// children (src/render/refine.rs).
    pub refine_cuts: u32,
    /// `bayes`: a slot with no observation of its own borrows up to this many
    /// pseudo-observations of the same node from its neighbouring regions (`--pool-priors`,
    /// 0 = off; src/learning/pooling.rs).
    pub pool_priors: f32,
    /// `bayes`: ε of the defensive mixture (`--defensive ε`): clusters are drawn with
    /// (1 − ε) × the learned pmf + ε × `wang`'s (learning.glsl), so none gets less than ε
    /// times the chance `wang` gives it. 0: the learned pmf alone.
    pub defensive: f32,
}

/// The regression of a cluster's contribution Î_C at a shading point x: the model learns
/// y = Î_C · d2 with the regressor 1/d2 (docs/method.md §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Regression {
    /// d2 ≡ 1: one constant per slot.
    Off,
    /// d2 = the clamped squared distance to the cluster (the paper's).
    Distance,
    /// d2 = 1 / Ĩ_C(x), the cluster's unoccluded importance at x (*ours*): y is the share
    /// of the unoccluded estimate that arrives, so the cosine bounds that vary across a
    /// region are not in what is learned. Equal spp against `distance`: strings 1.29×
    /// less variance (paths 1.47×), strings5k 1.42× (2.31×), the other committed and
    /// outside scenes 0.99–1.07× (docs/results.md, 2026-12-04, sixth session).
    Importance,
}

impl Regression {
    /// The d2 of a slot whose node is `nd`, with unoccluded importance `imp` > 0 at `p`
    /// (learning.glsl `bayes_slot_weight` and `sample_learned`, the same f32 arithmetic).
    pub fn d2(self, nd: &crate::abi::LightNode, imp: f32, p: glam::Vec3) -> f32 {
        match self {
            Regression::Off => 1.0,
            Regression::Distance => node_d2(nd, p),
            Regression::Importance => 1.0 / imp,
        }
    }
}

impl Default for LearnSettings {
    fn default() -> Self {
        LearnSettings {
            update_every: UpdateEvery::Auto,
            regression: Regression::Importance,
            target_mean: false,
            priors: true,
            brdf_aware: false,
            brdf_select: true,
            control_variates: false,
            prior_zero: 2.0,
            prior_nonzero: 2.0,
            prior_n: 1.0,
            prior_alpha: 1.0,
            prior_cv: 1.0,
            lambda: 0.1,
            // 1/(4π), exact for point lights; Ĩ bounds the cosines from above, so even for
            // area lights (exact: 1/π) the smaller prior mean measured better. Equal time,
            // 20 s, 128×96, noise-corrected MSE(wang)/MSE(bayes): rooms16 3.47 → 5.19, city
            // 6.50 → 8.84 (ci/bench_learning.sh ablation setting).
            prior_scale: 1.0 / (4.0 * std::f32::consts::PI),
            refine_cuts: 0,
            // Measured 1.29× less variance on city at 64 spp (1.14× at 256, 1.35× path
            // traced), cornell40 1.14–1.19×, city10k 1.07–1.08×, even elsewhere, strings
            // 7–9 % worse without each run's ten worst pixels (direct light, 128×96,
            // docs/results.md 2026-12-04); 8 was no better.
            pool_priors: 4.0,
            defensive: 0.0,
        }
    }
}

/// The largest prior pseudo-count (`--prior-zero`, `--prior-nonzero`, `--prior-n`,
/// `--prior-alpha`, `--pool-priors`) that [`LearnSettings::check`] accepts.
pub const MAX_PRIOR_COUNT: f32 = 1e6;
/// The largest `--prior-cv`.
pub const MAX_PRIOR_CV: f32 = 1e3;
/// The smallest pseudo-count (`--prior-zero`, `--prior-nonzero`, `--prior-n`) and
/// `--prior-scale` that [`LearnSettings::check`] accepts. Below them a prior is so sure that
/// a cluster gives nothing that, once seen dark, its weight falls ~1e-9 under its
/// neighbours' and the render never draws it again: unbiased in expectation, but the light
/// is missing from any image of practical length. Measured (rooms16, 16×12, 1024 spp,
/// `--stratify off`, direct; image mean against `power`'s 0.1603): `--prior-scale 1e-10`
/// 0.0954 (40 % of the light missing, exit 0, an audit 2026-12-06), 1e-6 0.263 (the tail's
/// rare samples), 1e-5 0.1594, 1e-4 0.1598, 1e-3 0.1602; `--prior-nonzero 1e-30 --prior-zero
/// 1e6` 0.097, `--prior-nonzero 1e-6` 0.1728, `1e-3 --prior-zero 1e6` 0.1603.
pub const MIN_PRIOR_COUNT: f32 = 1e-3;
pub const MIN_PRIOR_SCALE: f32 = 1e-4;

impl LearnSettings {
    pub fn check(&self) -> Result<()> {
        if self.update_every == UpdateEvery::Passes(0) {
            bail!("--update-every must be at least 1 (pass)");
        }
        // Upper bounds keep the weights' f32 arithmetic finite (a t² with t up to 1e15 in
        // posterior.glsl): --prior-cv 1e20 overflowed h² = α cv² / (α − ½) and every learned
        // sample was dropped as NaN, a black image with exit 0. Pseudo-counts past 1e6
        // observations, or a prior spread of 1000 times its mean, are no longer priors.
        // Lower bounds: MIN_PRIOR_COUNT says why.
        for (name, v, min, max) in [
            (
                "--prior-zero",
                self.prior_zero,
                MIN_PRIOR_COUNT,
                MAX_PRIOR_COUNT,
            ),
            (
                "--prior-nonzero",
                self.prior_nonzero,
                MIN_PRIOR_COUNT,
                MAX_PRIOR_COUNT,
            ),
            ("--prior-n", self.prior_n, MIN_PRIOR_COUNT, MAX_PRIOR_COUNT),
            ("--prior-cv", self.prior_cv, 0.0, MAX_PRIOR_CV),
        ] {
            let above_min = if min > 0.0 { v >= min } else { v > 0.0 };
            if !(v.is_finite() && above_min && v <= max) {
                let from = if min > 0.0 {
                    format!("from {min}")
                } else {
                    "above 0".into()
                };
                bail!("{name} {v} is out of range: use a number {from} up to {max} (--priors off for no priors)");
            }
        }
        // ĥ = β'/(α' − ½) must be finite before any data.
        if !(self.prior_alpha.is_finite()
            && self.prior_alpha > 0.5
            && self.prior_alpha <= MAX_PRIOR_COUNT)
        {
            bail!(
                "--prior-alpha {} is out of range: use a number above 0.5 (the variance estimate is β/(α − ½)) up to {MAX_PRIOR_COUNT}",
                self.prior_alpha
            );
        }
        if !(self.pool_priors.is_finite()
            && self.pool_priors >= 0.0
            && self.pool_priors <= MAX_PRIOR_COUNT)
        {
            bail!(
                "--pool-priors {} is out of range: use a number of observations from 0 (off) to {MAX_PRIOR_COUNT}",
                self.pool_priors
            );
        }
        if !(self.prior_scale.is_finite()
            && self.prior_scale >= MIN_PRIOR_SCALE
            && self.prior_scale <= 1e6)
        {
            bail!(
                "--prior-scale {} is out of range: use a number from {MIN_PRIOR_SCALE} up to 1e6 (the default 1/(4π) is exact for point lights)",
                self.prior_scale
            );
        }
        if !(self.defensive.is_finite() && (0.0..1.0).contains(&self.defensive)) {
            bail!(
                "--defensive {} is out of range: use a fraction in [0, 1) (0: off; 1 would be wang)",
                self.defensive
            );
        }
        if !(self.lambda > 0.0 && self.lambda <= 1.0) {
            bail!(
                "--lambda {} is out of range: use (0, 1] (0 would starve clusters: biased)",
                self.lambda
            );
        }
        Ok(())
    }

    /// The kernel's copy.
    pub fn gpu_params(&self) -> LearnParams {
        let flag = |on: bool, f: u32| if on { f } else { 0 };
        LearnParams {
            prior_zero: self.prior_zero,
            prior_nonzero: self.prior_nonzero,
            prior_n: self.prior_n,
            prior_alpha: self.prior_alpha,
            prior_cv: self.prior_cv,
            lambda: self.lambda,
            flags: flag(self.regression != Regression::Off, LEARN_REGRESSION)
                | flag(self.target_mean, LEARN_TARGET_MEAN)
                | flag(self.priors, LEARN_PRIORS)
                | flag(self.brdf_aware, LEARN_BRDF)
                | flag(self.brdf_select, LEARN_BRDF_SELECT)
                | flag(self.control_variates, LEARN_CONTROL_VARIATES)
                | flag(
                    self.regression == Regression::Importance,
                    LEARN_REGRESS_IMPORTANCE,
                )
                | flag(self.defensive > 0.0, LEARN_DEFENSIVE)
                | flag(self.refine_cuts > 0, LEARN_REFINE),
            prior_scale: self.prior_scale,
            defensive: self.defensive,
        }
    }
}
