//! `variance`: where each sampler's variance comes from (src/commands/variance.rs).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use super::{DeviceArgs, LearnArgs, RegionArgs};
use lightlearn::commands::variance::VarianceRequest;
use lightlearn::commands::{self, Ui};
use lightlearn::render::LightSampler;

#[derive(Args)]
pub struct VarianceArgs {
    /// glTF 2.0 scene (untextured Lambertian materials). Default: the built-in scene.
    pub scene: Option<PathBuf>,
    /// Comma-separated samplers, each decomposed (learned ones learning from scratch over
    /// --spp passes).
    #[arg(long, default_value = "wang,donikian,bayes")]
    pub samplers: String,
    /// Also decompose `bayes` with statistics learned over N spp and then frozen (the
    /// ceiling of the model as built).
    #[arg(long, value_name = "N")]
    pub converge: Option<u32>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 128)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 96)]
    pub height: u32,
    /// Samples per pixel of each measuring render and of the learning from scratch.
    #[arg(long, default_value_t = 256, value_name = "N")]
    pub spp: u32,
    /// Seed of the random numbers (the same seed gives the same numbers).
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Decompose every K-th pixel in x and in y.
    #[arg(long, default_value_t = 2, value_name = "K")]
    pub stride: u32,
    /// Jittered first hits per decomposed pixel (the footprint term needs ≥ 2).
    #[arg(long, default_value_t = 16, value_name = "J")]
    pub hits: u32,
    /// Shadow rays per triangle light at each hit (the exact terms' own noise is corrected
    /// for; more rays only make it smaller).
    #[arg(long, default_value_t = 32, value_name = "A")]
    pub area_samples: u32,
    /// Above 1: also measure the path-traced variance at this depth, and its ratio to the
    /// direct light's (not a split by vertex: at depth > 1 the first vertex also takes
    /// MIS-weighted BSDF rays, so its own estimator differs).
    #[arg(long, default_value_t = 1, value_name = "D")]
    pub max_depth: u32,
    /// Folder for variance.json and per-pixel maps (rowN.exr: channels cluster, light,
    /// point, footprint, value, and measured: the two-seed estimate of the same variance).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// No progress (the table on stdout, warnings and errors are still printed).
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub regions: RegionArgs,
    #[command(flatten)]
    pub learn: LearnArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

impl VarianceArgs {
    pub fn run(&self, ui: &mut dyn Ui) -> Result<String> {
        let samplers = if self.samplers.is_empty() {
            Vec::new()
        } else {
            LightSampler::parse_list(&self.samplers)?
        };
        let req = VarianceRequest {
            scene: self.scene.clone(),
            samplers,
            converge: self.converge,
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            stride: self.stride,
            hits: self.hits,
            area_samples: self.area_samples,
            max_depth: self.max_depth,
            regions: self.regions.settings()?,
            learn: self.learn.settings()?,
            device: self.device.options(),
            out: self.out.clone(),
        };
        Ok(commands::variance::run(&req, ui)?.table)
    }
}
