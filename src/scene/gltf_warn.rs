//! Warnings for what a glTF file asks that lightlearn renders otherwise, each one line a kind
//! however many elements: extensions it does not read, see-through materials, vertex colours,
//! skins, morph targets, mirrors smoother than the BRDF renders, nodes with a matrix and a
//! TRS. The file still renders; gltf_check refuses what cannot.

use gltf::json::Root;

use super::gltf_check::SUPPORTED_EXTENSIONS;

/// Warnings for what a file uses that lightlearn renders without: extensions it does not
/// read, materials that are not opaque, vertex colours, skins and morph targets (an audit, 2026-12-06:
/// each rendered a different picture with exit 0 and silence: cutout leaves as solid quads,
/// glass as an opaque surface, a posed character in its bind pose). Required extensions are
/// refused by gltf_check.
pub fn unsupported_features(doc: &gltf::Document, name: &str) -> Vec<String> {
    let mut out = Vec::new();
    let ignored: Vec<&str> = doc
        .extensions_used()
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    if !ignored.is_empty() {
        out.push(format!(
            "'{name}' uses {}, which lightlearn does not read; it renders without {} (read: {})",
            ignored.join(", "),
            if ignored.len() > 1 { "them" } else { "it" },
            SUPPORTED_EXTENSIONS.join(", ")
        ));
    }
    // One line a kind, however many elements (a file of 500 cutout leaves gave 500 lines).
    let mut see_through = Vec::new();
    for m in doc.materials() {
        // MASK is read since 2026-12-07 (cutouts); BLEND is transparency.
        if m.alpha_mode() != gltf::material::AlphaMode::Blend {
            continue;
        }
        let i = m.index().unwrap_or(0);
        see_through.push(format!("{i} ('{}')", m.name().unwrap_or("")));
    }
    if !see_through.is_empty() {
        out.push(format!(
            "'{name}': {} alphaMode BLEND; lightlearn renders it opaque (no transparency; MASK cutouts are read)",
            listed("material", "has", "have", &see_through)
        ));
    }
    // bsdf.glsl's MIN_ALPHA (GGX α = roughness² ≥ 1e-3): a smoother glossy layer renders at
    // this roughness, so a mirror of roughness 0 reflected a slightly blurred scene in
    // silence, where pbrt-v4 renders it perfectly specular (an audit, 2026-12-07).
    let smoothest = 1.0e-3f32.sqrt();
    let mirrors: Vec<String> = doc
        .materials()
        .filter(|m| {
            let pbr = m.pbr_metallic_roughness();
            let layer = m.specular().map_or(1.0, |sp| {
                sp.specular_factor() * sp.specular_color_factor().into_iter().fold(0.0, f32::max)
            });
            pbr.roughness_factor() < smoothest && (pbr.metallic_factor() > 0.0 || layer > 0.0)
        })
        .map(|m| {
            let roughness = m.pbr_metallic_roughness().roughness_factor();
            let i = m.index().unwrap_or(0);
            format!("{i} ('{}', {roughness})", m.name().unwrap_or(""))
        })
        .collect();
    if !mirrors.is_empty() {
        out.push(format!(
            "'{name}': {} a roughnessFactor below {smoothest:.4}; lightlearn renders glossy reflections no smoother than that (GGX α 1e-3, no perfect mirrors), so they come out slightly blurred",
            listed("material", "has", "have", &mirrors)
        ));
    }
    let (mut skinned, mut morphed) = (Vec::new(), Vec::new());
    for node in doc.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        let label = format!("{} ('{}')", node.index(), node.name().unwrap_or(""));
        if node.skin().is_some() {
            skinned.push(label.clone());
        }
        let morphs = mesh.primitives().any(|p| p.morph_targets().len() > 0);
        let weights = node.weights().or(mesh.weights()).unwrap_or(&[]);
        if morphs && weights.iter().any(|w| *w != 0.0) {
            morphed.push(label);
        }
    }
    // glTF multiplies COLOR_0 into the base colour (§3.9.2); an exporter writes it where a
    // material paints with vertex colours, which rendered as the plain factor in silence (an
    // audit, 2026-12-07). Sets beyond COLOR_0 mean nothing to a glTF material.
    let painted: Vec<String> = doc
        .meshes()
        .filter(|m| {
            m.primitives()
                .any(|p| p.get(&gltf::Semantic::Colors(0)).is_some())
        })
        .map(|m| format!("{} ('{}')", m.index(), m.name().unwrap_or("")))
        .collect();
    if !painted.is_empty() {
        out.push(format!("'{name}': {} vertex colours (COLOR_0), which glTF multiplies into the base colour; lightlearn renders without them", listed("mesh", "has", "have", &painted)));
    }
    if !skinned.is_empty() {
        out.push(format!("'{name}': {} skinned; lightlearn renders the meshes as stored (the bind pose), without the skin", listed("node", "is", "are", &skinned)));
    }
    if !morphed.is_empty() {
        out.push(format!("'{name}': {} morph-target weights; lightlearn renders the meshes without morph targets", listed("node", "has", "have", &morphed)));
    }
    out
}

