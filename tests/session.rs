//! The render session: the learned state outlives camera moves and film resets, regions that
//! a moved camera reaches get cuts between frames and learn, images after a move are
//! unbiased, and statistics of several sessions merge by addition.

mod common;

use std::path::Path;

use glam::Vec3;
use lightlearn::accel::Bvh;
use lightlearn::gpu::layout::{SlotDelta, SlotStats};
use lightlearn::learning::stats_file::SavedStats;
use lightlearn::learning::UpdateEvery;
use lightlearn::render::{
    Budget, GpuScene, LightSampler, RenderResult, RenderSettings, Session, POOL_AGE_MAX,
};
use lightlearn::scene::{gltf_load, Camera, Scene};

fn scene(name: &str) -> Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    gltf_load::load(&p, &mut |_| {}).unwrap()
}

fn settings(sampler: LightSampler, seed: u32) -> RenderSettings {
    RenderSettings {
        width: 48,
        height: 36,
        budget: Budget::Samples(1),
        seed,
        sampler,
        regions: Default::default(),
        learn: Default::default(),
        resume: None,
        stratify: lightlearn::render::Stratify::Sobol,
        max_depth: 1,
        light_point: Default::default(),
        indirect_light_samples: 1,
        first_light_samples: 1,
    }
}

/// A camera in the far corner of rooms16 looking back across it: it sees rooms and walls
/// the scene's own camera does not.
fn camera_b(s: &Scene) -> Camera {
    let (lo, hi) = s.bounds();
    let p = Vec3::new(
        lo.x + 0.85 * (hi.x - lo.x),
        1.5,
        lo.z + 0.85 * (hi.z - lo.z),
    );
    Camera::looking(p, Vec3::new(-1.0, -0.25, -0.6), Vec3::Y, s.camera.yfov)
}

/// Share of the film's light samples that fell in regions without their own cut.
fn fallback_share(r: &RenderResult) -> f64 {
    let all: f64 = r.accum.iter().map(|a| a.sum_sq[3] as f64).sum();
    r.learned.as_ref().unwrap().diagnostics.samples_in_fallback as f64 / all
}

/// |z| of the difference of two images' means per channel, from their estimated variances.
fn mean_z(a: &RenderResult, b: &RenderResult) -> f64 {
    let (ma, mb) = (a.mean(), b.mean());
    let (va, vb) = (a.variance_of_mean(), b.variance_of_mean());
    let n = ma.len() as f64;
    (0..3)
        .map(|k| {
            let d: f64 = ma
                .iter()
                .zip(&mb)
                .map(|(x, y)| (x[k] - y[k]) as f64)
                .sum::<f64>()
                / n;
            let v: f64 = va
                .iter()
                .zip(&vb)
                .map(|(x, y)| (x[k] + y[k]) as f64)
                .sum::<f64>()
                / (n * n);
            (d / v.sqrt()).abs()
        })
        .fold(0.0, f64::max)
}

/// A converged image at `camera` by a sampler that does not learn.
fn reference(
    ctx: &std::sync::Arc<lightlearn::gpu::Context>,
    s: &Scene,
    gpu: &GpuScene,
    camera: Camera,
    spp: u32,
) -> RenderResult {
    let mut r = Session::new(ctx, s, gpu, &settings(LightSampler::Lightbvh, 99)).unwrap();
    r.set_camera(camera).unwrap();
    r.run_passes(spp).unwrap();
    r.result().unwrap()
}

#[test]
fn a_moved_camera_keeps_the_learning_and_its_new_regions_learn() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let mut session = Session::new(&ctx, &s, &gpu, &settings(LightSampler::Bayes, 3)).unwrap();
    let a = s.camera;
    let b = camera_b(&s);
    let mut counter = vec![session.passes()];

    session.run_passes(16).unwrap();
    counter.push(session.passes());
    let at_a = session.result().unwrap();
    let cuts_at_a = at_a.regions.regions_with_cuts;

    // Camera B: the film restarts, the learning does not.
    session.set_camera(b).unwrap();
    assert_eq!(session.spp(), 0);
    assert_eq!(session.image().unwrap().iter().flatten().sum::<f32>(), 0.0);
    session.run_passes(1).unwrap();
    counter.push(session.passes());
    let first = fallback_share(&session.result().unwrap());
    session.run_passes(15).unwrap();
    session.reset_film().unwrap();
    session.run_passes(64).unwrap();
    counter.push(session.passes());
    let at_b = session.result().unwrap();
    let later = fallback_share(&at_b);
    let added = at_b.regions.regions_with_cuts - cuts_at_a;
    eprintln!(
        "camera B: fallback share {first:.3} in its first pass, {later:.4} after; {added} regions got cuts ({} built between frames in all)",
        at_b.regions.regions_added_between_frames
    );
    assert!(
        first > 0.2,
        "camera B should first reach regions without cuts ({first})"
    );
    assert!(
        later < 0.01,
        "fallback share after the first passes at B: {later}"
    );
    assert!(
        added >= 20,
        "regions reached only from B get cuts ({added})"
    );
    // They learn: the regions that got cuts after A hold observations.
    let (sa, sb) = (
        &at_a.learned.as_ref().unwrap().saved,
        &at_b.learned.as_ref().unwrap().saved,
    );
    let new: Vec<usize> = (0..sb.index.len())
        .filter(|&r| sa.index[r] == 0 && sb.index[r] != 0)
        .collect();
    let learned = new
        .iter()
        .filter(|&&r| {
            let o = sb.index[r] as usize;
            sb.stats[o + 1..o + 1 + sb.cuts[o] as usize]
                .iter()
                .any(|x| x.n_zero + x.n_nonzero > 0.0)
        })
        .count();
    assert!(
        learned * 2 >= new.len() && learned >= 10,
        "{learned} of the {} regions added after A hold observations",
        new.len()
    );

    // The image at B is unbiased against a fresh reference.
    let r = reference(&ctx, &s, &gpu, b, 512);
    let z = mean_z(&at_b, &r);
    eprintln!("camera B: |z| of the image mean against a fresh reference {z:.2}");
    assert!(z < 4.0, "camera B image biased: |z| = {z}");
    assert!(at_b.mean().iter().flatten().sum::<f32>() > 0.0);

    // Back to A: the film restarts again, the counter still only grows.
    session.set_camera(a).unwrap();
    session.run_passes(8).unwrap();
    counter.push(session.passes());
    assert_eq!(session.spp(), 8);
    assert!(counter.windows(2).all(|w| w[0] < w[1]), "{counter:?}");
    assert_eq!(counter, [0, 16, 17, 96, 104]);
}

