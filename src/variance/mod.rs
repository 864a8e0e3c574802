//! Where a light sampler's variance comes from (`lightlearn variance`, issue #17).
//!
//! One next-event sample at a shading point x picks a cluster C (P_C), a light l in it
//! (P(l|C); P_l = P_C P(l|C)) and a point y on l (p(y|l)), and returns F = f/(P_l p(y|l)).
//! With m_l = E[F P_l | l] (light l's exact contribution) and s_l = E[(F P_l)² | l], the law
//! of total variance splits Var[F | x] = Σ_l s_l/P_l − I² (I = Σ_l m_l) into closed sums:
//!
//! - cluster choice: Σ_C m_C²/P_C − I² (m_C = Σ_{l∈C} m_l);
//! - the light inside the cluster: Σ_l m_l²/P_l − Σ_C m_C²/P_C;
//! - the point on the light: Σ_l (s_l − m_l²)/P_l (0 for point and spot lights);
//!
//! and a pixel adds the footprint (jitter): the variance over the pixel of x's value. The m_l
//! and s_l come from many shadow rays at fixed first hits ([`crate::reference::light_samples`]);
//! the squares of their estimates are corrected for the estimates' own noise, so every term is
//! an unbiased estimate. The pmfs are the CPU mirrors of the kernels' samplers (tested
//! against the GPU in tests/regions.rs, tests/learning/pmfs.rs and tests/light_tree.rs), evaluated
//! on the statistics a session's passes sampled by.
//!
//! Plain data: no device. The command (src/commands/variance.rs) drives the sessions.

use glam::Vec3;

use crate::abi::SlotStats;
use crate::accel::Bvh;
use crate::learning::{learned_weights, LearnSettings};
use crate::lights::regions::{pmf_in_cut, slot_of, Cuts};
use crate::lights::tree::LightTree;
use crate::reference::{light_samples, Hit};
use crate::rng::SplitMix64;
use crate::scene::{luminance, Scene};

/// One light's share of a hit: luminance, BRDF included, selection pmf not.
#[derive(Clone, Copy, Debug)]
pub struct LightTerm {
    pub light: u32,
    /// m_l: the mean of the one-sample estimate f/p(y|l).
    pub mean: f64,
    /// s_l: its mean square.
    pub second: f64,
    /// The variance of `mean` as an estimate (0 for point and spot lights: exact).
    pub noise: f64,
    /// The chance that one sample of this light is not 0.
    pub nonzero: f64,
}

/// A fixed first hit with every light that can give it anything.
#[derive(Clone, Debug)]
pub struct HitTerms {
    pub p: Vec3,
    pub n: Vec3,
    /// Emitted luminance seen by the camera at the hit.
    pub emission: f64,
    /// Lights with at least one non-zero sample (the others add nothing to any term).
    pub lights: Vec<LightTerm>,
}

impl HitTerms {
    /// I: the hit's exact direct light.
    pub fn direct(&self) -> f64 {
        self.lights.iter().map(|t| t.mean).sum()
    }

    /// The variance of [`HitTerms::direct`] as an estimate.
    pub fn noise(&self) -> f64 {
        self.lights.iter().map(|t| t.noise).sum()
    }
}

/// The terms of every light at `hit`: `area_samples` uniform points per triangle light,
/// point and spot lights exact.
pub fn hit_terms(
    scene: &Scene,
    bvh: &Bvh,
    hit: &Hit,
    area_samples: u32,
    rng: &mut SplitMix64,
) -> HitTerms {
    let mut lights = Vec::new();
    for l in 0..scene.lights.len() {
        let s = light_samples(scene, bvh, hit, l, area_samples, rng);
        if s.zeros == s.count {
            continue;
        }
        let k = s.count as f64;
        let mean = luminance(hit.brdf * s.sum) as f64 / k;
        let second = s.sum_sq_lum / k;
        // Var of the mean of k samples, estimated without bias: (s − m²)/(k − 1).
        let noise = if s.count > 1 {
            ((second - mean * mean) / (k - 1.0)).max(0.0)
        } else {
            0.0
        };
        lights.push(LightTerm {
            light: l as u32,
            mean,
            second,
            noise,
            nonzero: (s.count - s.zeros) as f64 / k,
        });
    }
    HitTerms {
        p: hit.x,
        n: hit.n,
        emission: luminance(hit.emission) as f64,
        lights,
    }
}

