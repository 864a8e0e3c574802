//! The scene in GPU buffers (geometry BVH, materials, lights and their tree, textures),
//! uploaded once and shared by every pass of every session on it.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;

use crate::accel::Bvh;
use crate::gpu::layout::{
    GpuLight, GpuMaterial, GpuTexture, LIGHT_DIRECTIONAL, MATERIAL_ALPHA_MASK, MATERIAL_TWO_SIDED,
    TEXTURE_16_BIT, TEXTURE_LINEAR, TEXTURE_NEAREST,
};
use crate::gpu::{Buffer, Context};
use crate::learning::stats_file;
use crate::lights;
use crate::scene::Scene;

/// The scene in GPU buffers, shared by every pass.
pub struct GpuScene {
    pub nodes: Buffer,
    pub tris: Buffer,
    pub(super) tri_material: Buffer,
    pub(super) materials: Buffer,
    pub(super) lights: Buffer,
    pub(super) alias: Buffer,
    pub(super) light_nodes: Buffer,
    pub(super) light_order: Buffer,
    pub(super) light_position: Buffer,
    pub(super) tri_light: Buffer,
    pub(super) textures: Buffer,
    pub(super) texels: Buffer,
    pub(super) tri_uv: Buffer,
    /// The dielectric layer's albedo table (src/layer_albedo.rs), for bsdf.glsl.
    pub(super) layer_albedo: Buffer,
    /// Kept for building cuts: the tree, and the BVH to find which regions the camera sees.
    pub tree: lights::tree::LightTree,
    pub bvh: Bvh,
    pub light_count: u32,
    pub ray_eps: f32,
    /// What the kernels' results are multiplied by to give radiance: 1 / the factor their
    /// emission was scaled by ([`lights::emission_scale`]).
    pub radiance_scale: f32,
    /// Seconds spent building the light tree (reported in the JSON).
    pub light_tree_seconds: f64,
    /// What statistics learned on this scene are recorded against
    /// ([`stats_file::scene_fingerprint`]; an animation frame's:
    /// [`stats_file::topology_fingerprint`]).
    pub fingerprint: String,
    /// The kernel code the materials need (`render.comp` SCENE_FLAGS: [`SCENE_GLOSSY`],
    /// [`SCENE_TEXTURED`], [`SCENE_EMISSIVE_TEXTURED`]).
    pub kernel_flags: u32,
    /// The triangles and lights of the scene uploaded: a session checks its scene against
    /// them.
    pub uploaded_from: (usize, usize),
}

/// How far a ray starts off a surface at a point whose largest coordinate magnitude is
/// `local` (and stops short of an area light there): 1e-4 of it, and at least 1e-5 of `far`,
/// the magnitudes the point's rounding comes from (its ray's origin and length, the
/// triangle's corners: f32 rounds there at ~1e-7 of them). render.comp's `surface_eps` is
/// the kernel's copy; it says why the offset is local, not the scene's.
pub fn surface_epsilon(local: f32, far: f32) -> f32 {
    (1e-4 * local).max(1e-5 * far).max(1e-30)
}

/// [`surface_epsilon`] at the hit `x` = `o + t·d` on the triangle `tri`.
pub fn hit_epsilon(x: Vec3, o: Vec3, t: f32, tri: [Vec3; 3]) -> f32 {
    let far = tri.iter().fold(o.abs().max_element().max(t), |m, v| {
        m.max(v.abs().max_element())
    });
    surface_epsilon(x.abs().max_element(), far)
}

