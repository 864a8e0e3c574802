//! `animate --reference-spp N`: the temporal-coherence evaluation. Renders per-frame
//! references (`lightbvh`, N spp, independent jitter per frame), then every variant of the
//! comparison (`--variants`, e.g. `wang,bayes-off,bayes-on`) as its own animation, and
//! writes `DIR/report.html` (self-contained: a table of per-frame MSE and relMSE side by
//! side, a plot of MSE against frame, a flip between consecutive frames, the flicker
//! measures) and `DIR/report.json`.
//!
//! MSE is against the frame's reference, with the reference's own estimated noise
//! subtracted. Flicker (also in docs/features.md): `flicker` = std over frames of the
//! per-frame MSE ÷ its mean; `step` = mean |MSE(k+1) − MSE(k)| ÷ the mean MSE. A sampler
//! whose quality jumps from frame to frame flickers although each frame is unbiased.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use base64::Engine;
use serde_json::json;

use super::animate::{self, frame_stem, AnimateRequest};
use super::Ui;
use crate::compare::metrics;
use crate::film;
use crate::render::LightSampler;

/// One side of the comparison: a sampler, carrying on or off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variant {
    pub sampler: LightSampler,
    pub carry: bool,
}

impl Variant {
    pub fn name(&self) -> String {
        if self.sampler.learned() {
            format!(
                "{}-{}",
                self.sampler.name(),
                if self.carry { "on" } else { "off" }
            )
        } else {
            self.sampler.name().to_string()
        }
    }

    /// "wang", "bayes-on", "bayes-off", "donikian" (learned samplers: on by default).
    pub fn parse_list(s: &str) -> Result<Vec<Variant>> {
        let mut out = Vec::new();
        for item in s.split(',').map(str::trim).filter(|t| !t.is_empty()) {
            let (name, carry, suffix) = match item.rsplit_once('-') {
                Some((n, "on")) => (n, true, true),
                Some((n, "off")) => (n, false, true),
                _ => (item, true, false),
            };
            let sampler = LightSampler::from_name(name)?;
            // `wang-on` was taken (an audit, 2026-12-06): a sampler that learns nothing
            // carries nothing, so -on and -off would be one animation twice.
            if suffix && !sampler.learned() {
                bail!("--variants '{item}': {name} learns nothing to carry from frame to frame; write '{name}' (-on/-off go with bayes and donikian)");
            }
            let v = Variant { sampler, carry };
            if out.iter().any(|o: &Variant| o.name() == v.name()) {
                bail!("--variants lists '{item}' twice");
            }
            out.push(v);
        }
        if out.is_empty() {
            bail!("--variants needs at least one sampler, e.g. wang,bayes-off,bayes-on");
        }
        Ok(out)
    }
}

/// Per-frame errors of one variant.
#[derive(Clone, Debug, serde::Serialize)]
pub struct VariantErrors {
    pub name: String,
    pub mse: Vec<f64>,
    pub rel_mse: Vec<f64>,
    pub seconds: Vec<f64>,
    pub flicker: f64,
    pub step: f64,
}

/// std / mean and mean |Δ| / mean of a per-frame series.
pub fn flicker(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    if mean <= 0.0 || v.len() < 2 {
        return (0.0, 0.0);
    }
    let std = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
    let step = v.windows(2).map(|w| (w[1] - w[0]).abs()).sum::<f64>() / (n - 1.0) / mean;
    (std / mean, step)
}

fn read_json(p: &Path) -> Result<serde_json::Value> {
    Ok(serde_json::from_slice(&std::fs::read(p)?)?)
}

