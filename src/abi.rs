//! The shader ABI as plain data: every struct and constant the host shares with the
//! kernels (depends on bytemuck only, so the plain-data modules use it without the device
//! layer). Each is mirrored field by field in
//! `shaders/shared/types.glsl` (same names), and `tests/layout.rs` reads the compiled SPIR-V
//! and fails on any offset or size mismatch.
//!
//! std430 rules: a vec3 is 16-byte aligned but 12 bytes long, so a scalar packs into its
//! fourth word; every struct here is a multiple of 16 bytes.

use bytemuck::{Pod, Zeroable};

/// Marks a child reference in [`BvhNode`] as a leaf; the bits below it then hold the leaf's
/// triangle count (`BVH_LEAF_COUNT_SHIFT`) and its first triangle (`BVH_LEAF_FIRST_MASK`).
pub const BVH_LEAF_BIT: u32 = 0x8000_0000;
/// A leaf reference holds its triangle count, at most 255, in bits 23–30.
pub const BVH_LEAF_COUNT_SHIFT: u32 = 23;
/// A leaf reference holds its first triangle in bits 0–22: a BVH holds at most 2^23
/// triangles (the glTF loader's MAX_TRIANGLES is 2.5 M).
pub const BVH_LEAF_FIRST_MASK: u32 = (1 << BVH_LEAF_COUNT_SHIFT) - 1;

/// A 4-wide BVH node that stores the boxes of its (up to) four children, so one fetch tests
/// four boxes and a ray's chain of dependent node fetches is half as long as a binary tree's
/// (docs/results.md, "BVH nodes in 32 bytes": fewer bytes a node did not help, a shorter
/// chain did). The boxes plane by plane (`lo_x[i]` is child i's least x), then the four
/// references: 112 bytes, seven texels, where boxes with a reference and a count beside each
/// took eight (docs/results.md, thirty-eighth session: each texel a node step fetches costs
/// lavapipe a gather). A missing child is an empty leaf.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub lo_x: [f32; 4],
    pub lo_y: [f32; 4],
    pub lo_z: [f32; 4],
    pub hi_x: [f32; 4],
    pub hi_y: [f32; 4],
    pub hi_z: [f32; 4],
    /// Interior child: node index. Leaf: `BVH_LEAF_BIT | count << BVH_LEAF_COUNT_SHIFT |
    /// first triangle` (count 0 for an empty child).
    pub refs: [u32; 4],
}

/// A triangle in BVH leaf order, pre-transformed for Möller–Trumbore (v0 and two edges).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhTri {
    pub v0: [f32; 3],
    /// Index of the triangle in `Scene::triangles`.
    pub prim: u32,
    pub e1: [f32; 3],
    pub pad0: u32,
    pub e2: [f32; 3],
    pub pad1: u32,
}

pub const LIGHT_POINT: u32 = 0;
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_TRIANGLE: u32 = 2;
/// A directional light (`Scene::directional`), after the sampled lights in the light texels:
/// `p1` the way it travels, `radiance` its irradiance.
pub const LIGHT_DIRECTIONAL: u32 = 3;
/// Added to `LIGHT_TRIANGLE` when the triangle emits from both faces.
pub const LIGHT_TWO_SIDED: u32 = 0x100;
/// Added to `LIGHT_TRIANGLE` when its material has an emissive texture: the light's
/// `cos_outer` holds the triangle's index and `cos_inner` the texture's, as bits (a triangle
/// has no cone; render.comp reads those words as integers, never as floats).
pub const LIGHT_TEXTURED: u32 = 0x200;

/// One light. Point: `p0` position, `radiance` intensity (W/sr). Spot: additionally `p1` the
/// unit axis and the cone cosines. Triangle: vertices `p0..p2` (CCW front), `radiance`
/// emitted radiance, `area`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    pub p0: [f32; 3],
    pub kind: u32,
    pub p1: [f32; 3],
    pub cos_outer: f32,
    pub p2: [f32; 3],
    pub cos_inner: f32,
    pub radiance: [f32; 3],
    pub area: f32,
}