/// The scene's largest buffers against the device's limits, named by what the scene holds
/// and checked before the light tree is built: lavapipe's 128 MiB storage buffers hold the
/// tree of about 1 048 576 lights and 33.5 M texels, and past them the error came after 17 s
/// of building the tree, or read "buffer 'texels' needs 268435456 bytes … use a smaller
/// scene or image" for one 8192² texture (an audit, 2026-12-06).
pub fn check_fits(ctx: &Context, scene: &Scene) -> Result<()> {
    let limits = &ctx.properties.limits;
    let storage = limits.max_storage_buffer_range as u64;
    let node = std::mem::size_of::<crate::abi::GpuLightNode>() as u64;
    // The tree is read as 16-byte texels, and bound as a storage buffer.
    let most = storage.min(limits.max_texel_buffer_elements as u64 * 16);
    let n = scene.lights.len() as u64;
    let tree = (2 * n).saturating_sub(1) * node;
    if tree > most {
        anyhow::bail!(
            "'{}': its {n} lights need a light tree of {tree} bytes, more than this device's largest buffer ({most} bytes: about {} lights); use fewer lights",
            scene.source,
            (most / node).div_ceil(2)
        );
    }
    let size = |t: &crate::scene::Texture| t.width as u64 * t.height as u64;
    let texels: u64 = scene.textures.iter().map(size).sum();
    let words: u64 = scene.textures.iter().map(|t| t.words.len() as u64).sum();
    if let Some(largest) = scene.textures.iter().max_by_key(|t| t.words.len()) {
        if words * 4 > storage {
            anyhow::bail!(
                "'{}': its textures hold {texels} texels ({} bytes), more than this device's largest buffer ({storage} bytes); the largest is {}×{}: scale it down",
                scene.source,
                words * 4,
                largest.width,
                largest.height
            );
        }
    }
    Ok(())
}

/// 1e-4 of the scene's size: how far the host widens boxes in the tests of what a pixel's
/// rays can meet (coverage.rs: a larger margin only keeps more rows); rays themselves
/// leave surfaces by [`hit_epsilon`].
pub fn ray_epsilon(scene: &Scene) -> f32 {
    let (lo, hi) = scene.bounds();
    let size = (hi - lo).length().max(lo.abs().max(hi.abs()).max_element());
    1e-4 * size.max(1e-3)
}

impl GpuScene {
    /// Uploads a scene with a light tree built for it.
    pub fn upload(ctx: &Arc<Context>, scene: &Scene, bvh: &Bvh) -> Result<GpuScene> {
        Self::upload_with(ctx, scene, bvh, None)
    }

    /// Uploads a frame of an animation: `tree`'s topology refitted to the lights as they
    /// are now ([`lights::tree::LightTree::refit`]), recorded by topology, so statistics
    /// learned on earlier frames of the same tree carry over.
    pub fn upload_refit(
        ctx: &Arc<Context>,
        scene: &Scene,
        bvh: &Bvh,
        tree: &lights::tree::LightTree,
    ) -> Result<GpuScene> {
        Self::upload_with(ctx, scene, bvh, Some(tree))
    }