#[test]
fn statistics_of_two_sessions_merge_by_addition() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let learn = |seed: u32, camera: Camera, passes: u32| {
        let mut x = Session::new(&ctx, &s, &gpu, &settings(LightSampler::Bayes, seed)).unwrap();
        x.set_camera(camera).unwrap();
        x.run_passes(passes).unwrap();
        x.snapshot().unwrap().unwrap()
    };
    let pa = learn(1, s.camera, 16);
    let pb = learn(2, camera_b(&s), 24);
    let merged = SavedStats::merge(&[(pa.clone(), "a".into()), (pb.clone(), "b".into())]).unwrap();
    assert_eq!(merged.header.samples_done, 40);

    // Per cut of the merge: the sum of what each part holds for its regions, a part's own
    // cut of a region or the cut a block without lights shares among its regions, each
    // part's cut counted once (merging region by region counted a block's statistics once
    // for each of its regions: 3.2× the observations, an audit of 2026-12-07).
    let slots = |p: &SavedStats, o: u32| {
        let o = o as usize;
        p.stats[o + 1..o + 1 + p.cuts[o] as usize].to_vec()
    };
    let distinct = |p: &SavedStats| {
        let mut o: Vec<u32> = p.index.iter().copied().filter(|&o| o != 0).collect();
        o.sort_unstable();
        o.dedup();
        o
    };
    let observations = |p: &SavedStats| -> f64 {
        distinct(p)
            .iter()
            .flat_map(|&o| slots(p, o))
            .map(|s| s.n_zero as f64 + s.n_nonzero as f64)
            .sum()
    };
    let (mut both, mut one) = (0, 0);
    for m in distinct(&merged) {
        let group: Vec<usize> = (0..merged.index.len())
            .filter(|&r| merged.index[r] == m)
            .collect();
        let held: Vec<Vec<SlotStats>> = [&pa, &pb]
            .iter()
            .filter_map(|p| {
                let mut o: Vec<u32> = group
                    .iter()
                    .map(|&r| p.index[r])
                    .filter(|&o| o != 0)
                    .collect();
                o.dedup();
                assert!(o.len() <= 1, "a part splits merged cut {m}: {o:?}");
                o.first().map(|&o| slots(p, o))
            })
            .collect();
        let got = slots(&merged, m);
        match &held[..] {
            [x] => {
                one += 1;
                assert_eq!(&got, x, "cut {m}: taken as it is");
            }
            [x, y] => {
                both += 1;
                for ((m, x), y) in got.iter().zip(x).zip(y) {
                    assert_eq!(m.n_zero, x.n_zero + y.n_zero);
                    assert_eq!(m.n_nonzero, x.n_nonzero + y.n_nonzero);
                    assert_eq!(m.sum, (x.sum as f64 + y.sum as f64) as f32);
                    assert_eq!(m.sum_sq, (x.sum_sq as f64 + y.sum_sq as f64) as f32);
                }
            }
            _ => panic!("merged cut {m} held by no part"),
        }
    }
    eprintln!("merge: {both} cuts in both parts, {one} in one");
    assert!(both > 50 && one > 50, "both {both}, one {one}");
    let (oa, ob, om) = (observations(&pa), observations(&pb), observations(&merged));
    assert!(
        (om - (oa + ob)).abs() <= 1e-6 * om,
        "observations {om} against {oa} + {ob}"
    );

    // A part merged alone is itself: the same regions, sharing the same cuts, with the same
    // statistics (block sharing must be there for this to test anything).
    let alone = SavedStats::merge(&[(pa.clone(), "a".into())]).unwrap();
    let shared = |p: &SavedStats| distinct(p).len() < p.index.iter().filter(|&&o| o != 0).count();
    assert!(shared(&pa), "no block shares a cut in this part");
    assert_eq!(distinct(&alone).len(), distinct(&pa).len());
    for r in 0..pa.index.len() {
        assert_eq!(pa.index[r] == 0, alone.index[r] == 0, "region {r}");
        if pa.index[r] != 0 {
            assert_eq!(
                slots(&pa, pa.index[r]),
                slots(&alone, alone.index[r]),
                "region {r}"
            );
        }
    }
    // The part's offsets map one to one onto the merge's (regions share in one iff in both).
    let mut to: std::collections::HashMap<u32, u32> = Default::default();
    let mut from: std::collections::HashMap<u32, u32> = Default::default();
    for (&o, &m) in pa.index.iter().zip(&alone.index) {
        assert_eq!(*to.entry(o).or_insert(m), m, "part offset {o} split");
        assert_eq!(
            *from.entry(m).or_insert(o),
            o,
            "merged offset {m} joins two cuts"
        );
    }

    // A block that two parts reached in other regions stays split in their merge (nothing
    // there tells a light-free block from cells with equal cuts) and joins in a later merge
    // with a part that reached both (a review, 2026-12-07: that was refused as "other
    // --coarse-blocks settings", so merging was not associative).
    let (r1, r2) = (0..pa.index.len())
        .filter(|&r| pa.index[r] != 0)
        .find_map(|r| {
            let q = (r + 1..pa.index.len()).find(|&q| pa.index[q] == pa.index[r])?;
            Some((r, q))
        })
        .expect("a shared cut");
    let (mut a1, mut a2) = (pa.clone(), pa.clone());
    for r in 0..pa.index.len() {
        if pa.index[r] == pa.index[r1] {
            if r == r1 { &mut a2 } else { &mut a1 }.index[r] = 0;
        }
    }
    let m12 = SavedStats::merge(&[(a1, "a1".into()), (a2, "a2".into())]).unwrap();
    assert_ne!(m12.index[r1], m12.index[r2], "split");
    let m = SavedStats::merge(&[(m12.clone(), "m12".into()), (pa.clone(), "a".into())]).unwrap();
    assert_eq!(m.index[r1], m.index[r2], "joined again");
    let (o12, om) = (observations(&m12), observations(&m));
    assert!(
        (om - (o12 + oa)).abs() <= 1e-6 * om,
        "observations {om} against {o12} + {oa}"
    );

    // The merged file is whole, loads and renders unbiased.
    let merged = SavedStats::from_bytes(&merged.to_bytes(), "merged").unwrap();
    let mut set = settings(LightSampler::Bayes, 5);
    lightlearn::render::check_resume(&s, &gpu, &set, &merged, Path::new("merged")).unwrap();
    set.resume = Some(std::sync::Arc::new(merged));
    let mut m = Session::new(&ctx, &s, &gpu, &set).unwrap();
    assert_eq!(m.passes(), 40);
    m.run_passes(64).unwrap();
    let z = mean_z(
        &m.result().unwrap(),
        &reference(&ctx, &s, &gpu, s.camera, 512),
    );
    eprintln!("merged statistics: |z| against a fresh reference {z:.2}");
    assert!(z < 4.0, "render from merged statistics biased: |z| = {z}");

    // Parts of other settings or another scene are refused.
    let mut other = settings(LightSampler::Bayes, 1);
    other.regions.grid = 16;
    let mut x = Session::new(&ctx, &s, &gpu, &other).unwrap();
    x.run_passes(2).unwrap();
    let grid16 = x.snapshot().unwrap().unwrap();
    let err = SavedStats::merge(&[(pa.clone(), "a".into()), (grid16, "g".into())]).unwrap_err();
    assert!(format!("{err:#}").contains("--grid"), "{err:#}");
    let c = scene("cornell.glb");
    let cg = GpuScene::upload(&ctx, &c, &Bvh::build(&c.triangles)).unwrap();
    let mut y = Session::new(&ctx, &c, &cg, &settings(LightSampler::Bayes, 1)).unwrap();
    y.run_passes(2).unwrap();
    let err = SavedStats::merge(&[
        (pa, "a".into()),
        (y.snapshot().unwrap().unwrap(), "c".into()),
    ])
    .unwrap_err();
    assert!(format!("{err:#}").contains("other lights"), "{err:#}");
}

