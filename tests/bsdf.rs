//! The material BRDF (shaders/shared/bsdf.glsl, run through `bsdf.comp`):
//! - it is the documented formula (an f64 implementation written here from glTF 2.0's
//!   Appendix B and KHR_materials_specular, with bsdf.glsl's energy-conserving diffuse
//!   coupling by the layer's albedo in place of the specification's 1 − F(v·h)), reciprocal,
//!   and close to the specification for rough dielectrics;
//! - `bsdf_sample` draws directions with exactly the density `bsdf_pdf` reports (χ² test
//!   of a 16 × 16 histogram over the hemisphere, with a check that a 20 % wrong roughness is
//!   rejected), so MIS weights and path throughputs are right;
//! - energy: the directional albedo ∫ f cos dω is ≤ 1 for every material and angle, the two
//!   estimators of it (BRDF sampling, uniform directions) agree, a white metal of low
//!   roughness reflects almost everything, and a Lambertian material is exactly base / π.

mod common;

use std::f64::consts::PI;
use std::sync::{Arc, OnceLock};

use glam::{DVec3, Vec3};
use lightlearn::gpu::layout::{BsdfQuery, BsdfResult, GpuMaterial};
use lightlearn::gpu::{Buffer, ComputePipeline, Context};
use lightlearn::layer_albedo::{self, LayerAlbedo};
use lightlearn::rng::SplitMix64;

fn material(
    base: Vec3,
    metallic: f32,
    roughness: f32,
    specular: f32,
    specular_color: Vec3,
) -> GpuMaterial {
    GpuMaterial {
        base_color: base.to_array(),
        flags: 0,
        emission: [0.0; 3],
        texture: u32::MAX,
        specular_color: specular_color.to_array(),
        specular,
        metallic,
        roughness,
        emissive_texture: u32::MAX,
        metallic_roughness_texture: u32::MAX,
        normal_texture: u32::MAX,
        normal_scale: 1.0,
        alpha_cutoff: 0.0,
        alpha: 1.0,
    }
}

fn metal(base: f32, roughness: f32) -> GpuMaterial {
    material(Vec3::splat(base), 1.0, roughness, 1.0, Vec3::ONE)
}

fn dielectric(base: Vec3, roughness: f32) -> GpuMaterial {
    material(base, 0.0, roughness, 1.0, Vec3::ONE)
}

struct Kernel {
    ctx: Arc<Context>,
    pipeline: ComputePipeline,
}

impl Kernel {
    fn new() -> Kernel {
        let ctx = common::ctx();
        let pipeline =
            ComputePipeline::new(&ctx, "bsdf", lightlearn::gpu::kernels::BSDF, 3, 4, &[]).unwrap();
        Kernel { ctx, pipeline }
    }

    fn run(&self, q: &[BsdfQuery]) -> Vec<BsdfResult> {
        let qb = Buffer::from_slice(&self.ctx, "bsdf queries", q).unwrap();
        let rb = Buffer::zeroed(
            &self.ctx,
            "bsdf results",
            std::mem::size_of_val(q) as u64 / std::mem::size_of::<BsdfQuery>() as u64
                * std::mem::size_of::<BsdfResult>() as u64,
        )
        .unwrap();
        let table = Buffer::texels(
            &self.ctx,
            "layer albedo table",
            &layer_albedo::committed().texels(),
        )
        .unwrap();
        self.pipeline.bind(&[&qb, &rb, &table]).unwrap();
        let count = q.len() as u32;
        self.ctx
            .submit(|cmd| {
                self.pipeline
                    .dispatch(cmd, bytemuck::bytes_of(&count), [count.div_ceil(64), 1, 1])
            })
            .unwrap();
        let out: Vec<BsdfResult> = rb.read().unwrap();
        out[..q.len()].to_vec()
    }
}

/// A query with normal +z, viewing direction at cos θ = `cos_v` (φ = 0).
fn query(m: GpuMaterial, cos_v: f64, l: DVec3, u: (f32, f32)) -> BsdfQuery {
    let v = hemisphere(cos_v, 0.0);
    BsdfQuery {
        n: [0.0, 0.0, 1.0],
        u0: u.0,
        v: v.as_vec3().to_array(),
        u1: u.1,
        l: l.as_vec3().to_array(),
        pad: 0.0,
        material: m,
    }
}

/// The direction at cos θ = c and azimuth φ about +z.
fn hemisphere(c: f64, phi: f64) -> DVec3 {
    let s = (1.0 - c * c).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), c)
}

