//! The directional albedo of the dielectric's GGX layer, tabulated for the diffuse base's
//! coupling in `shaders/shared/bsdf.glsl` (Kulla & Conty 2017's energy compensation).
//!
//! A dielectric is a GGX layer (F0 = 0.04 × specular colour, weight `specularFactor`) over a
//! Lambertian base. The base gets what the layer does not keep, on the way in and out:
//! `base / π · (1 − K(n·v)) (1 − K(n·l)) / (1 − K_avg)`, with K(μ) the layer's directional
//! albedo E(μ) plus its multiple scattering (bsdf.glsl `layer_kept`) and K_avg = 2 ∫ K(μ) μ dμ.
//! That is reciprocal, and the base's albedo is exactly 1 − K(n·v), so a white dielectric
//! reflects all that arrives but the layer's multiple scattering, which is not rendered
//! (at most 0.35 % at F0 = 0.04). Until 2026-12-07 E was the
//! Fresnel of the macro normal, exact for a smooth layer only: a rough layer (roughness 1)
//! reflects little at grazing angles, yet the base was darkened as if it were a mirror, and
//! rough dielectrics rendered at 0.30–0.44× the specification's value under grazing light
//! (an audit against glTF's Appendix B by hand, 2026-12-07).
//!
//! With Schlick's Fresnel the albedo is linear in F0: E = specular · (F0 · M + (1 − F0) · S),
//! M(μ, α) = ∫ D G2 / (4 μ μ_l) μ_l dl (the layer's albedo with F = 1) and S(μ, α) the same
//! weighted by (1 − v·h)^5. Both are tabulated over μ and the roughness r (α = max(r², 1e-3),
//! as the kernel's), bilinear in between; the averages come from the interpolant itself, so
//! that the base's albedo is exactly 1 − K(n·v) as the kernel evaluates K. The kernels read
//! the committed tables (`src/layer_albedo_data.rs`, which [`rust_source`] writes; a test
//! checks that the file is its output) from a texel buffer: as GLSL constant arrays
//! lavapipe's LLVM 15 spent over ten minutes compiling the kernel (its coroutine frames).
//! bsdf.glsl adds the layer's multiple scattering (Kulla & Conty's F_ms) to what the layer
//! keeps from the base.

/// Points over μ = n·v in [0, 1].
pub const N_MU: usize = 32;
/// Points over the roughness r in [0, 1].
pub const N_ROUGH: usize = 32;
/// Visible-normal samples per entry: 2·GRID radii × GRID/2 angles (16384; within 2e-5 of
/// 16 times as many at r 0.23–0.36, μ 0–1).
const GRID: usize = 128;
/// The kernel's smallest α (bsdf.glsl MIN_ALPHA).
const MIN_ALPHA: f64 = 1.0e-3;

/// M and S at every (r, μ) point (row-major in r) and their averages 2 ∫ · μ dμ per r.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerAlbedo {
    pub ms: Vec<[f32; 2]>,
    pub avg: Vec<[f32; 2]>,
}

