//! glTF materials → ours: metallic-roughness factors, KHR_materials_specular,
//! KHR_materials_emissive_strength, the base-colour, emissive, metallic-roughness and normal
//! textures; what is ignored is said once.

use std::collections::HashMap;

use anyhow::{bail, Result};
use glam::Vec3;

use super::gltf_data::Images;
use super::{Material, Texture};

/// The scene's materials and their textures, each glTF material and texture converted
/// once, in the order first used.
pub(super) struct MaterialTable<'a> {
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// glTF material index (None: the default material) → ours.
    index: HashMap<Option<usize>, u32>,
    /// glTF image and sampler (the image's index, wrapS, wrapT, magFilter) and whether it is
    /// read as data ([`Texture::linear`]) → ours (None: could not be used, already warned
    /// about): textures that name one image with the same sampler share its texels.
    texture_index: HashMap<(TextureKey, bool), Option<u32>>,
    images: Images<'a>,
}

impl<'a> MaterialTable<'a> {
    pub fn new(images: Images<'a>) -> Self {
        MaterialTable {
            materials: Vec::new(),
            textures: Vec::new(),
            index: HashMap::new(),
            texture_index: HashMap::new(),
            images,
        }
    }

    /// Whether our material `slot` emits light.
    pub fn emits(&self, slot: u32) -> bool {
        self.materials[slot as usize].emission.max_element() > 0.0
    }

