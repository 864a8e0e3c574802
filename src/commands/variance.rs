//! `lightlearn variance`: splits each sampler's variance per sample into the cluster choice,
//! the light inside the cluster, the point on the light and the pixel footprint
//! (src/variance/mod.rs), at fixed first hits, and measures the same variance from two
//! renders of other seeds, so the split is checked against what the kernel does.
//!
//! Rows: every sampler of `--samplers` (a learned one learning from scratch: its pmfs are
//! evaluated on the statistics each pass sampled by, at checkpoints about two per octave of
//! passes, each standing for the passes up to the next), and with `--converge N` a `bayes`
//! row whose statistics were learned over N spp and then frozen.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{bail, Result};
use rayon::prelude::*;

use super::{check_depth, check_size, prepare, Ui};
use crate::abi::SlotStats;
use crate::gpu::{Context, ContextOptions};
use crate::learning::{LearnSettings, UpdateEvery};
use crate::lights::regions::RegionSettings;
use crate::reference::first_hit;
use crate::render::{camera_params, Budget, GpuScene, LightSampler, RenderSettings, Session};
use crate::rng::SplitMix64;
use crate::scene::{luminance, Scene};
use crate::variance::{hit_terms, pixel_terms, HitTerms, Learned, PixelTerms, Selection};

pub use super::variance_report::Row;
use super::variance_report::{earlier_maps, is_map_name, table, write_outputs};

pub struct VarianceRequest {
    pub scene: Option<PathBuf>,
    pub samplers: Vec<LightSampler>,
    /// A frozen `bayes` row after this many spp of learning.
    pub converge: Option<u32>,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of each measuring render (and of the learning from scratch).
    pub spp: u32,
    pub seed: u32,
    /// Every `stride`-th pixel in x and y is decomposed.
    pub stride: u32,
    /// Jittered first hits per decomposed pixel.
    pub hits: u32,
    /// Shadow rays per triangle light at each hit.
    pub area_samples: u32,
    /// Above 1: the measuring renders also run at this depth (GI), for the split between
    /// direct light at the first vertex and the rest of the path.
    pub max_depth: u32,
    pub regions: RegionSettings,
    pub learn: LearnSettings,
    pub device: ContextOptions,
    pub out: Option<PathBuf>,
}

pub struct VarianceOutcome {
    pub rows: Vec<Row>,
    pub table: String,
}

fn check(a: &VarianceRequest) -> Result<()> {
    check_size(a.width, a.height)?;
    check_depth(a.max_depth)?;
    if a.samplers.is_empty() && a.converge.is_none() {
        bail!("--samplers needs at least one sampler (or give --converge N)");
    }
    if !(2..=65536).contains(&a.spp) {
        bail!("--spp {} is out of range: use 2..=65536", a.spp);
    }
    // One hit a pixel has no spread between hits: the footprint term read 0 % and the
    // total came out too small, with exit 0.
    if !(1..=64).contains(&a.stride) || !(2..=256).contains(&a.hits) {
        bail!(
            "--stride takes 1..=64 and --hits 2..=256 (the footprint term needs two hits a pixel)"
        );
    }
    if !(2..=65536).contains(&a.area_samples) {
        bail!(
            "--area-samples {} is out of range: use 2..=65536",
            a.area_samples
        );
    }
    if let Some(n) = a.converge {
        if !(1..=1 << 20).contains(&n) {
            bail!("--converge {n} is out of range: use 1..=1048576 spp");
        }
    }
    if a.learn.brdf_aware || a.learn.control_variates {
        bail!("variance splits the plain estimator: drop --brdf-aware and --control-variates");
    }
    Ok(())
}

/// The scene's exact terms need a BRDF the CPU evaluates: base colour / π.
fn check_scene(scene: &Scene) -> Result<()> {
    if let Some(m) = scene.materials.iter().find(|m| {
        !m.is_lambertian()
            || m.base_color_texture.is_some()
            || m.emissive_texture.is_some()
            || m.normal_texture.is_some()
            || m.alpha_cutoff.is_some()
    }) {
        bail!(
            "{}: material '{}' is glossy or textured; `variance` evaluates untextured Lambertian materials only (give it KHR_materials_specular specularFactor 0, metallicFactor 0 and no baseColorTexture, emissiveTexture, normalTexture or alphaMode MASK)",
            scene.source,
            m.name
        );
    }
    if !scene.triangle_normals.is_empty() {
        bail!(
            "{}: the scene has smooth-shaded triangles (vertex normals), which `variance`'s exact sums do not interpolate; remove the NORMAL attributes to split its selection",
            scene.source
        );
    }
    if !scene.directional.is_empty() {
        bail!(
            "{}: the scene has directional lights ({}), which `variance`'s exact sums leave out (no sampler chooses them); remove them to split the other lights' selection",
            scene.source,
            scene.directional.len()
        );
    }
    if scene.lights.is_empty() {
        bail!(
            "{}: the scene has no lights: there is no light selection to split",
            scene.source
        );
    }
    Ok(())
}