#[test]
fn resize_gives_a_new_film_and_keeps_the_learning() {
    let ctx = common::ctx();
    let s = scene("cornell.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let mut x = Session::new(&ctx, &s, &gpu, &settings(LightSampler::Bayes, 1)).unwrap();
    x.run_passes(4).unwrap();
    x.resize(20, 10).unwrap();
    assert_eq!((x.spp(), x.passes()), (0, 4));
    x.run_passes(4).unwrap();
    let r = x.result().unwrap();
    assert_eq!((r.width, r.height, r.accum.len()), (20, 10, 200));
    assert!(r.mean().iter().flatten().all(|v| v.is_finite()));
    assert!(r.mean().iter().flatten().any(|&v| v > 0.0));
    assert!(x.resize(0, 10).is_err());
}

/// What the library takes that the CLI's flags never let through (an audit by reading,
/// 2026-12-07): a sample budget below what the film holds ran one more batch (u32 wrap), a
/// NaN time budget never ended, path settings of 0 or u32::MAX were taken (2^32 dispatches,
/// weights of 1/0), and an image of another size panicked in the EXR writer.
#[test]
fn the_library_refuses_what_the_cli_never_passes() {
    use lightlearn::render::{run_session, Checkpoints};
    let ctx = common::ctx();
    let s = scene("cornell.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let mut x = Session::new(&ctx, &s, &gpu, &settings(LightSampler::Wang, 1)).unwrap();
    let run = |x: &mut Session, b: Budget| {
        run_session(x, b, &Checkpoints::None, &mut |_| Ok(()), &mut |_, _| {})
    };
    run(&mut x, Budget::Samples(8)).unwrap();
    assert_eq!(x.spp(), 8);
    let r = run(&mut x, Budget::Samples(4)).unwrap();
    assert_eq!((x.spp(), r.spp), (8, 8), "a smaller budget ran passes");
    for t in [f64::NAN, -1.0, 0.0, f64::INFINITY] {
        assert!(run(&mut x, Budget::Seconds(t)).is_err(), "{t} s");
    }
    // A film takes 2^20 samples a pixel at most (its float32 sums lose samples past them).
    let max = lightlearn::render::MAX_FILM_SPP;
    let err = run(&mut x, Budget::Samples(max + 1))
        .err()
        .expect("past the film");
    assert!(err.to_string().contains("float sums"), "{err}");
    let err = x.run_passes(max - 7).unwrap_err();
    assert!(err.to_string().contains("float sums"), "{err}");
    assert_eq!(x.spp(), 8);
    for (depth, indirect, first) in [
        (0, 1, 1),
        (u32::MAX, 1, 1),
        (2, 0, 1),
        (2, 1, 0),
        (2, 17, 1),
    ] {
        let mut set = settings(LightSampler::Wang, 1);
        (
            set.max_depth,
            set.indirect_light_samples,
            set.first_light_samples,
        ) = (depth, indirect, first);
        let err = Session::new(&ctx, &s, &gpu, &set).err().expect("refused");
        assert!(err.to_string().contains("out of range"), "{err}");
    }
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.exr");
    let err = lightlearn::film::write_exr(&p, 4, 4, &[[0.0; 3]; 15]).unwrap_err();
    assert!(err.to_string().contains("15 pixels, not 4×4"), "{err}");
    assert!(!p.exists());
    // A second audit of the library (2026-12-07): another scene's GpuScene panicked in
    // build_cuts (bayes) or rendered black with Ok (uniform); a camera looking along its up
    // (look_at straight down) rendered black with Ok; a triangle light past the triangles
    // panicked in the upload.
    let rooms = scene("rooms.glb");
    for sampler in [LightSampler::Bayes, LightSampler::Uniform] {
        let err = Session::new(&ctx, &rooms, &gpu, &settings(sampler, 1))
            .err()
            .expect("another scene's GpuScene");
        assert!(
            err.to_string().contains("uploaded from another scene"),
            "{err}"
        );
    }
    let mut down = s.clone();
    down.camera = Camera::looking(s.camera.position, -Vec3::Y, Vec3::Y, s.camera.yfov);
    let err = Session::new(&ctx, &down, &gpu, &settings(LightSampler::Wang, 1))
        .err()
        .expect("a camera along its up");
    assert!(err.to_string().contains("not parallel"), "{err}");
    let mut broken = s.clone();
    broken
        .lights
        .push(lightlearn::scene::Light::Triangle { triangle: 9999 });
    let err = GpuScene::upload(&ctx, &broken, &Bvh::build(&broken.triangles))
        .err()
        .expect("a light past the triangles");
    assert!(
        err.to_string().contains("light 6 is triangle 9999"),
        "{err}"
    );
}

/// The path tracer (one dispatch per bounce, paths queued between them) gives the same
/// image bit for bit when its queues are small and the film's paths start in bands of rows:
/// fails if a band starts at the wrong row or a queue mixes two bands' paths.
#[test]
fn path_queue_bands_give_the_same_image() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let mut set = settings(LightSampler::Bayes, 5);
    set.max_depth = 4;
    let mut one = Session::new(&ctx, &s, &gpu, &set).unwrap();
    one.run_passes(3).unwrap();
    let mut banded = Session::new(&ctx, &s, &gpu, &set).unwrap();
    // 160 bytes a path, two queues: 8 rows of 48 pixels, 36 rows in 5 bands.
    banded.set_path_queue_bytes(2 * 160 * 48 * 8).unwrap();
    banded.run_passes(3).unwrap();
    let (a, b) = (one.image().unwrap(), banded.image().unwrap());
    assert!(a.iter().flatten().any(|&v| v > 0.0));
    assert_eq!(a, b);
    assert!(banded.set_path_queue_bytes(1000).is_err());
}

/// A session's scratch (the path queues) released between runs is made again by the next:
/// the same image bit for bit, also with the camera moved while it was released (the
/// preview frees the scratch of every session it does not show).
#[test]
fn released_scratch_gives_the_same_image() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    for depth in [4, 1] {
        let mut set = settings(LightSampler::Bayes, 5);
        set.max_depth = depth;
        let mut freed = Session::new(&ctx, &s, &gpu, &set).unwrap();
        let mut kept = Session::new(&ctx, &s, &gpu, &set).unwrap();
        for x in [&mut freed, &mut kept] {
            x.run_passes(2).unwrap();
        }
        freed.release_scratch();
        freed.release_scratch();
        for x in [&mut freed, &mut kept] {
            x.set_camera(camera_b(&s)).unwrap();
            x.run_passes(2).unwrap();
        }
        let (a, b) = (freed.image().unwrap(), kept.image().unwrap());
        assert!(a.iter().flatten().any(|&v| v > 0.0), "depth {depth}");
        assert_eq!(a, b, "depth {depth}");
    }
}