fn lambda(alpha: f64, c: f64) -> f64 {
    let c2 = (c * c).max(1e-12);
    let tan2 = (1.0 - c2).max(0.0) / c2;
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// (M, S) at view cosine `mu` and GGX `alpha`: the mean of G2(v, l) / G1(v) (and of it times
/// (1 − v·h)^5) over visible normals h, l the mirror of v about h (Heitz 2018: visible-normal
/// sampling makes the integrand that ratio).
pub fn directional(mu: f64, alpha: f64) -> (f64, f64) {
    directional_with(mu, alpha, GRID)
}

fn directional_with(mu: f64, alpha: f64, grid: usize) -> (f64, f64) {
    let mu = mu.clamp(1e-4, 1.0);
    let v = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
    // Heitz 2018, listing 1, with v in the xz plane.
    let vh = {
        let (x, z) = (alpha * v[0], v[2]);
        let len = (x * x + z * z).sqrt();
        [x / len, 0.0, z / len]
    };
    let t1 = if vh[0] > 0.0 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let t2 = [
        vh[1] * t1[2] - vh[2] * t1[1],
        vh[2] * t1[0] - vh[0] * t1[2],
        vh[0] * t1[1] - vh[1] * t1[0],
    ];
    let g1 = 1.0 / (1.0 + lambda(alpha, mu));
    let (mut m, mut s) = (0.0, 0.0);
    // The radius u1 from t by u1 = 1 − (1 − t)^4 (weight 4 (1 − t)^3): samples crowd toward
    // the disk's rim, GGX's long tail of steep normals that mirror v below the horizon (a
    // uniform 128² grid put M at μ = 1, r = 0.23 at 0.99985 against 0.99699 from 1024²).
    let (nt, nphi) = (grid * 2, grid / 2);
    for i in 0..nt {
        let t = (i as f64 + 0.5) / nt as f64;
        let u1 = 1.0 - (1.0 - t).powi(4);
        let weight = 4.0 * (1.0 - t).powi(3);
        for j in 0..nphi {
            let u2 = (j as f64 + 0.5) / nphi as f64;
            let r = u1.sqrt();
            let phi = 2.0 * std::f64::consts::PI * u2;
            let p1 = r * phi.cos();
            let mut p2 = r * phi.sin();
            let w = 0.5 * (1.0 + vh[2]);
            p2 = (1.0 - w) * (1.0 - p1 * p1).max(0.0).sqrt() + w * p2;
            let p3 = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
            let nh: Vec<f64> = (0..3)
                .map(|k| p1 * t1[k] + p2 * t2[k] + p3 * vh[k])
                .collect();
            let h = [alpha * nh[0], alpha * nh[1], nh[2].max(0.0)];
            let hl = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let h = [h[0] / hl, h[1] / hl, h[2] / hl];
            let vdh = v[0] * h[0] + v[1] * h[1] + v[2] * h[2];
            let lz = 2.0 * vdh * h[2] - v[2];
            if lz <= 0.0 || vdh <= 0.0 {
                continue;
            }
            let g2 = 1.0 / (1.0 + lambda(alpha, mu) + lambda(alpha, lz));
            let f = weight * g2 / g1;
            m += f;
            s += f * (1.0 - vdh).powi(5);
        }
    }
    let n = (nt * nphi) as f64;
    (m / n, s / n)
}

/// α of roughness `r` as the kernel takes it.
pub fn alpha_of(r: f64) -> f64 {
    (r * r).max(MIN_ALPHA)
}

/// The tables (about 1 s of f64 arithmetic on one core).
pub fn table() -> LayerAlbedo {
    let mut ms = Vec::with_capacity(N_MU * N_ROUGH);
    let mut avg = Vec::with_capacity(N_ROUGH);
    for j in 0..N_ROUGH {
        let alpha = alpha_of(j as f64 / (N_ROUGH - 1) as f64);
        let row: Vec<[f32; 2]> = (0..N_MU)
            .map(|i| {
                let (m, s) = directional(i as f64 / (N_MU - 1) as f64, alpha);
                [m as f32, s as f32]
            })
            .collect();
        // 2 ∫ f(μ) μ dμ of the piecewise-linear interpolant, exactly: on [a, b] with
        // f linear from fa to fb, ∫ f μ dμ = (b − a) (fa (2a + b) + fb (a + 2b)) / 6.
        let mut a2 = [0f64; 2];
        let h = 1.0 / (N_MU - 1) as f64;
        for i in 0..N_MU - 1 {
            let (a, b) = (i as f64 * h, (i + 1) as f64 * h);
            for k in 0..2 {
                let (fa, fb) = (row[i][k] as f64, row[i + 1][k] as f64);
                a2[k] += 2.0 * h * (fa * (2.0 * a + b) + fb * (a + 2.0 * b)) / 6.0;
            }
        }
        avg.push([a2[0] as f32, a2[1] as f32]);
        ms.extend(row);
    }
    LayerAlbedo { ms, avg }
}

impl LayerAlbedo {
    /// (M, S) at `mu` for GGX `alpha`, bilinear as `layer_albedo` in bsdf.glsl.
    pub fn lookup(&self, mu: f64, alpha: f64) -> (f64, f64) {
        let x = mu.clamp(0.0, 1.0) * (N_MU - 1) as f64;
        let y = alpha.sqrt().clamp(0.0, 1.0) * (N_ROUGH - 1) as f64;
        let (i, j) = ((x as usize).min(N_MU - 2), (y as usize).min(N_ROUGH - 2));
        let (fx, fy) = (x - i as f64, y - j as f64);
        let at = |j: usize, i: usize, k: usize| self.ms[j * N_MU + i][k] as f64;
        let mix = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let get = |k: usize| {
            let lo = mix(at(j, i, k), at(j, i + 1, k), fx);
            let hi = mix(at(j + 1, i, k), at(j + 1, i + 1, k), fx);
            mix(lo, hi, fy)
        };
        (get(0), get(1))
    }

    /// The averages 2 ∫ (M, S) μ dμ for GGX `alpha`, linear in r as `layer_albedo_avg`.
    pub fn lookup_avg(&self, alpha: f64) -> (f64, f64) {
        let y = alpha.sqrt().clamp(0.0, 1.0) * (N_ROUGH - 1) as f64;
        let j = (y as usize).min(N_ROUGH - 2);
        let fy = y - j as f64;
        let get = |k: usize| {
            let (a, b) = (self.avg[j][k] as f64, self.avg[j + 1][k] as f64);
            a + (b - a) * fy
        };
        (get(0), get(1))
    }
}

/// `src/layer_albedo_data.rs`: the tables as Rust constants, which [`committed`] reads
/// (computing them takes about 1 s, too long for every render's start).
pub fn rust_source(t: &LayerAlbedo) -> String {
    let pairs = |v: &[[f32; 2]]| {
        v.iter()
            .map(|p| format!("[{:?}, {:?}]", p[0], p[1]))
            .collect::<Vec<_>>()
            .chunks(4)
            .map(|c| format!("    {},", c.join(", ")))
            .collect::<Vec<_>>()
            .join("\n")
    };
    format!(
        "// Generated by src/layer_albedo.rs (`rust_source(&table())`; tests/bsdf.rs checks that this\n\
         // file is its output): the dielectric GGX layer's directional albedo terms (M, S) over\n\
         // {N_ROUGH} roughness rows × {N_MU} view cosines, and their averages 2 ∫ · μ dμ.\n\
         #[rustfmt::skip]\n\
         pub const MS: [[f32; 2]; {}] = [\n{}\n];\n\
         #[rustfmt::skip]\n\
         pub const AVG: [[f32; 2]; {}] = [\n{}\n];\n",
        t.ms.len(),
        pairs(&t.ms),
        t.avg.len(),
        pairs(&t.avg),
    )
}

mod data {
    include!("layer_albedo_data.rs");
}

/// The committed tables (what the kernels get).
pub fn committed() -> LayerAlbedo {
    LayerAlbedo {
        ms: data::MS.to_vec(),
        avg: data::AVG.to_vec(),
    }
}

impl LayerAlbedo {
    /// The kernels' texels (`layer_albedo_texels` in render.comp and bsdf.comp, RGBA32UI):
    /// the (M, S) pairs as float bits, two a texel, row-major in roughness, then the
    /// averages (an even count each: N_MU × N_ROUGH and N_ROUGH).
    pub fn texels(&self) -> Vec<[u32; 4]> {
        let pairs: Vec<[f32; 2]> = self.ms.iter().chain(&self.avg).copied().collect();
        pairs
            .chunks(2)
            .map(|c| {
                let b = c.get(1).copied().unwrap_or([0.0; 2]);
                [c[0][0], c[0][1], b[0], b[1]].map(f32::to_bits)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth layer reflects by the Fresnel of the macro normal: M → 1, S → (1 − μ)^5, and
    /// the averages 1 and 1/21 (the coupling before 2026-12-07, which stays exact there).
    #[test]
    fn a_smooth_layer_is_fresnel() {
        for mu in [0.2, 0.5, 0.9, 1.0] {
            let (m, s) = directional(mu, 1e-6);
            assert!((m - 1.0).abs() < 1e-3, "M({mu}) = {m}");
            assert!((s - (1.0f64 - mu).powi(5)).abs() < 1e-3, "S({mu}) = {s}");
        }
    }

    /// The quadrature against an independent estimate: uniform directions over the
    /// hemisphere, D G2 / (4 μ μ_l) μ_l, with many samples.
    #[test]
    fn the_quadrature_matches_uniform_sampling() {
        let mut rng = crate::rng::SplitMix64(11);
        for (mu, r) in [(0.1, 1.0), (0.5, 0.5), (0.9, 0.6), (0.3, 0.7)] {
            let alpha = alpha_of(r);
            let a2 = alpha * alpha;
            let v = [(1.0f64 - mu * mu).sqrt(), 0.0, mu];
            let n = 400_000;
            let (mut m, mut s) = (0.0, 0.0);
            for _ in 0..n {
                let z = rng.f32() as f64;
                let phi = 2.0 * std::f64::consts::PI * rng.f32() as f64;
                let q = (1.0 - z * z).max(0.0).sqrt();
                let l = [q * phi.cos(), q * phi.sin(), z];
                let h: Vec<f64> = (0..3).map(|k| v[k] + l[k]).collect();
                let hl = h.iter().map(|x| x * x).sum::<f64>().sqrt();
                let h: Vec<f64> = h.iter().map(|x| x / hl).collect();
                let nh = h[2];
                let d = a2 / (std::f64::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
                let g2 = 1.0 / (1.0 + lambda(alpha, mu) + lambda(alpha, z));
                let f = d * g2 / (4.0 * mu * z) * z * 2.0 * std::f64::consts::PI;
                let vdh = v[0] * h[0] + v[2] * h[2];
                m += f;
                s += f * (1.0 - vdh).powi(5);
            }
            let (m, s) = (m / n as f64, s / n as f64);
            let (qm, qs) = directional(mu, alpha);
            assert!(
                (qm - m).abs() < 0.01 && (qs - s).abs() < 0.01,
                "μ {mu}, r {r}: quadrature ({qm}, {qs}), uniform ({m}, {s})"
            );
        }
    }

    #[test]
    fn the_averages_are_the_interpolants() {
        let t = table();
        for j in [0, 10, N_ROUGH - 1] {
            let alpha = alpha_of(j as f64 / (N_ROUGH - 1) as f64);
            let k = 20_000;
            let (mut m, mut s) = (0.0, 0.0);
            for i in 0..k {
                let mu = (i as f64 + 0.5) / k as f64;
                let (a, b) = t.lookup(mu, alpha);
                m += 2.0 * a * mu / k as f64;
                s += 2.0 * b * mu / k as f64;
            }
            let (am, as_) = t.lookup_avg(alpha);
            assert!((am - m).abs() < 1e-5 && (as_ - s).abs() < 1e-5);
        }
    }
}
