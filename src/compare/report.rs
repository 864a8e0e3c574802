//! The comparison report: one self-contained HTML page (images as data URIs, the plot as
//! inline SVG, no network), plus the CSV of convergence checkpoints.

use std::fmt::Write as _;

use anyhow::Result;
use base64::Engine;

use super::{rel_error_map, Comparison};
use crate::film;

pub struct ReportInput<'a> {
    pub scene: &'a str,
    pub width: u32,
    pub height: u32,
    pub device: &'a str,
    pub reference: &'a [[f32; 3]],
    /// How the reference was made and its own estimated error.
    pub reference_note: &'a str,
    pub comparisons: &'a [Comparison],
}

const COLOURS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
];

/// Error maps show log10 of the per-pixel relative squared error over this range.
const ERR_LOG_MIN: f32 = -4.0;
const ERR_LOG_MAX: f32 = 1.0;
/// An approximation of matplotlib's "inferno" (perceptually ordered, readable in grey).
const INFERNO: [[f32; 3]; 5] = [
    [0.0, 0.0, 0.016],
    [0.341, 0.063, 0.431],
    [0.737, 0.216, 0.329],
    [0.976, 0.557, 0.035],
    [0.988, 1.0, 0.643],
];

fn inferno(t: f32) -> [u8; 3] {
    let x = t.clamp(0.0, 1.0) * 4.0;
    let i = (x as usize).min(3);
    let f = x - i as f32;
    let (a, b) = (INFERNO[i], INFERNO[i + 1]);
    [0, 1, 2].map(|k| ((a[k] + (b[k] - a[k]) * f) * 255.0 + 0.5) as u8)
}

fn data_uri(png: &[u8]) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

/// The longest side of the page's images: a 2048×2048 comparison embedded each image at full
/// size, some twice, in a 286 MB page that browsers choke on (an audit, 2026-12-07). Larger
/// images are shown shrunk by a whole factor; the EXRs beside the page hold every pixel.
pub const MAX_SHOWN: u32 = 1024;

/// The whole factor the page shrinks a `w`×`h` image by (1: shown as rendered).
pub fn shown_factor(w: u32, h: u32) -> u32 {
    w.max(h).div_ceil(MAX_SHOWN).max(1)
}

/// `v` (`w`×`h` pixels of `channels` floats, row by row) averaged over `f`×`f` boxes (those
/// at the right and bottom edges partial), with its new size.
fn shrink(w: u32, h: u32, f: u32, channels: usize, v: &[f32]) -> (u32, u32, Vec<f32>) {
    if f <= 1 {
        return (w, h, v.to_vec());
    }
    let (sw, sh) = (w.div_ceil(f), h.div_ceil(f));
    let mut sum = vec![0f64; (sw * sh) as usize * channels];
    let mut n = vec![0u32; (sw * sh) as usize];
    for y in 0..h {
        for x in 0..w {
            let (s, p) = (((y / f) * sw + x / f) as usize, (y * w + x) as usize);
            n[s] += 1;
            for c in 0..channels {
                sum[s * channels + c] += v[p * channels + c] as f64;
            }
        }
    }
    let out = sum
        .iter()
        .enumerate()
        .map(|(i, s)| (s / n[i / channels] as f64) as f32)
        .collect();
    (sw, sh, out)
}

/// Radiance averaged over boxes (linear, before the tone map).
fn image_uri(w: u32, h: u32, f: u32, rgb: &[[f32; 3]]) -> Result<String> {
    let (w, h, v) = shrink(w, h, f, 3, bytemuck::cast_slice(rgb));
    let rgb: Vec<[f32; 3]> = v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Ok(data_uri(&film::png_bytes(
        w,
        h,
        &film::tonemap_srgb8(&rgb),
    )?))
}

