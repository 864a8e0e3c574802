//! The posterior's math: against numerical integration, finite and positive for any
//! counts, and the kernels' three coefficients.

use super::*;

fn stats(n_zero: f32, ys: &[f64]) -> SlotStats {
    SlotStats {
        n_zero,
        n_nonzero: ys.len() as f32,
        sum: ys.iter().sum::<f64>() as f32,
        sum_sq: ys.iter().map(|y| y * y).sum::<f64>() as f32,
        scale: 1.0,
        ..Default::default()
    }
}

/// E[k] and E[1/h] under prior × likelihood, integrated on a grid: k linear around the data,
/// h on a log grid (density × h for the change of variables). (E[1/h] rather than E[h]: the
/// inverse-gamma's tail makes E[h] converge too slowly on a finite grid.)
fn integrated_posterior(ys: &[f64], mu0: f64, l: &LearnSettings) -> (f64, f64) {
    let (nbar, a0) = (l.prior_n as f64, l.prior_alpha as f64);
    let b0 = a0 * (l.prior_cv as f64 * mu0).powi(2);
    let (mut z, mut ek, mut eh) = (0f64, 0f64, 0f64);
    let (kn, hn) = (1500, 1500);
    let (klo, khi) = (mu0 - 12.0 * mu0.abs() - 10.0, mu0 + 12.0 * mu0.abs() + 10.0);
    let (lhlo, lhhi) = ((1e-4f64).ln(), (1e4f64).ln());
    for i in 0..kn {
        let k = klo + (khi - klo) * (i as f64 + 0.5) / kn as f64;
        for j in 0..hn {
            let lh = lhlo + (lhhi - lhlo) * (j as f64 + 0.5) / hn as f64;
            let h = lh.exp();
            // log of N(k; mu0, h/nbar) · InvGamma(h; a0, b0) · Π N(y; k, h) · h (log grid)
            let mut lp = -0.5 * (h / nbar).ln() - nbar * (k - mu0).powi(2) / (2.0 * h);
            lp += -(a0 + 1.0) * h.ln() - b0 / h;
            for y in ys {
                lp += -0.5 * h.ln() - (y - k).powi(2) / (2.0 * h);
            }
            lp += h.ln();
            let w = lp.exp();
            z += w;
            ek += w * k;
            eh += w / h;
        }
    }
    (ek / z, eh / z)
}

#[test]
fn posterior_matches_numerical_integration() {
    let l = LearnSettings::default();
    // Zero data, one sample, a few samples (α' > 1 is needed for E[h] to exist, hence ≥ 1
    // sample with n̄_α = 1; zero data checks the closed form equals the prior directly).
    let mu0 = 2.0;
    let p = Posterior::new(&stats(0.0, &[]), mu0, &l);
    assert_eq!((p.mu, p.kappa, p.alpha), (mu0, 1.0, 1.0));
    assert!((p.beta - mu0 * mu0).abs() < 1e-12);
    assert!((p.nonzero_chance() - 0.5).abs() < 1e-12);
    for ys in [
        vec![3.0],
        vec![1.0, 4.0, 2.5],
        vec![0.5, 0.7, 0.2, 0.9, 0.4, 0.6],
    ] {
        let p = Posterior::new(&stats(3.0, &ys), mu0, &l);
        let (ek, eh) = integrated_posterior(&ys, mu0, &l);
        // E[1/h] = α'/β' for the inverse-gamma posterior of h.
        let closed = p.alpha / p.beta;
        assert!(
            (p.mu - ek).abs() < 2e-3 * ek.abs().max(1.0),
            "{ys:?}: E[k] closed form {} vs integrated {ek}",
            p.mu
        );
        assert!(
            (closed - eh).abs() < 5e-3 * eh,
            "{ys:?}: E[1/h] closed form {closed} vs integrated {eh}"
        );
        // Beta: 3 zeros, n non-zeros, pseudo-counts 2 and 2.
        let n = ys.len() as f64;
        assert!((p.nonzero_chance() - (2.0 + n) / (7.0 + n)).abs() < 1e-12);
    }
}

