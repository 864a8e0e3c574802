//! `lightlearn merge` and `lightlearn merge-stats`: the parts of one render made apart (farm
//! chunks with other seeds, or on other machines) combined into what their summed samples
//! give, and their learned statistics summed.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use serde_json::{json, Value};

use crate::film::{self, OutputPaths};
use crate::learning::stats_file::SavedStats;

/// Report fields that every part of one image must share: what was rendered, and how
/// (the estimator's switches too: parts with another `--light-point`, `--stratify` or
/// light-sample count were merged without a word and the merged report named none of them:
/// an audit, 2026-12-06).
const SAME: [&str; 11] = [
    "scene_hash",
    "width",
    "height",
    "max_depth",
    "sampler",
    "integrator",
    "lightlearn_version",
    "light_point",
    "stratify",
    "first_light_samples",
    "indirect_light_samples",
];

/// The region settings of a report (its `regions` block without the per-run statistics).
fn region_settings(r: &Value) -> Value {
    let mut v = r["regions"].clone();
    if let Some(m) = v.as_object_mut() {
        m.remove("stats");
    }
    v
}

/// The first field in which two settings blocks differ, as "field: a vs b" (a field one
/// lacks shows as null: a report of a build before the field), so a refusal says which
/// (it said "other region settings (--grid, --tau, --k-max, …)": a review, 2026-12-06).
fn first_difference(a: &Value, b: &Value) -> String {
    let keys = |v: &Value| v.as_object().map(|m| m.keys().cloned().collect::<Vec<_>>());
    let (Some(ka), Some(kb)) = (keys(a), keys(b)) else {
        return format!("{a} vs {b}");
    };
    let mut all: Vec<String> = ka.into_iter().chain(kb).collect();
    all.sort();
    all.dedup();
    all.iter()
        .find(|k| a[k.as_str()] != b[k.as_str()])
        .map_or_else(String::new, |k| {
            format!("{k}: {} vs {}", a[k.as_str()], b[k.as_str()])
        })
}

/// What a merge wrote.
pub struct MergeOutcome {
    pub exr: PathBuf,
    pub parts: usize,
    pub spp: u64,
}