/// A sampler's light-selection pmf, as its kernel computes it.
pub enum Selection<'a> {
    Uniform {
        count: u32,
    },
    /// pmf of every light (the alias table's).
    Power {
        pmf: Vec<f64>,
    },
    LightBvh {
        tree: &'a LightTree,
    },
    /// `wang` (learned: None) or a learned sampler with the statistics it samples by.
    Cuts {
        tree: &'a LightTree,
        cuts: &'a Cuts,
        learned: Option<Learned<'a>>,
    },
}

pub struct Learned<'a> {
    pub stats: &'a [SlotStats],
    pub settings: &'a LearnSettings,
    pub donikian: bool,
}

/// One light's selection: P_l and the slot (cluster) it is chosen through.
#[derive(Clone, Copy, Debug)]
struct Choice {
    pmf: f64,
    /// P_C of its cluster; `None`: the sampler has no clusters.
    cluster: Option<(usize, f64)>,
}

impl Selection<'_> {
    fn choices(&self, p: Vec3, n: Vec3, lights: &[LightTerm]) -> Vec<Choice> {
        let flat = |pmf: f64| Choice { pmf, cluster: None };
        match self {
            Selection::Uniform { count } => {
                lights.iter().map(|_| flat(1.0 / *count as f64)).collect()
            }
            Selection::Power { pmf } => {
                lights.iter().map(|t| flat(pmf[t.light as usize])).collect()
            }
            Selection::LightBvh { tree } => lights
                .iter()
                .map(|t| flat(tree.pmf(p, n, t.light) as f64))
                .collect(),
            Selection::Cuts {
                tree,
                cuts,
                learned,
            } => {
                let o = cuts.offset_at(p, n);
                let cut = cuts.cut_at(p, n);
                let w = match learned {
                    None => Cuts::importances(tree, cut, p, n),
                    Some(l) => learned_weights(
                        tree, &cuts.cuts, o, l.stats, p, n, l.donikian, l.settings, 1.0,
                    ),
                };
                let total: f32 = w.iter().sum();
                let inside = cuts.inside(p, n);
                lights
                    .iter()
                    .map(|t| {
                        let pmf = pmf_in_cut(tree, cut, &w, t.light, inside) as f64;
                        let cluster = slot_of(tree, cut, t.light).map(|k| {
                            (
                                k,
                                if total > 0.0 {
                                    (w[k] / total) as f64
                                } else {
                                    0.0
                                },
                            )
                        });
                        Choice { pmf, cluster }
                    })
                    .collect()
            }
        }
    }
}

/// The variance of one next-event sample at a fixed hit, by stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Terms {
    pub cluster: f64,
    /// The light inside its cluster (samplers without clusters: the whole light choice).
    pub light: f64,
    pub point: f64,
    /// Direct light from lights the sampler can never pick (a bias: should be 0).
    pub missed: f64,
    /// The chance that the sample is 0 (no light chosen, or the chosen one gives 0).
    pub zero: f64,
}

impl Terms {
    pub fn total(&self) -> f64 {
        self.cluster + self.light + self.point
    }
}

/// The closed sums of the module comment at one hit, each corrected for the noise of the
/// m_l estimates (E[m̂²] = m² + noise), so each is an unbiased estimate of its term.
pub fn decompose(hit: &HitTerms, sel: &Selection) -> Terms {
    decompose_choices(hit, &sel.choices(hit.p, hit.n, &hit.lights))
}

fn decompose_choices(hit: &HitTerms, choices: &[Choice]) -> Terms {
    let mut t = Terms::default();
    let (mut i, mut i_noise) = (0.0, 0.0);
    let (mut by_light, mut second, mut nonzero) = (0.0, 0.0, 0.0);
    // (P_C, Σ m, Σ noise) per cluster, in the order met.
    let mut clusters: Vec<(usize, f64, f64, f64)> = Vec::new();
    let mut flat = true;
    for (lt, c) in hit.lights.iter().zip(choices) {
        if c.pmf <= 0.0 || c.pmf.is_nan() {
            t.missed += lt.mean;
            continue;
        }
        i += lt.mean;
        i_noise += lt.noise;
        by_light += (lt.mean * lt.mean - lt.noise) / c.pmf;
        second += lt.second / c.pmf;
        nonzero += c.pmf * lt.nonzero;
        if let Some((k, pc)) = c.cluster {
            flat = false;
            match clusters.iter_mut().find(|e| e.0 == k) {
                Some(e) => {
                    e.2 += lt.mean;
                    e.3 += lt.noise;
                }
                None => clusters.push((k, pc, lt.mean, lt.noise)),
            }
        }
    }
    let i2 = i * i - i_noise;
    let by_cluster = if flat {
        i2
    } else {
        clusters.iter().map(|&(_, pc, m, v)| (m * m - v) / pc).sum()
    };
    t.cluster = by_cluster - i2;
    t.light = by_light - by_cluster;
    t.point = second - by_light;
    t.zero = (1.0 - nonzero).max(0.0);
    t
}

