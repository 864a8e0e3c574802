//! Reference images: a long render by the most robust sampler we have, cached by a hash of the
//! scene's content and the render settings so each is computed once.
//!
//! Cache folder: `$LIGHTLEARN_CACHE`, else `$XDG_CACHE_HOME/lightlearn`, else
//! `~/.cache/lightlearn`; each entry is `<key>.exr` plus `<key>.json` (the render report,
//! which records the reference's own estimated error, and the EXR's checksum: an entry
//! whose files do not match it is damaged and rendered again, where a damaged entry once
//! failed every later `compare`).

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{bail, Context as _, Result};

use crate::film::{self, OutputPaths};
use crate::gpu::Context;
use crate::lights;
use crate::render::{self, camera_params, Budget, GpuScene, LightSampler, RenderSettings};
use crate::scene::Scene;

/// The sampler references are rendered with: the one with the lowest error per second on
/// every committed scene. Measured at 256×192, 3 s each, estimated relMSE power → lightbvh:
/// default 1.1e-1 → 1.7e-2, hall 5.4e-3 → 1.5e-3, city 2.2e-2 → 3.1e-3, strings 3.1e-2 →
/// 1.4e-2.
pub const REFERENCE_SAMPLER: LightSampler = LightSampler::Lightbvh;
/// Default reference budget; at 320×240 on the default scene about 3 minutes on lavapipe.
pub const DEFAULT_REFERENCE_SPP: u32 = 4096;
/// References draw from their own random stream: the seed of the renders they judge plus this.
/// With the same seed, a `power` run at the reference's sample count *is* the reference
/// (measured: relMSE fell to 1e-5 at 256 spp against a 256-spp reference, then rose again).
pub const REFERENCE_SEED_OFFSET: u32 = 0x5eed_0001;

/// The seed a reference for renders with `seed` uses.
pub fn reference_seed(seed: u32) -> u32 {
    seed.wrapping_add(REFERENCE_SEED_OFFSET)
}

/// Bump when the integrator changes what image a scene converges to.
/// v2: the shadow-ray fix (v1 images were wrong); v3: spots ramp over the file's cones (the
/// extension's sample code had widened ramps narrower than 1e-3 in cos θ) and a dielectric
/// layer of F0 = 1 no longer gives NaN: references of such scenes converge elsewhere.
const INTEGRATOR_VERSION: &str = "direct-v3";

/// The reference cache: `LIGHTLEARN_CACHE`, else `$XDG_CACHE_HOME/lightlearn`, else
/// `$HOME/.cache/lightlearn`. Empty values are unset and a relative XDG_CACHE_HOME or HOME is
/// ignored (the XDG base-directory rule): an empty `LIGHTLEARN_CACHE` put entries in the
/// current folder (an audit, 2026-12-07). An error when none is left: no cache.
pub fn cache_dir() -> Result<PathBuf> {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = var("LIGHTLEARN_CACHE") {
        return Ok(d);
    }
    if let Some(d) = var("XDG_CACHE_HOME").filter(|d| d.is_absolute()) {
        return Ok(d.join("lightlearn"));
    }
    match var("HOME").filter(|d| d.is_absolute()) {
        Some(h) => Ok(h.join(".cache").join("lightlearn")),
        None => bail!("no reference cache: HOME is unset or not an absolute path; set LIGHTLEARN_CACHE to a folder to keep references"),
    }
}

/// FNV-1a, 64 bit: stable across platforms and Rust versions (unlike `DefaultHasher`).
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// Cache key of the reference for this scene content and these settings.
pub fn key(scene: &Scene, width: u32, height: u32, spp: u32, seed: u32, max_depth: u32) -> String {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    h.bytes(INTEGRATOR_VERSION.as_bytes());
    hash_content(&mut h, scene);
    h.bytes(bytemuck::bytes_of(&camera_params(scene, width, height)));
    h.bytes(format!("{spp}/{seed}/{:?}", REFERENCE_SAMPLER).as_bytes());
    // Direct light (depth 1) keeps the key it had before the path tracer existed.
    if max_depth != 1 {
        h.bytes(format!("max depth {max_depth}").as_bytes());
    }
    format!("{:016x}-{width}x{height}-{spp}spp", h.0)
}