/// The layer albedo tables the kernel's constants hold (src/layer_albedo.rs).
fn layer_table() -> &'static LayerAlbedo {
    static T: OnceLock<LayerAlbedo> = OnceLock::new();
    T.get_or_init(layer_albedo::committed)
}

/// The committed tables (`src/layer_albedo_data.rs`, what the kernels get) are the
/// generator's output: a change of one without the other would make the kernel and this
/// file's formula part ways.
#[test]
fn the_layer_albedo_tables_are_the_generators_output() {
    let fresh = layer_albedo::table();
    assert!(
        fresh == layer_albedo::committed(),
        "src/layer_albedo_data.rs is not src/layer_albedo.rs's output: write `layer_albedo::rust_source(&layer_albedo::table())` to it"
    );
    assert_eq!(
        layer_albedo::rust_source(&fresh),
        include_str!("../src/layer_albedo_data.rs")
    );
}

/// The glTF metallic-roughness BRDF, f64, from the specification (Appendix B) with
/// KHR_materials_specular, height-correlated Smith visibility, α = max(roughness², 1e-3), and
/// the diffuse base weighted by (1 − K(n·v)) (1 − K(n·l)) / (1 − K_avg), K what the layer
/// keeps: its directional albedo and its multiple scattering (src/layer_albedo.rs and
/// bsdf.glsl say why).
fn gltf_brdf(m: &GpuMaterial, n: DVec3, v: DVec3, l: DVec3) -> DVec3 {
    let (nv, nl) = (n.dot(v), n.dot(l));
    if nv <= 0.0 || nl <= 0.0 {
        return DVec3::ZERO;
    }
    let a = (m.roughness as f64).powi(2).max(1e-3);
    let a2 = a * a;
    let h = (v + l).normalize();
    let nh = n.dot(h);
    let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let lambda = |c: f64| ((1.0 + a2 * (1.0 - c * c) / (c * c)).sqrt() - 1.0) / 2.0;
    let vis = 1.0 / (1.0 + lambda(nv) + lambda(nl)) / (4.0 * nv * nl);
    let s = d * vis;
    let w = (1.0 - v.dot(h).abs()).powi(5);
    let base = Vec3::from(m.base_color).as_dvec3();
    let f0 = (0.04 * Vec3::from(m.specular_color).as_dvec3()).min(DVec3::ONE);
    let fd = f0 + (DVec3::ONE - f0) * w;
    let fm = base + (DVec3::ONE - base) * w;
    let spec = m.specular as f64;
    let f0m = f0.max_element();
    let t = layer_table();
    // What the layer keeps: its albedo E and its multiple scattering (bsdf.glsl layer_kept).
    let (am, as_) = t.lookup_avg(a);
    let f_avg = spec * (f0m + (1.0 - f0m) / 21.0);
    let f_ms = f_avg * f_avg * am / (1.0 - f_avg * (1.0 - am)).max(1e-6);
    let kept = |(mm, ss): (f64, f64)| spec * (f0m * mm + (1.0 - f0m) * ss) + (1.0 - mm) * f_ms;
    let wf = |c: f64| kept(t.lookup(c, a));
    let w_avg = kept((am, as_));
    // The quotient's limit as f0 → 1 under a full-strength, smooth layer is 0 (bsdf.glsl).
    let coupling = if w_avg < 1.0 - 1e-6 {
        (1.0 - wf(nv)) * (1.0 - wf(nl)) / (1.0 - w_avg)
    } else {
        0.0
    };
    let dielectric = coupling * base / PI + spec * fd * s;
    let metallic = m.metallic as f64;
    dielectric * (1.0 - metallic) + fm * s * metallic
}

fn random_unit_above(rng: &mut SplitMix64, n: DVec3) -> DVec3 {
    loop {
        let d = DVec3::new(
            rng.range(-1.0, 1.0) as f64,
            rng.range(-1.0, 1.0) as f64,
            rng.range(-1.0, 1.0) as f64,
        );
        let len = d.length();
        if len > 0.05 && len <= 1.0 {
            let d = d / len;
            // Keep off the horizon, where cos → 0 makes f32 and f64 differ by design.
            if d.dot(n) > 0.05 {
                return d;
            }
        }
    }
}