#[test]
fn weights_are_finite_and_positive_for_any_counts() {
    // Up to 10¹² samples per slot and observations from 1e-30 to 1e12 (Σy² stays finite).
    let counts = [0.0f32, 1.0, 2.0, 1e3, 1e7, 1e9, 1e12];
    let values = [0.0f32, 1e-30, 1e-6, 1.0, 1e6, 1e12];
    for priors in [true, false] {
        for target_mean in [false, true] {
            let l = LearnSettings {
                priors,
                target_mean,
                ..Default::default()
            };
            for &nz in &counts {
                for &nv in &counts {
                    for &m in &values {
                        for &mu0 in &[1e-20f64, 1e-3, 1.0, 1e20] {
                            let s = SlotStats {
                                n_zero: nz,
                                n_nonzero: nv,
                                sum: m * nv,
                                sum_sq: ((m as f64).powi(2) * nv as f64).min(3e38) as f32,
                                scale: 1.0,
                                ..Default::default()
                            };
                            let w = Posterior::new(&s, mu0, &l).weight(target_mean);
                            assert!(
                                w.is_finite() && w > 0.0,
                                "priors {priors}, mean {target_mean}: weight {w} for n_zero {nz}, n_nonzero {nv}, y {m}, mu0 {mu0}"
                            );
                            // The kernels' f32 path (scale: the slot's RMS, as the fold sets it).
                            let s = fold(
                                &SlotStats {
                                    scale: if nv > 0.0 && m > 0.0 { m } else { 1.0 },
                                    ..s
                                },
                                &SlotDelta::default(),
                                &l,
                            );
                            let wc = lightlearn::learning::coefficient_weight(
                                &s,
                                [s.coef_a, s.coef_b, s.coef_c],
                                mu0 as f32,
                                &l,
                            );
                            assert!(
                                wc.is_finite() && wc > 0.0,
                                "priors {priors}, mean {target_mean}: f32 weight {wc} for n_zero {nz}, n_nonzero {nv}, y {m}, mu0 {mu0}"
                            );
                        }
                    }
                }
            }
        }
    }
}

/// The kernels evaluate the weight from three per-slot coefficients of the prior mean; they
/// must give what the posterior formulas give directly.
#[test]
fn coefficients_give_the_posterior_weight() {
    let mut r = SplitMix64(17);
    for priors in [true, false] {
        for target_mean in [false, true] {
            let l = LearnSettings {
                priors,
                target_mean,
                ..Default::default()
            };
            for i in 0..20_000 {
                let scale = 10f32.powf(r.range(-4.0, 4.0));
                let nv = [0.0, 1.0, 2.0, (r.f32() * 1e4).floor()][i % 4];
                let mean = scale * r.range(0.01, 3.0);
                let s = SlotStats {
                    n_zero: [0.0, 1.0, (r.f32() * 1e4).floor()][i % 3],
                    n_nonzero: nv,
                    sum: nv * mean,
                    sum_sq: nv * mean * mean * r.range(1.0, 5.0),
                    scale: scale * r.range(0.3, 3.0),
                    ..Default::default()
                };
                let mu0 = scale * 10f32.powf(r.range(-3.0, 1.0));
                let s = fold(&s, &SlotDelta::default(), &l);
                let c = lightlearn::learning::coefficient_weight(
                    &s,
                    [s.coef_a, s.coef_b, s.coef_c],
                    mu0,
                    &l,
                );
                let direct = Posterior::new(&s, mu0 as f64, &l).weight(target_mean);
                assert!(
                    ((c as f64) - direct).abs() <= 1e-3 * direct,
                    "priors {priors}, mean {target_mean}: coefficients give {c}, the posterior {direct} ({s:?}, mu0 {mu0})"
                );
            }
        }
    }
}