/// A hash of what a scene renders (geometry, materials, lights, textures and the camera),
/// so renders of one scene made from other paths or machines can be recognised
/// (`lightlearn merge`).
pub fn scene_hash(scene: &Scene) -> String {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    hash_content(&mut h, scene);
    let c = &scene.camera;
    for v in [c.position, c.forward, c.up] {
        h.bytes(bytemuck::bytes_of(&v.to_array()));
    }
    h.bytes(&c.yfov.to_le_bytes());
    format!("{:016x}", h.0)
}

fn hash_content(h: &mut Fnv, scene: &Scene) {
    for t in &scene.triangles {
        for v in t {
            h.bytes(bytemuck::bytes_of(&v.to_array()));
        }
    }
    h.bytes(bytemuck::cast_slice(&scene.triangle_material));
    for m in &scene.materials {
        h.bytes(bytemuck::bytes_of(&m.base_color.to_array()));
        h.bytes(bytemuck::bytes_of(&m.emission.to_array()));
        h.bytes(&[m.double_sided as u8]);
        // Only where there is one, so scenes without keep their keys (the texture's texels
        // are hashed below with the others).
        if let Some(t) = m.emissive_texture {
            h.bytes(b"emissive");
            h.bytes(&t.to_le_bytes());
        }
        if let Some(t) = m.metallic_roughness_texture {
            h.bytes(b"metallic-roughness");
            h.bytes(&t.to_le_bytes());
        }
        if let Some(c) = m.alpha_cutoff {
            h.bytes(b"mask");
            h.bytes(&c.to_le_bytes());
            h.bytes(&m.alpha.to_le_bytes());
            // The cutout reads the base-colour texture's alpha: which one, hashed below.
        }
        if let Some(t) = m.normal_texture {
            h.bytes(b"normal");
            h.bytes(&t.to_le_bytes());
            h.bytes(&m.normal_scale.to_le_bytes());
        }
        // glTF's BRDF parameters only for non-Lambertian materials, so Lambertian scenes keep
        // the keys they had before there were other materials.
        if !m.is_lambertian() {
            let p = [m.metallic, m.roughness, m.specular];
            h.bytes(bytemuck::cast_slice(&p));
            h.bytes(bytemuck::bytes_of(&m.specular_color.to_array()));
        }
    }
    h.bytes(bytemuck::cast_slice(&lights::gpu_lights(scene)));
    // Only where there are any, so scenes without keep their keys.
    if !scene.triangle_tangents.is_empty() {
        h.bytes(b"tangents");
        // As the kernels read them: packed, and the signs.
        for t in &scene.triangle_tangents {
            for v in t {
                h.bytes(&crate::render::pack_normal(v.truncate()).to_le_bytes());
                h.bytes(&[(v.w < 0.0) as u8]);
            }
        }
    }
    if !scene.triangle_normals.is_empty() {
        h.bytes(b"normals");
        // As the kernels read them (packed): normals that pack the same render the same
        // (×3 of the same normals took a new reference: an audit, 2026-12-07).
        for t in &scene.triangle_normals {
            for v in t {
                h.bytes(&crate::render::pack_normal(*v).to_le_bytes());
            }
        }
    }
    for d in &scene.directional {
        h.bytes(b"directional");
        h.bytes(bytemuck::bytes_of(&d.direction.to_array()));
        h.bytes(bytemuck::bytes_of(&d.irradiance.to_array()));
    }
    // Textures (only when there are any, so untextured scenes keep their keys).
    for t in &scene.textures {
        h.bytes(&[t.width.to_le_bytes(), t.height.to_le_bytes()].concat());
        h.bytes(&[t.wrap[0] as u8, t.wrap[1] as u8]);
        // The words of an 8-bit texture are its RGBA8 bytes as before, so their keys stay.
        h.bytes(bytemuck::cast_slice(&t.words));
        if t.wide || t.nearest {
            h.bytes(&[t.wide as u8, t.nearest as u8]);
        }
        if t.linear {
            h.bytes(b"linear");
        }
    }
    if !scene.textures.is_empty() {
        for m in &scene.materials {
            h.bytes(&m.base_color_texture.unwrap_or(u32::MAX).to_le_bytes());
        }
        h.bytes(bytemuck::cast_slice(&scene.triangle_uv));
    }
}