/// Averages the parts' images weighted by their spp (their JSON reports, beside each EXR,
/// say how many and how they were made) into `out` (+ .png, .json listing the parts).
/// Parts of another scene, size, depth or sampler settings, and parts that drew the same
/// random numbers (same seed and sample range), are refused naming the field.
/// A part of a render stopped before its count (its report says `interrupted`, or is a
/// checkpoint's) is merged by the samples it holds, and said through `warn`.
/// `exposure` is the PNG's factor (`--exposure`); None takes the parts' own (their reports'
/// `png_exposure`, 1 where absent), and where they differ the first part's, said through `warn`.
pub fn images(
    parts: &[PathBuf],
    out: &Path,
    exposure: Option<f32>,
    warn: &mut dyn FnMut(String),
) -> Result<MergeOutcome> {
    if parts.len() < 2 {
        bail!("merge needs at least two parts (PART.exr, each with its .json beside it)");
    }
    // A missing part first: a farm's merge run before its chunks was told that the output
    // folder does not exist (an audit, 2026-12-07).
    // Only a part surely missing: one that cannot be looked at (a folder without search
    // permission) is named by the read below, with its reason.
    if let Some(p) = parts.iter().find(|p| p.try_exists().is_ok_and(|e| !e)) {
        bail!(
            "part '{}' does not exist; render it first (in a farm job, its chunk's render task writes it)",
            p.display()
        );
    }
    let paths = OutputPaths::new(out)?;
    for p in parts {
        if paths.all().iter().any(|o| {
            crate::io::same_path(o, p) || crate::io::same_path(o, &p.with_extension("json"))
        }) {
            bail!(
                "--out '{}' would replace the part '{}'; name another file",
                out.display(),
                p.display()
            );
        }
    }
    // One file given twice was told "they hold the same samples; render the chunks with
    // different --seed" (an audit, 2026-12-07). Each path resolved once (a farm merges
    // thousands).
    let mut seen: std::collections::HashMap<PathBuf, &PathBuf> = Default::default();
    for p in parts {
        let key = std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
        if let Some(q) = seen.insert(key, p) {
            bail!(
                "part '{}' is given twice (also as '{}'); give each part once",
                p.display(),
                q.display()
            );
        }
    }
    let mut reports = Vec::new();
    for p in parts {
        // A missing image was reported as a missing report.
        if !p.exists() {
            bail!("part '{}' does not exist", p.display());
        }
        let j = p.with_extension("json");
        let text = crate::io::read_all(&j).with_context(|| {
            format!(
                "part '{}' has no report '{}' beside it (render writes one)",
                p.display(),
                j.display()
            )
        })?;
        let r: Value = serde_json::from_slice(&text)
            .with_context(|| format!("the report '{}' is not valid JSON", j.display()))?;
        // A merge's own output holds no seed or learning block of one render, so it was
        // refused for the wrong reason ("other settings", "the same samples").
        if let Some(from) = r["merged_from"].as_array() {
            let names: Vec<&str> = from.iter().filter_map(|f| f["exr"].as_str()).collect();
            bail!(
                "part '{}' is itself a merge (of {}); merge its parts together with the others instead",
                p.display(),
                names.join(", ")
            );
        }
        reports.push(r);
    }
    paths.check_not_foreign()?;
    let first = &reports[0];
    for (r, p) in reports.iter().zip(parts).skip(1) {
        for field in SAME {
            if r[field] != first[field] {
                bail!(
                    "part '{}' has {field} {} but '{}' has {}; only parts of one render can be merged",
                    p.display(),
                    r[field],
                    parts[0].display(),
                    first[field]
                );
            }
        }
        if region_settings(r) != region_settings(first) {
            bail!(
                "part '{}' used other region settings than '{}' ({})",
                p.display(),
                parts[0].display(),
                first_difference(&region_settings(r), &region_settings(first))
            );
        }
        if r["learning"]["settings"] != first["learning"]["settings"] {
            bail!(
                "part '{}' was learned with other settings than '{}' ({})",
                p.display(),
                parts[0].display(),
                first_difference(&r["learning"]["settings"], &first["learning"]["settings"])
            );
        }
    }
    // Each part's samples [first, first + spp): a report edited to a count past the random
    // streams made the weights' sum wrap and the merged image +inf, written with exit 0.
    let ranges: Vec<(u64, u64)> = reports
        .iter()
        .zip(parts)
        .map(|(r, p)| sample_range(r, p))
        .collect::<Result<_>>()?;
    // The same seed and sample range would be the same samples twice.
    for (i, (a, pa)) in reports.iter().zip(parts).enumerate() {
        for (j, (b, pb)) in reports.iter().zip(parts).enumerate().skip(i + 1) {
            let ((a0, a1), (b0, b1)) = (ranges[i], ranges[j]);
            if a["seed"] == b["seed"] && a0 < b1 && b0 < a1 {
                bail!(
                    "parts '{}' and '{}' share seed {} and samples {}..{}: they hold the same samples; render the chunks with different --seed",
                    pa.display(),
                    pb.display(),
                    a["seed"],
                    a0.max(b0),
                    a1.min(b1)
                );
            }
        }
    }
    let (w, h) = (
        first["width"].as_u64().unwrap_or(0),
        first["height"].as_u64().unwrap_or(0),
    );
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        bail!(
            "the report of part '{}' gives the size {w}×{h}, which no render writes; render it again",
            parts[0].display()
        );
    }
    let (w, h) = (w as u32, h as u32);
    // The sum is sized by the first part's image, once its EXR agrees with its report: a
    // report claiming 16384² beside a tiny EXR allocated 6.4 GB first (an audit,
    // 2026-12-07; harmless only where the system overcommits).
    let mut sum: Vec<[f64; 3]> = Vec::new();
    let mut total = 0u64;
    let mut listed = Vec::new();
    for (p, r) in parts.iter().zip(&reports) {
        // The image read with its report as one set, never across a render's commit (a
        // part being checkpointed was refused as split by a kill in 3 of 60 merges: an
        // audit, 2026-12-07): under a shared lock of its folder, which commits take
        // exclusively, one part at a time so that a render writing into another part's
        // folder is not held up by the whole merge.
        let _reading = crate::io::read_locks(std::iter::once(p.as_path()));
        let (pw, ph, px) = film::read_exr(p)?;
        let now: Option<Value> = crate::io::read_all(&p.with_extension("json"))
            .ok()
            .and_then(|t| serde_json::from_slice(&t).ok());
        if now.as_ref() != Some(r) {
            bail!(
                "part '{}' changed while it was merged (a render still writing it?); merge again when it has finished",
                p.display()
            );
        }
        if (pw, ph) != (w, h) {
            bail!(
                "part '{}' is {pw}×{ph} but its report says {w}×{h}; render it again",
                p.display()
            );
        }
        if sum.is_empty() {
            sum = vec![[0f64; 3]; (w * h) as usize];
        }
        // After the header's size (read_exr refuses sizes no render writes), before the
        // pixels are weighed by the report's spp.
        film::check_report(p, &p.with_extension("json"), r)?;
        let (first_sample, end) = sample_range(r, p)?;
        let spp = end - first_sample;
        if let Some(i) = px.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
            bail!(
                "part '{}' has a NaN or Inf at pixel {i}; render it again",
                p.display()
            );
        }
        for (s, v) in sum.iter_mut().zip(&px) {
            for k in 0..3 {
                s[k] += spp as f64 * v[k] as f64;
            }
        }
        total += spp;
        // The merged report's spp stays one a render's report can hold (2147483647 + 4
        // was written as 2147483651; an audit, 2026-12-06).
        if total > crate::render::MAX_PASSES as u64 {
            bail!(
                "the parts hold {total} samples together, past the {} a render's report can count; merge fewer parts",
                crate::render::MAX_PASSES
            );
        }
        let mut entry = json!({"exr": p.display().to_string(), "spp": spp, "seed": r["seed"]});
        // A render stopped before its count (Ctrl-C, a stop signal) or killed after a
        // checkpoint.
        if r["interrupted"] == json!(true) || r["checkpoint"] == json!(true) {
            entry["interrupted"] = json!(true);
            // The image has fewer samples than the job asked (merged silently, exit 0; an
            // audit, 2026-12-07).
            warn(format!(
                "part '{}' is of a render stopped before its count (interrupted, or a checkpoint), at {spp} spp; it counts by the samples it holds: render it again for the full count",
                p.display()
            ));
        }
        listed.push(entry);
    }
    let image: Vec<[f32; 3]> = sum
        .iter()
        .map(|s| s.map(|c| (c / total as f64) as f32))
        .collect();
    let mut report = json!({
        "merged_from": listed,
        "spp": total,
        "seconds_in_parts": reports.iter().filter_map(|r| r["render_seconds"].as_f64()).sum::<f64>(),
    });
    for field in SAME.iter().chain(&["scene"]) {
        report[*field] = first[*field].clone();
    }
    // Written by render only where the scene has any (so other reports stay as they were).
    if !first["directional_lights"].is_null() {
        report["directional_lights"] = first["directional_lights"].clone();
    }
    report["learning_settings"] = first["learning"]["settings"].clone();
    report["regions"] = region_settings(first);
    // A Ctrl-C during the writes ends the command at once (status 130) with no temporary
    // left and no output half moved (crate::io::remove_pending, crate::interrupt::Writing):
    // it had left a temporary behind (an audit, 2026-12-07), then printed "finishing the
    // current batch" and exited 0 (a review, 2026-12-07).
    // The parts' PNG exposure unless one is given: a farm's chunks rendered with --exposure
    // merged into a PNG at 0 EV (black for a dim scene), though each chunk's PNG showed it.
    let exposure = match exposure {
        Some(f) => f,
        None => {
            let of = |r: &Value| r["png_exposure"].as_f64().map_or(1.0, |f| f as f32);
            let own = of(first);
            // A report's factor as render writes it (2^−20 … 2^20): an edited 1e300 or −1
            // gave a black PNG in silence (a review, 2026-12-07).
            if !(own.is_finite() && (2f32.powi(-20)..=2f32.powi(20)).contains(&own)) {
                bail!(
                    "the report of part '{}' gives png_exposure {}, which no render writes; give --exposure, or render it again",
                    parts[0].display(),
                    first["png_exposure"]
                );
            }
            if let Some((_, p)) = (reports.iter().zip(parts)).find(|(r, _)| of(r) != own) {
                warn(format!(
                    "part '{}' was written with another PNG exposure than '{}'; the merged PNG takes the first part's (give --exposure to choose)",
                    p.display(),
                    parts[0].display()
                ));
            }
            own
        }
    };
    film::write_outputs_with(&paths, w, h, &image, &report, &[], exposure)?;
    Ok(MergeOutcome {
        exr: paths.exr,
        parts: parts.len(),
        spp: total,
    })
}