#[test]
fn brdf_is_the_documented_formula_and_reciprocal() {
    let k = Kernel::new();
    let mut rng = SplitMix64(7);
    let mut q = Vec::new();
    let mut cases = Vec::new();
    for i in 0..4000 {
        let base = Vec3::new(rng.f32(), rng.f32(), rng.f32());
        let metallic = match i % 3 {
            0 => 0.0,
            1 => 1.0,
            _ => rng.f32(),
        };
        let mut m = material(
            base,
            metallic,
            rng.range(0.1, 1.0),
            rng.f32(),
            Vec3::new(
                rng.range(0.0, 2.0),
                rng.range(0.0, 2.0),
                rng.range(0.0, 2.0),
            ),
        );
        // KHR_materials_specular allows colour factors past 1: a full-strength layer whose
        // F0 reaches 1 (0.04 × 26) made every value NaN (an audit, 2026-12-06).
        if i % 40 == 7 {
            m.specular = 1.0;
            m.specular_color = [26.0, rng.range(0.0, 30.0), 1.0];
        }
        let n = random_unit_above(&mut rng, DVec3::Z);
        let (v, l) = (
            random_unit_above(&mut rng, n),
            random_unit_above(&mut rng, n),
        );
        for (a, b) in [(v, l), (l, v)] {
            q.push(BsdfQuery {
                n: n.as_vec3().to_array(),
                u0: 0.5,
                v: a.as_vec3().to_array(),
                u1: 0.5,
                l: b.as_vec3().to_array(),
                pad: 0.0,
                material: m,
            });
        }
        cases.push((m, n, v, l));
    }
    let r = k.run(&q);
    let mut worst: f64 = 0.0;
    for (i, (m, n, v, l)) in cases.iter().enumerate() {
        let want = gltf_brdf(m, *n, *v, *l);
        let got = Vec3::from(r[2 * i].f).as_dvec3();
        let back = Vec3::from(r[2 * i + 1].f).as_dvec3();
        let err = (got - want).abs().max_element() / want.max_element().max(1e-3);
        worst = worst.max(err);
        assert!(
            err < 2e-3,
            "case {i}: f = {got} but the formula gives {want} (material {m:?}, n {n}, v {v}, l {l})"
        );
        let rec = (got - back).abs().max_element() / got.max_element().max(1e-3);
        assert!(
            rec < 1e-4,
            "case {i}: f(v, l) = {got} but f(l, v) = {back}: not reciprocal"
        );
    }
    println!("4000 random materials and directions: largest relative difference to the formula {worst:.2e}");
}

/// Against the specification's own dielectric (the diffuse base × (1 − F(v·h)), Appendix B):
/// a rough dielectric, where that form nearly conserves energy, stays close to it. With the
/// macro normal's Fresnel in the coupling it was 0.43× the specification at n·l = 0.1 and
/// 1.05× at normal light (an audit against the formula by hand, 2026-12-07).
#[test]
fn a_rough_dielectric_is_near_the_specification() {
    let k = Kernel::new();
    let base = Vec3::splat(0.8);
    let spec_form = |m: &GpuMaterial, v: DVec3, l: DVec3| {
        // gltf_brdf's layer with the specification's diffuse weight.
        let h = (v + l).normalize();
        let f = 0.04 + 0.96 * (1.0 - v.dot(h)).powi(5);
        let layer_only = gltf_brdf(
            &material(Vec3::ZERO, 0.0, m.roughness, 1.0, Vec3::ONE),
            DVec3::Z,
            v,
            l,
        );
        layer_only + base.as_dvec3() * (1.0 - f) / PI
    };
    let mut q = Vec::new();
    let mut cases = Vec::new();
    for roughness in [0.5f32, 0.8, 1.0] {
        for (cv, cl) in [(1.0, 1.0), (1.0, 0.5), (1.0, 0.1), (0.5, 0.5), (0.3, 0.1)] {
            let m = dielectric(base, roughness);
            let (v, l) = (hemisphere(cv, 0.0), hemisphere(cl, 2.0));
            q.push(query(m, cv, l, (0.5, 0.5)));
            cases.push((m, v, l, roughness, cv, cl));
        }
    }
    let r = k.run(&q);
    for (i, (m, v, l, roughness, cv, cl)) in cases.iter().enumerate() {
        let ours = Vec3::from(r[i].f).as_dvec3().x;
        let want = spec_form(m, *v, *l).x;
        let ratio = ours / want;
        println!("roughness {roughness}, n·v {cv}, n·l {cl}: ours ÷ specification {ratio:.4}");
        // Measured 0.99–1.035 at roughness 1, 0.96–1.03 at 0.8; at 0.5 0.84–1.02, where
        // the specification's form reflects more than arrives at grazing angles.
        let band = if *roughness >= 0.8 {
            0.95..1.04
        } else {
            0.8..1.03
        };
        assert!(
            band.contains(&ratio),
            "roughness {roughness}, n·v {cv}, n·l {cl}: {ours} against the specification's {want} ({ratio:.3}×)"
        );
    }
}