/// Renders the references and the variants under `req.out` and writes the report.
pub fn run(
    req: &AnimateRequest,
    reference_spp: u32,
    variants: &[Variant],
    ui: &mut dyn Ui,
) -> Result<Vec<VariantErrors>> {
    // Before the references' renders take it as their --spp, which the error then named
    // (an audit, 2026-12-06).
    super::check_spp("--reference-spp", reference_spp)?;
    animate::check(req)?;
    let reference_dir = req.out.join("reference");
    ui.message(&format!(
        "references: lightbvh, {reference_spp} spp per frame"
    ));
    let reference_req = AnimateRequest {
        out: reference_dir.clone(),
        sampler: LightSampler::Lightbvh,
        carry: false,
        spp: Some(reference_spp),
        seconds: None,
        load_stats: None,
        video: false,
        chunk: None,
        seed: req.seed ^ 0x5EED_0001,
        // Independent numbers, so that a reference's own noise can be estimated: with
        // animate's Sobol' numbers its estimate was many times its error, and every
        // variant's MSE came out 0 (a review, 2026-12-06).
        stratify: crate::render::Stratify::Off,
        ..req.clone()
    };
    let references = animate::run(&reference_req, ui)?;
    if references.interrupted {
        bail!("interrupted (Ctrl-C or a stop signal) while rendering the references; nothing compared");
    }
    let mut results = Vec::new();
    let mut unresolved: Vec<String> = Vec::new();
    let mut unknown: Option<String> = None;
    for v in variants {
        ui.message(&format!("variant {}", v.name()));
        let vreq = AnimateRequest {
            out: req.out.join(v.name()),
            sampler: v.sampler,
            carry: v.carry,
            ..req.clone()
        };
        let o = animate::run(&vreq, ui)?;
        if o.interrupted {
            bail!(
                "interrupted (Ctrl-C or a stop signal) in variant {}; no report written",
                v.name()
            );
        }
        let (mut mse, mut rel, mut seconds) = (Vec::new(), Vec::new(), Vec::new());
        for (f, r) in o.frames.iter().zip(&references.frames) {
            let (_, _, image) = film::read_exr(&f.exr)?;
            let (_, _, reference) = film::read_exr(&r.exr)?;
            let m = metrics(&image, &reference);
            // The reference's own noise adds its variance to the measured MSE; where it is
            // not below the measured MSE the frame's error is unresolved, said below.
            // Both errors lose the reference's own: `rel_mse` was left raw beside a
            // corrected `mse` (an audit, 2026-12-07), as compare's metrics.json keeps them
            // apart under `corrected`.
            let (noise, rel_noise) = match crate::compare::reference::noise(&read_json(
                &r.exr.with_extension("json"),
            )?) {
                Ok(n) => (n.mse, n.rel_mse),
                Err(why) => {
                    unknown.get_or_insert(why);
                    (0.0, 0.0)
                }
            };
            if m.mse <= noise {
                unresolved.push(format!("{} frame {}", v.name(), r.frame));
            }
            mse.push((m.mse - noise).max(0.0));
            rel.push((m.rel_mse - rel_noise).max(0.0));
            seconds.push(f.render_seconds);
        }
        let (fl, step) = flicker(&mse);
        results.push(VariantErrors {
            name: v.name(),
            mse,
            rel_mse: rel,
            seconds,
            flicker: fl,
            step,
        });
    }
    if !unresolved.is_empty() {
        ui.message(&format!(
            "warning: the references' own error is not below the measured error of {}: those MSEs are written as 0, not measured, and the flicker and step count them; use a larger --reference-spp",
            unresolved.join(", ")
        ));
    }
    if let Some(why) = &unknown {
        ui.message(&format!(
            "warning: the references' own error is unknown ({why}), so it is not taken out of the MSEs; use a larger --reference-spp"
        ));
    }
    let frames: Vec<u32> = references.frames.iter().map(|f| f.frame).collect();
    crate::io::write_atomic(
        &req.out.join("report.json"),
        serde_json::to_string_pretty(&json!({
            "scene": req.scene.as_ref().map(|p| p.display().to_string()),
            "reference_spp": reference_spp,
            "errors": if unknown.is_none() {
                "mse and rel_mse against the reference, its own estimated error taken out (as compare's `corrected`)"
            } else {
                "mse and rel_mse against the reference, raw: its own error is unknown"
            },
            "frames": frames,
            "variants": results,
        }))?
        .as_bytes(),
    )?;
    let html = report_html(req, reference_spp, &frames, &results)?;
    crate::io::write_atomic(&req.out.join("report.html"), html.as_bytes())?;
    Ok(results)
}

