//! The `lightlearn` command line: parses arguments (src/cli/) into the library's requests
//! (`lightlearn::commands`), shows progress and prints results. Nothing else lives here.

mod cli;

use std::process::ExitCode;

use anyhow::{bail, Result};
use clap::Parser;

use cli::{
    AnimateArgs, BenchArgs, Cli, Command, CompareArgs, ReferenceArgs, RenderArgs, SceneArgs,
};
use lightlearn::commands::{self, Ui};
use lightlearn::gpu::Context;

/// `eprintln!` that ignores a stderr it cannot write (a closed pipe: `2>&1 | head -1`):
/// eprintln! panicked there, so a render that had one warning to say ended with exit 101
/// and nothing written (an audit, 2026-12-06).
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// `println!` for results on stdout, likewise (`lightlearn profile … | head -3`).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

mod terminal;
use terminal::Terminal;

fn main() -> ExitCode {
    let cli = Cli::parse();
    // First Ctrl-C during a render (and, for `render --checkpoint`, `compare` and
    // `reference`, across their writes: `interrupt::Active`): finish the current batch and
    // write what is done; a second one, or one at any other time (loading, building): quit
    // now. SIGTERM
    // and SIGHUP too (ctrlc's `termination`): `timeout`, `kill`, a CI job's or a closed
    // terminal's stop had lost every sample of a long render.
    let _ = ctrlc::set_handler(|| {
        if lightlearn::interrupt::requested() || !lightlearn::interrupt::active() {
            // Status 130 for every signal, at once, or once a rename or commit of outputs in
            // progress ends (interrupt::Writing); the temporaries being written and the
            // folders made for the command go first (interrupt::quick_exit).
            if !lightlearn::interrupt::defer_exit() {
                lightlearn::interrupt::quick_exit();
            }
            return;
        }
        lightlearn::interrupt::request();
        say!("\ninterrupted: finishing the current batch (Ctrl-C again to quit at once)");
    });
    let result = match cli.command {
        Command::Render(a) => cmd_render(a),
        Command::Animate(a) => cmd_animate(a),
        Command::Preview(a) => a
            .request()
            .and_then(|r| lightlearn::preview::run(&r, &mut Terminal::new(false))),
        Command::Farm(a) => a.request().and_then(|r| {
            let quiet = a.quiet;
            let o = commands::farm::write(&r, &mut |w| say_line(&format!("warning: {w}")))?;
            if !quiet {
                say_line(&format!(
                    "wrote {}: {} steps, {} tasks; run it here with `openjd run {}`",
                    o.template.display(),
                    o.steps,
                    o.tasks,
                    shell_word(&o.template)
                ));
            }
            Ok(())
        }),
        Command::Compare(a) => cmd_compare(a),
        Command::Reference(a) => cmd_reference(a),
        Command::Scene(a) => cmd_scene(a),
        Command::BenchRays(a) => cmd_bench_rays(a),
        Command::Profile(a) => a.run(&mut Terminal::new(a.quiet)).map(|t| out!("{t}")),
        Command::Variance(a) => a.run(&mut Terminal::new(a.quiet)).map(|t| out!("{t}")),
        Command::Merge(a) => a
            .exposure
            .map(lightlearn::film::exposure_factor)
            .transpose()
            .and_then(|exposure| {
                commands::merge::images(&a.parts, &a.out, exposure, &mut |w| {
                    say_line(&format!("warning: {w}"))
                })
            })
            .map(|o| {
                if !a.quiet {
                    say_line(&format!(
                        "wrote {} (+ .png, .json): {} parts, {} spp",
                        o.exr.display(),
                        o.parts,
                        o.spp
                    ))
                }
            }),
        Command::MergeStats(a) => {
            commands::merge::stats(&a.parts, a.base.as_deref(), &a.out, a.force, &mut |w| {
                say_line(&format!("warning: {w}"))
            })
            .map(|m| {
                if !a.quiet {
                    say_line(&format!(
                        "wrote {}: {} files, {} passes learned, {} regions with cuts",
                        a.out.display(),
                        a.parts.len(),
                        m.header.samples_done,
                        m.index.iter().filter(|&&o| o != 0).count()
                    ))
                }
            })
        }
    };
    // `--validation`: what the layer said as the command's contexts were destroyed (objects
    // never destroyed), after the command's own result.
    let late = lightlearn::gpu::context::teardown_errors();
    let result = if late.is_empty() {
        result
    } else {
        let also = match &result {
            Err(e) => {
                say_line(&format!("error: {e:#}"));
                "and "
            }
            Ok(()) => "",
        };
        Err(anyhow::anyhow!(
            "{also}Vulkan validation errors while the device was released: {}",
            late.join(" | ")
        ))
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            say_line(&format!("error: {e:#}"));
            ExitCode::FAILURE
        }
    }
}

/// An error or message as one line: a newline or carriage return inside it (a file name may
/// hold one) is shown as `\n` / `\r`, so each message stays one line of the log (an error
/// naming such a file spanned two; an audit, 2026-12-06).
fn one_line(s: &str) -> String {
    s.replace('\n', "\\n").replace('\r', "\\r")
}

/// `s` on stderr as one line ([`one_line`]): every result, warning and error line outside a
/// [`Terminal`] (farm's loader warnings went out as they were).
fn say_line(s: &str) {
    say!("{}", one_line(s));
}