/// One entry of the power sampler's alias table (Walker/Vose): pick entry i uniformly, keep i
/// with probability `q`, else take `alias`. `pmf` is light i's selection probability.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AliasEntry {
    pub q: f32,
    pub alias: u32,
    pub pmf: f32,
    pub pad: u32,
}

/// `LightNode::flags`: some light below emits from both faces.
pub const LIGHT_NODE_TWO_SIDED: u32 = 1;
/// `LightNode::flags`: some light below is an area (triangle) light, whose irradiance is
/// bounded: the importance keeps pbrt-v4's distance clamp there (src/lights/bounds.rs
/// `d2_floor`).
pub const LIGHT_NODE_AREA: u32 = 2;

/// A light-tree node (src/lights/tree.rs), depth-first: the left child is the next node.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightNode {
    pub bmin: [f32; 3],
    /// Total power (luminance) of the lights below.
    pub phi: f32,
    pub bmax: [f32; 3],
    pub cos_o: f32,
    /// Axis of the emission cone.
    pub axis: [f32; 3],
    pub cos_e: f32,
    /// Index of the right child (`u32::MAX` for a leaf).
    pub right: u32,
    /// First tree position covered (`LightTree::order`).
    pub begin: u32,
    /// Number of lights below (1 = leaf).
    pub count: u32,
    pub flags: u32,
}

/// A light-tree node as the kernels read it (`GpuLightNode` in types.glsl): the box as its
/// centre and bounding-sphere radius, and the cone's sine, computed once on the host
/// (`lights::bounds::gpu_node`) instead of at every importance evaluation. The importance of a cut's
/// slots was about a quarter of a `wang` pass on lavapipe (the cut loop with a trivial
/// importance ran 24 % faster, default scene, depth 8, 320×240); this layout takes three
/// square roots, two divisions and the box arithmetic out of each evaluation.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLightNode {
    /// Centre of the bounding box.
    pub centre: [f32; 3],
    pub phi: f32,
    pub axis: [f32; 3],
    pub cos_o: f32,
    /// Half the box diagonal: the bounding sphere's radius, and pbrt-v4's clamp of d².
    pub radius: f32,
    /// sin θ_o, from cos_o.
    pub sin_o: f32,
    pub cos_e: f32,
    pub flags: u32,
    pub right: u32,
    pub begin: u32,
    pub count: u32,
    pub pad: u32,
}

/// One query of `light_sample.comp` (tests): a shading point, its normal, a random number,
/// and a light whose pmf to evaluate there (`u32::MAX`: none).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightQuery {
    pub p: [f32; 3],
    pub u: f32,
    pub n: [f32; 3],
    pub light: u32,
}

/// The answer: the light chosen (`u32::MAX`: none can contribute) and its pmf; for `bayes`
/// with control variates also Σ_C g_C and the chosen slot's g (0 otherwise).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightChoice {
    pub light: u32,
    pub pmf: f32,
    pub cv_total: f32,
    pub cv_chosen: f32,
    /// `light_pmf` of the chosen light (0 for none), and of the query's `light`.
    pub pmf_again: f32,
    pub pmf_query: f32,
}

/// The region grid (src/lights/grid.rs): cubic cells of size `cell` from `lo`,
/// `dims` cells per axis, `bins` normal bins per cell (6, or 1 when off).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GridParams {
    pub lo: [f32; 3],
    pub cell: f32,
    pub dims: [u32; 3],
    pub bins: u32,
}

/// Learned totals of one (region, cut slot), parallel to the cuts array (see
/// src/learning/mod.rs): counts of zero and non-zero observations, Σy, Σy², the scale of
/// the current window's fixed-point sums, and the posterior's sampling weight as a quadratic
/// in the prior mean (`coef_a..c`, written by the fold kernel).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SlotStats {
    pub n_zero: f32,
    pub n_nonzero: f32,
    pub sum: f32,
    pub sum_sq: f32,
    pub scale: f32,
    pub coef_a: f32,
    pub coef_b: f32,
    pub coef_c: f32,
}