const COLOURS: [&str; 6] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];

fn png_uri(p: &Path) -> Result<String> {
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(std::fs::read(p)?)
    ))
}

/// The MSE-against-frame plot (log scale), inline SVG.
fn plot(frames: &[u32], results: &[VariantErrors]) -> String {
    // Room on the right for the legend.
    let (w, h, pad) = (720.0, 280.0, 50.0);
    let right = 130.0;
    let all: Vec<f64> = results
        .iter()
        .flat_map(|r| r.mse.iter().copied())
        .filter(|v| *v > 0.0)
        .collect();
    let lo = all
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .log10()
        .floor();
    let hi = all
        .iter()
        .copied()
        .fold(0.0, f64::max)
        .log10()
        .ceil()
        .max(lo + 1.0);
    let n = frames.len().max(2) as f64 - 1.0;
    let x = |i: usize| pad + (w - pad - right) * i as f64 / n;
    let y = |v: f64| {
        let t = (v.max(10f64.powf(lo)).log10() - lo) / (hi - lo);
        h - pad - (h - 2.0 * pad) * t
    };
    let mut s = format!(
        "<svg width=\"{w}\" height=\"{h}\" xmlns=\"http://www.w3.org/2000/svg\" role=\"img\" aria-label=\"MSE against frame\">\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>"
    );
    for e in lo as i32..=hi as i32 {
        let yy = y(10f64.powi(e));
        let _ = write!(
            s,
            "<line x1=\"{pad}\" x2=\"{}\" y1=\"{yy}\" y2=\"{yy}\" stroke=\"#ddd\"/>\
             <text x=\"4\" y=\"{}\" font-size=\"11\">1e{e}</text>",
            w - right,
            yy + 4.0
        );
    }
    for (i, f) in frames.iter().enumerate() {
        let _ = write!(
            s,
            "<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">{f}</text>",
            x(i),
            h - pad + 16.0
        );
    }
    for (k, r) in results.iter().enumerate() {
        let c = COLOURS[k % COLOURS.len()];
        let pts: Vec<String> = r
            .mse
            .iter()
            .enumerate()
            .map(|(i, v)| format!("{:.1},{:.1}", x(i), y(*v)))
            .collect();
        let _ = write!(
            s,
            "<polyline fill=\"none\" stroke=\"{c}\" stroke-width=\"2\" points=\"{}\"/>\
             <text x=\"{}\" y=\"{}\" font-size=\"12\" fill=\"{c}\">{}</text>",
            pts.join(" "),
            w - right + 10.0,
            pad + 14.0 * k as f64,
            r.name
        );
    }
    s.push_str("</svg>");
    s
}