/// Direct light takes several passes per dispatch (render.comp main, `params.passes`): a
/// sampler that does not learn up to 2^20 samples, a learned one the passes of a learning
/// window. The image must be bit for bit that of one dispatch per pass (here one
/// `run_passes` call per pass), growth points included.
#[test]
fn direct_passes_in_one_dispatch_give_the_same_image() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    // The learned samplers take a learning window's passes in one dispatch: 4 passes, or
    // (auto) 1 up to pass 16, 2 up to 32 and 4 after it.
    for (sampler, every) in [
        (LightSampler::Uniform, UpdateEvery::Auto),
        (LightSampler::Wang, UpdateEvery::Auto),
        (LightSampler::Bayes, UpdateEvery::Passes(4)),
        (LightSampler::Bayes, UpdateEvery::Auto),
        (LightSampler::Donikian, UpdateEvery::Auto),
    ] {
        let mut set = settings(sampler, 3);
        set.learn.update_every = every;
        let mut single = Session::new(&ctx, &s, &gpu, &set).unwrap();
        for _ in 0..40 {
            single.run_passes(1).unwrap();
        }
        let mut batched = Session::new(&ctx, &s, &gpu, &set).unwrap();
        batched.run_passes(40).unwrap();
        assert_eq!(batched.spp(), 40);
        let (a, b) = (single.image().unwrap(), batched.image().unwrap());
        assert!(a.iter().flatten().any(|&v| v > 0.0));
        assert!(
            a == b,
            "{sampler:?}, update every {every}: batched passes changed the image"
        );
    }
    // After a camera move `auto` counts the film's passes: windows of 1 again, then of 2, 4.
    let set = settings(LightSampler::Bayes, 3);
    let mut single = Session::new(&ctx, &s, &gpu, &set).unwrap();
    let mut batched = Session::new(&ctx, &s, &gpu, &set).unwrap();
    for _ in 0..70 {
        single.run_passes(1).unwrap();
    }
    batched.run_passes(70).unwrap();
    single.set_camera(camera_b(&s)).unwrap();
    batched.set_camera(camera_b(&s)).unwrap();
    for _ in 0..40 {
        single.run_passes(1).unwrap();
    }
    batched.run_passes(40).unwrap();
    assert!(
        single.image().unwrap() == batched.image().unwrap(),
        "moved: batched windows changed the image"
    );
    // Up to pass 16 `auto` folds after every pass; a move there starts the film's 16 more
    // (by the learned passes alone they would be windows of 2): the same image as folding
    // after every pass throughout.
    let mut every = settings(LightSampler::Bayes, 3);
    every.learn.update_every = UpdateEvery::Passes(1);
    let mut a = Session::new(&ctx, &s, &gpu, &set).unwrap();
    let mut b = Session::new(&ctx, &s, &gpu, &every).unwrap();
    for x in [&mut a, &mut b] {
        x.run_passes(16).unwrap();
        x.set_camera(camera_b(&s)).unwrap();
        x.run_passes(16).unwrap();
    }
    assert!(
        a.image().unwrap() == b.image().unwrap(),
        "auto after a move: not a fold after every film pass"
    );
}