/// A pixel's variance per sample by stage: the mean of its hits' [`Terms`] plus the
/// footprint, the variance of the hits' values (emission + direct light) over the pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelTerms {
    pub cluster: f64,
    pub light: f64,
    pub point: f64,
    pub jitter: f64,
    /// The part of `jitter` at pixels where some hit sees an emitter.
    pub jitter_emitter: f64,
    pub missed: f64,
    /// Hits that some light reaches, and the mean chance of a zero sample over them.
    pub lit_hits: u32,
    pub zero_lit: f64,
    /// Hits (of the camera rays, misses counted as dark) that no light reaches.
    pub dark_hits: u32,
    pub hits: u32,
    /// The pixel's value: the mean over its hits.
    pub value: f64,
}

impl PixelTerms {
    pub fn total(&self) -> f64 {
        self.cluster + self.light + self.point + self.jitter
    }

    /// Adds `w` × `o`'s variances, value and zero chance (a weighted mean over the
    /// checkpoints of a learning sampler); the counts are `o`'s.
    pub fn mix(&mut self, o: &PixelTerms, w: f64) {
        self.cluster += w * o.cluster;
        self.light += w * o.light;
        self.point += w * o.point;
        self.jitter += w * o.jitter;
        self.jitter_emitter += w * o.jitter_emitter;
        self.missed += w * o.missed;
        self.zero_lit += w * o.zero_lit;
        self.value += w * o.value;
        self.lit_hits = o.lit_hits;
        self.dark_hits = o.dark_hits;
        self.hits = o.hits;
    }

    /// Sums pixels (the zero chance as a mean over lit hits).
    pub fn add(&mut self, o: &PixelTerms) {
        self.cluster += o.cluster;
        self.light += o.light;
        self.point += o.point;
        self.jitter += o.jitter;
        self.jitter_emitter += o.jitter_emitter;
        self.missed += o.missed;
        let lit = self.lit_hits + o.lit_hits;
        if lit > 0 {
            self.zero_lit = (self.zero_lit * self.lit_hits as f64 + o.zero_lit * o.lit_hits as f64)
                / lit as f64;
        }
        self.lit_hits = lit;
        self.dark_hits += o.dark_hits;
        self.hits += o.hits;
        self.value += o.value;
    }
}