    fn upload_with(
        ctx: &Arc<Context>,
        scene: &Scene,
        bvh: &Bvh,
        topology: Option<&lights::tree::LightTree>,
    ) -> Result<GpuScene> {
        scene.check_indices()?;
        check_fits(ctx, scene)?;
        // A 4-wide tree has fewer nodes than triangles, so a glTF scene (at most
        // gltf_mesh::MAX_TRIANGLES, 2.5 M) never comes near; a scene built in code might.
        if bvh.nodes.len() > crate::accel::bvh::MAX_NODES {
            anyhow::bail!(
                "'{}': its {} triangles need {} BVH nodes, more than the traversal addresses ({}); use fewer triangles",
                scene.source,
                scene.triangles.len(),
                bvh.nodes.len(),
                crate::accel::bvh::MAX_NODES
            );
        }
        let weights = lights::power_weights(scene);
        // The kernels' units count the suns too (their irradiance over the scene's cross-
        // section): a sun of 1000 beside a light of 1e-36 W/sr was scaled by 2^120 into an
        // EXR of Inf with exit 0 (an audit, 2026-12-07).
        // (The scene's bounds, a pass over every triangle, only where there are suns.)
        let emission_scale = if scene.directional.is_empty() {
            lights::emission_scale(&weights)
        } else {
            let (lo, hi) = scene.bounds();
            let cross_section = std::f64::consts::PI * (0.5 * (hi - lo).length() as f64).powi(2);
            let suns = (scene.directional.iter())
                .map(|d| crate::scene::luminance(d.irradiance) as f64 * cross_section.max(1e-30));
            lights::emission_scale(&weights.iter().copied().chain(suns).collect::<Vec<_>>())
        };
        let materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .map(|m| GpuMaterial {
                base_color: m.base_color.to_array(),
                flags: if m.double_sided {
                    MATERIAL_TWO_SIDED
                } else {
                    0
                } | if m.alpha_cutoff.is_some() {
                    MATERIAL_ALPHA_MASK
                } else {
                    0
                },
                emission: (m.emission * emission_scale).to_array(),
                texture: m.base_color_texture.unwrap_or(u32::MAX),
                specular_color: m.specular_color.to_array(),
                specular: m.specular,
                metallic: m.metallic,
                roughness: m.roughness,
                emissive_texture: m.emissive_texture.unwrap_or(u32::MAX),
                metallic_roughness_texture: m.metallic_roughness_texture.unwrap_or(u32::MAX),
                normal_texture: m.normal_texture.unwrap_or(u32::MAX),
                normal_scale: m.normal_scale,
                alpha_cutoff: m.alpha_cutoff.unwrap_or(0.0),
                alpha: m.alpha,
            })
            .collect();
        // Texture table and texels; one dummy entry each when there are none (a buffer is
        // never empty).
        let mut table = Vec::new();
        let mut texels: Vec<u32> = Vec::new();
        for t in &scene.textures {
            table.push(GpuTexture {
                offset: texels.len() as u32,
                width: t.width,
                height: t.height,
                wrap: t.wrap[0] as u32
                    | (t.wrap[1] as u32) << 8
                    | if t.nearest { TEXTURE_NEAREST } else { 0 }
                    | if t.wide { TEXTURE_16_BIT } else { 0 }
                    | if t.linear { TEXTURE_LINEAR } else { 0 },
            });
            texels.extend_from_slice(&t.words);
        }
        if table.is_empty() {
            table.push(GpuTexture::default());
            texels.push(0);
        }
        let uvs = triangle_attributes(scene);
        let mut gpu_lights = lights::gpu_lights(scene);
        for l in &mut gpu_lights {
            l.radiance = l.radiance.map(|c| c * emission_scale);
        }
        let alias = lights::alias_table(&weights);
        let t0 = Instant::now();
        let mut tree = match topology {
            Some(t) => t.refit(scene),
            None => lights::tree::LightTree::build(scene),
        };
        // Exact (a power of two): the tree's shape and every ratio stay as built.
        for n in &mut tree.nodes {
            n.phi *= emission_scale;
        }
        // Of the tree as the kernels use it (scaled).
        let fingerprint = match topology {
            Some(_) => stats_file::topology_fingerprint(&tree),
            None => stats_file::scene_fingerprint(&tree),
        };
        let light_tree_seconds = t0.elapsed().as_secs_f64();
        let kernel_flags = kernel_flags(&materials)
            | directional_flags(scene)?
            | if !scene.triangle_tangents.is_empty() {
                SCENE_SMOOTH | SCENE_NORMAL_MAPPED
            } else if !scene.triangle_normals.is_empty() {
                SCENE_SMOOTH
            } else {
                0
            };
        // The directional lights after the sampled ones (render.comp reads them from
        // light_count on; no sampler sees them).
        let light_count = gpu_lights.len() as u32;
        gpu_lights.extend(scene.directional.iter().map(|d| GpuLight {
            kind: LIGHT_DIRECTIONAL,
            p1: d.direction.to_array(),
            radiance: (d.irradiance * emission_scale).to_array(),
            ..Default::default()
        }));
        Ok(GpuScene {
            nodes: Buffer::texels(ctx, "bvh nodes", &bvh.nodes)?,
            tris: Buffer::texels(ctx, "bvh triangles", &bvh.tris)?,
            tri_material: Buffer::from_slice(ctx, "triangle materials", &scene.triangle_material)?,
            materials: Buffer::texels(ctx, "materials", &materials)?,
            lights: Buffer::texels(ctx, "lights", &gpu_lights)?,
            alias: Buffer::from_slice(ctx, "light alias table", &alias)?,
            light_nodes: Buffer::texels(ctx, "light tree", &tree.gpu_nodes())?,
            light_order: Buffer::from_slice(ctx, "light tree order", &tree.order)?,
            light_position: Buffer::from_slice(ctx, "light tree positions", &tree.position)?,
            tri_light: Buffer::from_slice(ctx, "triangle lights", &lights::triangle_lights(scene))?,
            textures: Buffer::from_slice(ctx, "texture table", &table)?,
            texels: Buffer::from_slice(ctx, "texels", &texels)?,
            tri_uv: Buffer::from_slice(ctx, "triangle texture coordinates", &uvs)?,
            layer_albedo: Buffer::texels(
                ctx,
                "layer albedo table",
                &crate::layer_albedo::committed().texels(),
            )?,
            tree,
            bvh: bvh.clone(),
            light_count,
            ray_eps: ray_epsilon(scene),
            radiance_scale: 1.0 / emission_scale,
            light_tree_seconds,
            fingerprint,
            kernel_flags,
            uploaded_from: (scene.triangles.len(), scene.lights.len()),
        })
    }
}

