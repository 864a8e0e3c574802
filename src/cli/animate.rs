//! `animate` and `farm`: the commands that render frames of an animation.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use super::{sampler_parser, DeviceArgs, LearnArgs, RegionArgs};
use lightlearn::commands::animate::AnimateRequest;
use lightlearn::commands::farm::FarmRequest;
use lightlearn::render::LightSampler;

#[derive(Args)]
pub struct AnimateArgs {
    /// glTF 2.0 scene with animations (.gltf or .glb). Default: the built-in scene (still:
    /// give --frames).
    pub scene: Option<PathBuf>,
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Frames to render, both ends included, e.g. 0..47 [default: the animation's whole
    /// time span at --fps].
    #[arg(long, value_name = "A..B", value_parser = parse_range, conflicts_with = "frame")]
    pub frames: Option<(u32, u32)>,
    /// Render only frame K (with --load-stats of frame K-1's .stats it equals frame K of the
    /// whole sequence: a render farm's unit of work).
    #[arg(long, value_name = "K")]
    pub frame: Option<u32>,
    /// Frames per second: frame k shows time t0 + k / fps (t0: the first keyframe).
    #[arg(long, default_value_t = 24.0)]
    pub fps: f64,
    /// Samples per pixel per frame [default: 64 unless --time is given].
    #[arg(long, value_name = "N", conflicts_with = "time")]
    pub spp: Option<u32>,
    /// Seconds per frame instead of a fixed sample count (not reproducible).
    #[arg(long, value_name = "SECONDS")]
    pub time: Option<f64>,
    /// Carry the learned statistics from each frame to the next (off: every frame learns
    /// from scratch, the comparison point).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub carry: String,
    /// When lights or geometry move between frames, the carried counts and sums are × G
    /// (0 < G ≤ 1) before the next frame: old knowledge weighs less as it may be stale.
    #[arg(long, default_value_t = 0.5, value_name = "G")]
    pub forget: f32,
    /// The statistics of the frame before the first (DIR/frame-NNNN.stats of an earlier run).
    #[arg(long, value_name = "FILE")]
    pub load_stats: Option<PathBuf>,
    /// Which frames' statistics files stay (.stats: 1–3 MB a frame on the committed scenes,
    /// growing with the regions the camera sees, not the image size): all (each frame
    /// re-renderable alone with --frame K --load-stats) or last (the newest whole frame's, to
    /// continue the sequence; this run's earlier ones are removed).
    #[arg(long, default_value = "all", value_parser = ["all", "last"], value_name = "WHICH")]
    pub keep_stats: String,
    /// Replace files in --out that lightlearn did not write (a frame-NNNN.json that is not a
    /// report, an image with no report beside it, a .stats that is not statistics, an
    /// animation.json that is not a summary, an animation.mp4 with no summary beside it):
    /// refused without it.
    #[arg(long)]
    pub force: bool,
    /// Do not encode DIR/animation.mp4 even when ffmpeg is installed.
    #[arg(long)]
    pub no_video: bool,
    #[command(flatten)]
    pub exposure: super::ExposureArgs,
    /// Render farm chunk K of one frame (--frame): the samples [K·spp, (K+1)·spp) after what
    /// --load-stats learned; `lightlearn merge` combines the chunks.
    #[arg(long, value_name = "K")]
    pub chunk: Option<u32>,
    /// Temporal-coherence evaluation: render per-frame references (lightbvh, N spp) and each
    /// of --variants into DIR/<variant>/, and write DIR/report.html and DIR/report.json
    /// (per-frame MSE and relMSE, a plot, a flip between frames, flicker).
    #[arg(long, value_name = "N", conflicts_with_all = ["load_stats", "chunk"])]
    pub reference_spp: Option<u32>,
    /// With --reference-spp: the variants side by side, SAMPLER or SAMPLER-on/-off (carry)
    /// [default: wang,S-off,S-on for a learning --sampler S, else S].
    #[arg(long, value_name = "LIST", requires = "reference_spp")]
    pub variants: Option<String>,
    #[arg(long, default_value = "bayes", value_parser = sampler_parser())]
    pub sampler: LightSampler,
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    #[arg(long, default_value_t = 240)]
    pub height: u32,
    /// Random seed (each frame mixes its index in).
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Surface vertices of a path (1 = direct light).
    #[arg(long, default_value_t = 8, value_name = "D")]
    pub max_depth: u32,
    #[command(flatten)]
    pub sampling: super::SamplingArgs,
    /// No progress bar or summary.
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub regions: RegionArgs,
    #[command(flatten)]
    pub learn: LearnArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

pub fn parse_range(s: &str) -> std::result::Result<(u32, u32), String> {
    let bad = || format!("'{s}' is not a frame range like 0..47");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let n = |t: &str| t.trim().parse::<u32>().map_err(|_| bad());
    Ok((n(a)?, n(b)?))
}

impl AnimateArgs {
    pub fn request(&self) -> Result<AnimateRequest> {
        Ok(AnimateRequest {
            scene: self.scene.clone(),
            out: self.out.clone(),
            frames: self.frame.map(|k| (k, k)).or(self.frames),
            fps: self.fps,
            spp: self.spp,
            seconds: self.time,
            carry: self.carry == "on",
            forget: self.forget,
            sampler: self.sampler,
            width: self.width,
            height: self.height,
            seed: self.seed,
            max_depth: self.max_depth,
            light_point: self.sampling.light_point,
            regions: self.regions.settings()?,
            learn: self.learn.settings()?,
            load_stats: self.load_stats.clone(),
            keep_all_stats: self.keep_stats == "all",
            force: self.force,
            video: !self.no_video,
            exposure: self.exposure.factor()?,
            chunk: self.chunk,
            device: self.device.options(),
            stratify: self.sampling.stratify,
        })
    }
}

#[derive(Args)]
pub struct FarmArgs {
    /// The glTF scene the workers render (copied into JOBDIR/scene/; that copy is the
    /// SceneFile job parameter's default).
    pub scene: PathBuf,
    /// The job bundle's folder (created; holds template.yaml).
    #[arg(long, value_name = "JOBDIR")]
    pub out: PathBuf,
    /// Frames of the animation, both ends included [default: every frame of an animated
    /// scene; a still otherwise].
    #[arg(long, value_name = "A..B", value_parser = parse_range)]
    pub frames: Option<(u32, u32)>,
    /// Render a still (render) even when the scene is animated.
    #[arg(long, conflicts_with = "frames")]
    pub still: bool,
    /// Sample chunks per image, 2 to 1000, each a task (chunk k renders the samples
    /// [k·spp, (k+1)·spp)).
    #[arg(long, default_value_t = 4)]
    pub chunks: u32,
    /// Samples per pixel of each chunk (an image gets chunks × spp).
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Frames per second of the animation: frame k shows t0 + k / fps.
    #[arg(long, default_value_t = 24.0)]
    pub fps: f64,
    /// Carry learned statistics from each frame to the next: a frame's chunks start from the
    /// previous frame's merged statistics, so frames run one after another (off: all frames'
    /// chunks are independent tasks).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub carry: String,
    /// When lights or geometry move between frames, the carried counts and sums are × G
    /// (0 < G ≤ 1), as `animate --forget`.
    #[arg(long, default_value_t = 0.5, value_name = "G")]
    pub forget: f32,
    /// The light sampler (the Sampler job parameter).
    #[arg(long, default_value = "bayes", value_parser = sampler_parser())]
    pub sampler: LightSampler,
    /// Image width in pixels (the Width job parameter).
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    /// Image height in pixels (the Height job parameter).
    #[arg(long, default_value_t = 240)]
    pub height: u32,
    /// Random seed (the Seed job parameter; chunks and frames mix in their index).
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Surface vertices of a path, 1 = direct light (the MaxDepth job parameter).
    #[arg(long, default_value_t = 8, value_name = "D")]
    pub max_depth: u32,
    #[command(flatten)]
    pub sampling: super::SamplingArgs,
    /// Exposure of the merged PNGs in stops (each task's and merge's `--exposure`; the EXRs
    /// hold the radiance either way), −20 to 20.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "EV",
        allow_hyphen_values = true
    )]
    pub exposure: f32,
    /// No summary line (warnings and errors are still printed).
    #[arg(long, short)]
    pub quiet: bool,
    /// The lightlearn executable the workers run [default: this one] (the Lightlearn job
    /// parameter).
    #[arg(long, value_name = "PATH")]
    pub lightlearn: Option<PathBuf>,
    #[command(flatten)]
    pub regions: RegionArgs,
    #[command(flatten)]
    pub learn: LearnArgs,
}