/// `profile --timeline`: a session that times each dispatch, fold and growth point on its own
/// renders the same image, and its events are the schedule's: `auto` windows of 1 up to
/// pass 16, of 2 up to 32, then 4, each followed by its fold, and growth points after
/// passes 1, 2, 4, 8, 16 and 32; `wang` folds nothing; paths take a pass a step.
#[test]
fn a_timed_session_renders_the_same_image_and_times_every_step() {
    use lightlearn::render::timeline::Event;
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    for (sampler, depth, passes) in [
        (LightSampler::Bayes, 1, 40),
        (LightSampler::Wang, 1, 40),
        (LightSampler::Bayes, 3, 6),
    ] {
        let mut set = settings(sampler, 5);
        set.max_depth = depth;
        let mut plain = Session::new(&ctx, &s, &gpu, &set).unwrap();
        plain.run_passes(passes).unwrap();
        let mut timed = Session::new(&ctx, &s, &gpu, &set).unwrap();
        timed.record_timeline();
        timed.run_passes(passes / 2).unwrap();
        timed.run_passes(passes - passes / 2).unwrap();
        assert!(plain.timeline().is_none());
        assert!(
            plain.image().unwrap() == timed.image().unwrap(),
            "{sampler:?}, depth {depth}: timing each step changed the image"
        );
        let events = timed.timeline().unwrap();
        let mut windows = Vec::new();
        let mut growths = 0;
        for e in events {
            match e {
                Event::Passes {
                    passes,
                    render,
                    fold,
                } => {
                    assert!(render.is_finite() && *render > 0.0, "{e:?}");
                    assert!(fold.is_none_or(|f| f.is_finite() && f > 0.0), "{e:?}");
                    windows.push((*passes, fold.is_some()));
                }
                Event::Growth {
                    read,
                    cuts,
                    pool,
                    submit,
                    ..
                } => {
                    assert!(
                        [read, cuts, pool, submit]
                            .iter()
                            .all(|t| t.is_finite() && **t >= 0.0),
                        "{e:?}"
                    );
                    growths += 1;
                }
            }
        }
        assert_eq!(
            windows.iter().map(|w| w.0).sum::<u32>(),
            passes,
            "{sampler:?}, depth {depth}: {windows:?}"
        );
        match (sampler, depth) {
            (LightSampler::Bayes, 1) => {
                let want: Vec<(u32, bool)> =
                    [[(1, true); 16].as_slice(), &[(2, true); 8], &[(4, true); 2]].concat();
                assert_eq!(windows, want);
                assert_eq!(growths, 6, "growth points after passes 1, 2, 4, 8, 16, 32");
            }
            (LightSampler::Wang, _) => {
                assert!(
                    windows.iter().all(|w| !w.1),
                    "wang folds nothing: {windows:?}"
                );
                assert_eq!(growths, 6);
            }
            _ => assert_eq!(
                windows,
                vec![(1, true); 6],
                "paths: a pass a step, each a window"
            ),
        }
    }
}