/// The samples [first, end) of a part's report, each within the 2^31 passes of the random
/// streams (so sums of counts cannot wrap); a report without a positive count is refused.
fn sample_range(r: &Value, p: &Path) -> Result<(u64, u64)> {
    let max = crate::render::MAX_PASSES as u64;
    let spp = r["spp"].as_u64().filter(|&n| n > 0).ok_or_else(|| {
        anyhow::anyhow!(
            "the report of part '{}' gives spp {}, not a positive sample count; render it again",
            p.display(),
            r["spp"]
        )
    })?;
    // Absent in reports older than chunks (0 then); anything else but a count is damage:
    // -1 or "x" was read as 0 (an audit, 2026-12-06).
    let first = match &r["first_sample_index"] {
        Value::Null => 0,
        v => v.as_u64().ok_or_else(|| {
            anyhow::anyhow!(
                "the report of part '{}' gives first_sample_index {v}, not a sample index; render it again",
                p.display()
            )
        })?,
    };
    if spp > max || first > max {
        bail!(
            "the report of part '{}' gives {spp} samples from sample {first}, past the {max} passes a render can take; render it again",
            p.display()
        );
    }
    Ok((first, first + spp))
}

/// Sums the statistics files `parts` ([`SavedStats::merge`], or with `base` the chunks
/// that all started from it, [`SavedStats::merge_onto`]) into `out`, written atomically;
/// `out` may not be one of the parts, and an existing `out` that is not a statistics file is
/// replaced only with `force` (a scene or a report was overwritten before).
/// Warnings (a start two parts share without `--base`) go to `warn`.
pub fn stats(
    parts: &[PathBuf],
    base: Option<&Path>,
    out: &Path,
    force: bool,
    warn: &mut dyn FnMut(String),
) -> Result<SavedStats> {
    if parts.is_empty() {
        bail!("merge-stats needs at least one statistics file");
    }
    // Each path resolved once (pairs of same_path took 12 s for 2000 farm chunks, quadratic:
    // a review, 2026-12-07); a part that does not exist is named when it is loaded below.
    let mut seen: std::collections::HashMap<PathBuf, &PathBuf> = Default::default();
    for b in parts {
        let key = b.canonicalize().unwrap_or_else(|_| b.clone());
        if let Some(a) = seen.insert(key, b) {
            bail!(
                "'{}' and '{}' are the same file: its samples would count twice; give each part once",
                a.display(),
                b.display()
            );
        }
    }
    crate::io::check_not_special(out)?;
    if out.exists() && !out.is_dir() && !crate::learning::stats_file::is_stats_file(out) && !force {
        bail!(
            "--out '{}' exists and is not a lightlearn statistics file; name another file, or add --force to replace it",
            out.display()
        );
    }
    if let Some(p) = parts.iter().find(|p| crate::io::same_path(p, out)) {
        bail!(
            "--out '{}' is one of the parts ('{}'); name another file",
            out.display(),
            p.display()
        );
    }
    crate::io::check_writable(out)?;
    check_memory(parts, base)?;
    let loaded: Vec<(SavedStats, String)> = parts
        .iter()
        .map(|p| Ok((SavedStats::load(p)?, p.display().to_string())))
        .collect::<Result<_>>()?;
    // A copy of a part under another name passed the path check and counted its samples
    // twice with exit 0 (an audit, 2026-12-06). Two renders that learned anything do not
    // end with the same totals bit for bit unless they are one.
    for (i, (a, an)) in loaded.iter().enumerate() {
        let learned = |s: &SavedStats| s.stats.iter().any(|t| t.n_zero + t.n_nonzero > 0.0);
        if let Some((_, bn)) = loaded[i + 1..].iter().find(|(b, _)| {
            learned(a)
                && (&a.header, &a.index, &a.cuts, &a.stats)
                    == (&b.header, &b.index, &b.cuts, &b.stats)
        }) {
            bail!(
                "'{an}' and '{bn}' hold the same statistics bit for bit (one a copy of the other?): its samples would count twice; give each part once"
            );
        }
    }
    if let Some(b) = base.filter(|b| crate::io::same_path(b, out)) {
        bail!(
            "--out '{}' is the --base file; name another file",
            b.display()
        );
    }
    let base = base.map(SavedStats::load).transpose()?;
    check_lineage(&loaded, base.as_ref(), warn)?;
    let merged = match &base {
        Some(b) => SavedStats::merge_onto(b, &loaded)?,
        None => SavedStats::merge(&loaded)?,
    };
    // As images() above (a 14.7 MB temporary was left).
    merged.save(out)?;
    Ok(merged)
}

