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