pub fn run(a: &VarianceRequest, ui: &mut dyn Ui) -> Result<VarianceOutcome> {
    check(a)?;
    crate::io::removing_created_folders_on_error(a.out.as_deref(), || run_checked(a, ui))
}

fn run_checked(a: &VarianceRequest, ui: &mut dyn Ui) -> Result<VarianceOutcome> {
    let mut earlier = Vec::new();
    if let Some(out) = &a.out {
        crate::io::create_output_folder(out, "output folder")?;
        crate::io::check_writable(&out.join("variance.json"))?;
        // The report's files are variance.json and rowN.exr (their count is known only
        // later): none may be the scene or a file it names (a scene named variance.json in
        // --out was replaced, with exit 0).
        if let Some(scene) = &a.scene {
            for f in crate::scene::gltf_load::input_files(scene) {
                let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("");
                let row = is_map_name(name);
                let inside = f.parent().is_some_and(|d| {
                    crate::io::same_path(d, out)
                        || (d.as_os_str().is_empty() && crate::io::same_path(Path::new("."), out))
                });
                if inside && (name == "variance.json" || row) {
                    bail!(
                        "--out '{}' would replace '{}', which the scene is read from; name another --out",
                        out.display(),
                        f.display()
                    );
                }
            }
        }
        earlier = earlier_maps(out)?;
    }
    let (scene, ctx, gpu, _) = prepare(a.scene.as_deref(), (a.width, a.height), &a.device, ui)?;
    check_scene(&scene)?;
    ui.message(&format!(
        "{}: {} lights; decomposing {}×{} pixels of {}×{} with {} hits each, {} shadow rays per triangle light",
        scene.source,
        scene.lights.len(),
        a.width.div_ceil(a.stride),
        a.height.div_ceil(a.stride),
        a.width,
        a.height,
        a.hits,
        a.area_samples
    ));
    // The exact terms trace every light from every hit: bound the work (and the memory of
    // the per-hit light lists) before starting it.
    let hit_count =
        a.width.div_ceil(a.stride) as f64 * a.height.div_ceil(a.stride) as f64 * a.hits as f64;
    let triangles = scene
        .lights
        .iter()
        .filter(|l| matches!(l, crate::scene::Light::Triangle { .. }))
        .count() as f64;
    let points = scene.lights.len() as f64 - triangles;
    let rays = hit_count * (points + triangles * a.area_samples as f64);
    let pairs = hit_count * scene.lights.len() as f64;
    if rays > 4e9 || pairs > 2.5e8 {
        bail!(
            "{}: {} hits × {} lights ({:.1e} shadow rays) is too much work for the exact terms; raise --stride or lower --hits / --area-samples (at most 4e9 rays and 2.5e8 hit-light pairs)",
            scene.source,
            hit_count,
            scene.lights.len(),
            rays
        );
    }
    let hits = first_hits(&scene, &gpu, a);
    let settings = |sampler: LightSampler, depth: u32| RenderSettings {
        width: a.width,
        height: a.height,
        budget: Budget::Samples(a.spp),
        seed: a.seed,
        sampler,
        regions: a.regions,
        learn: a.learn,
        // The decomposition's footprint term is that of independent jitter.
        stratify: crate::render::Stratify::Off,
        max_depth: depth,
        resume: None,
        light_point: Default::default(),
        indirect_light_samples: 1,
        first_light_samples: 1,
    };
    let mut rows = Vec::new();
    for &sampler in &a.samplers {
        ui.progress(sampler.name(), 0, 0.0);
        let s = settings(sampler, 1);
        let (pixels, first) = if sampler.learned() {
            learning_terms(&ctx, &scene, &gpu, &s, a.spp, &hits, ui)?
        } else {
            let mut session = Session::new(&ctx, &scene, &gpu, &s)?;
            session.run_passes(a.spp)?;
            let sel = selection(&scene, &gpu, &session, sampler, &s.learn, &[]);
            let pixels = evaluate(&sel, &hits);
            (pixels, session.image()?)
        };
        let row = measure(
            &ctx,
            a,
            &scene,
            &gpu,
            sampler.name().into(),
            pixels,
            first,
            &s,
            ui,
        )?;
        rows.push(row);
        ui.phase_done();
    }
    if let Some(n) = a.converge {
        ui.progress("bayes, converging", 0, 0.0);
        let mut s = settings(LightSampler::Bayes, 1);
        s.seed = a.seed.wrapping_add(2);
        let mut learner = Session::new(&ctx, &scene, &gpu, &s)?;
        learner.run_passes(n)?;
        let saved = learner.snapshot()?.expect("bayes learns");
        drop(learner);
        // Frozen: no fold (and so no growth) within the measuring renders.
        s.seed = a.seed;
        s.learn.update_every = UpdateEvery::Passes(u32::MAX);
        s.resume = Some(Arc::new(saved));
        let mut session = Session::new(&ctx, &scene, &gpu, &s)?;
        session.run_passes(a.spp)?;
        let stats = session.sampling_stats()?;
        let sel = selection(
            &scene,
            &gpu,
            &session,
            LightSampler::Bayes,
            &s.learn,
            &stats,
        );
        let pixels = evaluate(&sel, &hits);
        let first = session.image()?;
        drop(session);
        let row = measure(
            &ctx,
            a,
            &scene,
            &gpu,
            format!("bayes, {n} spp learned, frozen"),
            pixels,
            first,
            &s,
            ui,
        )?;
        rows.push(row);
        ui.phase_done();
    }
    let table = table(a, &rows);
    if let Some(out) = &a.out {
        write_outputs(out, a, &rows, &earlier)?;
    }
    Ok(VarianceOutcome { rows, table })
}