/// The specular lobe is drawn about as often as the layer reflects: its directional albedo
/// at roughness 1, n·v 0.1 is 0.05, and with the macro normal's Fresnel (0.62) the lobe was
/// drawn 62 % of the time (a review, 2026-12-07: variance, not bias); a smooth layer at
/// grazing views still gets its Fresnel share.
#[test]
fn the_lobe_choice_follows_the_layers_albedo() {
    let k = Kernel::new();
    let white = |r: f32| dielectric(Vec3::ONE, r);
    let q = [
        query(white(1.0), 0.1, DVec3::Z, (0.5, 0.5)),
        query(white(0.05), 0.1, DVec3::Z, (0.5, 0.5)),
    ];
    let r = k.run(&q);
    assert!(r[0].p_spec < 0.15, "rough: p_spec {}", r[0].p_spec);
    assert!(r[1].p_spec > 0.5, "smooth: p_spec {}", r[1].p_spec);
}

/// Upper tail of χ² with `k` degrees of freedom as a z-score (Wilson–Hilferty).
fn chi2_z(chi2: f64, k: f64) -> f64 {
    ((chi2 / k).powf(1.0 / 3.0) - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt()
}

const BINS_COS: usize = 16;
const BINS_PHI: usize = 16;
const SUB: usize = 48;

/// The probability of each (cos θ, φ) bin of the hemisphere under `pdf_of` (midpoint rule,
/// SUB × SUB points a bin), as bsdf_pdf evaluated on the GPU for material m seen at cos_v.
fn expected_bins(k: &Kernel, m: GpuMaterial, cos_v: f64) -> Vec<f64> {
    let mut q = Vec::with_capacity(BINS_COS * BINS_PHI * SUB * SUB);
    let (nc, np) = ((BINS_COS * SUB) as f64, (BINS_PHI * SUB) as f64);
    for ci in 0..BINS_COS * SUB {
        for pi in 0..BINS_PHI * SUB {
            let l = hemisphere((ci as f64 + 0.5) / nc, 2.0 * PI * (pi as f64 + 0.5) / np);
            q.push(query(m, cos_v, l, (0.5, 0.5)));
        }
    }
    let r = k.run(&q);
    let cell = (1.0 / nc) * (2.0 * PI / np);
    let mut bins = vec![0.0; BINS_COS * BINS_PHI];
    for ci in 0..BINS_COS * SUB {
        for pi in 0..BINS_PHI * SUB {
            let p = r[ci * BINS_PHI * SUB + pi].pdf as f64;
            bins[(ci / SUB) * BINS_PHI + pi / SUB] += p * cell;
        }
    }
    bins
}

/// χ² z-score of `count` samples from material m at cos_v against the expected bins (plus a
/// bin for samples that left the hemisphere, expected 1 − Σ bins).
fn chi2_of_samples(
    k: &Kernel,
    m: GpuMaterial,
    cos_v: f64,
    expected: &[f64],
    seed: u64,
) -> (f64, f64) {
    let count = 200_000;
    let mut rng = SplitMix64(seed);
    let q: Vec<BsdfQuery> = (0..count)
        .map(|_| query(m, cos_v, DVec3::Z, (rng.f32(), rng.f32())))
        .collect();
    let r = k.run(&q);
    let mut observed = vec![0.0; expected.len() + 1];
    for s in &r {
        let l = Vec3::from(s.sampled).as_dvec3();
        if s.sampled_pdf > 0.0 && l.z > 0.0 {
            let ci = ((l.z * BINS_COS as f64) as usize).min(BINS_COS - 1);
            let phi = l.y.atan2(l.x).rem_euclid(2.0 * PI);
            let pi = ((phi / (2.0 * PI) * BINS_PHI as f64) as usize).min(BINS_PHI - 1);
            observed[ci * BINS_PHI + pi] += 1.0;
        } else {
            observed[expected.len()] += 1.0;
        }
    }
    let mut exp: Vec<f64> = expected.iter().map(|p| p * count as f64).collect();
    exp.push((1.0 - expected.iter().sum::<f64>()).max(0.0) * count as f64);
    // Bins expected to hold < 5 samples are pooled, as the χ² approximation needs.
    let (mut chi2, mut dof, mut pool_o, mut pool_e) = (0.0, 0.0, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&exp) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            chi2 += (o - e).powi(2) / e;
            dof += 1.0;
        }
    }
    if pool_e >= 5.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        dof += 1.0;
    } else if pool_o > 20.0 {
        // Samples where the pdf says there are (almost) none.
        chi2 += 1e6;
    }
    (chi2_z(chi2, dof - 1.0), dof - 1.0)
}