/// With `--update-every` above 1 the cuts still grow, at the first fold boundary after each
/// growth point (before, growth was skipped unless the two coincided: with 3, not before
/// pass 192).
#[test]
fn regions_grow_at_fold_boundaries_with_update_every() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    // 7: no growth point (learning passes 1, 2, 4, 8, 16; after the move at 8 the film's
    // 1, 2, 4, 8, 16, i.e. passes 9, 10, 12, 16, 24) is a multiple of it before pass 28.
    let mut set = settings(LightSampler::Bayes, 3);
    set.learn.update_every = UpdateEvery::Passes(7);
    let mut x = Session::new(&ctx, &s, &gpu, &set).unwrap();
    x.run_passes(8).unwrap();
    x.set_camera(camera_b(&s)).unwrap();
    x.run_passes(16).unwrap();
    x.reset_film().unwrap();
    x.run_passes(2).unwrap();
    let r = x.result().unwrap();
    let share = fallback_share(&r);
    eprintln!(
        "update-every 7: fallback share {share:.4}, {} regions added",
        r.regions.regions_added_between_frames
    );
    assert!(share < 0.01, "fallback share {share}");
    // A snapshot in the middle of a window leaves what later passes sample by unchanged.
    let mut y = Session::new(&ctx, &s, &gpu, &set).unwrap();
    let mut z = Session::new(&ctx, &s, &gpu, &set).unwrap();
    y.run_passes(7).unwrap();
    z.run_passes(7).unwrap();
    let _ = y.snapshot().unwrap();
    y.run_passes(5).unwrap();
    z.run_passes(5).unwrap();
    assert_eq!(y.image().unwrap(), z.image().unwrap());
    // A camera move with a window open (auto: windows of 4 from pass 32) neither loses nor
    // folds it: a snapshot holds the same statistics before and after the move.
    let mut w = Session::new(&ctx, &s, &gpu, &settings(LightSampler::Bayes, 3)).unwrap();
    w.run_passes(39).unwrap();
    let before = w.snapshot().unwrap().unwrap();
    w.set_camera(camera_b(&s)).unwrap();
    let after = w.snapshot().unwrap().unwrap();
    let total = |x: &SavedStats| x.stats.iter().map(|t| t.n_zero + t.n_nonzero).sum::<f32>();
    assert!(total(&before) > 0.0);
    assert!(
        before.stats == after.stats,
        "a move dropped the open window from the snapshot: {} → {} observations",
        total(&before),
        total(&after)
    );
}

/// The window's list of touched slots, which the fold visits instead of every slot: after
/// each pass of an open window it holds every slot with observations exactly once (and no
/// other), with the fold's workgroup count to match; the fold at the window's end empties
/// it and clears every slot. A slot missing from the list would keep its window unfolded
/// (and sample by stale coefficients); one listed twice would be folded twice at once.
#[test]
fn the_fold_visits_exactly_the_slots_the_window_touched() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    for depth in [1, 3] {
        let mut set = settings(LightSampler::Bayes, 5);
        set.learn.update_every = UpdateEvery::Passes(3);
        set.max_depth = depth;
        let mut x = Session::new(&ctx, &s, &gpu, &set).unwrap();
        let mut seen_zero_only = 0;
        for pass in 1..=3 {
            x.run_passes(1).unwrap();
            let (delta, list) = x.open_window().unwrap();
            let count = list[3] as usize;
            if pass == 3 {
                assert_eq!(
                    &list[..4],
                    &[0, 1, 1, 0],
                    "depth {depth}: the fold empties the list"
                );
                assert!(
                    list[4..].iter().all(|&e| e == u32::MAX),
                    "depth {depth}: stale entries"
                );
                assert!(
                    delta.iter().all(|d| *d == Default::default()),
                    "depth {depth}: the fold clears every window"
                );
                continue;
            }
            let mut listed: Vec<u32> = list[4..4 + count].to_vec();
            assert!(list[4 + count..].iter().all(|&e| e == u32::MAX));
            listed.sort_unstable();
            let before = listed.len();
            listed.dedup();
            assert_eq!(
                listed.len(),
                before,
                "depth {depth}, pass {pass}: a slot listed twice"
            );
            let touched: Vec<u32> = (0..delta.len() as u32)
                .filter(|&i| delta[i as usize].n_zero + delta[i as usize].n_nonzero > 0)
                .collect();
            assert_eq!(
                listed, touched,
                "depth {depth}, pass {pass}: list vs window"
            );
            for (i, d) in delta.iter().enumerate() {
                let want = touched.binary_search(&(i as u32)).is_ok() as u32;
                assert_eq!(
                    d.touched, want,
                    "depth {depth}, pass {pass}: slot {i}'s flag"
                );
                seen_zero_only += (d.n_zero > 0 && d.n_nonzero == 0) as usize;
            }
            assert_eq!(list[0] as usize, count.div_ceil(64), "workgroup count");
            assert!(count > 0);
            eprintln!(
                "depth {depth}, pass {pass}: {count} of {} slots touched",
                delta.len()
            );
        }
        // Slots that saw only occluded samples must be listed too (their zeros count).
        assert!(seen_zero_only > 0, "depth {depth}: no slot saw zeros alone");
    }
}

