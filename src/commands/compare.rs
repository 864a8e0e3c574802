//! `lightlearn compare`: samplers side by side on one scene at equal time and/or equal
//! samples against a reference; writes the EXRs (the reference's with `reference.json`),
//! `metrics.json`, `convergence.csv` and the HTML report together. Everything that can be
//! wrong with the request is checked before any rendering, and a refused request leaves no
//! folder behind.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use serde_json::json;

use super::{check_depth, prepare, Ui};
use crate::compare::{self, reference, report, Comparison};
use crate::film;
use crate::gpu::ContextOptions;
use crate::learning::LearnSettings;
use crate::lights::regions::RegionSettings;
use crate::lights::LightPoint;
use crate::render::{Budget, LightSampler};

/// What `compare` is asked for.
#[derive(Clone, Debug)]
pub struct CompareRequest {
    pub scene: Option<PathBuf>,
    /// The first is the baseline of the speed-ups.
    pub samplers: Vec<LightSampler>,
    pub time: Option<f64>,
    pub spp: Option<u32>,
    /// A given reference image; None: rendered once and cached.
    pub reference: Option<PathBuf>,
    pub reference_spp: u32,
    pub out: PathBuf,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub max_depth: u32,
    pub light_point: LightPoint,
    pub regions: RegionSettings,
    pub learn: LearnSettings,
    pub device: ContextOptions,
}

/// What a comparison measured and where its report is.
pub struct CompareOutcome {
    pub comparisons: Vec<Comparison>,
    pub report: PathBuf,
}

/// Runs the comparison; the folders it creates are removed again if it fails.
pub fn run(a: &CompareRequest, ui: &mut dyn Ui) -> Result<CompareOutcome> {
    let outcome =
        crate::io::removing_created_folders_on_error(Some(&a.out), || run_checked(a, ui))?;
    if crate::interrupt::requested() {
        ui.message("a stop was asked for after the last render met its budget or while the comparison was written; it is complete");
    }
    Ok(outcome)
}

