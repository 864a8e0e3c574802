//! `lightlearn variance`'s results: a row per sampler, the Markdown table, and the report
//! (variance.json and a float EXR of per-pixel maps a row) that src/commands/variance.rs
//! measures.

use std::path::Path;

use anyhow::{bail, Context, Result};
use serde_json::json;

use super::variance::VarianceRequest;
use crate::variance::PixelTerms;

/// One row: the decomposition summed over the decomposed pixels, and the measurement.
#[derive(Clone, Debug)]
pub struct Row {
    pub name: String,
    pub sum: PixelTerms,
    pub pixels: Vec<PixelTerms>,
    /// Σ over the decomposed pixels of spp · (a − b)² / 2 from two renders of other seeds
    /// (independent jitter): the variance per sample the kernel shows.
    pub measured: f64,
    /// Per decomposed pixel: spp · (a − b)² / 2 (the terms of `measured`).
    pub measured_pixels: Vec<f64>,
    /// The same with the renderer's own jitter, stratified over the passes (the default
    /// `--stratify`, Sobol'; R2 before 2026-12-05, hence the name); the table shows
    /// `measured` ÷ this, what stratification takes out.
    pub measured_r2: f64,
    /// The same at `max_depth` (None for direct light only), stratified jitter.
    pub measured_gi: Option<f64>,
}

impl Row {
    /// The largest single pixel's share of `measured`: near 1 the measurement (and any
    /// equal-spp ratio on this image) rests on a pixel or two of a heavy-tailed estimator.
    pub fn top_pixel_share(&self) -> f64 {
        let top = self.measured_pixels.iter().copied().fold(0.0, f64::max);
        if self.measured > 0.0 {
            top / self.measured
        } else {
            0.0
        }
    }
}

/// The measured variance with independent numbers over the one with the renderer's
/// stratified numbers. (Until 2026-12-05 this column was a "stratified footprint",
/// stratified − the independent selection terms: stratification takes variance out of the
/// light choice as well as out of the footprint, so that difference went negative, e.g.
/// −184 % for `wang` on rooms16, and meant nothing.)
fn stratification_gain(independent: f64, stratified: f64) -> String {
    if stratified > 0.0 && independent.is_finite() {
        format!("{:.1}×", independent / stratified)
    } else {
        "—".into()
    }
}