    /// Index of our material for a glTF material (the default material gets its own slot).
    pub fn slot(
        &mut self,
        m: &gltf::Material,
        file: &str,
        warn: &mut dyn FnMut(String),
    ) -> Result<u32> {
        let MaterialTable {
            materials,
            textures,
            index,
            texture_index,
            images,
        } = self;
        if let Some(&i) = index.get(&m.index()) {
            return Ok(i);
        }
        let label = match m.index() {
            Some(i) => format!("material {i} ('{}')", m.name().unwrap_or("")),
            None => "the default material".to_string(),
        };
        let base = m.pbr_metallic_roughness().base_color_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        // Each on its own (a negative factor times a negative strength passed as a positive
        // emission: a review, 2026-12-07).
        let factor = Vec3::from(m.emissive_factor());
        if !(strength >= 0.0 && factor.min_element() >= 0.0) {
            bail!("'{file}': {label} has a negative emissiveFactor ({factor}) or emissiveStrength ({strength}); use values ≥ 0");
        }
        let emission = factor * strength;
        let base_color = Vec3::new(base[0], base[1], base[2]);
        if !emission.is_finite() || emission.min_element() < 0.0 {
            bail!("'{file}': {label} has a non-finite or negative emission (emissiveFactor × emissiveStrength = {emission}); use finite values ≥ 0");
        }
        if !base_color.is_finite() || base_color.min_element() < 0.0 {
            bail!(
                "'{file}': {label} has a non-finite or negative baseColorFactor; use values in [0, 1]"
            );
        }
        // glTF bounds it by 1 and the BRDF clamps it there (an albedo above 1 would create
        // energy): said, where it was silent (an audit, 2026-12-06).
        if base_color.max_element() > 1.0 {
            warn(format!(
                "'{file}': {label} has baseColorFactor {base_color} above 1; rendered with it clamped to 1 (glTF asks for values in [0, 1])"
            ));
        }
        let pbr = m.pbr_metallic_roughness();
        let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
        if !(0.0..=1.0).contains(&metallic) || !(0.0..=1.0).contains(&roughness) {
            bail!(
                "'{file}': {label} has metallicFactor {metallic} and roughnessFactor {roughness}; \
                 both must be in [0, 1]"
            );
        }
        let (specular, specular_color) = match m.specular() {
            Some(sp) => (sp.specular_factor(), Vec3::from(sp.specular_color_factor())),
            None => (1.0, Vec3::ONE),
        };
        if !(0.0..=1.0).contains(&specular)
            || !specular_color.is_finite()
            || specular_color.min_element() < 0.0
        {
            bail!(
                "'{file}': {label} has KHR_materials_specular specularFactor {specular} and \
                 specularColorFactor {specular_color}; use a factor in [0, 1] and colours ≥ 0"
            );
        }
        if m.specular().is_some_and(|sp| {
            sp.specular_texture().is_some() || sp.specular_color_texture().is_some()
        }) {
            warn(format!(
                "'{file}': {label} has a specular texture; lightlearn uses the material's factors only"
            ));
        }
        // glTF: roughness = roughnessFactor × the texture's green, metallic = metallicFactor ×
        // its blue, both linear. Read only where the BRDF has a GGX layer (a Lambertian
        // material's is never looked at), and on the triangles' one coordinate mapping.
        let lambertian = metallic == 0.0 && specular == 0.0;
        let metallic_roughness_info = match pbr.metallic_roughness_texture() {
            Some(info) if !lambertian => {
                let map = super::gltf_mesh::UvMap::of(&info);
                if super::gltf_mesh::coordinate_map(m).is_some_and(|c| c != map) {
                    warn(format!(
                        "'{file}': {label}: its metallicRoughnessTexture reads another texture coordinate set or KHR_texture_transform than its base-colour (or emissive) texture; lightlearn maps a triangle's coordinates once, so it uses metallicFactor and roughnessFactor alone (give the textures one set and transform)"
                    ));
                    None
                } else {
                    Some(info)
                }
            }
            _ => None,
        };
        // glTF normalTexture: a tangent-space normal (linear), on the triangles' one
        // coordinate mapping.
        let normal_info = match m.normal_texture() {
            Some(n) => match super::gltf_mesh::UvMap::of_normal(&n) {
                Err(why) => {
                    warn(format!("'{file}': {label}: its normal texture: {why}; it is shaded without it (fix the extension's values)"));
                    None
                }
                Ok(map) if super::gltf_mesh::coordinate_map(m).is_some_and(|c| c != map) => {
                    warn(format!(
                        "'{file}': {label}: its normal texture reads another texture coordinate set or KHR_texture_transform than its other textures; lightlearn maps a triangle's coordinates once, so it is shaded without it (give the textures one set and transform)"
                    ));
                    None
                }
                Ok(_) => Some(n),
            },
            None => None,
        };
        // One texture, decoded once for every material naming it with the same sampler and
        // as the same kind (colour or data).
        let mut load = |warn: &mut dyn FnMut(String),
                        t: gltf::Texture,
                        what: &str,
                        fallback: &str,
                        linear: bool| {
            let key = (texture_key(&t), linear);
            if let Some(&known) = texture_index.get(&key) {
                // One that could not be used was said for its first role only: an image
                // both base colour and emission lost its emission in silence (an audit,
                // 2026-12-07).
                if known.is_none() {
                    warn(format!(
                        "'{file}': {label}: {what} texture {} could not be used (said above); using {fallback} alone",
                        t.index()
                    ));
                }
                return known;
            }
            let words: u64 = textures.iter().map(|t| t.words.len() as u64).sum();
            let loaded = match images.decode(&t, words, linear) {
                Ok(tex) => {
                    textures.push(tex);
                    Some(textures.len() as u32 - 1)
                }
                Err(e) => {
                    warn(format!(
                        "'{file}': {label}: {what} texture {}: {e}; using {fallback} alone",
                        t.index()
                    ));
                    None
                }
            };
            texture_index.insert(key, loaded);
            loaded
        };
        let base_info = m.pbr_metallic_roughness().base_color_texture();
        // The set the file's base-colour texture names, loaded or not: the mesh reads (and the
        // loader checks) that set whenever there is one.
        let base_map = base_info.as_ref().map(super::gltf_mesh::UvMap::of);
        let base_color_texture = base_info.and_then(|info| {
            load(
                warn,
                info.texture(),
                "base-colour",
                "baseColorFactor",
                false,
            )
        });
        // Only an emitting material's texture is read (glTF: emission = factor × texture, so
        // with a zero factor the texture changes nothing). A triangle holds one coordinate set,
        // so an emissive texture on another set than the base colour's is left out, said.
        let emissive_texture = match m.emissive_texture() {
            Some(info) if emission.max_element() > 0.0 => {
                let map = super::gltf_mesh::UvMap::of(&info);
                if let Some(b) = base_map.filter(|b| b.set != map.set) {
                    warn(format!(
                        "'{file}': {label}: its emissive texture reads TEXCOORD_{} but its base-colour texture TEXCOORD_{}; lightlearn reads one set a triangle, so it uses emissiveFactor alone (give both textures one set)",
                        map.set, b.set
                    ));
                    None
                } else if base_map.is_some_and(|b| b != map) {
                    warn(format!(
                        "'{file}': {label}: its emissive texture's KHR_texture_transform differs from its base-colour texture's; lightlearn maps a triangle's coordinates once, so it uses emissiveFactor alone (give both textures one transform)"
                    ));
                    None
                } else {
                    load(warn, info.texture(), "emissive", "emissiveFactor", false)
                }
            }
            _ => None,
        };
        let metallic_roughness_texture = metallic_roughness_info.and_then(|info| {
            load(
                warn,
                info.texture(),
                "metallic-roughness",
                "metallicFactor and roughnessFactor",
                true,
            )
        });
        let normal_scale = normal_info.as_ref().map_or(1.0, |n| n.scale());
        if !normal_scale.is_finite() {
            bail!("'{file}': {label} has normalTexture.scale {normal_scale}; give a finite number (1: as the texture is)");
        }
        let normal_texture = normal_info.and_then(|n| {
            load(
                warn,
                n.texture(),
                "normal",
                "the surface's own normals",
                true,
            )
        });
        // glTF alphaMode MASK: the surface is there where alpha (the factor's × the
        // base-colour texture's) is at least alphaCutoff (default 0.5); BLEND is warned about
        // (gltf_warn) and rendered opaque.
        let alpha_cutoff = (m.alpha_mode() == gltf::material::AlphaMode::Mask)
            .then(|| m.alpha_cutoff().unwrap_or(0.5));
        if alpha_cutoff.is_some_and(|c| !(c >= 0.0 && c.is_finite())) {
            bail!(
                "'{file}': {label} has alphaCutoff {}; use a cutoff ≥ 0 (0.5 by default)",
                alpha_cutoff.unwrap_or(0.5)
            );
        }
        // As baseColorFactor's colour above: clamped and said (a review, 2026-12-07).
        let alpha = base[3].clamp(0.0, 1.0);
        if alpha_cutoff.is_some() && alpha != base[3] {
            warn(format!("'{file}': {label} has baseColorFactor alpha {} outside [0, 1]; its cutout uses it clamped to {alpha}", base[3]));
        }
        // Light samples draw points over the whole triangle, cut out or not, while rays pass
        // the cut: the two estimates of its light would disagree. Said, not mended (rare).
        if alpha_cutoff.is_some() && emission.max_element() > 0.0 {
            warn(format!("'{file}': {label} emits and has alphaMode MASK; its cut-out parts still emit when lights are sampled but rays pass them, so its light is estimated inconsistently: give emitters alphaMode OPAQUE"));
        }
        let slot = materials.len() as u32;
        materials.push(Material {
            name: m.name().unwrap_or("").to_string(),
            base_color: base_color.clamp(Vec3::ZERO, Vec3::ONE),
            metallic,
            roughness,
            specular,
            specular_color,
            emission,
            double_sided: m.double_sided(),
            base_color_texture,
            emissive_texture,
            metallic_roughness_texture,
            normal_texture,
            normal_scale,
            alpha_cutoff,
            alpha,
        });
        index.insert(m.index(), slot);
        Ok(slot)
    }
}

/// What makes two glTF textures the same texture for us: the image, the wrap modes and the
/// magnification filter.
type TextureKey = (usize, u32, u32, bool);

fn texture_key(t: &gltf::Texture) -> TextureKey {
    let s = t.sampler();
    (
        t.source().index(),
        s.wrap_s().as_gl_enum(),
        s.wrap_t().as_gl_enum(),
        s.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
    )
}