fn run_checked(a: &CompareRequest, ui: &mut dyn Ui) -> Result<CompareOutcome> {
    // Everything that can be wrong with the request is checked before any rendering.
    check_depth(a.max_depth)?;
    let samplers = a.samplers.clone();
    if samplers.is_empty() {
        bail!("--samplers needs at least one sampler");
    }
    let (regions, learn) = (a.regions, a.learn);
    regions.check()?;
    learn.check()?;
    if learn.control_variates && !samplers.contains(&LightSampler::Bayes) {
        bail!("--control-variates applies to bayes only: add bayes to --samplers");
    }
    let mut budgets = Vec::new();
    if let Some(t) = a.time {
        if !(t.is_finite() && t > 0.0) {
            bail!("--time must be a positive number of seconds");
        }
        budgets.push(Budget::Seconds(t));
    }
    if let Some(n) = a.spp {
        super::check_spp("--spp", n)?;
        budgets.push(Budget::Samples(n));
    }
    if budgets.is_empty() {
        bail!("give --time SECONDS (equal time) and/or --spp N (equal samples)");
    }
    let ref_settings =
        reference::settings(a.width, a.height, a.reference_spp, a.seed, a.max_depth)?;
    // Every file the report writes, against what the comparison reads (a scene or a given
    // reference inside --out under one of these names was replaced, with exit 0). A given
    // reference that is --out/reference.exr is written back with its own pixels.
    let mut written = vec![
        "metrics.json".to_string(),
        "convergence.csv".into(),
        "index.html".into(),
    ];
    if a.reference
        .as_ref()
        .is_none_or(|r| !crate::io::same_path(r, &a.out.join("reference.exr")))
    {
        written.push("reference.exr".into());
    }
    // Written in every case (with the given reference's own pixels where it is this one).
    written.push("reference.json".into());
    for prefix in budgets.iter().map(|b| match b {
        Budget::Seconds(_) => "time",
        Budget::Samples(_) => "spp",
    }) {
        written.extend(
            samplers
                .iter()
                .map(|s| format!("{prefix}-{}.exr", s.name())),
        );
    }
    let written: Vec<PathBuf> = written.iter().map(|n| a.out.join(n)).collect();
    let written: Vec<&std::path::Path> = written.iter().map(PathBuf::as_path).collect();
    let mut others: Vec<(&str, &std::path::Path)> = Vec::new();
    if let Some(r) = &a.reference {
        others.push(("the --reference", r));
    }
    let mut inputs = crate::io::check_outputs_spare_scene(&written, a.scene.as_deref(), &others)?;
    inputs.extend(a.reference.clone());
    let stale = check_out_folder(&a.out, &written, &inputs)?;
    let given = match &a.reference {
        Some(p) => {
            let (w, h, px) = film::read_exr(p)?;
            if (w, h) != (a.width, a.height) {
                bail!(
                    "reference '{}' is {w}×{h} but the comparison renders {}×{}; pass --width {w} --height {h} or another reference",
                    p.display(),
                    a.width,
                    a.height
                );
            }
            if let Some(i) = px.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
                bail!(
                    "reference '{}' has a NaN or Inf at pixel ({}, {}); render it again",
                    p.display(),
                    i as u32 % w,
                    i as u32 / w
                );
            }
            // Its report's noise is subtracted from every error below: only this image's.
            let json = p.with_extension("json");
            // A report there that cannot be read was taken for no report, and an image of
            // another scene passed with only the no-report warning (an audit, 2026-12-07).
            let sidecar: Option<serde_json::Value> = match crate::io::read_all(&json) {
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
                Err(e) => bail!(
                    "cannot read the report beside the reference, '{}' ({e}); make it readable, or move it away to use the image unchecked",
                    json.display()
                ),
                Ok(b) => Some(serde_json::from_slice(&b).map_err(|e| {
                    anyhow::anyhow!(
                        "the report beside the reference, '{}', is damaged ({e}); restore it, or move it away to use the image unchecked",
                        json.display()
                    )
                })?),
            };
            if let Some(r) = &sidecar {
                film::check_report(p, &json, r)?;
            }
            Some((p.clone(), px, sidecar))
        }
        None => None,
    };

    let (scene, ctx, gpu, _) = prepare(a.scene.as_deref(), (a.width, a.height), &a.device, ui)?;
    // From here on a stop is honoured at a render's next batch (the comparison then writes
    // nothing and its folder goes) or after the writes, never in the middle of them: one
    // during the writes ended the program there, every render lost and temporaries left,
    // and one between renders left an empty folder (an audit, 2026-12-06). While the scene
    // loads, one still ends the program at once.
    let _active = crate::interrupt::Active::begin();
    // Made here, under the guard: a stop while the scene loaded left it empty.
    crate::io::create_output_folder(&a.out, "output folder")?;
    crate::io::write_atomic(&a.out.join(".write-test"), b"")
        .with_context(|| format!("the output folder '{}' is not writable", a.out.display()))?;
    let _ = std::fs::remove_file(a.out.join(".write-test"));
    let scene_hash = reference::scene_hash(&scene);
    // Whether the reference is known to be of this scene at this depth: made here, or given
    // with a report that says so, tied to its pixels by the EXR's checksum (checked when it
    // was read) and checked here. Only then does reference.json say so.
    let verified = given.as_ref().is_none_or(|(_, _, sidecar)| {
        sidecar.as_ref().is_some_and(|r| {
            r[film::EXR_CHECKSUM].is_string()
                && r["scene_hash"].is_string()
                && r["max_depth"].is_u64()
        })
    });
    if let Some((p, _, sidecar)) = &given {
        if let Some(r) = sidecar {
            check_reference_matches(p, r, &scene_hash, a.max_depth)?;
            check_reference_independent(p, r, &samplers, a.seed, ui)?;
        }
        if !verified {
            // Not an error: a reference from another renderer (Mitsuba) has no report. But
            // an EXR of another scene was compared against with no word (an audit,
            // 2026-12-06: compare's own reference.exr, given back without its report).
            ui.message(&format!(
                "warning: the reference '{}' has no report beside it ({}) that names its checksum, scene and depth, so they are not all checked: make sure it is an image of this scene at --max-depth {}",
                p.display(),
                p.with_extension("json").display(),
                a.max_depth
            ));
        }
    }
    if samplers.iter().any(|s| s.uses_cuts()) {
        crate::render::check_region_index_fits(&ctx, &scene, &regions)?;
    }
    let (reference_image, reference_note, reference_noise, reference_origin) = match given {
        Some((p, px, sidecar)) => {
            let noise = match sidecar.as_ref() {
                Some(r) => reference::noise(r),
                None => Err("no report beside it gives an estimate".to_string()),
            };
            let note = match &noise {
                Ok(e) => format!("its own estimated relMSE {:.2e}", e.rel_mse),
                Err(why) => format!("its own error is unknown ({why}), so no corrected numbers"),
            };
            // Whose samples it holds, for the check above when this comparison's
            // reference.json is given back (it said nothing, and a reference holding a
            // run's own samples passed: MSE 0, speed-up inf; an audit, 2026-12-07).
            let origin = sidecar.map(|r| {
                ["seed", "sampler", "merged_from"]
                    .iter()
                    .filter_map(|k| Some((k.to_string(), r.get(*k)?.clone())))
                    .collect()
            });
            (
                px,
                format!("{} (given); {note}", p.display()),
                noise.ok(),
                origin.unwrap_or_default(),
            )
        }
        None => {
            // Progress and messages both go to the one Ui, as they happen.
            let shared = std::cell::RefCell::new(&mut *ui);
            let r = reference::cached(
                &ctx,
                &scene,
                &gpu,
                &ref_settings,
                &mut |spp, f| shared.borrow_mut().progress("reference", spp, f),
                &mut |m| shared.borrow_mut().message(&m),
            );
            ui.phase_done();
            let (image, note, noise) = r?;
            let origin: serde_json::Map<String, serde_json::Value> = [
                ("seed".to_string(), json!(ref_settings.seed)),
                ("sampler".into(), json!(ref_settings.sampler.name())),
            ]
            .into_iter()
            .collect();
            (image, note, noise, origin)
        }
    };

    let mut comparisons = Vec::new();
    for budget in budgets {
        let c = compare::compare(
            &ctx,
            &scene,
            &gpu,
            &samplers,
            &regions,
            &learn,
            budget,
            a.width,
            a.height,
            a.seed,
            a.max_depth,
            a.light_point,
            &reference_image,
            reference_noise,
            &mut |sampler, spp, f| ui.progress(sampler.name(), spp, f),
        )?;
        ui.phase_done();
        if let Some(w) = &c.warning {
            ui.message(&format!("warning: {w}"));
        }
        comparisons.push(c);
    }

    // Outputs: EXRs, metrics.json, convergence.csv, index.html, moved into place together.
    let (w, h) = (a.width, a.height);
    let mut out = crate::io::FileSet::default();
    // The reference with a report of its own, so that given back as --reference it is
    // checked like any render's (its scene and depth only where they are known).
    let mut reference_sum = String::new();
    out.add_with(&a.out.join("reference.exr"), |tmp| {
        film::write_exr(tmp, w, h, &reference_image)?;
        reference_sum = film::exr_checksum(tmp)?;
        Ok(())
    })?;
    let mut reference_report = json!({
        "what": "the reference of a lightlearn compare",
        "width": w,
        "height": h,
        "reference": reference_note,
        film::EXR_CHECKSUM: reference_sum,
    });
    if verified {
        reference_report["scene_hash"] = json!(scene_hash);
        reference_report["max_depth"] = json!(a.max_depth);
    }
    for (k, v) in reference_origin {
        reference_report[k] = v;
    }
    if let Some(n) = &reference_noise {
        reference_report["estimated_mse_of_mean"] = json!(n.mse);
        reference_report["estimated_rel_mse_of_mean"] = json!(n.rel_mse);
    }
    out.add(
        &a.out.join("reference.json"),
        (serde_json::to_string_pretty(&reference_report)? + "\n").as_bytes(),
    )?;
    let mut exr = |name: String, img: &[[f32; 3]]| {
        out.add_with(&a.out.join(name), |tmp| film::write_exr(tmp, w, h, img))
    };
    for c in &comparisons {
        let prefix = if c.budget_seconds.is_some() {
            "time"
        } else {
            "spp"
        };
        for r in &c.runs {
            exr(format!("{prefix}-{}.exr", r.sampler.name()), &r.image)?;
        }
    }
    let metrics = json!({
        "scene": scene.source,
        "width": w,
        "height": h,
        "seed": a.seed,
        "max_depth": a.max_depth,
        "light_point": a.light_point,
        "device": ctx.describe(),
        "reference": reference_note,
        "comparisons": comparisons,
    });
    out.add(
        &a.out.join("metrics.json"),
        (serde_json::to_string_pretty(&metrics)? + "\n").as_bytes(),
    )?;
    out.add(
        &a.out.join("convergence.csv"),
        report::convergence_csv(&comparisons).as_bytes(),
    )?;
    let page = report::html(&report::ReportInput {
        scene: &scene.source,
        width: w,
        height: h,
        device: &ctx.describe(),
        reference: &reference_image,
        reference_note: &reference_note,
        comparisons: &comparisons,
    })?;
    out.add(&a.out.join("index.html"), page.as_bytes())?;
    out.commit()?;
    // An earlier comparison's images that this one did not replace (other samplers or
    // budgets) stayed beside a report that no longer listed them (an audit, 2026-12-07).
    for p in stale {
        if let Err(e) = std::fs::remove_file(&p) {
            ui.message(&format!(
                "warning: cannot remove '{}', an earlier comparison's image this report does not list ({e})",
                p.display()
            ));
        }
    }
    Ok(CompareOutcome {
        comparisons,
        report: a.out.join("index.html"),
    })
}