/// `render.comp` SCENE_FLAGS: a glossy material (GGX code compiled in).
pub const SCENE_GLOSSY: u32 = 1;
/// `render.comp` SCENE_FLAGS: a base-colour or metallic-roughness texture (texture lookups at
/// the surfaces rays hit compiled in).
pub const SCENE_TEXTURED: u32 = 2;
/// `render.comp` SCENE_FLAGS: smooth triangles (`Scene::triangle_normals`: shading normals
/// interpolated, TRI_ATTR_STRIDE 9).
pub const SCENE_SMOOTH: u32 = 8;
/// `render.comp` SCENE_FLAGS: an emissive texture (its lookups at light samples and at
/// emitters a ray hits compiled in).
pub const SCENE_EMISSIVE_TEXTURED: u32 = 4;

/// `render.comp` SCENE_FLAGS: a material of alphaMode MASK (the alpha test on every triangle
/// a ray meets compiled in: shaders/shared/alpha.glsl).
pub const SCENE_ALPHA_MASK: u32 = 32;

/// `render.comp` SCENE_FLAGS: normal textures (`Scene::triangle_tangents`: each triangle's
/// tangent frames after its normals, TRI_ATTR_STRIDE 13; always with [`SCENE_SMOOTH`]).
pub const SCENE_NORMAL_MAPPED: u32 = 16;

/// Words a triangle's attributes take in `TriUv` (render.comp TRI_ATTR_STRIDE): its
/// corners' texture coordinates (6 floats, as bits), in a smooth scene their normals
/// (3 octahedral words, [`pack_normal`]), and in a normal-mapped one their tangents (3
/// octahedral words) and the tangents' signs (bit k set: corner k's w is −1).
pub fn tri_attr_stride(scene: &Scene) -> usize {
    if !scene.triangle_tangents.is_empty() {
        13
    } else if !scene.triangle_normals.is_empty() {
        9
    } else {
        6
    }
}

