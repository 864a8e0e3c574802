//! Temporal coherence of two `lightlearn animate` runs that differ only in `--seed`: per
//! frame, the image variance estimated without a reference (the mean over pixels of
//! (a − b)² / 2, an unbiased estimate of one run's MSE), and two flicker measures
//! (docs/features.md): std / mean of the per-frame variances, and the mean absolute change
//! of the variance from one frame to the next, ÷ the mean (a sampler whose quality jumps
//! between frames flickers even when each frame is unbiased).
//!
//! cargo run --release --example temporal -- RUN_A/ RUN_B/

use anyhow::{bail, Result};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 2 {
        bail!("usage: temporal RUN_A/ RUN_B/ (two animate output folders, other seeds)");
    }
    let (a, b) = (
        std::path::Path::new(&args[0]),
        std::path::Path::new(&args[1]),
    );
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("animation.json"))?)?;
    let mut vars = Vec::new();
    for f in summary["frames"].as_array().into_iter().flatten() {
        let k = f["frame"].as_u64().unwrap_or(0);
        let name = format!("frame-{k:04}.exr");
        let (_, _, pa) = lightlearn::film::read_exr(&a.join(&name))?;
        let (_, _, pb) = lightlearn::film::read_exr(&b.join(&name))?;
        let v = pa
            .iter()
            .zip(&pb)
            .map(|(x, y)| {
                (0..3)
                    .map(|c| ((x[c] - y[c]) as f64).powi(2) / 2.0)
                    .sum::<f64>()
                    / 3.0
            })
            .sum::<f64>()
            / pa.len() as f64;
        vars.push(v);
    }
    let n = vars.len() as f64;
    let mean = vars.iter().sum::<f64>() / n;
    let std = (vars.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let step =
        vars.windows(2).map(|w| (w[1] - w[0]).abs()).sum::<f64>() / (n - 1.0).max(1.0) / mean;
    let line: Vec<String> = vars.iter().map(|v| format!("{v:.3e}")).collect();
    println!("per-frame variance: {}", line.join(" "));
    println!(
        "mean {mean:.3e}  flicker std/mean {:.2}  step |dv|/mean {step:.2}",
        std / mean
    );
    Ok(())
}