/// Checks an existing --out folder before any rendering: every file compare writes there
/// must be a regular file (a folder named index.html failed only after every render), and
/// where any of them exists the folder's metrics.json must be a comparison's (a user's
/// index.html and metrics.json were replaced with exit 0; an audit, 2026-12-07). Returns
/// the images of the earlier comparison there that this one does not write, to remove once
/// its own files are in place; only names compare gives (a sampler's, a budget's) are taken
/// from the old report, and never one of the comparison's `inputs` (a given --reference
/// that was an earlier run's image was removed: a review, 2026-12-07). A reference and its
/// lightlearn report (`reference` or a comparison wrote them) are not a user's files.
fn check_out_folder(out: &Path, written: &[&Path], inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    if !out.is_dir() {
        return Ok(Vec::new());
    }
    for p in written {
        if p.is_dir() {
            bail!(
                "cannot write '{}': it is a folder; move it away or give another --out",
                p.display()
            );
        }
        crate::io::check_not_special(p)?;
    }
    let metrics = out.join("metrics.json");
    let old = crate::io::read_regular(&metrics, 64 << 20)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .filter(|v| v["comparisons"].is_array() && v.get("reference").is_some());
    let Some(old) = old else {
        let report = out.join("reference.json");
        let ours = |p: &Path| {
            (p == report || p == out.join("reference.exr")) && crate::film::is_report(&report)
        };
        if let Some(p) = written
            .iter()
            .find(|p| std::fs::symlink_metadata(p).is_ok() && !ours(p))
        {
            bail!(
                "'{}' exists and '{}' is not a lightlearn compare's report, so it is a file of yours that compare would replace; give another --out (a new folder, or an earlier comparison's)",
                p.display(),
                metrics.display()
            );
        }
        return Ok(Vec::new());
    };
    let mut stale = Vec::new();
    for c in old["comparisons"].as_array().into_iter().flatten() {
        let prefix = if c["budget_seconds"].is_number() {
            "time"
        } else {
            "spp"
        };
        for r in c["runs"].as_array().into_iter().flatten() {
            let Some(s) = LightSampler::ALL
                .iter()
                .find(|s| r["sampler"].as_str() == Some(s.name()))
            else {
                continue;
            };
            let p = out.join(format!("{prefix}-{}.exr", s.name()));
            let regular = std::fs::symlink_metadata(&p).is_ok_and(|m| m.is_file());
            let input = inputs.iter().any(|i| crate::io::same_path(i, &p));
            if regular && !input && !written.contains(&p.as_path()) && !stale.contains(&p) {
                stale.push(p);
            }
        }
    }
    Ok(stale)
}

