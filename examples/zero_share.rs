//! The share of light samples that come out zero (occluded, facing away, a dead end in a
//! cluster), with the pixels that no light can reach counted apart (issue #17 asks for
//! converged `bayes` on rooms16 "well below 25 %, with the ceiling pixels counted apart").
//!
//! A pixel is unlightable when every one of `uniform`'s light samples there came out zero
//! over 1024 passes (each light equally likely, so a pixel that any light reaches gets a
//! non-zero sample unless that light's visible share is tiny); its samples are zero for any
//! sampler. For `wang`, `bayes` learning from scratch and `bayes` with statistics learned
//! over 2048 passes and then frozen (also with learned cut refinement, `--refine-cuts 8`, and
//! with finer cuts, `--k-max 64 --tau 0.005`): the zero share over all light samples and over
//! the lightable pixels' alone.
//!
//! `cargo run --release --example zero_share [SPP] [SCENE.glb ...]` (default: 256 spp; the
//! committed rooms16, city, hall and strings), direct light, 128×96.

use std::path::PathBuf;

use lightlearn::accel::Bvh;
use lightlearn::gpu::{Context, ContextOptions};
use lightlearn::learning::UpdateEvery;
use lightlearn::render::{Budget, GpuScene, LightSampler, RenderResult, RenderSettings, Session};

/// Zero light samples and all light samples, per pixel (`PixelAccum` channel 3).
fn zero_and_all(r: &RenderResult) -> Vec<(f64, f64)> {
    r.accum
        .iter()
        .map(|a| (a.sum[3] as f64, a.sum_sq[3] as f64))
        .collect()
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1).peekable();
    let spp: u32 = match args.peek().map(|a| a.parse()) {
        Some(Ok(n)) => {
            args.next();
            n
        }
        _ => 256,
    };
    let mut scenes: Vec<PathBuf> = args.map(PathBuf::from).collect();
    if scenes.is_empty() {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
        scenes = ["rooms16", "city", "hall", "strings"]
            .iter()
            .map(|n| dir.join(format!("{n}.glb")))
            .collect();
    }
    let ctx = Context::new(&ContextOptions::default())?;
    println!(
        "device: {}; direct light, 128×96, {spp} spp",
        ctx.describe()
    );
    println!("| scene | unlightable pixels (their share of light samples) | sampler | zero share, all | zero share, lightable pixels |");
    println!("|---|---|---|---|---|");
    for path in &scenes {
        let scene = lightlearn::scene::gltf_load::load(path, &mut |_| {})?;
        let gpu = GpuScene::upload(&ctx, &scene, &Bvh::build(&scene.triangles))?;
        let settings = |sampler, seed| RenderSettings {
            budget: Budget::Samples(spp),
            seed,
            ..RenderSettings::new(sampler, 128, 96, 1)
        };
        let run = |set: &RenderSettings, passes: u32| -> anyhow::Result<Session> {
            let mut s = Session::new(&ctx, &scene, &gpu, set)?;
            s.run_passes(passes)?;
            Ok(s)
        };
        let uniform = run(&settings(LightSampler::Uniform, 7), 1024)?.result()?;
        let unlightable: Vec<bool> = zero_and_all(&uniform)
            .iter()
            .map(|&(zero, all)| all > 0.0 && zero == all)
            .collect();
        let dark_pixels = unlightable.iter().filter(|&&d| d).count();

        // bayes learned over 2048 passes (another seed), then frozen: no fold in the
        // measured passes; `refine`: with learned cut refinement (--refine-cuts).
        // `fine`: cuts of up to 64 clusters split to τ = 0.005 (docs/results.md, thirteenth
        // session: the converged model's best ceiling).
        let frozen = |refine: u32, fine: bool| -> anyhow::Result<RenderSettings> {
            let with = |mut s: RenderSettings| {
                s.learn.refine_cuts = refine;
                if fine {
                    s.regions.k_max = 64;
                    s.regions.tau = 0.005;
                }
                s
            };
            let learn = with(settings(LightSampler::Bayes, 9));
            let learned = run(&learn, 2048)?.snapshot()?.expect("bayes learns");
            let mut frozen = with(settings(LightSampler::Bayes, 1));
            frozen.resume = Some(std::sync::Arc::new(learned));
            frozen.learn.update_every = UpdateEvery::Passes(1 << 30);
            Ok(frozen)
        };

        let mut first = true;
        for (name, set) in [
            ("wang", settings(LightSampler::Wang, 1)),
            ("bayes, from scratch", settings(LightSampler::Bayes, 1)),
            ("bayes, learned over 2048 spp and frozen", frozen(0, false)?),
            ("the same with --refine-cuts 8", frozen(8, false)?),
            ("the same with --k-max 64 --tau 0.005", frozen(0, true)?),
        ] {
            let r = run(&set, spp)?.result()?;
            let per_pixel = zero_and_all(&r);
            let (mut zero, mut all, mut zero_lit, mut all_lit) = (0.0, 0.0, 0.0, 0.0);
            for (&(z, a), &dark) in per_pixel.iter().zip(&unlightable) {
                zero += z;
                all += a;
                if !dark {
                    zero_lit += z;
                    all_lit += a;
                }
            }
            let head = if first {
                format!(
                    "{} | {dark_pixels} ({:.1} %)",
                    path.file_stem().unwrap().to_string_lossy(),
                    100.0 * (all - all_lit) / all
                )
            } else {
                " | ".to_string()
            };
            first = false;
            println!(
                "| {head} | {name} | {:.1} % | {:.1} % |",
                100.0 * zero / all,
                100.0 * zero_lit / all_lit
            );
        }
    }
    Ok(())
}
