//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod hostile;

use std::path::Path;
use std::sync::Arc;

use lightlearn::gpu::{Context, ContextOptions};
use lightlearn::scene::gltf_write::GltfBuilder;
use lightlearn::scene::{gltf_load, Scene};

/// A Vulkan context with the validation layer on: any validation error fails the test.
pub fn ctx() -> Arc<Context> {
    // Objects left at a context's end fail the test (src/gpu/context.rs).
    lightlearn::gpu::context::strict_teardown(true);
    Context::new(&ContextOptions {
        device: std::env::var("LIGHTLEARN_TEST_DEVICE").ok(),
        validation: true,
    })
    .expect("a Vulkan device (run ci/setup.sh to install lavapipe)")
}

/// Loads a builder's scene through the real glTF path (.glb bytes → loader).
pub fn load(b: &GltfBuilder, name: &str) -> Scene {
    gltf_load::load_bytes(&b.to_glb(), name, Path::new("."), &mut |w| {
        panic!("unexpected warning: {w}")
    })
    .expect("test scene loads")
}

/// Loads glTF bytes through the real loader and returns the scene with every warning it gave.
pub fn load_warned(bytes: &[u8], name: &str) -> (Scene, Vec<String>) {
    let mut warnings = Vec::new();
    let scene = gltf_load::load_bytes(bytes, name, Path::new("."), &mut |w| warnings.push(w))
        .expect("the scene loads");
    (scene, warnings)
}

/// The floor many tests light: y = 0 over [−1, 1]², its corners in this order.
pub const FLOOR: [glam::Vec3; 4] = [
    glam::Vec3::new(-1.0, 0.0, -1.0),
    glam::Vec3::new(-1.0, 0.0, 1.0),
    glam::Vec3::new(1.0, 0.0, 1.0),
    glam::Vec3::new(1.0, 0.0, -1.0),
];

pub fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_lightlearn")
}

/// Runs the binary with `args` in `dir` (with `env` added) and waits for it.
pub fn run_in(args: &[&str], dir: &Path, env: &[(&str, &str)]) -> std::process::Output {
    std::process::Command::new(exe())
        .args(args)
        .current_dir(dir)
        .envs(env.iter().copied())
        .output()
        .expect("run lightlearn")
}

pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The run failed with exit 1 and one `error:` line holding every piece of `wants`.
pub fn refused(o: &std::process::Output, wants: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "should fail with exit 1: {err}");
    assert!(!err.contains("panicked"), "panicked: {err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "one error line expected: {err}");
    for w in wants {
        assert!(errors[0].contains(w), "'{w}' missing from: {err}");
    }
}

/// The names in `dir`, sorted.
pub fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Runs `light_sample.comp` (sampler 2 = lightbvh, 3 = wang) on (p, n, u) queries.
pub fn gpu_light_samples(
    ctx: &Arc<Context>,
    tree: &lightlearn::lights::tree::LightTree,
    cuts: &lightlearn::lights::regions::Cuts,
    sampler: u32,
    queries: &[(glam::Vec3, glam::Vec3, f32)],
) -> Vec<lightlearn::gpu::layout::LightChoice> {
    let stats = vec![lightlearn::gpu::layout::SlotStats::default(); cuts.cuts.len()];
    let params = lightlearn::learning::LearnSettings::default().gpu_params();
    gpu_learned_samples(ctx, tree, cuts, sampler, &stats, params, queries)
}

/// `light_sample.comp` with learned statistics (sampler 4 = donikian, 5 = bayes; the BRDF
/// factor is 1).
pub fn gpu_learned_samples(
    ctx: &Arc<Context>,
    tree: &lightlearn::lights::tree::LightTree,
    cuts: &lightlearn::lights::regions::Cuts,
    sampler: u32,
    stats: &[lightlearn::gpu::layout::SlotStats],
    params: lightlearn::gpu::layout::LearnParams,
    queries: &[(glam::Vec3, glam::Vec3, f32)],
) -> Vec<lightlearn::gpu::layout::LightChoice> {
    gpu_samples_and_pmfs(ctx, tree, cuts, sampler, stats, params, queries, &[])
}