/// The current window's observations: counts and 64-bit fixed-point sums (lo, hi words) of
/// y / scale and (y / scale)², 24 fraction bits.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SlotDelta {
    pub n_zero: u32,
    pub n_nonzero: u32,
    pub sum_lo: u32,
    pub sum_hi: u32,
    pub sq_lo: u32,
    pub sq_hi: u32,
    /// 1 while the slot is in the window's list of touched slots (render.comp
    /// `mark_touched`); the fold of its window clears it.
    pub touched: u32,
    pub pad1: u32,
}

pub const LEARN_REGRESSION: u32 = 1;
pub const LEARN_TARGET_MEAN: u32 = 2;
pub const LEARN_PRIORS: u32 = 4;
pub const LEARN_BRDF: u32 = 8;
pub const LEARN_CONTROL_VARIATES: u32 = 16;
pub const LEARN_BRDF_SELECT: u32 = 32;
/// With LEARN_REGRESSION: the regressor is Ĩ_C(x) instead of 1/d² (`--regression importance`).
pub const LEARN_REGRESS_IMPORTANCE: u32 = 64;
pub const LEARN_DEFENSIVE: u32 = 128;
/// `--refine-cuts`: observations also counted by the side of the slot's node (render.comp
/// `side_counts`).
pub const LEARN_REFINE: u32 = 256;

/// Hyperparameters and switches of the learned samplers.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LearnParams {
    pub prior_zero: f32,
    pub prior_nonzero: f32,
    pub prior_n: f32,
    pub prior_alpha: f32,
    pub prior_cv: f32,
    pub lambda: f32,
    pub flags: u32,
    /// μ0 = Ĩ · d² · prior_scale: Ĩ's power Φ in the units of the observations (by
    /// importance μ0 = prior_scale: y is a share of Ĩ).
    pub prior_scale: f32,
    /// `bayes`: ε of the defensive mixture with `wang`'s pmf (`--defensive`; read only
    /// under LEARN_DEFENSIVE).
    pub defensive: f32,
}

/// `fold.comp`'s push constants: which slots it folds (`mode`: FOLD_TOUCHED, the listed
/// ones; FOLD_ALL, those from `first` to `slot_count`) and the learning's parameters.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FoldPush {
    pub slot_count: u32,
    pub mode: u32,
    pub first: u32,
    pub learn: LearnParams,
}

pub const MATERIAL_TWO_SIDED: u32 = 1;
/// `GpuMaterial::flags`: glTF alphaMode MASK (a surface where alpha < `alpha_cutoff` is not
/// there: rays pass it).
pub const MATERIAL_ALPHA_MASK: u32 = 2;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub base_color: [f32; 3],
    /// `MATERIAL_TWO_SIDED` when emission leaves both faces, `MATERIAL_ALPHA_MASK`.
    pub flags: u32,
    pub emission: [f32; 3],
    /// Index of the base-colour texture in the texture table, `u32::MAX` for none.
    pub texture: u32,
    /// KHR_materials_specular specularColorFactor and specularFactor.
    pub specular_color: [f32; 3],
    pub specular: f32,
    /// glTF metallicFactor and roughnessFactor (shaders/shared/bsdf.glsl).
    pub metallic: f32,
    pub roughness: f32,
    /// Index of the emissive texture in the texture table, `u32::MAX` for none.
    pub emissive_texture: u32,
    /// Index of the metallic-roughness texture (linear; green × roughness, blue × metallic),
    /// `u32::MAX` for none.
    pub metallic_roughness_texture: u32,
    /// Index of the normal texture (linear, tangent space), `u32::MAX` for none, and the
    /// scale of its X and Y.
    pub normal_texture: u32,
    pub normal_scale: f32,
    /// With `MATERIAL_ALPHA_MASK`: glTF alphaCutoff, and baseColorFactor's alpha (× the
    /// base-colour texture's alpha where there is one).
    pub alpha_cutoff: f32,
    pub alpha: f32,
}

/// One query of `bsdf.comp` (tests): a material seen from `v` at normal `n`, a direction `l`
/// to evaluate, and the random numbers (u0, u1) of a sample.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BsdfQuery {
    pub n: [f32; 3],
    pub u0: f32,
    pub v: [f32; 3],
    pub u1: f32,
    pub l: [f32; 3],
    pub pad: f32,
    pub material: GpuMaterial,
}

