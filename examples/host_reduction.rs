//! What a host-side reduction of the learned statistics between frames would cost against
//! the frame it follows (the GPU fold, `fold.comp`, is what runs). A frame is a batch of
//! passes of about `render::PASS_BATCH_SECONDS`, as `render` submits them.
//!
//! `cargo run --release --example host_reduction [SCENE.glb ...]` (default: the committed
//! rooms16, city and hall), bayes, direct light and depth 8, 128×96.

use std::path::PathBuf;

use lightlearn::accel::Bvh;
use lightlearn::gpu::{Context, ContextOptions};
use lightlearn::render::{GpuScene, LightSampler, RenderSettings, Session};

fn main() -> anyhow::Result<()> {
    let mut scenes: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if scenes.is_empty() {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
        scenes = ["rooms16", "city", "hall"]
            .iter()
            .map(|n| dir.join(format!("{n}.glb")))
            .collect();
    }
    let ctx = Context::new(&ContextOptions::default())?;
    println!("device: {}", ctx.describe());
    println!("| scene | depth | slots | MB moved | read ms | reduce ms | upload ms | frame ms | host ÷ frame |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for path in &scenes {
        let scene = lightlearn::scene::gltf_load::load(path, &mut |_| {})?;
        let gpu = GpuScene::upload(&ctx, &scene, &Bvh::build(&scene.triangles))?;
        for depth in [1, 8] {
            let settings = RenderSettings::new(LightSampler::Bayes, 128, 96, depth);
            let mut s = Session::new(&ctx, &scene, &gpu, &settings)?;
            // Warm up past the growth points, then time frames of ~0.25 s.
            s.run_passes(64)?;
            let per_pass = s.run_passes(8)? / 8.0;
            let k = ((lightlearn::render::PASS_BATCH_SECONDS / per_pass) as u32).max(1);
            let (mut frame, mut host) = (0.0, Vec::new());
            for _ in 0..5 {
                frame += s.run_passes(k)?;
                host.push(s.measure_host_reduction()?);
            }
            frame /= 5.0;
            let mean = |f: fn(&lightlearn::render::HostReduction) -> f64| {
                host.iter().map(f).sum::<f64>() / host.len() as f64
            };
            let (r, d, u) = (
                mean(|h| h.read_seconds),
                mean(|h| h.reduce_seconds),
                mean(|h| h.upload_seconds),
            );
            println!(
                "| {} | {depth} | {} | {:.2} | {:.1} | {:.1} | {:.1} | {:.0} | {:.1} % |",
                path.file_stem().unwrap().to_string_lossy(),
                host[0].slots,
                host[0].bytes as f64 / 1e6,
                1e3 * r,
                1e3 * d,
                1e3 * u,
                1e3 * frame,
                100.0 * (r + d + u) / frame
            );
        }
    }
    Ok(())
}