/// Whether two slots' weight coefficients agree to 1e-5 of the weight polynomial's size
/// (w² = scale² (a t² + b t + c) with t = μ0 / scale near 1): a coefficient that is a
/// cancellation residue (b = 2PQ − 2 H1 ȳ can be 1e-8 beside a = 0.49) differs between
/// devices far more than relatively (an H200 contracts other products into FMAs: b −8.0e-9
/// against the host's −4.1e-9), while the weight it gives is the same.
fn same_weight(g: &SlotStats, want: &SlotStats) -> bool {
    let size = want.coef_a.abs() + want.coef_b.abs() + want.coef_c.abs();
    let near = |a: f32, b: f32| (a - b).abs() <= 1e-5 * size + 1e-30;
    near(g.coef_a, want.coef_a) && near(g.coef_b, want.coef_b) && near(g.coef_c, want.coef_c)
}

/// Slots appended by region growth start from the statistics a fresh session gives its
/// slots (`initial_stats`: zero totals, the scale of the node's unoccluded estimate, and the
/// coefficients the fold derives from them and from what the slot borrowed of its
/// neighbours, `--pool-priors`), whether the statistics buffer had to be made anew or had
/// room for them (it grows by doubling and is written in place in between).
#[test]
fn grown_slots_start_from_their_initial_statistics() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let set = settings(LightSampler::Bayes, 3);
    let mut x = Session::new(&ctx, &s, &gpu, &set).unwrap();
    let first = x.sampling_stats().unwrap().len();
    let mut grown = vec![first];
    // Growth points 1, 2, 4 (the buffer doubles at the first, the others fit), then a move
    // and the film's growth points.
    for (k, moved) in [
        (1, false),
        (1, false),
        (2, false),
        (1, true),
        (1, false),
        (2, false),
        (4, false),
    ] {
        if moved {
            x.set_camera(camera_b(&s)).unwrap();
        }
        x.run_passes(k).unwrap();
        grown.push(x.sampling_stats().unwrap().len());
    }
    eprintln!("slots after each step: {grown:?}");
    let appends = grown.windows(2).filter(|w| w[1] > w[0]).count();
    assert!(appends >= 3, "too few growths to test: {grown:?}");
    let stats = x.sampling_stats().unwrap();
    let priors = x.borrowed_priors().unwrap();
    let init = lightlearn::render::initial_stats(&gpu.tree, x.cuts(), set.observed_regression());
    assert_eq!(stats.len(), init.len());
    assert_eq!(priors.len(), init.len());
    let mut checked = 0;
    let mut borrowing = 0;
    for (i, (g, c)) in stats.iter().zip(&init).enumerate().skip(first) {
        if g.n_zero + g.n_nonzero > 0.0 {
            continue;
        }
        // Cold slots borrow their neighbours' observations (--pool-priors): the
        // coefficients are those of the initial totals plus what they borrowed.
        let want =
            lightlearn::learning::fold_with_prior(c, &SlotDelta::default(), &priors[i], &set.learn);
        borrowing += (priors[i][0] + priors[i][1] > 0.0) as usize;
        assert!(
            g.scale == want.scale && same_weight(g, &want),
            "appended slot {i}: {g:?}, want {want:?}"
        );
        checked += 1;
    }
    // Every slot, old or new, cold or not: its coefficients are those of its totals and what
    // it borrows now (old slots whose borrowed observations changed are refolded).
    let mut stale = 0;
    for (i, g) in stats.iter().enumerate() {
        let want =
            lightlearn::learning::fold_with_prior(g, &SlotDelta::default(), &priors[i], &set.learn);
        stale += !same_weight(g, &want) as usize;
    }
    assert_eq!(
        stale,
        0,
        "{stale} of {} slots have stale coefficients",
        stats.len()
    );
    eprintln!("{checked} appended slots without observations checked, {borrowing} borrowing");
    assert!(checked > 0);
    assert!(borrowing > 0, "no appended cold slot borrowed observations");
}

/// Cold slots borrow (`--pool-priors`) only while the learning is young: at the first growth
/// point past `POOL_AGE_MAX` passes every slot's borrowed observations are dropped on the
/// GPU, and the slots that borrowed get their coefficients from their own totals again.
#[test]
fn borrowed_observations_end_with_the_young_age() {
    let ctx = common::ctx();
    let s = scene("rooms16.glb");
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let mut set = settings(LightSampler::Bayes, 5);
    (set.width, set.height) = (16, 12);
    let mut x = Session::new(&ctx, &s, &gpu, &set).unwrap();
    x.run_passes(POOL_AGE_MAX).unwrap();
    let young = x.borrowed_priors().unwrap();
    let lending = young.iter().filter(|p| p[0] + p[1] > 0.0).count();
    assert!(lending > 0, "no slot borrowed at the young age");
    // The next growth point (every 64th pass) is past the young age.
    x.run_passes(64).unwrap();
    let priors = x.borrowed_priors().unwrap();
    let still = priors.iter().filter(|p| **p != [0.0; 4]).count();
    assert_eq!(still, 0, "{still} slots still borrow past the young age");
    let stats = x.sampling_stats().unwrap();
    let stale = stats
        .iter()
        .filter(|g| {
            let own = lightlearn::learning::fold_with_prior(
                g,
                &SlotDelta::default(),
                &[0.0; 4],
                &set.learn,
            );
            !same_weight(g, &own)
        })
        .count();
    assert_eq!(
        stale, 0,
        "{stale} slots keep the coefficients of what they borrowed"
    );
    eprintln!("{lending} slots borrowed at {POOL_AGE_MAX} passes, none after");
}