/// What the parts hold of each other (their headers' `holds`, files saved since
/// 2026-12-07): a part that another part was made from (its continuation, a later frame,
/// or a merge of it) would count its observations twice, so it is refused; a start that two
/// parts were made from and that is not the `--base` file (chunks that loaded one file,
/// merged without it as `--base`) counts twice in the sum, said in a warning (the merge
/// still only guides sampling: the images stay unbiased). Linear in the parts (a farm merge
/// takes up to 10000 chunks).
fn check_lineage(
    loaded: &[(SavedStats, String)],
    base: Option<&SavedStats>,
    warn: &mut dyn FnMut(String),
) -> Result<()> {
    use std::collections::HashMap;
    let by_sum: HashMap<String, &str> = (loaded.iter())
        .map(|(s, name)| (s.checksum(), name.as_str()))
        .collect();
    let base_sum = base.map(SavedStats::checksum);
    let mut started: HashMap<&str, &str> = HashMap::new();
    let mut shared: Option<(&str, &str, &str)> = None;
    for (s, bn) in loaded {
        for x in s.header.holds.iter().flatten() {
            if let Some(an) = by_sum.get(x.as_str()) {
                bail!("'{bn}' already holds the statistics of '{an}' (it continued from them with --load-stats, or merged them): drop '{an}' from the parts, or, where several parts started from it, give it as --base");
            }
            if base_sum.as_deref() == Some(x.as_str()) {
                continue;
            }
            match started.insert(x, bn) {
                Some(an) if an != bn.as_str() && shared.is_none() => {
                    shared = Some((an, bn, x));
                }
                _ => {}
            }
        }
    }
    if let Some((an, bn, x)) = shared {
        let fix = match base {
            Some(_) => "it is not the --base file: give the file both loaded as --base",
            None => "give the file both loaded as --base to count it once",
        };
        warn(format!("'{an}' and '{bn}' both hold the statistics of one start (checksum {x}), which this merge counts twice; {fix}"));
    }
    Ok(())
}

