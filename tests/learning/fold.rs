//! The fold kernel against its CPU mirror.

use super::*;

#[test]
fn fold_kernel_matches_its_cpu_mirror() {
    let ctx = common::ctx();
    let mut r = SplitMix64(9);
    let n = 5000;
    let mut st = Vec::new();
    let mut de = Vec::new();
    for i in 0..n {
        let scale = 10f32.powf(r.range(-3.0, 3.0));
        st.push(SlotStats {
            n_zero: (r.f32() * 100.0).floor(),
            n_nonzero: (r.f32() * 100.0).floor(),
            sum: r.f32() * scale * 50.0,
            sum_sq: r.f32() * scale * scale * 50.0,
            scale,
            ..Default::default()
        });
        // Windows: empty, only zeros, and with non-zero observations (then sums > 0).
        let nonzero = if i % 5 == 0 {
            0
        } else {
            1 + (r.f32() * 1000.0) as u32
        };
        let big = |r: &mut SplitMix64| (r.next_u64() >> (20 + (i % 30))) * (nonzero > 0) as u64;
        let (s1, s2) = (big(&mut r), big(&mut r));
        de.push(SlotDelta {
            n_zero: if i % 7 == 0 {
                0
            } else {
                (r.f32() * 1000.0) as u32
            },
            n_nonzero: nonzero,
            sum_lo: s1 as u32,
            sum_hi: (s1 >> 32) as u32,
            sq_lo: s2 as u32,
            sq_hi: (s2 >> 32) as u32,
            ..Default::default()
        });
    }
    let l = LearnSettings::default();
    let sb = Buffer::texels(&ctx, "stats", &st).unwrap();
    // The list of touched slots as render.comp's mark_touched leaves it (in a scrambled
    // order, as atomics would): every slot with a non-empty window, flagged.
    let mut listed: Vec<u32> = (0..n as u32)
        .filter(|&i| de[i as usize].n_zero + de[i as usize].n_nonzero > 0)
        .collect();
    for i in (1..listed.len()).rev() {
        listed.swap(i, (r.next_u64() % (i as u64 + 1)) as usize);
    }
    for &i in &listed {
        de[i as usize].touched = 1;
    }
    let mut list = lightlearn::render::touched_list(n as u32);
    list[0] = (listed.len() as u32).div_ceil(64);
    list[3] = listed.len() as u32;
    list[4..4 + listed.len()].copy_from_slice(&listed);
    let db = Buffer::texels(&ctx, "deltas", &de).unwrap();
    let tb = Buffer::indirect(&ctx, "touched", &list).unwrap();
    // Borrowed observations (--pool-priors) for every third slot: they must reach the
    // coefficients, never the totals.
    let priors: Vec<[f32; 4]> = (0..n)
        .map(|i| {
            if i % 3 != 0 {
                return [0.0; 4];
            }
            let (z, v) = ((r.f32() * 4.0).floor(), (r.f32() * 4.0).floor());
            let y = st[i].scale * 10f32.powf(r.range(-2.0, 2.0));
            [z, v, v * y, v * y * y * (1.0 + r.f32())]
        })
        .collect();
    let pb = Buffer::texels(&ctx, "borrowed", &priors).unwrap();
    let push = FoldPush {
        slot_count: n as u32,
        mode: 0,
        first: 0,
        learn: l.gpu_params(),
    };
    let k = common::fold_pipeline(&ctx, &sb, &db, &tb, &pb);
    // Mode 0, as between passes: the listed slots, by an indirect dispatch; the others
    // are left alone.
    ctx.submit(|cmd| k.dispatch_indirect(cmd, bytemuck::bytes_of(&push), &tb, 0))
        .unwrap();
    let got: Vec<SlotStats> = sb.read().unwrap();
    let cleared: Vec<SlotDelta> = db.read().unwrap();
    let emptied: Vec<u32> = tb.read().unwrap();
    assert_eq!(
        &emptied[..4],
        &[0, 1, 1, 0],
        "the list's header after the fold"
    );
    assert!(
        emptied[4..].iter().all(|&e| e == u32::MAX),
        "the list after the fold"
    );
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()) + 1e-30;
    let mut borrowed_moved = 0;
    for i in 0..n {
        if de[i].n_zero + de[i].n_nonzero == 0 {
            assert_eq!(
                got[i], st[i],
                "slot {i}: an empty window must leave the slot alone"
            );
            continue;
        }
        let want = fold_with_prior(&st[i], &de[i], &priors[i], &l);
        let g = got[i];
        assert!(
            close(g.n_zero, want.n_zero)
                && close(g.n_nonzero, want.n_nonzero)
                && close(g.sum, want.sum)
                && close(g.sum_sq, want.sum_sq)
                && close(g.scale, want.scale),
            "slot {i}: GPU {g:?} vs CPU {want:?}"
        );
        // The coefficients: the same f32 formulas on totals that differ by rounding.
        let big = want
            .coef_a
            .abs()
            .max(want.coef_b.abs())
            .max(want.coef_c.abs());
        let near = |a: f32, b: f32| (a - b).abs() <= 1e-3 * big + 1e-30;
        assert!(
            near(g.coef_a, want.coef_a)
                && near(g.coef_b, want.coef_b)
                && near(g.coef_c, want.coef_c),
            "slot {i} (borrowed {:?}): GPU coefficients {:?} vs CPU {:?}",
            priors[i],
            [g.coef_a, g.coef_b, g.coef_c],
            [want.coef_a, want.coef_b, want.coef_c]
        );
        if priors[i][0] + priors[i][1] > 0.0 {
            let alone = fold(&st[i], &de[i], &l);
            borrowed_moved += ((alone.coef_a, alone.coef_b, alone.coef_c)
                != (want.coef_a, want.coef_b, want.coef_c)) as usize;
        }
        assert_eq!(
            cleared[i],
            SlotDelta::default(),
            "slot {i}: window not cleared"
        );
    }
    assert!(
        borrowed_moved > 100,
        "borrowed observations moved only {borrowed_moved} slots' coefficients"
    );
}