impl FarmArgs {
    pub fn request(&self) -> Result<FarmRequest> {
        self.regions.settings()?;
        self.learn.settings()?;
        lightlearn::film::exposure_factor(self.exposure)?;
        // A relative path with a folder in it is the tasks' working folder's, which is
        // OpenJD's session folder (every task failed "not found"; an audit, 2026-12-07): taken
        // from here. A bare name is looked up on the workers' PATH.
        let exe = match &self.lightlearn {
            Some(p) if p.is_relative() && p.components().count() > 1 => {
                std::env::current_dir()?.join(p)
            }
            Some(p) => p.clone(),
            None => std::env::current_exe()?,
        };
        Ok(FarmRequest {
            scene: self.scene.clone(),
            job_dir: self.out.clone(),
            frames: self.frames,
            still: self.still,
            chunks: self.chunks,
            spp: self.spp,
            fps: self.fps,
            carry: self.carry == "on",
            forget: self.forget,
            sampler: self.sampler,
            width: self.width,
            height: self.height,
            seed: self.seed,
            max_depth: self.max_depth,
            lightlearn: exe,
            options: [
                self.sampling.to_args(),
                self.regions.to_args(),
                self.learn.to_args(),
            ]
            .concat(),
            exposure: self.exposure,
        })
    }
}