/// A given reference must not share the runs' random numbers: one rendered by a compared
/// sampler with the comparison's seed holds that run's own first samples, and its MSE came
/// out 0 and its speed-up "inf" with exit 0 (an audit, 2026-12-06) — refused; another
/// sampler with the same seed shares its camera jitter and light numbers, which lowers every
/// MSE a little — said.
fn check_reference_independent(
    p: &std::path::Path,
    report: &serde_json::Value,
    samplers: &[LightSampler],
    seed: u32,
    ui: &mut dyn Ui,
) -> Result<()> {
    // A merge's report keeps its parts' seeds in `merged_from` (a farm's chunk 0 of the
    // compared sampler with this seed holds the run's own first samples: a review).
    let seeds: Vec<u64> = std::iter::once(&report["seed"])
        .chain(
            report["merged_from"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|p| &p["seed"]),
        )
        .filter_map(|v| v.as_u64())
        .collect();
    if !seeds.contains(&(seed as u64)) {
        return Ok(());
    }
    let by = report["sampler"].as_str().unwrap_or("");
    if let Some(s) = samplers.iter().find(|s| s.name() == by) {
        bail!(
            "reference '{}' is {by} with --seed {seed}, as this comparison's {} run: it holds that run's own samples; render the reference with another --seed, or give this comparison another",
            p.display(),
            s.name()
        );
    }
    ui.message(&format!(
        "warning: reference '{}' was rendered with --seed {seed}, as these runs: it shares their random numbers, which lowers every MSE a little; render it with another --seed",
        p.display()
    ));
    Ok(())
}

/// A given reference must be an image of this scene at this depth where its report says
/// (reports without the fields pass): one of another scene, or of direct light for a path
/// traced comparison, gave metrics against the wrong image with exit 0 (an audit,
/// 2026-12-06).
fn check_reference_matches(
    p: &std::path::Path,
    report: &serde_json::Value,
    scene_hash: &str,
    max_depth: u32,
) -> Result<()> {
    if let Some(h) = report["scene_hash"].as_str() {
        if h != scene_hash {
            bail!(
                "reference '{}' is an image of another scene (its report's scene_hash {h}, this scene's {scene_hash}); give a reference of this scene, or leave out --reference to have one made",
                p.display()
            );
        }
    }
    if let Some(d) = report["max_depth"].as_u64() {
        if d != max_depth as u64 {
            bail!(
                "reference '{}' was rendered with --max-depth {d} but this comparison uses {max_depth}; pass --max-depth {d}, or give another reference",
                p.display()
            );
        }
    }
    Ok(())
}