/// The per-pixel relative squared error, averaged over boxes.
fn error_uri(w: u32, h: u32, f: u32, image: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<String> {
    let (w, h, e) = shrink(w, h, f, 1, &rel_error_map(image, reference));
    let rgb8: Vec<u8> = e
        .iter()
        .flat_map(|e| {
            let l = e.max(1e-12).log10();
            inferno((l - ERR_LOG_MIN) / (ERR_LOG_MAX - ERR_LOG_MIN))
        })
        .collect();
    Ok(data_uri(&film::png_bytes(w, h, &rgb8)?))
}

/// A map of fractions in [0, 1] on the inferno scale, averaged over boxes.
fn fraction_uri(w: u32, h: u32, f: u32, v: &[f32]) -> Result<String> {
    let (w, h, v) = shrink(w, h, f, 1, v);
    let rgb8: Vec<u8> = v.iter().flat_map(|&x| inferno(x)).collect();
    Ok(data_uri(&film::png_bytes(w, h, &rgb8)?))
}

/// Text for HTML (also `animate --reference-spp`'s page: a scene named `<img …>.glb` went
/// into its heading as markup; an audit, 2026-12-07).
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn sci(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3e}")
    } else {
        "∞".into()
    }
}

/// Log–log plot of relMSE against render time, one line per sampler.
fn plot_svg(c: &Comparison) -> String {
    let (w, h, ml, mr, mt, mb) = (560.0, 340.0, 70.0, 130.0, 20.0, 45.0);
    let pts: Vec<(f64, f64)> = c
        .runs
        .iter()
        .flat_map(|r| r.convergence.iter())
        .filter(|p| p.seconds > 0.0 && p.metrics.rel_mse > 0.0)
        .map(|p| (p.seconds.log10(), p.metrics.rel_mse.log10()))
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in &pts {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if pts.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (x0, x1) = (x0.floor(), x1.ceil().max(x0.floor() + 1.0));
    let (y0, y1) = (y0.floor(), y1.ceil().max(y0.floor() + 1.0));
    let sx = |x: f64| ml + (x - x0) / (x1 - x0) * (w - ml - mr);
    let sy = |y: f64| h - mb - (y - y0) / (y1 - y0) * (h - mt - mb);
    let mut s = format!(
        r#"<svg class="plot" xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = write!(
        s,
        r##"<rect x="{ml}" y="{mt}" width="{}" height="{}" fill="#fafafa" stroke="#888"/>"##,
        w - ml - mr,
        h - mt - mb
    );
    for k in (x0 as i32)..=(x1 as i32) {
        let x = sx(k as f64);
        let _ = write!(
            s,
            r##"<line x1="{x}" y1="{mt}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">10<tspan dy="-5" font-size="9">{k}</tspan></text>"##,
            h - mb,
            h - mb + 18.0
        );
    }
    for k in (y0 as i32)..=(y1 as i32) {
        let y = sy(k as f64);
        let _ = write!(
            s,
            r##"<line x1="{ml}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">10<tspan dy="-5" font-size="9">{k}</tspan></text>"##,
            w - mr,
            ml - 6.0,
            y + 4.0
        );
    }
    let _ = write!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">render time (s)</text><text transform="translate(16 {}) rotate(-90)" text-anchor="middle">relMSE</text>"#,
        (ml + w - mr) / 2.0,
        h - 8.0,
        (mt + h - mb) / 2.0
    );
    for (i, r) in c.runs.iter().enumerate() {
        let col = COLOURS[i % COLOURS.len()];
        let line: Vec<String> = r
            .convergence
            .iter()
            .filter(|p| p.seconds > 0.0 && p.metrics.rel_mse > 0.0)
            .map(|p| {
                format!(
                    "{:.1},{:.1}",
                    sx(p.seconds.log10()),
                    sy(p.metrics.rel_mse.log10())
                )
            })
            .collect();
        let name = r.sampler.name().to_string();
        let _ = write!(
            s,
            r#"<polyline class="series" data-sampler="{name}" points="{}" fill="none" stroke="{col}" stroke-width="2"/>"#,
            line.join(" ")
        );
        for p in line {
            let (x, y) = p.split_once(',').expect("x,y");
            let _ = write!(s, r#"<circle cx="{x}" cy="{y}" r="3" fill="{col}"/>"#);
        }
        let ly = mt + 16.0 + 20.0 * i as f64;
        let _ = write!(
            s,
            r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="{col}" stroke-width="3"/><text x="{}" y="{}">{name}</text>"#,
            w - mr + 10.0,
            w - mr + 34.0,
            w - mr + 40.0,
            ly + 4.0
        );
    }
    s.push_str("</svg>");
    s
}

/// The whole page.
pub fn html(input: &ReportInput) -> Result<String> {
    let (w, h) = (input.width, input.height);
    let f = shown_factor(w, h);
    let reference_uri = image_uri(w, h, f, input.reference)?;
    let mut body = String::new();
    let _ = write!(
        body,
        r#"<h1>lightlearn compare</h1><p class="meta">Scene <b>{}</b>, {w}×{h}, device {}. Reference: {}.</p>"#,
        esc(input.scene),
        esc(input.device),
        esc(input.reference_note)
    );
    if f > 1 {
        let _ = write!(
            body,
            r#"<p class="meta shrunk">Images are shown at 1/{f} of their size ({}×{}: each shown pixel the mean of {f}×{f}), so that the page stays small; the EXRs beside it hold every pixel.</p>"#,
            w.div_ceil(f),
            h.div_ceil(f)
        );
    }
    for (ci, c) in input.comparisons.iter().enumerate() {
        let budget = match (c.budget_seconds, c.budget_spp) {
            (Some(s), _) => format!("{} s per sampler", super::seconds(s)),
            (_, Some(n)) => format!("{n} samples per pixel"),
            _ => String::new(),
        };
        let base = c.runs[0].sampler.name();
        let ratio = if c.budget_seconds.is_some() {
            format!("speed-up vs {base} (MSE ratio)")
        } else {
            format!("MSE ratio vs {base}")
        };
        let warning = c
            .warning
            .as_ref()
            .map(|w| format!(r#"<p class="warning">Warning: {}</p>"#, esc(w)))
            .unwrap_or_default();
        // The errors with the reference's noise taken out, where it is known: the page's
        // note named them and the table did not show them (an audit, 2026-12-07).
        let corrected = c.runs.iter().any(|r| r.corrected.is_some());
        let _ = write!(
            body,
            r#"<section class="cmp" id="cmp{ci}"><h2>{} — {budget}</h2>{warning}<table class="metrics"><thead><tr><th>sampler</th><th>spp</th><th>seconds</th><th>MSE</th><th>relMSE</th><th>RMSE</th>{}<th>{ratio}</th><th>zero light samples</th></tr></thead><tbody>"#,
            c.kind,
            if corrected {
                "<th>MSE, reference noise out</th><th>relMSE, reference noise out</th>"
            } else {
                ""
            }
        );
        for r in &c.runs {
            let out = match (&r.corrected, corrected) {
                (_, false) => String::new(),
                (Some(m), true) => {
                    format!("<td>{}</td><td>{}</td>", sci(m.mse), sci(m.rel_mse))
                }
                (None, true) => "<td>—</td><td>—</td>".to_string(),
            };
            let _ = write!(
                body,
                "<tr><td>{}</td><td>{}</td><td>{:.2}</td><td>{}</td><td>{}</td><td>{}</td>{out}<td>{:.3}</td><td>{:.1} %</td></tr>",
                r.sampler.name(),
                r.spp,
                r.seconds,
                sci(r.metrics.mse),
                sci(r.metrics.rel_mse),
                sci(r.metrics.rmse),
                r.speedup,
                100.0 * r.zero_sample_fraction
            );
        }
        body.push_str("</tbody></table>");
        let _ = write!(
            body,
            r#"<h3>Convergence</h3><div class="plotbox">{}</div><h3>Images <small>(wheel: zoom, drag: pan, double-click: reset — all views move together)</small></h3><div class="grid">"#,
            plot_svg(c)
        );
        let mut names = vec![("reference".to_string(), reference_uri.clone())];
        for r in &c.runs {
            names.push((r.sampler.name().to_string(), image_uri(w, h, f, &r.image)?));
        }
        for (n, uri) in &names {
            let _ = write!(
                body,
                r#"<figure><div class="view"><img class="zoom" alt="{n}" src="{uri}"></div><figcaption>{n}</figcaption></figure>"#
            );
        }
        body.push_str(r#"</div><h3>Error against the reference <small>(per-pixel relative squared error, log scale)</small></h3><div class="grid">"#);
        for r in &c.runs {
            let n = r.sampler.name().to_string();
            let _ = write!(
                body,
                r#"<figure><div class="view"><img class="zoom" alt="{n} error" src="{}"></div><figcaption>{n}: relMSE {}</figcaption></figure>"#,
                error_uri(w, h, f, &r.image, input.reference)?,
                sci(r.metrics.rel_mse)
            );
        }
        let stops: Vec<String> = INFERNO
            .iter()
            .enumerate()
            .map(|(i, c)| {
                format!(
                    "rgb({},{},{}) {}%",
                    (c[0] * 255.0) as u8,
                    (c[1] * 255.0) as u8,
                    (c[2] * 255.0) as u8,
                    i * 25
                )
            })
            .collect();
        let _ = write!(
            body,
            r#"</div><div class="legend"><span>10<sup>{ERR_LOG_MIN}</sup></span><div class="bar" style="background:linear-gradient(to right,{})"></div><span>10<sup>{ERR_LOG_MAX}</sup></span></div>"#,
            stops.join(",")
        );
        // Where the light samples are wasted: the map learning should darken.
        body.push_str(r#"<h3>Zero light samples <small>(per pixel, the fraction of light samples that were occluded, faced away or met a dead end: black 0, yellow 1)</small></h3><div class="grid">"#);
        for r in &c.runs {
            let n = r.sampler.name().to_string();
            let _ = write!(
                body,
                r#"<figure><div class="view"><img class="zoom" alt="{n} zero samples" src="{}"></div><figcaption>{n}: {:.1} % zero</figcaption></figure>"#,
                fraction_uri(w, h, f, &r.zero_map)?,
                100.0 * r.zero_sample_fraction
            );
        }
        body.push_str("</div>");
        // Flip / slider between any two images of this comparison.
        let options: String = names
            .iter()
            .enumerate()
            .map(|(i, (n, _))| format!(r#"<option value="{i}">{n}</option>"#))
            .collect();
        let _ = write!(
            body,
            r#"<h3>Flip / slider</h3><div class="flip" data-cmp="{ci}"><label>A <select class="fa">{options}</select></label> <label>B <select class="fb">{options}</select></label> <input class="fs" type="range" min="0" max="100" value="50"> <button class="ff">flip A/B (key f)</button><div class="view stack"><img class="zoom a" alt="A" src="{}"><img class="zoom b" alt="B" src="{}"></div></div></section>"#,
            names[0].1,
            names.get(1).map_or(&names[0].1, |n| &n.1)
        );
        // The image sources for the flip selects.
        let srcs: Vec<String> = names.iter().map(|(_, u)| format!("\"{u}\"")).collect();
        let _ = write!(
            body,
            "<script>window.flipSources = window.flipSources || []; window.flipSources[{ci}] = [{}];</script>",
            srcs.join(",")
        );
    }
    Ok(format!(
        r#"<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>lightlearn compare — {}</title><style>{CSS}</style></head><body data-ready="0">{body}<script>{JS}</script></body></html>"#,
        esc(input.scene)
    ))
}

const CSS: &str = r#"
body{font-family:sans-serif;margin:20px;color:#222;background:#fff}
.meta{color:#555}
.warning{color:#a40;font-weight:bold}
table.metrics{border-collapse:collapse;margin:8px 0}
table.metrics td,table.metrics th{border:1px solid #ccc;padding:4px 10px;text-align:right}
table.metrics td:first-child,table.metrics th:first-child{text-align:left}
.grid{display:flex;flex-wrap:wrap;gap:10px}
figure{margin:0}
figcaption{font-size:13px;text-align:center}
.view{width:320px;height:240px;overflow:hidden;position:relative;background:#000;cursor:grab;border:1px solid #999}
.view img{position:absolute;left:0;top:0;width:100%;height:100%;object-fit:contain;transform-origin:0 0;image-rendering:pixelated}
.stack{width:640px;height:480px;margin-top:6px}
.legend{display:flex;align-items:center;gap:6px;margin:6px 0;font-size:12px}
.legend .bar{width:300px;height:12px;border:1px solid #999}
"#;

const JS: &str = r#"
(function(){
  // One zoom/pan state shared by every view on the page.
  var s=1,tx=0,ty=0,drag=null;
  function apply(){document.querySelectorAll('img.zoom').forEach(function(i){
    i.style.transform='translate('+tx+'px,'+ty+'px) scale('+s+')';});}
  document.querySelectorAll('.view').forEach(function(v){
    v.addEventListener('wheel',function(e){e.preventDefault();
      var r=v.getBoundingClientRect(),x=(e.clientX-r.left)*320/r.width,y=(e.clientY-r.top)*240/r.height;
      var f=e.deltaY<0?1.25:0.8,ns=Math.min(64,Math.max(1,s*f));f=ns/s;
      tx=x-(x-tx)*f;ty=y-(y-ty)*f;s=ns;if(s==1){tx=0;ty=0;}apply();},{passive:false});
    v.addEventListener('mousedown',function(e){drag=[e.clientX-tx,e.clientY-ty];});
    v.addEventListener('dblclick',function(){s=1;tx=0;ty=0;apply();});
  });
  window.addEventListener('mousemove',function(e){if(drag){tx=e.clientX-drag[0];ty=e.clientY-drag[1];apply();}});
  window.addEventListener('mouseup',function(){drag=null;});
  // Flip / slider: B over A, clipped at the slider; the button swaps them.
  document.querySelectorAll('.flip').forEach(function(f){
    var src=window.flipSources[+f.dataset.cmp],a=f.querySelector('img.a'),b=f.querySelector('img.b'),
        fa=f.querySelector('.fa'),fb=f.querySelector('.fb'),sl=f.querySelector('.fs');
    fb.value=Math.min(1,src.length-1);
    function upd(){a.src=src[+fa.value];b.src=src[+fb.value];b.style.clipPath='inset(0 0 0 '+sl.value+'%)';}
    function flip(){var t=fa.value;fa.value=fb.value;fb.value=t;upd();}
    fa.onchange=fb.onchange=sl.oninput=upd;f.querySelector('.ff').onclick=flip;
    window.addEventListener('keydown',function(e){if(e.key=='f')flip();});upd();
  });
  window.addEventListener('load',function(){
    var imgs=document.querySelectorAll('img'),ok=0;
    imgs.forEach(function(i){if(i.complete&&i.naturalWidth>0)ok++;});
    document.body.dataset.imagesLoaded=ok;document.body.dataset.imagesTotal=imgs.length;
    document.body.dataset.ready='1';
  });
})();
"#;

/// convergence.csv: one row per checkpoint.
pub fn convergence_csv(comparisons: &[Comparison]) -> String {
    let mut s = String::from("comparison,sampler,spp,seconds,mse,rel_mse,rmse\n");
    for c in comparisons {
        for r in &c.runs {
            for p in &r.convergence {
                let _ = writeln!(
                    s,
                    "{},{},{},{:.6},{:e},{:e},{:e}",
                    c.kind,
                    r.sampler.name(),
                    p.spp,
                    p.seconds,
                    p.metrics.mse,
                    p.metrics.rel_mse,
                    p.metrics.rmse
                );
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shrink_averages_boxes_with_partial_edges() {
        // 3×3 of one channel, factor 2: boxes of 4, 2, 2 and 1 pixels.
        let v = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];
        assert_eq!(shrink(3, 3, 2, 1, &v), (2, 2, vec![3.0, 4.5, 7.5, 9.0]));
        assert_eq!(shrink(3, 3, 1, 1, &v), (3, 3, v.to_vec()));
        // Channels stay apart.
        let rgb = [1.0, 10.0, 3.0, 30.0];
        assert_eq!(shrink(2, 1, 2, 2, &rgb), (1, 1, vec![2.0, 20.0]));
        assert_eq!(shown_factor(1024, 8), 1);
        assert_eq!(shown_factor(1025, 8), 2);
        assert_eq!(shown_factor(8, 2048), 2);
        assert_eq!(shown_factor(3000, 3000), 3);
    }
}
