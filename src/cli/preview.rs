//! `preview`: the interactive window.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use super::{sampler_parser, DeviceArgs, LearnArgs, RegionArgs};
use lightlearn::render::LightSampler;

#[derive(Args)]
pub struct PreviewArgs {
    /// glTF 2.0 scene. Default: the built-in scene.
    pub scene: Option<PathBuf>,
    #[arg(long, default_value = "bayes", value_parser = sampler_parser())]
    pub sampler: LightSampler,
    /// Window width in pixels (the film's at rest).
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Surface vertices of a path (1 = direct light; G toggles).
    #[arg(long, default_value_t = 1, value_name = "D")]
    pub max_depth: u32,
    #[command(flatten)]
    pub sampling: super::SamplingArgs,
    #[command(flatten)]
    pub regions: RegionArgs,
    #[command(flatten)]
    pub learn: LearnArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

impl PreviewArgs {
    pub fn request(&self) -> Result<lightlearn::preview::PreviewRequest> {
        lightlearn::commands::check_size(self.width, self.height)?;
        Ok(lightlearn::preview::PreviewRequest {
            scene: self.scene.clone(),
            sampler: self.sampler,
            width: self.width,
            height: self.height,
            seed: self.seed,
            max_depth: self.max_depth,
            light_point: self.sampling.light_point,
            stratify: self.sampling.stratify,
            regions: self.regions.settings()?,
            learn: self.learn.settings()?,
            device: self.device.options(),
        })
    }
}