/// Combines the jittered hits of one pixel (None: the ray left the scene) under `sel`.
pub fn pixel_terms(hits: &[Option<HitTerms>], sel: &Selection) -> PixelTerms {
    let mut px = PixelTerms {
        hits: hits.len() as u32,
        ..Default::default()
    };
    let j = hits.len() as f64;
    let (mut sum, mut sum_sq, mut noise) = (0.0, 0.0, 0.0);
    let mut emitter = false;
    for h in hits {
        let Some(h) = h else {
            px.dark_hits += 1;
            continue;
        };
        let v = h.emission + h.direct();
        emitter |= h.emission > 0.0;
        sum += v;
        sum_sq += v * v;
        noise += h.noise();
        if h.lights.is_empty() {
            px.dark_hits += 1;
            continue;
        }
        let t = decompose(h, sel);
        px.cluster += t.cluster / j;
        px.light += t.light / j;
        px.point += t.point / j;
        px.missed += t.missed / j;
        px.zero_lit += t.zero;
        px.lit_hits += 1;
    }
    if px.lit_hits > 0 {
        px.zero_lit /= px.lit_hits as f64;
    }
    px.value = sum / j;
    if hits.len() > 1 {
        // The sample variance of the hits' values, less the part their estimates' own noise
        // adds to it (each value's noise, averaged).
        px.jitter = (sum_sq - sum * sum / j) / (j - 1.0) - noise / j;
        if emitter {
            px.jitter_emitter = px.jitter;
        }
    }
    px
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(light: u32, mean: f64, second: f64) -> LightTerm {
        LightTerm {
            light,
            mean,
            second,
            noise: 0.0,
            nonzero: 1.0,
        }
    }

    /// Uniform choice of two point lights of 1 and 3: F is 2 or 6 with chance ½ each, so
    /// Var = E[F²] − 4² = (4 + 36)/2 − 16 = 4, all of it the light choice.
    #[test]
    fn uniform_choice_of_two_point_lights() {
        let h = HitTerms {
            p: Vec3::ZERO,
            n: Vec3::Z,
            emission: 0.0,
            lights: vec![term(0, 1.0, 1.0), term(1, 3.0, 9.0)],
        };
        let t = decompose(&h, &Selection::Uniform { count: 2 });
        assert!((t.light - 4.0).abs() < 1e-12, "{t:?}");
        assert_eq!((t.cluster, t.point, t.missed, t.zero), (0.0, 0.0, 0.0, 0.0));
    }

    /// A light with mean 2 whose samples are 0 or 4 (second moment 8) picked surely: all the
    /// variance, 8 − 4, is the point on the light; half the samples are zero.
    #[test]
    fn the_point_on_an_area_light() {
        let mut l = term(0, 2.0, 8.0);
        l.nonzero = 0.5;
        let h = HitTerms {
            p: Vec3::ZERO,
            n: Vec3::Z,
            emission: 0.0,
            lights: vec![l],
        };
        let t = decompose(&h, &Selection::Uniform { count: 1 });
        assert!(
            (t.point - 4.0).abs() < 1e-12 && t.light.abs() < 1e-12,
            "{t:?}"
        );
        assert!((t.zero - 0.5).abs() < 1e-12);
    }

    /// Two clusters: A = {l0: m 1, l1: m 3} with P_A ½ and P(l|A) ½ each, B = {l2: m 2, an
    /// area light with s 8} with P_B ½. I = 6; Σ_C m_C²/P_C = 16/½ + 4/½ = 40, so the cluster
    /// term is 40 − 36 = 4; Σ_l m_l²/P_l = 1/¼ + 9/¼ + 4/½ = 48, the light term 48 − 40 = 8;
    /// Σ_l s_l/P_l = 48 − 8 + 16 = 56, the point term 56 − 48 = 8. A fourth light with
    /// pmf 0 is missed (bias), not counted in any term.
    #[test]
    fn two_clusters_by_hand() {
        let h = HitTerms {
            p: Vec3::ZERO,
            n: Vec3::Z,
            emission: 0.0,
            lights: vec![
                term(0, 1.0, 1.0),
                term(1, 3.0, 9.0),
                term(2, 2.0, 8.0),
                term(3, 0.5, 0.25),
            ],
        };
        let c = |pmf: f64, k: usize| Choice {
            pmf,
            cluster: Some((k, 0.5)),
        };
        let t = decompose_choices(&h, &[c(0.25, 0), c(0.25, 0), c(0.5, 1), c(0.0, 2)]);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(
            close(t.cluster, 4.0) && close(t.light, 8.0) && close(t.point, 8.0),
            "{t:?}"
        );
        assert!(close(t.missed, 0.5) && close(t.total(), 20.0));
        // The noise of an estimated m_l comes off its square: m 2 ± noise 1 gives m² − 1.
        let mut noisy = h.clone();
        noisy.lights[2].noise = 1.0;
        let u = decompose_choices(&noisy, &[c(0.25, 0), c(0.25, 0), c(0.5, 1), c(0.0, 2)]);
        // Σ m_C²/P_C − I² loses 1/½ − 1, Σ m_l²/P_l loses 1/½.
        assert!(
            close(u.cluster, 4.0 - 2.0 + 1.0) && close(u.light, 8.0) && close(u.point, 8.0 + 2.0),
            "{u:?}"
        );
    }

    /// Jitter: two hits of values 1 and 3 (exact) in a pixel: sample variance 2; a missed
    /// ray counts as a dark hit of value 0.
    #[test]
    fn footprint_is_the_variance_over_the_pixel() {
        let hit = |m: f64| {
            Some(HitTerms {
                p: Vec3::ZERO,
                n: Vec3::Z,
                emission: 0.0,
                lights: vec![term(0, m, m * m)],
            })
        };
        let px = pixel_terms(&[hit(1.0), hit(3.0)], &Selection::Uniform { count: 1 });
        assert!(
            (px.jitter - 2.0).abs() < 1e-12 && px.total() - 2.0 < 1e-12,
            "{px:?}"
        );
        let px = pixel_terms(&[hit(2.0), None], &Selection::Uniform { count: 1 });
        assert_eq!((px.dark_hits, px.lit_hits), (1, 1));
        assert!((px.jitter - 2.0).abs() < 1e-12 && (px.value - 1.0).abs() < 1e-12);
    }
}
