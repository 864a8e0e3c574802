//! The arguments of the light samplers' regions, cuts and learning (`--grid`, `--tau`,
//! `--k-max`, `--update-every`, the priors, …), shared by every command that renders, and
//! their conversion into the library's settings.

use anyhow::Result;
use clap::Args;

use lightlearn::learning::{LearnSettings, Regression, UpdateEvery};
use lightlearn::lights::regions::RegionSettings;

/// Regions and cuts (docs/method.md §2), used by `--sampler wang`.
#[derive(Args)]
pub struct RegionArgs {
    /// Region grid: cells along the longest axis of the scene bounds.
    #[arg(long, default_value_t = 32)]
    pub grid: u32,
    /// Split each cell by the dominant axis and sign of the shading normal (6 bins).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub normal_bins: String,
    /// Refine a cut until its largest cluster's importance ≤ τ × the cut's total.
    #[arg(long, default_value_t = 0.02)]
    pub tau: f32,
    /// At most this many clusters per cut (1..=64).
    #[arg(long, default_value_t = 32)]
    pub k_max: u32,
    /// How a chosen cluster picks its light: by importance at the shading point (a light-BVH
    /// descent of the cluster's subtree; measured better on rooms16 and city) or by power
    /// (Wang & Åkerlund 2009 as published).
    #[arg(long, default_value = "importance", value_parser = ["importance", "power"])]
    pub in_cluster: String,
    /// The regions of a block of 2×2×2 cells (one normal bin) that holds no light share one
    /// cut and one set of statistics; near lights each region keeps its own. Measured: the
    /// same variance (0.96–1.04× on ten scenes), 0.84× the time on cornell40 (3.7× fewer
    /// slots), elsewhere within the noise (docs/results.md, seventh session).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub coarse_blocks: String,
}

impl RegionArgs {
    pub fn settings(&self) -> Result<RegionSettings> {
        let s = RegionSettings {
            grid: self.grid,
            normal_bins: self.normal_bins == "on",
            tau: self.tau,
            k_max: self.k_max,
            in_cluster_importance: self.in_cluster == "importance",
            coarse_blocks: self.coarse_blocks == "on",
        };
        s.check()?;
        Ok(s)
    }
}

/// The learned samplers (`--sampler bayes|donikian`, docs/method.md §3–§8).
#[derive(Args)]
pub struct LearnArgs {
    /// Fold new observations into the posteriors every K passes (1 pass = 1 spp); auto:
    /// every pass up to pass 16, then windows of 2, 4, 8 and (from pass 128) 16 passes,
    /// counted from the last camera move, resize or farm chunk start.
    #[arg(long, default_value = "auto", value_name = "K|auto")]
    pub update_every: UpdateEvery,
    /// bayes: what a cluster's contribution is regressed on across its region. importance:
    /// its unoccluded importance at the shading point (wang's weight), so what is learned is
    /// the share that arrives (measured on strings 1.29× less variance direct, 1.47× path
    /// traced; 0.99–1.07× elsewhere);
    /// distance: 1/d² (the paper's; `on` is its old name); off: one constant per slot.
    #[arg(long, default_value = "importance", value_parser = ["importance", "distance", "on", "off"])]
    pub regression: String,
    /// bayes: pick clusters ∝ sqrt(mean² + variance) (the method) or ∝ the mean.
    #[arg(long, default_value = "sqrt", value_parser = ["sqrt", "mean"])]
    pub target: String,
    /// bayes: Beta and Normal-inverse-gamma priors from the unoccluded estimate (off: no
    /// pseudo-counts; divisions guarded, a slot never seen lit keeps chance ≥ 1/(n+1)).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub priors: String,
    /// bayes: observations include the BRDF towards the sampled light (luminance of f(v, l)), so glossy receivers learn the reflected contribution; the prior uses the BRDF's albedo / π.
    #[arg(long)]
    pub brdf_aware: bool,
    /// bayes: multiply each cluster's learned weight by the BRDF at the shading point towards
    /// the cluster (its direction nearest the mirror direction, plus a floor of 0.1 × albedo/π
    /// so no cluster drops to 0); observations stay BRDF-free. Only glossy materials change
    /// (measured 2.0× and 3.5× better than off at equal time on two glossy scenes; docs/results.md).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub brdf_select: String,
    /// bayes: subtract the model's predicted mean of every cluster as a control variate
    /// (unbiased; measured 1.4× better on rooms16, no gain on city, so off by default; see
    /// docs/results.md).
    #[arg(long)]
    pub control_variates: bool,
    /// bayes: Beta prior pseudo-count of zero observations (n̄_o).
    #[arg(long, default_value_t = 2.0)]
    pub prior_zero: f32,
    /// bayes: Beta prior pseudo-count of non-zero observations (n̄_v).
    #[arg(long, default_value_t = 2.0)]
    pub prior_nonzero: f32,
    /// bayes: pseudo-count of the Normal prior on the regression constant (n̄).
    #[arg(long, default_value_t = 1.0)]
    pub prior_n: f32,
    /// bayes: shape of the inverse-gamma prior on the variance (n̄_α).
    #[arg(long, default_value_t = 1.0)]
    pub prior_alpha: f32,
    /// bayes: prior coefficient of variation c_v (β = n̄_α (c_v μ0)²).
    #[arg(long, default_value_t = 1.0)]
    pub prior_cv: f32,
    /// donikian: weight of the unoccluded estimate in the defensive mixture.
    #[arg(long, default_value_t = 0.1)]
    pub lambda: f32,
    /// bayes: prior mean μ0 = Ĩ · d² · S (S itself by --regression importance), Ĩ's power in the units of the observations
    /// [default: 1/(4π), exact for point lights (1/π would be for one-sided area lights);
    /// measured better on rooms16 and city, see docs/results.md].
    #[arg(long, value_name = "S")]
    pub prior_scale: Option<f32>,
    /// bayes/donikian: learned cut refinement. Observations are also counted by the child
    /// of the cluster they came through, and at each growth point (passes 1, 2, 4, …, 32,
    /// then every 64) a region splits up to N of its clusters into their two children where
    /// the children's observations differ enough that drawing them apart saves more than the
    /// longer cut costs (≥ 64 observations); the children inherit the cluster's statistics as
    /// their prior, up to 64 clusters (--k-max caps the cut as built). 0: cuts never change
    /// (the default: at equal time 1.05× on rooms36, 1.01× on rooms16, and 1–7 % lost where
    /// little splits; docs/results.md). A continuation (--load-stats) refines from its own
    /// counts, so it is not the uninterrupted run bit for bit (still unbiased).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub refine_cuts: u32,
    /// bayes: a cluster slot with no observation of its own borrows up to N observations of
    /// the same cluster from the regions around it (the same 4×4×4 block of grid cells and
    /// normal bin), recomputed at each growth point until it has data of its own, within the
    /// first 256 passes counted from the last camera move, resize or farm chunk start
    /// (dropped after); they move only its posterior. Measured 1.29× less variance on city at 64 spp (1.14× at 256),
    /// 7–9 % more on strings; 0: off.
    #[arg(long, default_value_t = 4.0, value_name = "N")]
    pub pool_priors: f32,
    /// bayes: defensive mixture. Clusters are drawn with (1 − ε) × the learned pmf + ε ×
    /// wang's, so none gets less than ε times wang's chance. 0: off.
    #[arg(long, default_value_t = 0.0, value_name = "ε")]
    pub defensive: f32,
}