/// Settings of a reference for renders with `seed` (own random stream, reference sampler).
pub fn settings(
    width: u32,
    height: u32,
    spp: u32,
    seed: u32,
    max_depth: u32,
) -> Result<RenderSettings> {
    crate::commands::check_spp("the reference's spp", spp)?;
    crate::commands::check_size(width, height)?;
    Ok(RenderSettings {
        width,
        height,
        budget: Budget::Samples(spp),
        seed: reference_seed(seed),
        sampler: REFERENCE_SAMPLER,
        regions: Default::default(),
        learn: Default::default(),
        resume: None,
        stratify: crate::render::Stratify::Off,
        max_depth,
        light_point: Default::default(),
        indirect_light_samples: 1,
        first_light_samples: 1,
    })
}

/// Renders a reference and writes EXR + PNG + JSON report to `paths`.
pub fn render_to(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    paths: &OutputPaths,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<(Vec<[f32; 3]>, serde_json::Value)> {
    let (image, report) = render_image(ctx, scene, gpu, settings, progress)?;
    film::write_outputs(paths, settings.width, settings.height, &image, &report)?;
    Ok((image, report))
}

/// The reference image and its report, not written anywhere.
fn render_image(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<(Vec<[f32; 3]>, serde_json::Value)> {
    let result = render::render(ctx, scene, gpu, settings, progress)?;
    if result.interrupted {
        bail!(
            "interrupted (Ctrl-C or a stop signal) after {} spp; the reference was not written or cached",
            result.spp
        );
    }
    // A reference with samples dropped is darker than the scene: not one to measure against.
    if result.invalid_samples > 0 {
        bail!(
            "{} samples of the reference came out NaN/Inf; it was not written or cached (please report this scene)",
            result.invalid_samples
        );
    }
    let report = render::report_json(scene, settings, &result, &ctx.describe());
    Ok((result.mean(), report))
}

/// A reference's spp: references are always rendered to a sample budget.
fn reference_spp(settings: &RenderSettings) -> u32 {
    match settings.budget {
        Budget::Samples(spp) => spp,
        Budget::Seconds(_) => unreachable!("references have a sample budget"),
    }
}

fn cache_paths(scene: &Scene, settings: &RenderSettings) -> Result<(String, OutputPaths)> {
    let spp = reference_spp(settings);
    let key = key(
        scene,
        settings.width,
        settings.height,
        spp,
        settings.seed,
        settings.max_depth,
    );
    let dir = cache_dir()?;
    let paths = OutputPaths {
        exr: dir.join(format!("{key}.exr")),
        png: dir.join(format!("{key}.png")),
        json: dir.join(format!("{key}.json")),
    };
    Ok((key, paths))
}

/// Copies a reference written elsewhere into the cache. An error is for a warning, not a
/// failure: a cache that cannot be written only costs a re-render later (`reference` said
/// nothing of it while its help promised the cache: an audit, 2026-12-07).
pub fn store_in_cache(
    scene: &Scene,
    settings: &RenderSettings,
    written: &OutputPaths,
) -> Result<()> {
    let (_, cached) = cache_paths(scene, settings)?;
    let dir = cached.exr.parent().unwrap_or(std::path::Path::new("."));
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create the reference cache '{}'", dir.display()))?;
    let b = crate::io::read_all(&written.exr)?;
    crate::io::write_atomic(&cached.exr, &b)?;
    seal(&written.json, &cached)
}

/// The key of the EXR's checksum in the JSON of entries cached before every report carried
/// one ([`film::EXR_CHECKSUM`]).
const LEGACY_CHECKSUM: &str = "cache_exr_fnv1a";

/// Writes the cache entry's JSON: the report at `report_path` plus the checksum of the
/// entry's EXR as it is on disk (the entry counts as whole only once this is written).
fn seal(report_path: &std::path::Path, entry: &OutputPaths) -> Result<()> {
    let mut report: serde_json::Value = serde_json::from_slice(&crate::io::read_all(report_path)?)?;
    report[film::EXR_CHECKSUM] = serde_json::json!(film::exr_checksum(&entry.exr)?);
    crate::io::write_atomic(
        &entry.json,
        (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
    )
}

/// A cache entry's image and report: None if there is none, an error saying what is wrong
/// if it is damaged (unreadable, checksum, size, non-finite pixels).
fn read_entry(
    paths: &OutputPaths,
    settings: &RenderSettings,
    scene_hash: &str,
) -> Result<Option<(Vec<[f32; 3]>, serde_json::Value)>> {
    let (width, height) = (settings.width, settings.height);
    if !paths.exr.exists() && !paths.json.exists() {
        return Ok(None);
    }
    let report: serde_json::Value = serde_json::from_slice(
        &crate::io::read_all(&paths.json).context("its JSON cannot be read")?,
    )
    .context("its JSON is damaged")?;
    let sum = film::exr_checksum(&paths.exr).context("its EXR cannot be read")?;
    // Entries cached before the checksum existed have none: checked below by what can be
    // checked, and sealed.
    let want = report[film::EXR_CHECKSUM]
        .as_str()
        .or(report[LEGACY_CHECKSUM].as_str());
    let legacy = want.is_none();
    if !legacy && want != Some(sum.as_str()) {
        bail!("its EXR does not match the checksum in its JSON");
    }
    // What the report says it is must be what its name stands for: a 4-spp render under a
    // 16-spp entry's name was used as the 16-spp reference (an audit, 2026-12-06).
    let spp = reference_spp(settings);
    for (field, want) in [
        ("spp", serde_json::json!(spp)),
        ("max_depth", serde_json::json!(settings.max_depth)),
        ("seed", serde_json::json!(settings.seed)),
        ("sampler", serde_json::json!(settings.sampler.name())),
        // Another scene's entry copied under this one's name was used, and its report
        // relabelled with this scene (an audit, 2026-12-06).
        ("scene_hash", serde_json::json!(scene_hash)),
    ] {
        let got = &report[field];
        if !got.is_null() && *got != want {
            bail!("its report says {field} {got}, not {want}");
        }
    }
    let (w, h, px) = film::read_exr(&paths.exr)?;
    if (w, h) != (width, height) {
        bail!("it is {w}×{h}, not {width}×{height}");
    }
    if px.iter().flatten().any(|c| !c.is_finite()) {
        bail!("it holds NaN or Inf pixels");
    }
    // An entry cached before references with dropped samples were refused (a review,
    // 2026-12-06): darker than the scene.
    if let Some(n) = report["invalid_samples_dropped"]
        .as_u64()
        .filter(|n| *n > 0)
    {
        bail!("its render dropped {n} NaN/Inf samples");
    }
    if legacy {
        let _ = seal(&paths.json, paths);
    }
    Ok(Some((px, report)))
}

/// A reference's own estimated error (variance of its mean), from its JSON report, or why
/// there is none. The estimate is the pixels' sample variance over their spp, which holds
/// for independent samples only: a render with stratified numbers (`--stratify sobol`, the
/// default of `render`) overstated it 17× and the corrected MSEs came out negative, and one
/// of 1 spp has no variance at all (an audit, 2026-12-06).
pub fn noise(report: &serde_json::Value) -> std::result::Result<super::Metrics, String> {
    let stratify = report["stratify"].as_str().unwrap_or("off");
    if stratify != "off" {
        return Err(format!("its samples are stratified (--stratify {stratify}), so its per-pixel variance overstates its error; render it with --stratify off for an estimate"));
    }
    if report["spp"].as_u64().is_some_and(|n| n < 2) {
        return Err("it has 1 spp, and a variance needs 2".to_string());
    }
    match (
        report["estimated_mse_of_mean"].as_f64(),
        report["estimated_rel_mse_of_mean"].as_f64(),
    ) {
        (Some(mse), Some(rel_mse)) => Ok(super::Metrics {
            mse,
            rel_mse,
            rmse: mse.sqrt(),
        }),
        _ => Err("its report gives no estimate".to_string()),
    }
}

/// What a reference's report says of its own error, for the comparison's note.
fn own_error(report: &serde_json::Value) -> String {
    match noise(report) {
        Ok(n) => format!("its own estimated relMSE {:.2e} (a floor under every raw relMSE below; the corrected numbers subtract it)", n.rel_mse),
        Err(why) => format!("its own error is unknown ({why}), so no corrected numbers"),
    }
}

/// The cached reference for these settings, rendered (and cached) now if missing. Returns
/// the image, a note on how it was made and its own estimated error.
pub fn cached(
    ctx: &Arc<Context>,
    scene: &Scene,
    gpu: &GpuScene,
    settings: &RenderSettings,
    progress: &mut dyn FnMut(u32, f64),
    log: &mut dyn FnMut(String),
) -> Result<(Vec<[f32; 3]>, String, Option<super::Metrics>)> {
    let spp = reference_spp(settings);
    let paths = match cache_paths(scene, settings) {
        Ok((_, paths)) => paths,
        Err(why) => {
            log(format!("warning: {why:#}"));
            log(format!("rendering the reference ({spp} spp; not cached)"));
            let (image, report) = render_image(ctx, scene, gpu, settings, progress)?;
            let note = format!(
                "{} at {spp} spp, not cached ({why:#}); {}",
                settings.sampler.name(),
                own_error(&report)
            );
            return Ok((image, note, noise(&report).ok()));
        }
    };
    let note = |report: &serde_json::Value, cached: bool| {
        format!(
            "{} at {spp} spp, {} {}; {}",
            settings.sampler.name(),
            if cached {
                "cached as"
            } else {
                "not cached: could not write"
            },
            paths.exr.display(),
            own_error(report)
        )
    };
    match read_entry(&paths, settings, &scene_hash(scene)) {
        Ok(Some((px, report))) => {
            log(format!("using cached reference {}", paths.exr.display()));
            return Ok((px, note(&report, true), noise(&report).ok()));
        }
        Ok(None) => {}
        Err(why) => log(format!(
            "the cached reference {} is damaged ({why:#}); rendering it again",
            paths.exr.display()
        )),
    }
    let dir = paths
        .exr
        .parent()
        .unwrap_or(std::path::Path::new("."))
        .to_path_buf();
    log(format!(
        "rendering the reference once ({spp} spp; cached for later runs)"
    ));
    let (image, report) = render_image(ctx, scene, gpu, settings, progress)?;
    // The cache is best effort: a cache that cannot be written (read-only, a folder in an
    // entry's place) failed the comparison after the whole reference was rendered.
    let stored = std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create the reference cache '{}'", dir.display()))
        // Its JSON names the EXR's checksum ([`film::write_outputs`]): the entry is whole.
        .and_then(|_| {
            film::write_outputs(&paths, settings.width, settings.height, &image, &report)
        });
    if let Err(e) = &stored {
        log(format!(
            "warning: the reference is used but not cached ({e:#}); set LIGHTLEARN_CACHE to a writable folder to keep it"
        ));
    }
    Ok((image, note(&report, stored.is_ok()), noise(&report).ok()))
}