/// Direct light covers only the rows of 8 pixels whose camera rays can meet the scene
/// (src/render/coverage.rs): the pixels left out would have added exact zeros, so the image
/// is bit for bit that of every pixel, learning and region growth included, before and
/// after a camera move; on city (a street under an empty sky) rows are left out.
#[test]
fn pixels_that_cannot_see_the_scene_are_left_out_with_the_same_image() {
    let ctx = common::ctx();
    for name in ["city.glb", "strings.glb"] {
        let s = scene(name);
        let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
        // Looking up and sideways from the scene's camera: the sky's edge moves across the
        // film.
        let c = s.camera;
        let turned = Camera::looking(
            c.position,
            c.forward + 0.4 * c.up + 0.3 * c.forward.cross(c.up),
            c.up,
            c.yfov,
        );
        for sampler in [LightSampler::Uniform, LightSampler::Bayes] {
            let mut set = settings(sampler, 5);
            set.width = 61;
            set.height = 43;
            let all_rows = 43 * 61u32.div_ceil(8);
            let mut culled = Session::new(&ctx, &s, &gpu, &set).unwrap();
            let mut full = Session::new(&ctx, &s, &gpu, &set).unwrap();
            full.set_pixel_culling(false).unwrap();
            assert_eq!(full.covered_rows(), all_rows);
            if name == "city.glb" {
                assert!(
                    culled.covered_rows() < all_rows * 3 / 4,
                    "{name}: {} of {all_rows} rows covered",
                    culled.covered_rows()
                );
            }
            for cam in [None, Some(turned)] {
                for x in [&mut culled, &mut full] {
                    if let Some(cam) = cam {
                        x.set_camera(cam).unwrap();
                    }
                    x.run_passes(40).unwrap();
                }
                let (a, b) = (culled.image().unwrap(), full.image().unwrap());
                assert!(a.iter().flatten().any(|&v| v > 0.0));
                assert!(
                    a == b,
                    "{name}, {sampler:?}, turned {}: leaving rows out changed the image",
                    cam.is_some()
                );
            }
            // Outside the scene's box looking away from it: no row can see the scene, no
            // dispatch runs, and the image is black as with every row covered.
            let (lo, hi) = s.bounds();
            let away = Camera::looking(hi + (hi - lo), hi - lo, Vec3::Y, c.yfov);
            for x in [&mut culled, &mut full] {
                x.set_camera(away).unwrap();
                x.run_passes(3).unwrap();
            }
            assert_eq!(
                culled.covered_rows(),
                0,
                "{name}: rows covered looking away"
            );
            let (a, b) = (culled.image().unwrap(), full.image().unwrap());
            assert!(a == b && a.iter().flatten().all(|&v| v == 0.0));
        }
    }
}

/// A session's kernels are compiled once per context and specialization: lavapipe spent
/// ~0.2 s of CPU creating them for every session, which `animate` paid every frame (an
/// audit, 2026-12-07: 60 frames of 8×6 took 16.2 s; 1.1 s since, the same bytes). Two
/// sessions sharing the compiled kernels, each with its own descriptor sets, interleaved,
/// render what one alone renders.
#[test]
fn sessions_share_compiled_kernels_and_keep_their_own_bindings() {
    let s = scene("rooms16.glb");
    let set = settings(LightSampler::Bayes, 3);
    let alone = {
        let ctx = common::ctx();
        let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
        let mut one = Session::new(&ctx, &s, &gpu, &set).unwrap();
        one.run_passes(4).unwrap();
        one.image().unwrap()
    };
    let ctx = common::ctx();
    let gpu = GpuScene::upload(&ctx, &s, &Bvh::build(&s.triangles)).unwrap();
    let mut a = Session::new(&ctx, &s, &gpu, &set).unwrap();
    let compiled = ctx.compiled_kernels();
    assert!(compiled > 0);
    let mut other = set.clone();
    other.seed = 4;
    let mut b = Session::new(&ctx, &s, &gpu, &other).unwrap();
    assert_eq!(
        ctx.compiled_kernels(),
        compiled,
        "the same kernels compiled again"
    );
    for _ in 0..4 {
        a.run_passes(1).unwrap();
        b.run_passes(1).unwrap();
    }
    assert_eq!(a.image().unwrap(), alone);
    assert_ne!(b.image().unwrap(), alone);
    let _wang = Session::new(&ctx, &s, &gpu, &settings(LightSampler::Wang, 3)).unwrap();
    assert!(
        ctx.compiled_kernels() > compiled,
        "another sampler's kernel"
    );
}
