//! The light list as the kernels see it, and the light-selection pmfs of the non-learning
//! samplers (`uniform`, `power`; `lightbvh` in [`tree`]).

pub mod bounds;
pub mod grid;
pub mod regions;
pub mod tree;

use crate::abi::{
    AliasEntry, GpuLight, LIGHT_POINT, LIGHT_SPOT, LIGHT_TEXTURED, LIGHT_TRIANGLE, LIGHT_TWO_SIDED,
};
use crate::scene::{Light, Scene};

/// The GPU form of every light, in `Scene::lights` order.
pub fn gpu_lights(scene: &Scene) -> Vec<GpuLight> {
    scene
        .lights
        .iter()
        .map(|l| match *l {
            Light::Point {
                position,
                intensity,
            } => GpuLight {
                p0: position.to_array(),
                kind: LIGHT_POINT,
                radiance: intensity.to_array(),
                ..Default::default()
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => GpuLight {
                p0: position.to_array(),
                kind: LIGHT_SPOT,
                p1: direction.to_array(),
                cos_outer,
                cos_inner,
                radiance: intensity.to_array(),
                ..Default::default()
            },
            Light::Triangle { triangle } => {
                let [a, b, c] = scene.triangles[triangle as usize];
                let (emission, two) = scene.triangle_emission(triangle);
                let m = &scene.materials[scene.triangle_material[triangle as usize] as usize];
                // The texture only where the triangle has coordinates to read it by.
                let texture = m
                    .emissive_texture
                    .filter(|_| (triangle as usize) < scene.triangle_uv.len());
                GpuLight {
                    p0: a.to_array(),
                    kind: LIGHT_TRIANGLE
                        | if two { LIGHT_TWO_SIDED } else { 0 }
                        | if texture.is_some() { LIGHT_TEXTURED } else { 0 },
                    p1: b.to_array(),
                    cos_outer: f32::from_bits(if texture.is_some() { triangle } else { 0 }),
                    p2: c.to_array(),
                    cos_inner: f32::from_bits(texture.unwrap_or(0)),
                    radiance: emission.to_array(),
                    area: 0.5 * (b - a).cross(c - a).length(),
                }
            }
        })
        .collect()
}

/// Walker/Vose alias table for picking light i with probability weights[i] / Σ weights.
/// Built in f64 so that the stored `q` values are as exact as f32 allows.
pub fn alias_table(weights: &[f64]) -> Vec<AliasEntry> {
    let n = weights.len();
    let total: f64 = weights.iter().sum();
    assert!(n > 0 && total > 0.0, "alias table needs positive weights");
    let mut scaled: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
    let mut table: Vec<AliasEntry> = weights
        .iter()
        .enumerate()
        .map(|(i, w)| AliasEntry {
            q: 1.0,
            alias: i as u32,
            pmf: (w / total) as f32,
            pad: 0,
        })
        .collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
        table[s].q = scaled[s] as f32;
        table[s].alias = l as u32;
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // Whatever is left has scaled weight 1 up to rounding: keep it always.
    table
}

/// The factor (a power of two, so scaling by it is exact), for lights of powers `weights`
/// ([`power_weights`]), that the kernels' emission is
/// multiplied by, and the images divided by: 1 for scenes whose lights emit 2^-20..2^40 W
/// in total (every committed scene), else what brings the total to about 1 W. Without it
/// the squared observations of `bayes` overflowed f32 from about 1e20 W (measured on
/// cornell with emissiveStrength and point intensities × 1e20: 2416 of 12288 samples NaN).
pub fn emission_scale(weights: &[f64]) -> f32 {
    let total: f64 = weights.iter().sum();
    if !(total > 0.0 && total.is_finite()) || (2f64.powi(-20)..=2f64.powi(40)).contains(&total) {
        return 1.0;
    }
    2f32.powi(-(total.log2().round() as i32).clamp(-120, 120))
}

/// Light-selection weights of the `power` sampler: emitted power as luminance.
pub fn power_weights(scene: &Scene) -> Vec<f64> {
    scene
        .lights
        .iter()
        .map(|l| scene.light_power(l) as f64)
        .collect()
}

/// The probability that the alias table returns each entry (what sampling really does,
/// for tests).
pub fn alias_pmf(table: &[AliasEntry]) -> Vec<f64> {
    let n = table.len() as f64;
    let mut p = vec![0.0; table.len()];
    for (i, e) in table.iter().enumerate() {
        p[i] += e.q as f64 / n;
        p[e.alias as usize] += (1.0 - e.q as f64) / n;
    }
    p
}

/// For every scene triangle the index of its light (emissive triangles), `u32::MAX` for the
/// others: what a BSDF-sampled ray that hits an emitter needs to ask for its light pmf.
pub fn triangle_lights(scene: &Scene) -> Vec<u32> {
    let mut out = vec![u32::MAX; scene.triangles.len()];
    for (i, l) in scene.lights.iter().enumerate() {
        if let Light::Triangle { triangle } = l {
            out[*triangle as usize] = i as u32;
        }
    }
    out
}

/// How the next-event sample draws a point on a triangle light (`--light-point`). Point and
/// spot lights have one point either way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightPoint {
    /// Uniformly by area (density r² / (A cos θ_y) per steradian).
    #[default]
    Area,
    /// Uniformly by solid angle over the spherical triangle (Arvo 1995) where its solid angle
    /// is between 3e-4 and 6 sr, by area elsewhere (shaders/shared/lights.glsl): no variance
    /// from 1/r² and cos θ_y across the light.
    SolidAngle,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alias_table_realises_the_weights() {
        let w = [1.0, 1e-6, 3.0, 0.5, 7.0, 1e3, 2.0];
        let t = alias_table(&w);
        let total: f64 = w.iter().sum();
        for (i, p) in alias_pmf(&t).iter().enumerate() {
            let want = w[i] / total;
            assert!(
                (p - want).abs() <= 1e-6 * want + 1e-9,
                "light {i}: {p} vs {want}"
            );
            assert!(*p > 0.0, "every light keeps a non-zero probability");
            assert!((t[i].pmf as f64 - want).abs() <= 1e-6 * want);
        }
    }
}
