//! Randomness. The renderer's random numbers are a pure function of
//! (seed, pixel, sample index, dimension), mirrored exactly in `shaders/shared/rng.glsl`, so a
//! render is reproducible and any sample can be recomputed on the host.

/// 32-bit integer hash ("lowbias32", Chris Wellons' hash-prospector): full avalanche, cheap on
/// GPUs and lavapipe alike.
#[inline]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The renderer's random number in [0, 1) for (seed, pixel, sample, dimension).
#[inline]
pub fn sample_rand(seed: u32, pixel: u32, sample: u32, dim: u32) -> f32 {
    let h = hash32(seed ^ hash32(pixel ^ hash32(sample.wrapping_mul(0x9e37_79b9) ^ hash32(dim))));
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// What [`jitter_keys`] and [`vertex_key`] hash in (rng.glsl has the same literals).
pub const JITTER_KEY_X: u32 = 0x68bc_21eb;
pub const JITTER_KEY_Y: u32 = 0x02e5_be93;
pub const VERTEX_KEY: u32 = 0xa511_e9b3;

/// A pixel's keys for its jitter (x, then y from x's) and for number `k` of its first vertex:
/// the rotations of R2 and R5 and the scrambles of Sobol' (mirror of `jitter_keys` and
/// `vertex_key` in rng.glsl).
fn jitter_keys(seed: u32, pixel: u32) -> [u32; 2] {
    let kx = hash32(seed ^ hash32(pixel ^ JITTER_KEY_X));
    [kx, hash32(kx ^ JITTER_KEY_Y)]
}

fn vertex_key(seed: u32, pixel: u32, k: u32) -> u32 {
    hash32(seed ^ hash32(pixel ^ hash32(k ^ VERTEX_KEY)))
}

/// The point in the pixel of sample `s` when jitter is stratified (mirror of
/// `pixel_jitter_r2` in rng.glsl): the R2 sequence in 32-bit fixed point, rotated per pixel.
pub fn pixel_jitter_r2(seed: u32, pixel: u32, s: u32) -> [f32; 2] {
    let [ox, oy] = jitter_keys(seed, pixel);
    let x = s.wrapping_mul(3_242_174_889).wrapping_add(ox);
    let y = s.wrapping_mul(2_447_445_414).wrapping_add(oy);
    [
        (x >> 8) as f32 * (1.0 / 16_777_216.0),
        (y >> 8) as f32 * (1.0 / 16_777_216.0),
    ]
}

/// The R5 sequence's steps in 32-bit fixed point: round(frac(φ^-k) · 2^32), k = 1 … 5, with
/// φ ≈ 1.1347241384 the real root of x^6 = x + 1 (Roberts 2018).
pub const R5_STEP: [u32; 5] = [
    3_785_032_107,
    3_335_640_777,
    2_939_605_023,
    2_590_590_015,
    2_283_013_049,
];

/// Number `k` (0 … 4: light choice, point on the light u and v, BSDF direction u and v) of
/// the first vertex of sample `s` when stratified (mirror of `first_vertex_r5` in rng.glsl):
/// the R5 sequence, rotated per pixel and dimension.
pub fn first_vertex_r5(seed: u32, pixel: u32, s: u32, k: u32) -> f32 {
    let o = vertex_key(seed, pixel, k);
    let x = s.wrapping_mul(R5_STEP[k as usize]).wrapping_add(o);
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The multipliers of the Laine–Karras permutation in [`owen_scramble`] (and rng.glsl's).
pub const OWEN_MUL: [u32; 4] = [0x6c50_b47c, 0xb82f_1e52, 0xc7af_e638, 0x8d22_f6e6];

/// Degree, coefficients and initial direction numbers m of Sobol' dimensions 1 … 6 (Joe & Kuo
/// 2008, new-joe-kuo-6.21201), from which rng.glsl `sobol_point`'s constants and recurrence are
/// made.
pub const SOBOL_PARAMS: [(u32, u32, [u32; 4]); 6] = [
    (1, 0, [1, 0, 0, 0]),
    (2, 1, [1, 3, 0, 0]),
    (3, 1, [1, 3, 1, 0]),
    (3, 2, [1, 1, 1, 0]),
    (4, 1, [1, 1, 3, 3]),
    (4, 4, [1, 3, 5, 13]),
];

/// Dimension `d` (0 … 6) of the unscrambled Sobol' point `i` in 32-bit fixed point (mirror of
/// `sobol_point` in rng.glsl, which has bits 0–15 as constants): the direction numbers by
/// their recurrence.
pub fn sobol_dim(i: u32, d: u32) -> u32 {
    if d == 0 {
        return i.reverse_bits();
    }
    let (deg, a, m) = SOBOL_PARAMS[d as usize - 1];
    let mut r = [0u32; 4];
    let mut x = 0;
    let mut b = 0;
    while b < 32 && (i >> b) != 0 {
        let v = if b < deg {
            m[b as usize] << (31 - b)
        } else {
            let vs = r[deg as usize - 1];
            let mut v = vs ^ (vs >> deg);
            for k in 1..deg {
                if (a >> (deg - 1 - k)) & 1 != 0 {
                    v ^= r[k as usize - 1];
                }
            }
            v
        };
        if (i >> b) & 1 != 0 {
            x ^= v;
        }
        r = [v, r[0], r[1], r[2]];
        b += 1;
    }
    x
}

/// A nested uniform (Owen) scramble of the bits of `x`, keyed by `seed` (mirror of
/// `owen_scramble` in rng.glsl; Burley 2020).
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    let mut x = x.reverse_bits().wrapping_add(seed);
    for m in OWEN_MUL {
        x ^= x.wrapping_mul(m);
    }
    x.reverse_bits()
}

fn owen_sobol(i: u32, d: u32, seed: u32) -> f32 {
    (owen_scramble(sobol_dim(i, d), seed) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The point in the pixel of sample `s` under `--stratify sobol` (mirror of
/// `pixel_jitter_sobol` in rng.glsl): Sobol' dimensions 0 and 1, Owen-scrambled per pixel.
pub fn pixel_jitter_sobol(seed: u32, pixel: u32, s: u32) -> [f32; 2] {
    let [kx, ky] = jitter_keys(seed, pixel);
    [owen_sobol(s, 0, kx), owen_sobol(s, 1, ky)]
}

/// Number `k` (0 … 4, as [`first_vertex_r5`]) of the first vertex of sample `s` under
/// `--stratify sobol` (mirror of `first_vertex_sobol` in rng.glsl): Sobol' dimension 2 + k.
pub fn first_vertex_sobol(seed: u32, pixel: u32, s: u32, k: u32) -> f32 {
    owen_sobol(s, 2 + k, vertex_key(seed, pixel, k))
}

/// A small sequential generator (SplitMix64) for host-side work: scene generation, test data.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The steps are frac(φ^-k) · 2^32 for φ the real root of x^6 = x + 1, here and in the
    /// kernel (a wrong digit would still give uniform numbers, but stratify worse).
    #[test]
    fn r5_steps_are_the_inverse_powers_of_the_root_of_x6_eq_x_plus_1() {
        let mut phi = 1.2f64;
        for _ in 0..50 {
            phi -= (phi.powi(6) - phi - 1.0) / (6.0 * phi.powi(5) - 1.0);
        }
        for (k, &step) in R5_STEP.iter().enumerate() {
            let want = (phi.powi(-(k as i32 + 1)).fract() * 4_294_967_296.0).round();
            assert_eq!(step as f64, want, "step {k}");
        }
        let glsl = include_str!("../shaders/shared/rng.glsl");
        let list = glsl
            .split("R5_STEP[5] = uint[5](")
            .nth(1)
            .and_then(|t| t.split(");").next())
            .expect("R5_STEP in rng.glsl");
        let kernel: Vec<u32> = list
            .split(',')
            .map(|w| w.trim().trim_end_matches('u').parse().unwrap())
            .collect();
        assert_eq!(
            kernel, R5_STEP,
            "rng.glsl's R5_STEP differs from the host's"
        );
    }

    /// Each of the five numbers of a pixel's first 256 samples leaves no gap wider than
    /// 4 / 256 in [0, 1): the widest is 1.07–3.87 / 256 (the three-gap theorem: a Kronecker
    /// sequence has at most three gap lengths), where 256 independent numbers leave a
    /// median widest gap of 5.9 / 256 (3.9 / 256 at best in 200 draws).
    #[test]
    fn first_vertex_numbers_are_evenly_spread() {
        for pixel in [0, 7, 12345] {
            for k in 0..5 {
                let mut v: Vec<f32> = (0..256).map(|s| first_vertex_r5(1, pixel, s, k)).collect();
                v.sort_by(f32::total_cmp);
                let wrap = v[0] + 1.0 - v[255];
                let gap = v.windows(2).map(|w| w[1] - w[0]).fold(wrap, f32::max);
                assert!(gap < 4.0 / 256.0, "pixel {pixel}, number {k}: gap {gap}");
            }
        }
    }

    /// The seven numbers of a pixel's sample s (jitter, then the first vertex's five) as
    /// `--stratify sobol` makes them.
    fn sobol_sample(pixel: u32, s: u32) -> [f32; 7] {
        let j = pixel_jitter_sobol(1, pixel, s);
        let mut v = [j[0], j[1], 0.0, 0.0, 0.0, 0.0, 0.0];
        for k in 0..5 {
            v[2 + k] = first_vertex_sobol(1, pixel, s, k as u32);
        }
        v
    }

    /// A pixel's first 2^m samples (m ≤ 12) put one number of each dimension in every interval
    /// [i, i + 1) / 2^m; the jitter (dimensions 0, 1) is a (0, m, 2)-net (one point in every
    /// 2^j × 2^(m−j) box) and the point on the light (3, 4) and the BSDF direction (5, 6) are
    /// (3, m, 2)-nets (8 points in every box of 8 / 2^m; t ≤ 2 up to m = 8, 3 at m = 9–16):
    /// the t-values of these Sobol' pairs, which a nested scramble keeps. An even initial direction number breaks it
    /// (checked: m = (1, 2, 3, 3) for dimension 5).
    #[test]
    fn sobol_numbers_are_nets() {
        for pixel in [0, 7, 12345] {
            for m in 0..=12u32 {
                let n = 1usize << m;
                let pts: Vec<[f32; 7]> = (0..n as u32).map(|s| sobol_sample(pixel, s)).collect();
                for d in 0..7 {
                    let mut seen = vec![false; n];
                    for p in &pts {
                        seen[(p[d] * n as f32) as usize] = true;
                    }
                    assert!(
                        seen.iter().all(|&b| b),
                        "pixel {pixel}, 2^{m}, dimension {d}"
                    );
                }
                for (a, b, t) in [(0, 1, 0), (3, 4, 3), (5, 6, 3)] {
                    let t = t.min(m);
                    for j in 0..=m - t {
                        let (nx, ny) = (1usize << j, 1usize << (m - t - j));
                        let mut count = vec![0usize; nx * ny];
                        for p in &pts {
                            let (x, y) = ((p[a] * nx as f32) as usize, (p[b] * ny as f32) as usize);
                            count[y * nx + x] += 1;
                        }
                        assert!(
                            count.iter().all(|&c| c == 1 << t),
                            "pixel {pixel}, 2^{m}, dimensions {a}, {b}, boxes {nx}×{ny}: {count:?}"
                        );
                    }
                }
            }
        }
    }

    /// The unscrambled points are Joe & Kuo's Sobol' sequence: scipy 1.x's
    /// `qmc.Sobol(7, scramble=False, bits=32)` (new-joe-kuo-6.21201) gives the same set of the
    /// first 2^16 points (checked once, 2026-12-05); two of them here. A wrong initial
    /// direction number that still makes nets (m = (1, 1, 3, 1) for dimension 5) fails this.
    #[test]
    fn sobol_points_are_joe_kuo() {
        let want: [(u32, [u32; 7]); 2] = [
            (
                65535,
                [
                    0xffff0000, 0x10000, 0xb0ff0000, 0x42f30000, 0xc3050000, 0x81110000, 0x8cad0000,
                ],
            ),
            (
                43690,
                [
                    0x55550000, 0x30000, 0x50990000, 0xc3990000, 0x410f0000, 0x9fef0000, 0x54330000,
                ],
            ),
        ];
        for (i, point) in want {
            for (d, &x) in point.iter().enumerate() {
                assert_eq!(sobol_dim(i, d as u32), x, "point {i}, dimension {d}");
            }
        }
    }

    /// The kernel's Sobol' code is the host's (rng.glsl `sobol_point`, `sobol_next`,
    /// `owen_scramble` and the keys): the direction numbers of bits 0–15, the windows of bits
    /// 12–15 that the recurrence starts from, the recurrence's loop over bits 16 and up with
    /// each dimension's degree and coefficients in its place, the recurrence itself, the
    /// scramble's multipliers and the keys. The kernel's own net test cannot see bits 16 and up
    /// (tests/closed_form.rs), so this pins them. Changing any constant or line fails it.
    #[test]
    fn sobol_constants_match_the_kernel() {
        let glsl = include_str!("../shaders/shared/rng.glsl").replace("\r\n", "\n");
        let has = |text: &str| assert!(glsl.contains(text), "rng.glsl lacks:\n{text}");
        let v = |b: u32, d: u32| format!("{:#010x}u", sobol_dim(1 << b, d));
        for b in 0..16 {
            has(&format!(
                "    bit = (i >> {b}u) & 1u;\n    lo.yzw ^= bit * uvec3({}, {}, {});\n    \
                 hi.xyz ^= bit * uvec3({}, {}, {});",
                v(b, 1),
                v(b, 2),
                v(b, 3),
                v(b, 4),
                v(b, 5),
                v(b, 6)
            ));
        }
        let mut tail = String::from("    if (i >= 65536u) {\n");
        for d in 1..=6 {
            tail += &format!(
                "        uvec4 r{d} = uvec4({}, {}, {}, {});\n",
                v(15, d),
                v(14, d),
                v(13, d),
                v(12, d)
            );
        }
        let next = |d: usize| {
            let (deg, a, _) = SOBOL_PARAMS[d - 1];
            format!("sobol_next(r{d}, {deg}u, {a}u)")
        };
        tail += &format!(
            "        uint b = 16u;\n        do {{\n            \
             uvec3 v = uvec3({}, {}, {});\n            uvec3 w = uvec3({}, {}, {});\n            \
             bit = (i >> b) & 1u;\n            lo.yzw ^= bit * v;\n            \
             hi.xyz ^= bit * w;\n            ++b;\n        }} while (b < 32u && (i >> b) != 0u);",
            next(1),
            next(2),
            next(3),
            next(4),
            next(5),
            next(6)
        );
        has(&tail);
        has(
            "    uint vs = r[deg - 1u];\n    uint v = vs ^ (vs >> deg);\n    \
             for (uint k = 1u; k < deg; ++k) {\n        \
             if (((a >> (deg - 1u - k)) & 1u) != 0u) v ^= r[k - 1u];\n    }\n    \
             r = uvec4(v, r.xyz);\n    return v;",
        );
        has("    lo = uvec4(bitfieldReverse(i), 0u, 0u, 0u);");
        let muls: Vec<String> = OWEN_MUL
            .iter()
            .map(|m| format!("    x ^= x * {m:#010x}u;"))
            .collect();
        has(&format!(
            "    x = bitfieldReverse(x);\n    x += seed;\n{}\n    return bitfieldReverse(x);",
            muls.join("\n")
        ));
        has(&format!(
            "hash32(seed ^ hash32(pixel ^ {JITTER_KEY_X:#010x}u))"
        ));
        has(&format!("hash32(kx ^ {JITTER_KEY_Y:#010x}u)"));
        has(&format!(
            "hash32(seed ^ hash32(pixel ^ hash32(k ^ {VERTEX_KEY:#010x}u)))"
        ));
        has(
            "    uint x = k == 0u ? sobol_lo.z : (k == 1u ? sobol_lo.w : (k == 2u ? sobol_hi.x : \
             (k == 3u ? sobol_hi.y : sobol_hi.z)));",
        );
    }
}