/// `bsdf.comp`'s answer: f(v, l) and pdf(v, l); the sampled direction, its pdf, and its
/// weight f cos / pdf; the specular-lobe probability.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BsdfResult {
    pub f: [f32; 3],
    pub pdf: f32,
    pub sampled: [f32; 3],
    pub sampled_pdf: f32,
    pub weight: [f32; 3],
    pub p_spec: f32,
}

/// One texture of the texture table: where its texels start in the texel buffer (packed
/// RGBA8, sRGB unless `TEXTURE_LINEAR`, or RGBA16 in two words with `TEXTURE_16_BIT`), its size, and its wrap modes
/// (wrapS | wrapT << 8, `scene::Wrap` codes) with the flags below.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTexture {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub wrap: u32,
}

/// `GpuTexture::wrap` flag: the sampler's magFilter is NEAREST (one texel, no interpolation).
pub const TEXTURE_NEAREST: u32 = 1 << 16;
/// `GpuTexture::wrap` flag: 16 bits a channel, two words a texel (R | G << 16, B | A << 16).
pub const TEXTURE_16_BIT: u32 = 1 << 17;
/// `GpuTexture::wrap` flag: data, read as stored (no sRGB decoding: `scene::Texture::linear`).
pub const TEXTURE_LINEAR: u32 = 1 << 18;

/// Push constants of `render.comp` (96 of the 128 bytes every device guarantees).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderParams {
    pub cam_pos: [f32; 4],
    /// Camera right × tan(yfov/2) × aspect.
    pub cam_u: [f32; 4],
    /// Camera up × tan(yfov/2).
    pub cam_v: [f32; 4],
    /// Camera forward.
    pub cam_w: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub sample_index: u32,
    pub seed: u32,
    pub light_count: u32,
    /// 1e-4 of the scene's size (`render::ray_epsilon`). The kernel offsets rays by the
    /// coordinates where they start (render.comp `surface_eps`) and no longer reads it; the
    /// field keeps the block's layout, which tests/layout.rs checks against the SPIR-V.
    pub ray_eps: f32,
    /// Surface vertices of a path (1: direct light by light sampling alone).
    pub max_depth: u32,
    /// The wavefront's bounce (`render.comp` WAVEFRONT): 0 starts paths, d ≥ 1 takes
    /// vertex d of the queued ones.
    pub bounce: u32,
    /// The first film row of a dispatch that starts paths.
    pub row0: u32,
    /// Paths per queue of the wavefront.
    pub queue_cap: u32,
    /// Direct light with a sampler that does not learn: samples per pixel this dispatch
    /// takes, sample indices `sample_index` on (0 counts as 1). Otherwise 1.
    pub passes: u32,
}

/// A ray for `trace.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRay {
    pub origin: [f32; 3],
    pub tmin: f32,
    pub dir: [f32; 3],
    pub tmax: f32,
}

/// Result of `trace.comp`: `prim` is the hit triangle (`u32::MAX` for a miss).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuHit {
    pub t: f32,
    pub prim: u32,
}

/// Push constants of `trace.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TraceParams {
    pub ray_count: u32,
    /// 0: closest hit; 1: any hit (shadow rays).
    pub any_hit: u32,
    pub pad0: u32,
    pub pad1: u32,
}

/// Push constants of `preview.comp`: the film's size, the window's, how to scale and show.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PreviewParams {
    pub film_width: u32,
    pub film_height: u32,
    pub out_width: u32,
    pub out_height: u32,
    /// radiance_scale × exposure / spp.
    pub mean_scale: f32,
    pub spp: f32,
    /// 0: the image; 1: the relative standard error of each pixel's mean; 2: the share of
    /// its light samples that were zero.
    pub view: u32,
    /// Pixels blue first (B8G8R8A8 swapchains).
    pub bgra: u32,
}

/// Per-pixel accumulator: sum and sum of squares of the pixel samples (rgb; w unused).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PixelAccum {
    pub sum: [f32; 4],
    pub sum_sq: [f32; 4],
}