/// `light_sample.comp` as [`gpu_learned_samples`], also asking `light_pmf` for `lights[i]` at
/// query i (missing: none; the answer is `pmf_query`).
#[allow(clippy::too_many_arguments)]
pub fn gpu_samples_and_pmfs(
    ctx: &Arc<Context>,
    tree: &lightlearn::lights::tree::LightTree,
    cuts: &lightlearn::lights::regions::Cuts,
    sampler: u32,
    stats: &[lightlearn::gpu::layout::SlotStats],
    params: lightlearn::gpu::layout::LearnParams,
    queries: &[(glam::Vec3, glam::Vec3, f32)],
    lights: &[u32],
) -> Vec<lightlearn::gpu::layout::LightChoice> {
    use lightlearn::gpu::layout::LightQuery;
    use lightlearn::gpu::{Buffer, ComputePipeline};
    let q: Vec<LightQuery> = queries
        .iter()
        .enumerate()
        .map(|(i, (p, n, u))| LightQuery {
            p: p.to_array(),
            u: *u,
            n: n.to_array(),
            light: lights.get(i).copied().unwrap_or(u32::MAX),
        })
        .collect();
    let b = |name: &str, data: &[u32]| Buffer::from_slice(ctx, name, data).unwrap();
    let nodes = Buffer::texels(ctx, "nodes", &tree.gpu_nodes()).unwrap();
    let order = b("order", &tree.order);
    let position = b("position", &tree.position);
    let qb = Buffer::from_slice(ctx, "queries", &q).unwrap();
    let cb = Buffer::zeroed(
        ctx,
        "choices",
        (q.len() * std::mem::size_of::<lightlearn::gpu::layout::LightChoice>()) as u64,
    )
    .unwrap();
    let grid = Buffer::texels(ctx, "grid", &[cuts.grid.params]).unwrap();
    let index = Buffer::words(ctx, "region index", &cuts.index).unwrap();
    let cut = Buffer::words(ctx, "cuts", &cuts.cuts).unwrap();
    let sb = Buffer::texels(ctx, "stats", stats).unwrap();
    let db = Buffer::zeroed_texels(ctx, "deltas", (stats.len() * 32) as u64).unwrap();
    let lb = Buffer::from_slice(ctx, "learn", &[params]).unwrap();
    // The fold kernel over every slot (mode 1) with empty windows writes the weight
    // coefficients.
    let tb = Buffer::indirect(
        ctx,
        "touched",
        &lightlearn::render::touched_list(stats.len() as u32),
    )
    .unwrap();
    // No borrowed observations (--pool-priors): the coefficients of `stats` alone.
    let pb = Buffer::zeroed_texels(ctx, "borrowed", (stats.len() * 16) as u64).unwrap();
    let push = lightlearn::gpu::layout::FoldPush {
        slot_count: stats.len() as u32,
        mode: 1,
        first: 0,
        learn: params,
    };
    let fold = fold_pipeline(ctx, &sb, &db, &tb, &pb);
    ctx.submit(|cmd| {
        fold.dispatch(
            cmd,
            bytemuck::bytes_of(&push),
            [push.slot_count.div_ceil(64), 1, 1],
        )
    })
    .unwrap();
    let k = ComputePipeline::new(
        ctx,
        "light_sample",
        lightlearn::gpu::kernels::LIGHT_SAMPLE,
        11,
        4,
        &[sampler, cuts.in_cluster_importance as u32, 0, params.flags],
    )
    .unwrap();
    k.bind(&[
        &nodes, &order, &qb, &cb, &grid, &index, &cut, &sb, &db, &lb, &position,
    ])
    .unwrap();
    let count = q.len() as u32;
    ctx.submit(|cmd| k.dispatch(cmd, bytemuck::bytes_of(&count), [count.div_ceil(64), 1, 1]))
        .unwrap();
    let out: Vec<lightlearn::gpu::layout::LightChoice> = cb.read().unwrap();
    out[..q.len()].to_vec()
}

