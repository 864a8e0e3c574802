//! `profile`: where a render pass spends its time (src/bench/stages.rs).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use super::{sampler_parser, DeviceArgs, LearnArgs, RegionArgs};
use lightlearn::commands::{self, Ui};
use lightlearn::render::{Budget, LightSampler, RenderSettings};

#[derive(Args)]
pub struct ProfileArgs {
    /// glTF 2.0 scene. Default: the built-in scene.
    pub scene: Option<PathBuf>,
    #[arg(long, default_value = "bayes", value_parser = sampler_parser())]
    pub sampler: LightSampler,
    /// Passes (samples per pixel) timed per variant.
    #[arg(long, default_value_t = 16, value_name = "N")]
    pub spp: u32,
    /// Image width in pixels.
    #[arg(long, default_value_t = 160)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 120)]
    pub height: u32,
    /// Seed of the random numbers (the same seed gives the same numbers).
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Surface vertices of a path (1 = direct light).
    #[arg(long, default_value_t = 8, value_name = "D")]
    pub max_depth: u32,
    /// Timed rounds (each runs every variant once); a variant's fastest run counts. 5 by
    /// default: on a shared 2-core machine 3 rounds still left rows of -7 % and -21 %, 5 none
    /// (docs/results.md, thirteenth session).
    #[arg(long, default_value_t = 5)]
    pub repeats: u32,
    /// Also render once more with each dispatch, learning window's fold and growth point
    /// submitted and timed on its own, and print them by kind: where a learned sampler's time
    /// between its passes goes.
    #[arg(long)]
    pub timeline: bool,
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

impl ProfileArgs {
    pub fn run(&self, ui: &mut dyn Ui) -> Result<String> {
        commands::check_size(self.width, self.height)?;
        commands::check_depth(self.max_depth)?;
        if !(1..=4096).contains(&self.spp) || !(1..=100).contains(&self.repeats) {
            anyhow::bail!("--spp takes 1..=4096 and --repeats 1..=100");
        }
        let (scene, ctx, gpu, _) = commands::prepare(
            self.scene.as_deref(),
            (self.width, self.height),
            &self.device.options(),
            ui,
        )?;
        let settings = RenderSettings {
            width: self.width,
            height: self.height,
            budget: Budget::Samples(self.spp),
            seed: self.seed,
            sampler: self.sampler,
            regions: self.regions.settings()?,
            learn: self.learn.settings()?,
            stratify: lightlearn::render::Stratify::Sobol,
            max_depth: self.max_depth,
            resume: None,
            light_point: Default::default(),
            indirect_light_samples: 1,
            first_light_samples: 1,
        };
        let (times, learned) = lightlearn::bench::stages::profile(
            &ctx,
            &scene,
            &gpu,
            &settings,
            self.spp,
            self.repeats,
            &mut |l| ui.message(l),
        )?;
        let paths = self.spp as f64 * self.width as f64 * self.height as f64;
        let timeline = if self.timeline {
            ui.message("timeline: one more render, each step on its own");
            let events =
                lightlearn::bench::stages::timeline(&ctx, &scene, &gpu, &settings, self.spp)?;
            format!(
                "\n\none render, each dispatch, fold and growth point submitted alone (each with one submission's wait):\n\n{}",
                lightlearn::render::timeline::table(&events)
            )
        } else {
            String::new()
        };
        Ok(format!(
            "{}: {} triangles, {}; {} on {}; {}×{}, {} spp, depth {}: {:.3} M paths/s{}\n\n{}{}",
            scene.source,
            scene.triangles.len(),
            scene.lights_summary(),
            self.sampler.name(),
            ctx.describe(),
            self.width,
            self.height,
            self.spp,
            self.max_depth,
            paths / times[0].seconds / 1e6,
            learned.map_or(String::new(), |d| format!(
                "\nlearned state: {} cluster slots in {} cuts for {} regions, {} observations ({:.3} a slot)",
                d.slots,
                d.cuts,
                d.regions_with_cuts,
                d.observations,
                d.observations / d.slots.max(1) as f64
            )),
            lightlearn::bench::stages::table(&times),
            timeline
        ))
    }
}