/// "node 3 ('a') is" or "nodes 3 ('a'), 4 ('b') and 2 more are": up to three named.
fn listed(kind: &str, one: &str, many: &str, items: &[String]) -> String {
    match items {
        [only] => format!("{kind} {only} {one}"),
        _ => {
            let shown = items[..items.len().min(3)].join(", ");
            let more = match items.len().saturating_sub(3) {
                0 => String::new(),
                n => format!(" and {n} more"),
            };
            format!("{kind}s {shown}{more} {many}")
        }
    }
}

/// Nodes with both a matrix and a translation, rotation or scale (glTF 2.0 §5.25: "when
/// matrix is defined, translation, rotation, and scale MUST NOT be defined"): the matrix is
/// used and the rest ignored, which was silent (an audit, 2026-12-06). A warning, not a
/// refusal: exporters that write both usually write the same transform twice.
pub fn matrix_with_trs(root: &Root, name: &str) -> Vec<String> {
    root.nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| {
            n.matrix.is_some()
                && (n.translation.is_some() || n.rotation.is_some() || n.scale.is_some())
        })
        .map(|(i, n)| {
            format!(
                "'{name}': node {i} ('{}') has both a matrix and a translation, rotation or scale, which glTF forbids; the matrix is used (export it again to silence this)",
                n.name.as_deref().unwrap_or("")
            )
        })
        .collect()
}

/// Extensions a file uses on its elements without listing them in `extensionsUsed` (an
/// invalid file, the validator's UNDECLARED_EXTENSION, which exporters still write) and that
/// lightlearn does not read: `unsupported_features` reads the list only, so a texture
/// transform or transmission rendered without them in silence (an audit, 2026-12-07). The
/// JSON is walked once more as a stream, keeping only the keys of `extensions` objects and
/// skipping `extras` (an application's own data): a `.gltf` of `data:` buffers is mostly one
/// long string, which is not copied.
pub fn undeclared_extensions(bytes: &[u8], doc: &gltf::Document, name: &str) -> Option<String> {
    let glb = if bytes.starts_with(b"glTF") {
        Some(gltf::binary::Glb::from_slice(bytes).ok()?)
    } else {
        None
    };
    let json: &[u8] = glb.as_ref().map_or(bytes, |g| &g.json);
    let mut found = std::collections::BTreeSet::new();
    let mut de = serde_json::Deserializer::from_slice(json);
    serde::de::DeserializeSeed::deserialize(
        Walk {
            found: &mut found,
            keys: false,
        },
        &mut de,
    )
    .ok()?;
    let listed: Vec<&str> = doc.extensions_used().collect();
    let unread: Vec<&str> = (found.iter().map(String::as_str))
        .filter(|e| !listed.contains(e) && !SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    let them = if unread.len() > 1 { "them" } else { "it" };
    (!unread.is_empty()).then(|| {
        format!(
            "'{name}' uses {} without listing {them} in extensionsUsed (an invalid file); lightlearn does not read {them} and renders without {them} (read: {})",
            unread.join(", "),
            SUPPORTED_EXTENSIONS.join(", ")
        )
    })
}

/// A JSON value walked for the keys of its `extensions` objects (`keys`: this value is one,
/// so its own keys are extension names).
struct Walk<'a> {
    found: &'a mut std::collections::BTreeSet<String>,
    keys: bool,
}

impl<'de> serde::de::DeserializeSeed<'de> for Walk<'_> {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> serde::de::Visitor<'de> for Walk<'_> {
    type Value = ();
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("JSON")
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut m: A) -> Result<(), A::Error> {
        while let Some(k) = m.next_key::<std::borrow::Cow<'de, str>>()? {
            if self.keys {
                self.found.insert(k.to_string());
            }
            if k == "extras" {
                m.next_value::<serde::de::IgnoredAny>()?;
            } else {
                let keys = k == "extensions";
                m.next_value_seed(Walk {
                    found: &mut *self.found,
                    keys,
                })?;
            }
        }
        Ok(())
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut s: A) -> Result<(), A::Error> {
        while s
            .next_element_seed(Walk {
                found: &mut *self.found,
                keys: false,
            })?
            .is_some()
        {}
        Ok(())
    }
    fn visit_str<E>(self, _: &str) -> Result<(), E> {
        Ok(())
    }
    fn visit_bool<E>(self, _: bool) -> Result<(), E> {
        Ok(())
    }
    fn visit_i64<E>(self, _: i64) -> Result<(), E> {
        Ok(())
    }
    fn visit_u64<E>(self, _: u64) -> Result<(), E> {
        Ok(())
    }
    fn visit_f64<E>(self, _: f64) -> Result<(), E> {
        Ok(())
    }
    fn visit_unit<E>(self) -> Result<(), E> {
        Ok(())
    }
}