fn report_html(
    req: &AnimateRequest,
    reference_spp: u32,
    frames: &[u32],
    results: &[VariantErrors],
) -> Result<String> {
    let scene = req
        .scene
        .as_ref()
        .map_or("the default scene".to_string(), |p| {
            crate::compare::report::esc(&p.display().to_string())
        });
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>lightlearn animate: {scene}</title>\
         <style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}\
         td,th{{border:1px solid #ccc;padding:2px 8px;text-align:right}}</style></head><body>\
         <h1>Temporal coherence: {scene}</h1>\
         <p>{} frames at {} fps, {}×{}, depth {}, {} per frame; references: lightbvh, {reference_spp} spp per frame \
         (their estimated noise subtracted from each MSE and relMSE). Flicker: std over frames of the MSE ÷ its mean; step: \
         mean |MSE(k+1) − MSE(k)| ÷ mean MSE.</p>",
        frames.len(),
        req.fps,
        req.width,
        req.height,
        req.max_depth,
        match (req.spp, req.seconds) {
            (Some(n), _) => format!("{n} spp"),
            (None, Some(t)) => format!("{t} s"),
            _ => "64 spp".to_string(),
        }
    );
    h.push_str("<h2>Summary</h2><table><tr><th>variant</th><th>mean MSE</th><th>mean relMSE</th><th>flicker</th><th>step</th><th>seconds</th></tr>");
    for r in results {
        let n = r.mse.len().max(1) as f64;
        let _ = write!(
            h,
            "<tr><th>{}</th><td>{:.3e}</td><td>{:.3e}</td><td>{:.2}</td><td>{:.2}</td><td>{:.2}</td></tr>",
            r.name,
            r.mse.iter().sum::<f64>() / n,
            r.rel_mse.iter().sum::<f64>() / n,
            r.flicker,
            r.step,
            r.seconds.iter().sum::<f64>()
        );
    }
    h.push_str("</table><h2>MSE against frame</h2>");
    h.push_str(&plot(frames, results));
    h.push_str("<h2>Per frame</h2><table><tr><th>frame</th>");
    for r in results {
        let _ = write!(h, "<th>{} MSE</th><th>{} relMSE</th>", r.name, r.name);
    }
    h.push_str("</tr>");
    for (i, f) in frames.iter().enumerate() {
        let _ = write!(h, "<tr><th>{f}</th>");
        for r in results {
            let _ = write!(h, "<td>{:.3e}</td><td>{:.3e}</td>", r.mse[i], r.rel_mse[i]);
        }
        h.push_str("</tr>");
    }
    h.push_str("</table>");
    // Flip: each variant's consecutive frames, alternating on a click (and every 0.5 s).
    h.push_str("<h2>Flip between consecutive frames</h2><p>Click an image to stop or start it; the slider picks the pair.</p>");
    let pair_max = frames.len().saturating_sub(2);
    let _ = write!(
        h,
        "<input id=\"pair\" type=\"range\" min=\"0\" max=\"{pair_max}\" value=\"0\"> <span id=\"pairlabel\"></span><div>"
    );
    let mut scripts = Vec::new();
    for r in results
        .iter()
        .map(|r| r.name.clone())
        .chain(["reference".to_string()])
    {
        let dir: PathBuf = req.out.join(&r);
        let uris: Vec<String> = frames
            .iter()
            .map(|&k| png_uri(&frame_stem(&dir, k).with_extension("png")))
            .collect::<Result<_>>()?;
        let id = format!("flip-{r}");
        let _ = write!(
            h,
            "<figure style=\"display:inline-block\"><img id=\"{id}\" src=\"{}\" width=\"{}\"><figcaption>{r}</figcaption></figure>",
            uris[0],
            req.width.max(160)
        );
        scripts.push(format!("[\"{id}\", {}]", serde_json::to_string(&uris)?));
    }
    let _ = write!(
        h,
        "</div><script>const flips=[{}];const frames={};let second=false,running=true;\
         function show(){{const p=+document.getElementById('pair').value;const k=p+(second?1:0);\
         document.getElementById('pairlabel').textContent='frames '+frames[p]+' / '+frames[Math.min(p+1,frames.length-1)]+': showing '+frames[Math.min(k,frames.length-1)];\
         for(const [id,u] of flips){{document.getElementById(id).src=u[Math.min(k,u.length-1)];}}}}\
         setInterval(()=>{{if(running){{second=!second;show();}}}},500);\
         for(const [id] of flips){{document.getElementById(id).onclick=()=>{{running=!running;}};}}\
         document.getElementById('pair').oninput=show;show();</script></body></html>",
        scripts.join(","),
        serde_json::to_string(frames)?
    );
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flicker_by_hand() {
        assert_eq!(flicker(&[2.0, 2.0, 2.0]), (0.0, 0.0));
        // mean 2, std 1, one step of 2.
        assert_eq!(flicker(&[1.0, 3.0]), (0.5, 1.0));
        let v = Variant::parse_list("wang,bayes-off,bayes").unwrap();
        let names: Vec<String> = v.iter().map(Variant::name).collect();
        assert_eq!(names, ["wang", "bayes-off", "bayes-on"]);
        assert!(Variant::parse_list("bayes-on,bayes").is_err());
        assert!(Variant::parse_list("nope").is_err());
        assert!(Variant::parse_list("wang-on").is_err());
        assert!(Variant::parse_list("uniform-off").is_err());
    }
}