/// Refuses, before reading any, parts that together need more memory than is free: every
/// part is held at once, and 40 parts of 134 MB aborted with a failed allocation and a
/// backtrace under a 4 GB limit (an audit, 2026-12-07). Where /proc/meminfo says nothing,
/// nothing is checked.
fn check_memory(parts: &[PathBuf], base: Option<&Path>) -> Result<()> {
    let bytes: u64 = (parts.iter().map(PathBuf::as_path).chain(base))
        .filter_map(|p| std::fs::metadata(p).ok())
        .map(|m| m.len())
        .sum();
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| {
            let line = m.lines().find(|l| l.starts_with("MemAvailable:"))?;
            line.split_whitespace().nth(1)?.parse::<u64>().ok()
        })
        .map(|kib| kib * 1024);
    // A container's own limit (cgroup v2), where it is below the host's free memory (a
    // review, 2026-12-07).
    let read = |f: &str| -> Option<u64> {
        std::fs::read_to_string(format!("/sys/fs/cgroup/{f}"))
            .ok()?
            .trim()
            .parse()
            .ok()
    };
    let cgroup =
        read("memory.max").map(|max| max.saturating_sub(read("memory.current").unwrap_or(0)));
    let available = match (available, cgroup) {
        (Some(a), Some(c)) => Some(a.min(c)),
        (a, c) => a.or(c),
    };
    // The merge holds each part and its result: about 1.2× the files (measured 1.46 GB for
    // 10 parts of 134 MB).
    let need = bytes + bytes / 5;
    if let Some(free) = available.filter(|&free| need > free) {
        bail!(
            "these {} statistics files hold {:.1} GB together and a merge keeps them all in memory (about {:.1} GB), more than the {:.1} GB free; merge them in groups and merge the groups (merges are order-free)",
            parts.len(),
            bytes as f64 / 1e9,
            need as f64 / 1e9,
            free as f64 / 1e9
        );
    }
    Ok(())
}
