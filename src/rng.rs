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

/// The point in the pixel of sample `s` when jitter is stratified (mirror of
/// `pixel_jitter_r2` in rng.glsl): the R2 sequence in 32-bit fixed point, rotated per pixel.
pub fn pixel_jitter_r2(seed: u32, pixel: u32, s: u32) -> [f32; 2] {
    let ox = hash32(seed ^ hash32(pixel ^ 0x68bc_21eb));
    let oy = hash32(ox ^ 0x02e5_be93);
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
    let o = hash32(seed ^ hash32(pixel ^ hash32(k ^ 0xa511_e9b3)));
    let x = s.wrapping_mul(R5_STEP[k as usize]).wrapping_add(o);
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
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
}