#[test]
fn samples_follow_bsdf_pdf() {
    let k = Kernel::new();
    let cases = [
        ("white metal r 0.3, cos 0.9", metal(1.0, 0.3), 0.9),
        ("white metal r 0.2, cos 0.3", metal(1.0, 0.2), 0.3),
        ("metal r 0.7, cos 0.6", metal(0.5, 0.7), 0.6),
        (
            "dielectric r 0.3, cos 0.7",
            dielectric(Vec3::new(0.6, 0.5, 0.4), 0.3),
            0.7,
        ),
        (
            "dielectric r 0.25, cos 0.15",
            dielectric(Vec3::splat(0.2), 0.25),
            0.15,
        ),
        (
            "half metal r 0.5, cos 0.5",
            material(Vec3::new(0.9, 0.6, 0.3), 0.5, 0.5, 1.0, Vec3::ONE),
            0.5,
        ),
        (
            "lambert, cos 0.4",
            material(Vec3::splat(0.5), 0.0, 0.5, 0.0, Vec3::ONE),
            0.4,
        ),
    ];
    for (i, (name, m, cos_v)) in cases.iter().enumerate() {
        let expected = expected_bins(&k, *m, *cos_v);
        let (z, dof) = chi2_of_samples(&k, *m, *cos_v, &expected, 100 + i as u64);
        println!(
            "{name}: χ² z = {z:.2} ({dof} dof), P(sample leaves the hemisphere) = {:.4}",
            1.0 - expected.iter().sum::<f64>()
        );
        assert!(
            z < 4.0,
            "{name}: bsdf_sample's directions do not follow bsdf_pdf (χ² z = {z:.1})"
        );
    }
    // The test must see a wrong density: samples of roughness 0.3 against the pdf of 0.36.
    let wrong = expected_bins(&k, metal(1.0, 0.36), 0.9);
    let (z, _) = chi2_of_samples(&k, metal(1.0, 0.3), 0.9, &wrong, 99);
    println!("roughness 0.3 samples vs the roughness 0.36 pdf: χ² z = {z:.1} (must be rejected)");
    assert!(
        z > 4.0,
        "the χ² test accepts a 20 % wrong roughness (z = {z:.1}): it cannot fail"
    );
}

/// Directional albedo of m at cos_v two ways: the mean of bsdf_sample's weights, and f cos
/// averaged over uniform directions (× 2π); each with its standard error (luminance).
fn albedo(k: &Kernel, m: GpuMaterial, cos_v: f64, seed: u64) -> ((f64, f64), (f64, f64)) {
    let count = 40_000;
    let mut rng = SplitMix64(seed);
    let mut q = Vec::with_capacity(2 * count);
    for _ in 0..count {
        q.push(query(m, cos_v, DVec3::Z, (rng.f32(), rng.f32())));
    }
    for _ in 0..count {
        // Uniform on the hemisphere: cos θ uniform in [0, 1).
        let l = hemisphere(rng.f32() as f64, 2.0 * PI * rng.f32() as f64);
        q.push(query(m, cos_v, l, (0.5, 0.5)));
    }
    let r = k.run(&q);
    let lum = |c: [f32; 3]| lightlearn::scene::luminance(Vec3::from(c)) as f64;
    let stats = |xs: Vec<f64>| {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, (var / n).sqrt())
    };
    let sampled = stats(r[..count].iter().map(|s| lum(s.weight)).collect());
    let uniform = stats(
        r[count..]
            .iter()
            .zip(&q[count..])
            .map(|(s, q)| lum(s.f) * q.l[2] as f64 * 2.0 * PI)
            .collect(),
    );
    (sampled, uniform)
}