pub(super) fn table(a: &VarianceRequest, rows: &[Row]) -> String {
    let wang = rows
        .iter()
        .find(|r| r.name == "wang")
        .map(|r| r.sum.total());
    let mut t = String::new();
    t += &format!(
        "Variance per sample, luminance, summed over {} pixels ({} hits each); shares of the predicted total\n\n",
        rows.first().map_or(0, |r| r.pixels.len()),
        a.hits
    );
    t += "| sampler | predicted | measured | gain over wang (wang ÷ this) | cluster | light in cluster | point on light | footprint (at emitter pixels) | measured, stratified | stratification's gain | zero samples (lit hits) | dark hits | top pixel's share of measured |";
    if a.max_depth > 1 {
        t += &format!(
            " measured, depth {} (stratified) | depth {} ÷ direct |",
            a.max_depth, a.max_depth
        );
    }
    t += "\n|---|---|---|---|---|---|---|---|---|---|---|---|---|";
    if a.max_depth > 1 {
        t += "---|---|";
    }
    t += "\n";
    for r in rows {
        let s = &r.sum;
        let tot = s.total();
        // A scene whose decomposed hits are all dark has nothing to share out: "—", not NaN.
        let pct = |v: f64| {
            if tot > 0.0 {
                format!("{:.1} %", 100.0 * v / tot)
            } else {
                "—".into()
            }
        };
        let ratio = wang
            .filter(|_| tot > 0.0)
            .map_or("—".into(), |w| format!("{:.2}×", w / tot));
        t += &format!(
            "| {} | {:.3e} | {:.3e} | {} | {} | {} | {} | {} ({}) | {:.3e} | {} | {:.1} % | {:.1} % | {:.1} % |",
            r.name,
            tot,
            r.measured,
            ratio,
            pct(s.cluster),
            pct(s.light),
            pct(s.point),
            pct(s.jitter),
            pct(s.jitter_emitter),
            r.measured_r2,
            stratification_gain(r.measured, r.measured_r2),
            100.0 * s.zero_lit,
            100.0 * s.dark_hits as f64 / s.hits.max(1) as f64,
            100.0 * r.top_pixel_share(),
        );
        if let Some(g) = r.measured_gi {
            // The ratio, not a share of "later vertices": at depth > 1 the first vertex's
            // light also comes by MIS-weighted BSDF rays and the learned samplers learn at
            // every vertex, so the first vertex's estimator is not depth 1's; a scene with
            // no indirect light at all showed "later vertices" of 69 % (uniform) and −32 %
            // (bayes) (an audit, 2026-12-07). No variance at all (no hit lit) says "—".
            let later = if r.measured_r2 > 0.0 && g > 0.0 {
                format!("{:.2}×", g / r.measured_r2)
            } else {
                "—".into()
            };
            t += &format!(" {g:.3e} | {later} |");
        }
        t += "\n";
    }
    if rows.iter().any(|r| r.top_pixel_share() > 0.2) {
        t += "\nwarning: one pixel holds over 20 % of a measured variance: the estimator is heavy-tailed there, so measured and predicted can disagree widely (more --hits sample the hits better; more pixels the measurement)\n";
    }
    if rows.iter().any(|r| r.sum.missed > 0.0) {
        t += "\nwarning: a sampler gave some light probability 0 (biased): see `missed` in variance.json\n";
    }
    t
}

/// `rowN.exr`.
pub(super) fn is_map_name(name: &str) -> bool {
    name.strip_prefix("row")
        .and_then(|r| r.strip_suffix(".exr"))
        .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
}

/// The maps that an earlier variance report in `out` lists (none where there is no report).
/// Refuses a `variance.json` that is not such a report and a `rowN.exr` that it does not
/// list: a user's files of those names were replaced, and `row1.exr`, `row2.exr`, …
/// deleted, with exit 0 (an audit, 2026-12-07).
pub(super) fn earlier_maps(out: &Path) -> Result<Vec<String>> {
    let report = out.join("variance.json");
    let mut listed: Vec<String> = match std::fs::read(&report) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => bail!("cannot read '{}': {e}", report.display()),
        Ok(bytes) => {
            let v: Option<serde_json::Value> = serde_json::from_slice(&bytes).ok();
            let maps = v
                .as_ref()
                .filter(|v| v.get("map_channels").is_some())
                .and_then(|v| v["rows"].as_array())
                .map(|rows| {
                    rows.iter()
                        .filter_map(|r| r["maps"].as_str())
                        .filter(|m| is_map_name(m))
                        .map(String::from)
                        .collect()
                });
            match maps {
                Some(m) => m,
                None => bail!(
                    "'{}' exists and is not a `lightlearn variance` report; name another --out, or move the file away",
                    report.display()
                ),
            }
        }
    };
    let entries = std::fs::read_dir(out)
        .with_context(|| format!("cannot list the output folder '{}'", out.display()))?;
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        if !is_map_name(name) || listed.iter().any(|m| m == name) {
            continue;
        }
        if is_our_map(&e.path()) {
            listed.push(name.to_string());
        } else {
            bail!(
                "'{}' is not a map of an earlier `lightlearn variance` run in this folder; name another --out, or move the file away",
                out.join(name).display()
            );
        }
    }
    Ok(listed)
}

