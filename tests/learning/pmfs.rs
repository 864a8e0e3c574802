//! The learned pmfs: `bayes` starts where `wang` is; exact, covering every light, the same on
//! GPU and CPU; MIS's pmf of an emitter a BSDF ray hits is the sampler's.

use super::*;

#[test]
fn bayes_starts_as_wang_on_gpu_and_cpu() {
    let s = scene("rooms.glb");
    let tree = LightTree::build(&s);
    let (cuts, points) = cuts_and_points(&s, &tree, 2000, RegionSettings::default());
    let ctx = common::ctx();
    let zero = vec![SlotStats::default(); cuts.cuts.len()];
    let l = LearnSettings::default();
    let bayes = common::gpu_learned_samples(&ctx, &tree, &cuts, 5, &zero, l.gpu_params(), &points);
    let wang = common::gpu_light_samples(&ctx, &tree, &cuts, 3, &points);
    let mut same = 0;
    for (i, ((b, w), &(p, n, _))) in bayes.iter().zip(&wang).zip(&points).enumerate() {
        same += (b.light == w.light) as usize;
        if b.light == w.light {
            assert!(
                (b.pmf - w.pmf).abs() <= 1e-4 * w.pmf,
                "query {i}: bayes pmf {} vs wang {}",
                b.pmf,
                w.pmf
            );
        }
        // CPU: the bayes weights before data are ∝ Ĩ_C(x).
        let o = cuts.offset_at(p, n);
        let cut = &cuts.cuts[o + 1..o + 1 + cuts.cuts[o] as usize];
        let wb = learned_weights(&tree, &cuts.cuts, o, &zero, p, n, false, &l, 1.0);
        let wi = Cuts::importances(&tree, cut, p, n);
        let (sb, si): (f32, f32) = (wb.iter().sum(), wi.iter().sum());
        for (a, b) in wb.iter().zip(&wi) {
            assert!(
                (a / sb.max(1e-30) - b / si.max(1e-30)).abs() < 1e-5,
                "query {i}: bayes weight share {} vs wang {}",
                a / sb,
                b / si
            );
        }
    }
    // Rounding may move a u at a slot boundary to the neighbour.
    assert!(
        same * 1000 >= points.len() * 995,
        "only {same} of {} queries pick the same light",
        points.len()
    );
}

#[test]
fn learned_pmfs_are_exact_cover_every_light_and_match_the_gpu() {
    for (name, in_cluster_importance) in [
        ("rooms.glb", false),
        ("city.glb", false),
        ("rooms.glb", true),
    ] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        let settings = RegionSettings {
            in_cluster_importance,
            ..Default::default()
        };
        let (cuts, points) = cuts_and_points(&s, &tree, 600, settings);
        let ctx = common::ctx();
        for (sampler, donikian) in [(5u32, false), (4u32, true)] {
            for seed in [1u64, 2] {
                let st = adversarial_stats(cuts.cuts.len(), seed);
                // Control variates on: bayes reports its g's (checked below), donikian 0.
                // Seed 1 regresses on the unoccluded importance (the default), seed 2 on
                // distance with the defensive mixture.
                let l = LearnSettings {
                    control_variates: true,
                    regression: if seed == 1 {
                        Regression::Importance
                    } else {
                        Regression::Distance
                    },
                    defensive: if seed == 1 { 0.0 } else { 0.1 },
                    ..Default::default()
                };
                let gpu = common::gpu_learned_samples(
                    &ctx,
                    &tree,
                    &cuts,
                    sampler,
                    &st,
                    l.gpu_params(),
                    &points,
                );
                let mut agree = 0;
                for (i, (&(p, n, u), g)) in points.iter().zip(&gpu).enumerate() {
                    let o = cuts.offset_at(p, n);
                    let cut = &cuts.cuts[o + 1..o + 1 + cuts.cuts[o] as usize];
                    let w = learned_weights(&tree, &cuts.cuts, o, &st, p, n, donikian, &l, 1.0);
                    assert!(
                        w.iter().all(|x| x.is_finite() && *x >= 0.0),
                        "{name}: weights {w:?}"
                    );
                    let inside = cuts.inside(p, n);
                    let cpu = lightlearn::lights::regions::pick_in_cut(&tree, cut, &w, u, inside);
                    let cv = if donikian {
                        vec![0.0; cut.len()]
                    } else {
                        predicted_means(&tree, &cuts.cuts, o, &st, p, n, &l, 1.0)
                    };
                    let cv_total: f32 = cv.iter().sum();
                    let near =
                        |a: f32, b: f32| (a - b).abs() <= 1e-3 * a.abs().max(b.abs()) + 1e-30;
                    assert!(
                        near(g.cv_total, cv_total),
                        "{name} query {i}: GPU Σg {} vs CPU {cv_total}",
                        g.cv_total
                    );
                    // The pmf returned with the sample equals the one recomputed for its light.
                    if cpu.is_none() && g.light == u32::MAX {
                        agree += 1; // both met no light (all weights 0 or a dead end)
                    }
                    if let Some((light, pmf, k)) = cpu {
                        let again = pmf_in_cut(&tree, cut, &w, light, inside);
                        assert!(
                            (pmf - again).abs() <= 1e-5 * pmf,
                            "{name} query {i}: pmf {pmf} vs recomputed {again}"
                        );
                        if g.light == light {
                            agree += 1;
                            assert!(
                                near(g.cv_chosen, cv[k]),
                                "{name} query {i}: GPU g of the chosen slot {} vs CPU {}",
                                g.cv_chosen,
                                cv[k]
                            );
                            assert!(
                                (g.pmf - pmf).abs() <= 1e-3 * pmf,
                                "{name} query {i}: GPU pmf {} vs CPU {pmf}",
                                g.pmf
                            );
                        }
                    }
                    // Cover: every light that can contribute (lightbvh pmf > 0) keeps pmf > 0.
                    let total: f64 = (0..s.lights.len() as u32)
                        .map(|li| pmf_in_cut(&tree, cut, &w, li, inside) as f64)
                        .sum();
                    // Sum to 1, or below 1 by the chance of a dead end inside a cluster (no
                    // light below can reach here: a zero sample, as in lightbvh).
                    if cpu.is_some() && !in_cluster_importance {
                        assert!((total - 1.0).abs() < 1e-3, "{name}: pmfs sum to {total}");
                    }
                    assert!(total < 1.0 + 1e-3, "{name}: pmfs sum to {total}");
                    for li in 0..s.lights.len() as u32 {
                        if tree.pmf(p, n, li) > 0.0 {
                            assert!(pmf_in_cut(&tree, cut, &w, li, inside) > 0.0, "{name}, sampler {sampler}: light {li} can contribute at {p} but has pmf 0 under adversarial statistics");
                        }
                    }
                }
                assert!(
                    agree * 1000 >= points.len() * 990,
                    "{name}: GPU and CPU agree on {agree} of {}",
                    points.len()
                );
            }
        }
    }
}