/// `hits` jittered first hits of every decomposed pixel, in row-major order of those pixels.
fn first_hits(scene: &Scene, gpu: &GpuScene, a: &VarianceRequest) -> Vec<Vec<Option<HitTerms>>> {
    let cam = camera_params(scene, a.width, a.height);
    let v = |x: [f32; 4]| glam::Vec3::new(x[0], x[1], x[2]);
    let (pos, cu, cv, cw) = (v(cam.cam_pos), v(cam.cam_u), v(cam.cam_v), v(cam.cam_w));
    let pixels = decomposed_pixels(a);
    pixels
        .par_iter()
        .map(|&(px, py)| {
            let p = (py * a.width + px) as u64;
            let mut rng =
                SplitMix64(a.seed as u64 ^ p.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x5641_5249);
            (0..a.hits)
                .map(|_| {
                    let nx = (px as f32 + rng.f32()) / a.width as f32 * 2.0 - 1.0;
                    let ny = 1.0 - (py as f32 + rng.f32()) / a.height as f32 * 2.0;
                    let dir = (cw + nx * cu + ny * cv).normalize();
                    first_hit(scene, &gpu.bvh, pos, dir)
                        .map(|h| hit_terms(scene, &gpu.bvh, &h, a.area_samples, &mut rng))
                })
                .collect()
        })
        .collect()
}

fn decomposed_pixels(a: &VarianceRequest) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    for py in (0..a.height).step_by(a.stride as usize) {
        for px in (0..a.width).step_by(a.stride as usize) {
            v.push((px, py));
        }
    }
    v
}

fn evaluate(sel: &Selection, hits: &[Vec<Option<HitTerms>>]) -> Vec<PixelTerms> {
    hits.par_iter().map(|h| pixel_terms(h, sel)).collect()
}

/// `sampler`'s pmfs as `session` samples now: `wang` with the session's cuts, a learned
/// sampler also with `stats` (what its next pass samples by).
fn selection<'a>(
    scene: &Scene,
    gpu: &'a GpuScene,
    session: &'a Session,
    sampler: LightSampler,
    learn: &'a LearnSettings,
    stats: &'a [SlotStats],
) -> Selection<'a> {
    match sampler {
        LightSampler::Uniform => Selection::Uniform {
            count: scene.lights.len() as u32,
        },
        LightSampler::Power => Selection::Power {
            pmf: crate::lights::alias_pmf(&crate::lights::alias_table(
                &crate::lights::power_weights(scene),
            )),
        },
        LightSampler::Lightbvh => Selection::LightBvh { tree: &gpu.tree },
        LightSampler::Wang | LightSampler::Donikian | LightSampler::Bayes => Selection::Cuts {
            tree: &gpu.tree,
            cuts: session.cuts(),
            learned: sampler.learned().then_some(Learned {
                stats,
                settings: learn,
                donikian: sampler == LightSampler::Donikian,
            }),
        },
    }
}