/// `TriUv`: each triangle's [`tri_attr_stride`] words (one triangle of zeros for a scene
/// with neither).
fn triangle_attributes(scene: &Scene) -> Vec<u32> {
    let stride = tri_attr_stride(scene);
    let n = scene.triangles.len();
    // (A normal-mapped triangle's frames need its words too: a hand-built scene of
    // tangents alone got one triangle's, a review, 2026-12-07.)
    if scene.triangle_uv.is_empty()
        && scene.triangle_normals.is_empty()
        && scene.triangle_tangents.is_empty()
    {
        return vec![0; stride];
    }
    let mut out = Vec::with_capacity(n * stride);
    for i in 0..n {
        let uv = scene.triangle_uv.get(i).copied().unwrap_or_default();
        out.extend(uv.iter().flatten().map(|f| f.to_bits()));
        if let Some(ns) = scene.triangle_normals.get(i) {
            out.extend(ns.iter().map(|&v| pack_normal(v)));
        } else if stride >= 9 {
            out.extend([0; 3]);
        }
        if stride == 13 {
            let t = scene.triangle_tangents[i];
            out.extend(t.iter().map(|v| pack_normal(v.truncate())));
            out.push((0..3).map(|k| ((t[k].w < 0.0) as u32) << k).sum());
        }
    }
    out
}

/// A unit normal as two 16-bit snorm octahedral coordinates (render.comp unpack_normal;
/// about 1e-4 rad apart at worst); the zero vector (a flat triangle) as 0, which no unit
/// vector packs to.
pub fn pack_normal(n: Vec3) -> u32 {
    if n == Vec3::ZERO {
        return 0;
    }
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs());
    let (mut x, mut y) = (n.x, n.y);
    if n.z < 0.0 {
        (x, y) = (
            (1.0 - n.y.abs()) * n.x.signum(),
            (1.0 - n.x.abs()) * n.y.signum(),
        );
    }
    let q = |v: f32| ((v.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    let w = q(x) | (q(y) << 16);
    // (0, 0) is ±Z's code; keep it distinct from "flat".
    if w == 0 {
        if n.z >= 0.0 {
            // +Z: (0, 0) → the next code up, 3e-5 off.
            1
        } else {
            1 << 16
        }
    } else {
        w
    }
}

/// The most directional lights a scene may have (render.comp loops over all of them at every
/// vertex; SCENE_FLAGS holds their count in its bits 8–15).
pub const MAX_DIRECTIONAL: usize = 255;

/// `render.comp` SCENE_FLAGS' bits 8–15: the scene's directional lights (its loop over them
/// is compiled out where there are none).
fn directional_flags(scene: &Scene) -> Result<u32> {
    let n = scene.directional.len();
    if n > MAX_DIRECTIONAL {
        anyhow::bail!(
            "'{}' has {n} directional lights; lightlearn renders at most {MAX_DIRECTIONAL} (each is sampled at every path vertex): merge the suns",
            scene.source
        );
    }
    Ok((n as u32) << 8)
}

/// What the scene's materials need of `render.comp`, as its SCENE_FLAGS: a scene without
/// glossy or textured materials gets a kernel without that code, with the same arithmetic
/// (every material of such a scene takes the Lambertian / untextured branch anyway).
fn kernel_flags(materials: &[GpuMaterial]) -> u32 {
    // The kernel's test for a Lambertian material (bsdf.glsl make_bsdf), on the same values.
    let glossy = materials
        .iter()
        .any(|m| !(m.metallic == 0.0 && m.specular == 0.0));
    let textured = materials
        .iter()
        .any(|m| m.texture != u32::MAX || m.metallic_roughness_texture != u32::MAX);
    let emissive = materials.iter().any(|m| m.emissive_texture != u32::MAX);
    let masked = materials.iter().any(|m| m.flags & MATERIAL_ALPHA_MASK != 0);
    (glossy as u32 * SCENE_GLOSSY)
        | (masked as u32 * SCENE_ALPHA_MASK)
        | ((textured || emissive) as u32 * SCENE_TEXTURED)
        | (emissive as u32 * SCENE_EMISSIVE_TEXTURED)
}