/// What MIS needs for an emitter that a BSDF-sampled ray hits: the pmf with which the light
/// sampler would have picked it. `light_pmf` (light_pmf.glsl) gives the light a sampler chose
/// the very pmf the sampler reported, and any other light the CPU mirror's pmf — lightbvh,
/// wang, donikian and bayes (adversarial statistics), inside clusters by power and by
/// importance.
#[test]
fn light_pmf_equals_the_samplers_pmf() {
    for (name, in_cluster_importance) in [
        ("rooms.glb", true),
        ("rooms.glb", false),
        ("city.glb", true),
    ] {
        let s = scene(name);
        let tree = LightTree::build(&s);
        let settings = RegionSettings {
            in_cluster_importance,
            ..Default::default()
        };
        let (cuts, points) = cuts_and_points(&s, &tree, 500, settings);
        let mut r = SplitMix64(7);
        let lights: Vec<u32> = points
            .iter()
            .map(|_| (r.next_u64() % s.lights.len() as u64) as u32)
            .collect();
        let ctx = common::ctx();
        let st = adversarial_stats(cuts.cuts.len(), 3);
        // city with the defensive mixture: light_pmf_of_cut must repeat its λ.
        let l = LearnSettings {
            defensive: if name == "city.glb" { 0.1 } else { 0.0 },
            ..Default::default()
        };
        for sampler in [2u32, 3, 4, 5] {
            let gpu = common::gpu_samples_and_pmfs(
                &ctx,
                &tree,
                &cuts,
                sampler,
                &st,
                l.gpu_params(),
                &points,
                &lights,
            );
            let (mut agree, mut chosen, mut positive) = (0, 0, 0);
            for (i, ((&(p, n, _), g), &li)) in points.iter().zip(&gpu).zip(&lights).enumerate() {
                if g.light != u32::MAX {
                    chosen += 1;
                    assert!(
                        (g.pmf_again - g.pmf).abs() <= 1e-5 * g.pmf,
                        "{name} sampler {sampler} query {i}: light_pmf {} vs the sampler's {}",
                        g.pmf_again,
                        g.pmf
                    );
                }
                let o = cuts.offset_at(p, n);
                let cut = &cuts.cuts[o + 1..o + 1 + cuts.cuts[o] as usize];
                let inside = cuts.inside(p, n);
                let cpu = match sampler {
                    2 => tree.pmf(p, n, li),
                    3 => pmf_in_cut(&tree, cut, &Cuts::importances(&tree, cut, p, n), li, inside),
                    _ => {
                        let w =
                            learned_weights(&tree, &cuts.cuts, o, &st, p, n, sampler == 4, &l, 1.0);
                        pmf_in_cut(&tree, cut, &w, li, inside)
                    }
                };
                positive += (cpu > 0.0) as usize;
                // Within rounding of the GPU's and CPU's importance (tests/importance.rs).
                agree += ((g.pmf_query - cpu).abs() <= 2e-3 * cpu.max(g.pmf_query)) as usize;
            }
            assert!(
                agree * 1000 >= points.len() * 990,
                "{name} sampler {sampler}: light_pmf and the CPU agree on {agree} of {}",
                points.len()
            );
            assert!(chosen * 2 > points.len() && positive * 10 > points.len(), "{name} sampler {sampler}: {chosen} lights chosen, {positive} queried pmfs > 0: too few to test");
        }
    }
}