/// `p` as one word a POSIX shell reads back as `p`: quoted where it holds anything but
/// letters, digits and `_./-`, and after `./` where it starts with `-` (farm's hint to paste
/// read `openjd run -job/template.yaml`, an option, and broke on spaces and quotes; an
/// audit, 2026-12-07).
fn shell_word(p: &std::path::Path) -> String {
    let s = p.display().to_string();
    let s = if s.starts_with('-') {
        format!("./{s}")
    } else {
        s
    };
    let plain = |c: char| c.is_ascii_alphanumeric() || "_./-".contains(c);
    if !s.is_empty() && s.chars().all(plain) {
        s
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

fn cmd_render(a: RenderArgs) -> Result<()> {
    let mut ui = Terminal::new(a.quiet);
    let o = commands::render::run(&a.request()?, &mut ui)?;
    if o.interrupted {
        bail!(
            "interrupted (Ctrl-C or a stop signal) after {} spp; wrote the image so far to {} (+ .png, .json{})",
            o.spp,
            o.exr.display(),
            if o.wrote_stats { ", statistics" } else { "" }
        );
    }
    ui.message(&format!(
        "wrote {} (+ .png, .json): {} spp in {:.2} s ({:.1} Msamples/s)",
        o.exr.display(),
        o.spp,
        o.render_seconds,
        o.msamples_per_second
    ));
    Ok(())
}

fn cmd_animate(a: AnimateArgs) -> Result<()> {
    let mut ui = Terminal::new(a.quiet);
    if let Some(n) = a.reference_spp {
        use commands::animate_report::Variant;
        let s = a.sampler.name();
        let list = a.variants.clone().unwrap_or(if a.sampler.learned() {
            format!("wang,{s}-off,{s}-on")
        } else {
            s.to_string()
        });
        let results =
            commands::animate_report::run(&a.request()?, n, &Variant::parse_list(&list)?, &mut ui)?;
        for r in &results {
            ui.message(&format!(
                "{}: mean MSE {:.3e}, flicker {:.2}, step {:.2}",
                r.name,
                r.mse.iter().sum::<f64>() / r.mse.len().max(1) as f64,
                r.flicker,
                r.step
            ));
        }
        ui.message(&format!("wrote {}", a.out.join("report.html").display()));
        return Ok(());
    }
    let o = commands::animate::run(&a.request()?, &mut ui)?;
    let (frames, seconds) = (
        o.frames.len(),
        o.frames.iter().map(|f| f.render_seconds).sum::<f64>(),
    );
    let noun = if frames == 1 { "frame" } else { "frames" };
    if o.interrupted {
        let at = o.frames.last().map_or(0, |f| f.frame);
        bail!(
            "interrupted (Ctrl-C or a stop signal) {}; wrote {frames} {noun}{} and animation.json to {}",
            if o.last_partial {
                format!("during frame {at}")
            } else {
                format!("after frame {at}")
            },
            if o.last_partial { " (the last one partial)" } else { "" },
            a.out.display()
        );
    }
    let stats = a.carry == "on" && a.sampler.learned();
    ui.message(&format!(
        "wrote {frames} {noun} to {} (frame-NNNN.exr/.png/.json{}, animation.json{}) in {seconds:.1} s of rendering",
        a.out.display(),
        if stats { "/.stats" } else { "" },
        if o.video.is_some() { ", animation.mp4" } else { "" }
    ));
    Ok(())
}

fn cmd_reference(a: ReferenceArgs) -> Result<()> {
    let mut ui = Terminal::new(a.image.quiet);
    let report = commands::reference::run(&a.request(), &mut ui)?;
    // Null at 1 spp (no variance): "NaN" was printed (a review, 2026-12-07).
    let error = match report["estimated_rel_mse_of_mean"].as_f64() {
        Some(e) => format!("{e:.2e}"),
        None => "unknown (1 spp)".to_string(),
    };
    ui.message(&format!(
        "wrote {} ({} spp in {:.1} s; estimated relMSE {error})",
        a.out.display(),
        a.spp,
        report["render_seconds"].as_f64().unwrap_or(0.0),
    ));
    Ok(())
}

fn cmd_compare(a: CompareArgs) -> Result<()> {
    let mut ui = Terminal::new(a.image.quiet);
    let o = commands::compare::run(&a.request()?, &mut ui)?;
    for c in &o.comparisons {
        ui.message(&format!("{}:", c.kind));
        for r in &c.runs {
            let corrected = match (r.corrected, r.speedup_corrected) {
                (Some(m), Some(s)) => format!(
                    "  (reference noise out: relMSE {:.3e}, MSE {:.3e}, speed-up {s:.2})",
                    m.rel_mse, m.mse
                ),
                _ => String::new(),
            };
            ui.message(&format!(
                "  {:<8} {:>6} spp {:>7.2} s  relMSE {:.3e}  MSE {:.3e}  speed-up vs {} {:.2}{corrected}",
                r.sampler.name(),
                r.spp,
                r.seconds,
                r.metrics.rel_mse,
                r.metrics.mse,
                c.runs[0].sampler.name(),
                r.speedup
            ));
        }
    }
    ui.message(&format!("report: {}", o.report.display()));
    Ok(())
}

fn cmd_scene(a: SceneArgs) -> Result<()> {
    let bytes = commands::scene::run(a.family, &a.params()?, &a.out, a.force)?;
    if a.quiet {
        return Ok(());
    }
    say_line(&format!(
        "wrote {} ({}, {} lights, {bytes} bytes)",
        a.out.display(),
        a.family.name(),
        a.lights
    ));
    Ok(())
}

fn cmd_bench_rays(a: BenchArgs) -> Result<()> {
    lightlearn::bench::rays::check_args(a.triangles, a.width, a.height, a.repeats)?;
    let ctx = Context::new(&a.device.options())?;
    out!("device: {}", ctx.describe());
    lightlearn::bench::rays::run(&ctx, a.triangles, a.width, a.height, a.repeats, &mut |l| {
        out!("{l}")
    })?;
    Ok(())
}