/// The passes at which a learning sampler's statistics are read: 0, 1, 2, 3, 4, 6, 8, 12, …
/// (about two per octave) below `spp`.
fn checkpoints(spp: u32) -> Vec<u32> {
    let mut v = vec![0u32];
    let mut k = 1u32;
    while k < spp {
        v.push(k);
        let half = k + k / 2;
        if half > k && half < spp && half < 2 * k {
            v.push(half);
        }
        k *= 2;
    }
    v.dedup();
    v
}

/// A learned sampler from scratch: the mean over its passes of each pixel's terms, each
/// checkpoint's statistics standing for the passes up to the next; and the session's image.
fn learning_terms(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    s: &RenderSettings,
    spp: u32,
    hits: &[Vec<Option<HitTerms>>],
    ui: &mut dyn Ui,
) -> Result<(Vec<PixelTerms>, Vec<[f32; 3]>)> {
    let mut session = Session::new(ctx, scene, gpu, s)?;
    let cps = checkpoints(spp);
    let mut acc = vec![PixelTerms::default(); hits.len()];
    for (i, &c) in cps.iter().enumerate() {
        let next = cps.get(i + 1).copied().unwrap_or(spp);
        let stats = session.sampling_stats()?;
        let sel = selection(scene, gpu, &session, s.sampler, &s.learn, &stats);
        let w = (next - c) as f64 / spp as f64;
        for (a, p) in acc.iter_mut().zip(evaluate(&sel, hits)) {
            a.mix(&p, w);
        }
        session.run_passes(next - c)?;
        ui.progress(s.sampler.name(), next, next as f64 / spp as f64);
    }
    Ok((acc, session.image()?))
}

/// The row: `first` (this sampler's render at `s`) against a second seed's, and at
/// `max_depth` two more when GI is asked for.
#[allow(clippy::too_many_arguments)]
fn measure(
    ctx: &Arc<Context>,
    a: &VarianceRequest,
    scene: &Scene,
    gpu: &GpuScene,
    name: String,
    pixels: Vec<PixelTerms>,
    first: Vec<[f32; 3]>,
    s: &RenderSettings,
    ui: &mut dyn Ui,
) -> Result<Row> {
    let render = |seed: u32, depth: u32, stratified: bool| -> Result<Vec<[f32; 3]>> {
        let mut s = s.clone();
        s.seed = seed;
        s.max_depth = depth;
        s.stratify = if stratified {
            crate::render::Stratify::Sobol
        } else {
            crate::render::Stratify::Off
        };
        let mut session = Session::new(ctx, scene, gpu, &s)?;
        session.run_passes(a.spp)?;
        session.image()
    };
    ui.progress(&name, a.spp, 0.5);
    let second = render(a.seed.wrapping_add(1), 1, false)?;
    let measured_pixels = two_seed_pixels(a, &first, &second);
    let measured = measured_pixels.iter().sum();
    let x = render(a.seed, 1, true)?;
    let y = render(a.seed.wrapping_add(1), 1, true)?;
    let measured_r2 = two_seed_variance(a, &x, &y);
    let measured_gi = if a.max_depth > 1 {
        let x = render(a.seed, a.max_depth, true)?;
        let y = render(a.seed.wrapping_add(1), a.max_depth, true)?;
        Some(two_seed_variance(a, &x, &y))
    } else {
        None
    };
    let mut sum = PixelTerms::default();
    for p in &pixels {
        sum.add(p);
    }
    Ok(Row {
        name,
        sum,
        pixels,
        measured,
        measured_pixels,
        measured_r2,
        measured_gi,
    })
}

/// Σ over the decomposed pixels of spp · (a − b)²/2 (luminance): each pixel's variance per
/// sample, estimated from two independent renders.
fn two_seed_variance(a: &VarianceRequest, x: &[[f32; 3]], y: &[[f32; 3]]) -> f64 {
    two_seed_pixels(a, x, y).iter().sum()
}

fn two_seed_pixels(a: &VarianceRequest, x: &[[f32; 3]], y: &[[f32; 3]]) -> Vec<f64> {
    decomposed_pixels(a)
        .iter()
        .map(|&(px, py)| {
            let i = (py * a.width + px) as usize;
            let d =
                luminance(glam::Vec3::from(x[i])) as f64 - luminance(glam::Vec3::from(y[i])) as f64;
            a.spp as f64 * d * d / 2.0
        })
        .collect()
}