/// Whether `p` is an EXR with exactly a variance map's channels: a map that an earlier run
/// left unlisted (stopped between its commit and the removal of its extra maps) is ours to
/// replace (a review, 2026-12-07).
fn is_our_map(p: &Path) -> bool {
    let Ok((file, _)) = crate::io::open_regular(p) else {
        return false;
    };
    let mut reader = std::io::BufReader::new(file);
    let Ok(meta) = exr::meta::MetaData::read_from_buffered(&mut reader, false) else {
        return false;
    };
    let mut names: Vec<String> = meta
        .headers
        .iter()
        .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
        .collect();
    names.sort();
    names
        == [
            "cluster",
            "footprint",
            "light",
            "measured",
            "point",
            "value",
        ]
}

/// Writes the report and the maps into `out`; `earlier`: the maps the report there listed
/// ([`earlier_maps`]), of which those past this run's rows are removed.
pub(super) fn write_outputs(
    out: &Path,
    a: &VarianceRequest,
    rows: &[Row],
    earlier: &[String],
) -> Result<()> {
    let (w, h) = (a.width.div_ceil(a.stride), a.height.div_ceil(a.stride));
    let mut set = crate::io::FileSet::default();
    let mut json_rows = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        let file = format!("row{i}.exr");
        set.add_with(&out.join(&file), |tmp| write_maps(tmp, w, h, r))?;
        let s = &r.sum;
        json_rows.push(json!({
            "name": r.name,
            "maps": file,
            "predicted": s.total(),
            "measured": r.measured,
            "measured_r2": r.measured_r2,
            "top_pixel_share_of_measured": r.top_pixel_share(),
            "measured_gi": r.measured_gi,
            "cluster": s.cluster,
            "light": s.light,
            "point": s.point,
            "footprint": s.jitter,
            "footprint_at_emitter_pixels": s.jitter_emitter,
            "missed": s.missed,
            "zero_share_lit_hits": s.zero_lit,
            "dark_hits": s.dark_hits,
            "hits": s.hits,
        }));
    }
    let report = json!({
        "scene": a.scene.as_ref().map(|p| p.display().to_string()),
        "width": a.width,
        "height": a.height,
        "spp": a.spp,
        "seed": a.seed,
        "stride": a.stride,
        "hits_per_pixel": a.hits,
        "area_samples": a.area_samples,
        "max_depth": a.max_depth,
        "map_channels": ["cluster", "light", "point", "footprint", "value", "measured"],
        "rows": json_rows,
    });
    set.add(
        &out.join("variance.json"),
        (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
    )?;
    set.commit()?;
    // Maps of an earlier run with more samplers would stay beside a report that lists fewer
    // (an audit, 2026-12-07): those its report listed, past this run's rows.
    let ours: Vec<String> = (0..rows.len()).map(|i| format!("row{i}.exr")).collect();
    for m in earlier.iter().filter(|m| !ours.contains(m)) {
        let stale = out.join(m);
        if std::fs::symlink_metadata(&stale).is_ok_and(|m| m.is_file()) {
            std::fs::remove_file(&stale).with_context(|| {
                format!("cannot remove the earlier run's '{}'", stale.display())
            })?;
        }
    }
    Ok(())
}

/// Per-pixel maps (variance per sample by stage, and the pixel's value) as a float EXR
/// with named channels, one pixel per decomposed pixel.
fn write_maps(path: &Path, w: u32, h: u32, r: &Row) -> Result<()> {
    use exr::prelude::*;
    let px = &r.pixels;
    let chan = |name: &str, f: &dyn Fn(&PixelTerms) -> f64| {
        AnyChannel::new(
            name,
            FlatSamples::F32(px.iter().map(|p| f(p) as f32).collect()),
        )
    };
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        chan("cluster", &|p| p.cluster),
        chan("light", &|p| p.light),
        chan("point", &|p| p.point),
        chan("footprint", &|p| p.jitter),
        chan("value", &|p| p.value),
        AnyChannel::new(
            "measured",
            FlatSamples::F32(r.measured_pixels.iter().map(|&v| v as f32).collect()),
        ),
    ]));
    Image::from_channels((w as usize, h as usize), channels)
        .write()
        .non_parallel()
        .to_file(path)
        .map_err(|e| anyhow::anyhow!("EXR write failed: {e}"))
}