/// Random shading points on a scene's surfaces, as (point lifted off the surface, normal facing
/// the ray, a uniform number): hits of rays from random points in the bounds.
pub fn surface_points(s: &Scene, count: usize, seed: u64) -> Vec<(glam::Vec3, glam::Vec3, f32)> {
    use glam::Vec3;
    let bvh = lightlearn::accel::Bvh::build(&s.triangles);
    let (lo, hi) = s.bounds();
    let mut r = lightlearn::rng::SplitMix64(seed);
    let mut points = Vec::new();
    while points.len() < count {
        let o = lo + (hi - lo) * Vec3::new(r.f32(), r.f32(), r.f32());
        let d = Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
            .normalize_or(Vec3::X);
        if let Some((t, prim)) = bvh.intersect(o, d, 0.0, f32::INFINITY) {
            let [a, b, c] = s.triangles[prim as usize];
            let ng = (b - a).cross(c - a).normalize();
            let n = if ng.dot(d) < 0.0 { ng } else { -ng };
            points.push((o + t * d + n * 1e-3, n, r.f32()));
        }
    }
    points
}

/// Edits the JSON chunk of a .glb.
pub fn edit_glb(bytes: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
    edit(&mut json);
    let mut text = serde_json::to_vec(&json).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let rest = &bytes[20 + len..];
    let mut out = bytes[..8].to_vec();
    out.extend_from_slice(&((20 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(&bytes[16..20]);
    out.extend_from_slice(&text);
    out.extend_from_slice(rest);
    out
}

/// fold.comp as the session binds it (render::FOLD_BINDINGS): the totals `stats` and window
/// sums `delta` written as storage buffers and read as texels, the touched list, the
/// borrowed observations.
pub fn fold_pipeline(
    ctx: &Arc<Context>,
    stats: &lightlearn::gpu::Buffer,
    delta: &lightlearn::gpu::Buffer,
    touched: &lightlearn::gpu::Buffer,
    prior: &lightlearn::gpu::Buffer,
) -> lightlearn::gpu::ComputePipeline {
    let fold = lightlearn::gpu::ComputePipeline::new(
        ctx,
        "fold",
        lightlearn::gpu::kernels::FOLD,
        lightlearn::render::FOLD_BINDINGS.len() as u32,
        std::mem::size_of::<lightlearn::gpu::layout::FoldPush>() as u32,
        &[],
    )
    .unwrap();
    fold.bind(&[stats, delta, touched, prior, stats, delta])
        .unwrap();
    fold
}

/// An 8-bit RGB PNG of `w`×`h` texels, row by row.
pub fn png_rgb(w: u32, h: u32, rgb: &[[u8; 3]]) -> Vec<u8> {
    png_of(w, h, png::ColorType::Rgb, rgb.as_flattened())
}

/// An 8-bit RGBA PNG of `w`×`h` texels, row by row.
pub fn png_rgba(w: u32, h: u32, rgba: &[[u8; 4]]) -> Vec<u8> {
    png_of(w, h, png::ColorType::Rgba, rgba.as_flattened())
}

fn png_of(w: u32, h: u32, color: png::ColorType, bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut e = png::Encoder::new(&mut out, w, h);
    e.set_color(color);
    e.set_depth(png::BitDepth::Eight);
    let mut wr = e.write_header().unwrap();
    wr.write_image_data(bytes).unwrap();
    wr.finish().unwrap();
    out
}

/// The mean image of `sampler` on a `size` film at `depth`, `spp` samples of independent
/// numbers (`--stratify off`, so seeds' differences measure the noise), seed `seed`.
pub fn render_mean(
    scene: &Scene,
    sampler: lightlearn::render::LightSampler,
    size: (u32, u32),
    depth: u32,
    spp: u32,
    seed: u32,
) -> Vec<[f32; 3]> {
    use lightlearn::render::{self, Budget, GpuScene, RenderSettings, Stratify};
    let ctx = ctx();
    let gpu = GpuScene::upload(
        &ctx,
        scene,
        &lightlearn::accel::Bvh::build(&scene.triangles),
    )
    .unwrap();
    let settings = RenderSettings {
        budget: Budget::Samples(spp),
        seed,
        stratify: Stratify::Off,
        ..RenderSettings::new(sampler, size.0, size.1, depth)
    };
    render::render(&ctx, scene, &gpu, &settings, &mut |_, _| {})
        .unwrap()
        .mean()
}