#[test]
fn energy_is_conserved() {
    let k = Kernel::new();
    let mut seed = 1000;
    for metallic in [0.0, 0.5, 1.0] {
        for roughness in [0.05, 0.2, 0.5, 1.0] {
            for cos_v in [1.0, 0.5, 0.1] {
                let m = material(Vec3::ONE, metallic, roughness, 1.0, Vec3::ONE);
                seed += 1;
                let ((a, sa), (b, sb)) = albedo(&k, m, cos_v, seed);
                let z = (a - b) / (sa * sa + sb * sb).sqrt();
                println!(
                    "white, metallic {metallic}, roughness {roughness}, cos θ {cos_v}: albedo {a:.4} ± {sa:.4} (sampled), {b:.4} ± {sb:.4} (uniform), z {z:+.2}"
                );
                assert!(
                    a <= 1.0 + 4.0 * sa + 1e-3,
                    "metallic {metallic}, roughness {roughness}, cos θ {cos_v}: albedo {a} > 1"
                );
                // Smooth lobes are too peaked for uniform directions to estimate well.
                if roughness >= 0.2 {
                    assert!(
                        z.abs() < 4.5,
                        "metallic {metallic}, roughness {roughness}, cos θ {cos_v}: sampled albedo {a} ± {sa} but uniform {b} ± {sb}: sample, pdf and eval disagree"
                    );
                }
                // Smooth and white: nearly everything comes back (a metal reflects it all).
                if metallic == 1.0 && roughness <= 0.2 && cos_v >= 0.5 {
                    assert!(a > 0.97, "a smooth white metal reflects only {a}");
                }
                // A white dielectric at any roughness and angle: what the layer does not
                // reflect the white base does (the base's coupling by the layer's albedo).
                // With the macro normal's Fresnel in its place a rough one kept only 0.5–0.9
                // at grazing views.
                if metallic == 0.0 {
                    assert!(
                        (a - 1.0).abs() < 4.0 * sa + 0.01,
                        "a white dielectric of roughness {roughness} at cos θ {cos_v} reflects {a} ± {sa}, not 1"
                    );
                }
            }
        }
    }
    // A layer of F0 = 1 (specularColorFactor 26) over a white base, rough: the layer keeps
    // everything it reflects, multiple scattering included, so the base gets nothing and
    // sampling (the layer alone) and uniform directions agree. With the single-scattering
    // albedo alone the base got 1 − M (69 % of the light at normal view), which BRDF
    // sampling never drew (p_spec 1): uniform directions saw more than sampling (a review,
    // 2026-12-07).
    for cos_v in [1.0, 0.5] {
        let m = material(Vec3::ONE, 0.0, 1.0, 1.0, Vec3::splat(26.0));
        let dark = material(Vec3::ZERO, 0.0, 1.0, 1.0, Vec3::splat(26.0));
        let ((a, sa), (b, sb)) = albedo(&k, m, cos_v, 77);
        let ((_, _), (c, sc)) = albedo(&k, dark, cos_v, 78);
        let z = (a - b) / (sa * sa + sb * sb).sqrt();
        let zb = (b - c) / (sb * sb + sc * sc).sqrt();
        println!("F0 = 1, roughness 1, cos θ {cos_v}: sampled {a:.4} ± {sa:.4}, uniform {b:.4} ± {sb:.4}, black base {c:.4}");
        assert!(z.abs() < 4.5 && zb.abs() < 4.5, "F0 = 1 at cos θ {cos_v}: sampled {a} ± {sa}, uniform {b} ± {sb}, with a black base {c} ± {sc}");
    }
    // Lambertian (metallic 0, specularFactor 0): every sample weighs exactly the base colour.
    let base = Vec3::new(0.7, 0.4, 0.2);
    let m = material(base, 0.0, 0.3, 0.0, Vec3::ONE);
    let mut rng = SplitMix64(5);
    let q: Vec<BsdfQuery> = (0..1000)
        .map(|_| {
            query(
                m,
                rng.range(0.05, 1.0) as f64,
                DVec3::new(0.3, 0.2, 0.9).normalize(),
                (rng.f32(), rng.f32()),
            )
        })
        .collect();
    for r in k.run(&q) {
        assert_eq!(r.p_spec, 0.0);
        assert!(
            (Vec3::from(r.f) - base / std::f32::consts::PI)
                .abs()
                .max_element()
                < 1e-7
        );
        if r.sampled_pdf > 0.0 {
            assert!(
                (Vec3::from(r.weight) - base).abs().max_element() < 1e-5,
                "weight {:?}",
                r.weight
            );
            let c = r.sampled[2];
            assert!((r.sampled_pdf - c / std::f32::consts::PI).abs() < 1e-6);
        }
    }
}