impl RegionArgs {
    /// These options as a command line gives them (for the farm's task commands).
    pub fn to_args(&self) -> Vec<String> {
        [
            ("--grid", self.grid.to_string()),
            ("--normal-bins", self.normal_bins.clone()),
            ("--tau", self.tau.to_string()),
            ("--k-max", self.k_max.to_string()),
            ("--in-cluster", self.in_cluster.clone()),
            ("--coarse-blocks", self.coarse_blocks.clone()),
        ]
        .into_iter()
        .flat_map(|(k, v)| [k.to_string(), v])
        .collect()
    }
}

impl LearnArgs {
    /// These options as a command line gives them (for the farm's task commands).
    pub fn to_args(&self) -> Vec<String> {
        let mut a: Vec<String> = [
            ("--update-every", self.update_every.to_string()),
            ("--regression", self.regression.clone()),
            ("--target", self.target.clone()),
            ("--priors", self.priors.clone()),
            ("--brdf-select", self.brdf_select.clone()),
            ("--prior-zero", self.prior_zero.to_string()),
            ("--prior-nonzero", self.prior_nonzero.to_string()),
            ("--prior-n", self.prior_n.to_string()),
            ("--prior-alpha", self.prior_alpha.to_string()),
            ("--prior-cv", self.prior_cv.to_string()),
            ("--lambda", self.lambda.to_string()),
            ("--refine-cuts", self.refine_cuts.to_string()),
            ("--pool-priors", self.pool_priors.to_string()),
            ("--defensive", self.defensive.to_string()),
        ]
        .into_iter()
        .flat_map(|(k, v)| [k.to_string(), v])
        .collect();
        if let Some(s) = self.prior_scale {
            a.extend(["--prior-scale".to_string(), s.to_string()]);
        }
        for (on, flag) in [
            (self.brdf_aware, "--brdf-aware"),
            (self.control_variates, "--control-variates"),
        ] {
            if on {
                a.push(flag.to_string());
            }
        }
        a
    }

    pub fn settings(&self) -> Result<LearnSettings> {
        let s = LearnSettings {
            update_every: self.update_every,
            regression: match self.regression.as_str() {
                "importance" => Regression::Importance,
                "distance" | "on" => Regression::Distance,
                _ => Regression::Off,
            },
            target_mean: self.target == "mean",
            priors: self.priors == "on",
            brdf_aware: self.brdf_aware,
            brdf_select: self.brdf_select == "on",
            control_variates: self.control_variates,
            prior_zero: self.prior_zero,
            prior_nonzero: self.prior_nonzero,
            prior_n: self.prior_n,
            prior_alpha: self.prior_alpha,
            prior_cv: self.prior_cv,
            lambda: self.lambda,
            prior_scale: self
                .prior_scale
                .unwrap_or(LearnSettings::default().prior_scale),
            refine_cuts: self.refine_cuts,
            pool_priors: self.pool_priors,
            defensive: self.defensive,
        };
        s.check()?;
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{CommandFactory, Parser};

    #[derive(Parser)]
    struct Both {
        #[command(flatten)]
        regions: RegionArgs,
        #[command(flatten)]
        learn: LearnArgs,
    }

    /// The farm's tasks get these options through `to_args`: every flag must be there
    /// (`farm --coarse-blocks off` rendered its chunks with coarse blocks on: an audit,
    /// 2026-12-06). Flags that are optional or switches are set, so they are written too.
    #[test]
    fn to_args_names_every_flag() {
        let b = Both::parse_from([
            "x",
            "--prior-scale",
            "0.5",
            "--brdf-aware",
            "--control-variates",
        ]);
        let given = [b.regions.to_args(), b.learn.to_args()].concat();
        for a in Both::command().get_arguments() {
            let Some(long) = a.get_long() else { continue };
            if long == "help" {
                continue;
            }
            let flag = format!("--{long}");
            assert!(
                given.contains(&flag),
                "to_args leaves out {flag}: {given:?}"
            );
        }
    }
}
