//! A small glTF 2.0 writer: the procedural scenes and the tests build their scenes through it,
//! so every scene we render is also a file any other renderer can open.
//!
//! Output is deterministic: JSON objects are key-sorted (serde_json's default map) and the
//! binary buffer is laid out in call order, so the same calls give byte-identical files.

use glam::{Mat3, Quat, Vec3};
use serde_json::value::RawValue;
use serde_json::{json, Value};

#[derive(Default)]
pub struct GltfBuilder {
    bin: Vec<u8>,
    buffer_views: Vec<Value>,
    accessors: Vec<Value>,
    materials: Vec<Value>,
    meshes: Vec<Value>,
    /// Nodes and lights as their JSON text: a scene of a million punctual lights held them
    /// as `Value` maps (~3 KB each), copied them again into the document, and `scene strings
    /// --lights 1000000` took 6.6 GB (an audit, 2026-12-06).
    nodes: Vec<Box<RawValue>>,
    lights: Vec<Box<RawValue>>,
    cameras: Vec<Value>,
    images: Vec<Value>,
    samplers: Vec<Value>,
    textures: Vec<Value>,
    /// Triangles in the meshes so far.
    triangles: usize,
    /// One animation's channels and samplers (written when any were added).
    channels: Vec<Value>,
    anim_samplers: Vec<Value>,
}

impl GltfBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a Lambertian material (metallic 0 and KHR_materials_specular specularFactor 0, so
    /// glTF's 4 % dielectric specular layer is off and any renderer that reads the extension
    /// sees base colour / π); `emission` is radiance, stored as emissiveFactor (max component
    /// ≤ 1) × KHR_materials_emissive_strength.
    pub fn material(
        &mut self,
        name: &str,
        base_color: Vec3,
        emission: Vec3,
        double_sided: bool,
    ) -> usize {
        let strength = emission.max_element().max(1.0);
        let factor = emission / strength;
        let mut m = json!({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [base_color.x, base_color.y, base_color.z, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0
            },
            "emissiveFactor": [factor.x, factor.y, factor.z],
            "doubleSided": double_sided
        });
        m["extensions"] = json!({"KHR_materials_specular": {"specularFactor": 0.0}});
        if strength != 1.0 {
            m["extensions"]["KHR_materials_emissive_strength"] =
                json!({"emissiveStrength": strength});
        }
        self.materials.push(m);
        self.materials.len() - 1
    }

    /// Adds a plain glTF metallic-roughness material (no extensions: a metallic 0 material
    /// has the 4 % dielectric specular layer on a Lambertian base), one-sided, not emitting.
    pub fn glossy_material(
        &mut self,
        name: &str,
        base_color: Vec3,
        metallic: f32,
        roughness: f32,
    ) -> usize {
        self.materials.push(json!({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [base_color.x, base_color.y, base_color.z, 1.0],
                "metallicFactor": metallic,
                "roughnessFactor": roughness
            }
        }));
        self.materials.len() - 1
    }

    /// Adds a PNG image as a texture with wrap modes (glTF codes: 10497 repeat, 33071 clamp
    /// to edge, 33648 mirrored repeat) for wrapS and wrapT; returns the texture index.
    pub fn texture_png(&mut self, png: &[u8], wrap: [u32; 2]) -> usize {
        self.texture_png_filtered(png, wrap, None)
    }

    /// [`Self::texture_png`] with the sampler's magFilter (glTF's GL code: 9728 NEAREST,
    /// 9729 LINEAR).
    pub fn texture_png_filtered(&mut self, png: &[u8], wrap: [u32; 2], mag: Option<u32>) -> usize {
        self.texture_image(png, "image/png", wrap, mag)
    }

    /// A texture of an image in the file's buffer (`mime`: image/png or image/jpeg), with
    /// the sampler's wrap modes and magFilter.
    pub fn texture_image(
        &mut self,
        image: &[u8],
        mime: &str,
        wrap: [u32; 2],
        mag: Option<u32>,
    ) -> usize {
        let view = self.push_view(image, None);
        self.images
            .push(json!({"bufferView": view, "mimeType": mime}));
        let mut sampler = json!({"wrapS": wrap[0], "wrapT": wrap[1]});
        if let Some(m) = mag {
            sampler["magFilter"] = json!(m);
        }
        self.samplers.push(sampler);
        self.textures.push(json!({
            "source": self.images.len() - 1, "sampler": self.samplers.len() - 1
        }));
        self.textures.len() - 1
    }

    /// Gives a material a base-colour texture (it multiplies baseColorFactor).
    pub fn set_base_color_texture(&mut self, material: usize, texture: usize) {
        self.materials[material]["pbrMetallicRoughness"]["baseColorTexture"] =
            json!({"index": texture});
    }

    /// Gives a material an emissive texture (it multiplies emissiveFactor, so the material's
    /// emission must not be 0).
    pub fn set_emissive_texture(&mut self, material: usize, texture: usize) {
        self.materials[material]["emissiveTexture"] = json!({"index": texture});
    }

    /// Gives a material a metallic-roughness texture (linear; its green multiplies
    /// roughnessFactor, its blue metallicFactor).
    pub fn set_metallic_roughness_texture(&mut self, material: usize, texture: usize) {
        self.materials[material]["pbrMetallicRoughness"]["metallicRoughnessTexture"] =
            json!({"index": texture});
    }

    /// Makes a material a cutout (alphaMode MASK) of baseColorFactor alpha `alpha` and
    /// `cutoff` (None: glTF's default 0.5).
    pub fn set_alpha_mask(&mut self, material: usize, alpha: f32, cutoff: Option<f32>) {
        let m = &mut self.materials[material];
        m["alphaMode"] = json!("MASK");
        m["pbrMetallicRoughness"]["baseColorFactor"][3] = json!(alpha);
        if let Some(c) = cutoff {
            m["alphaCutoff"] = json!(c);
        }
    }

    /// Gives a material a normal texture (linear, tangent space) of `scale`.
    pub fn set_normal_texture(&mut self, material: usize, texture: usize, scale: f32) {
        self.materials[material]["normalTexture"] = json!({"index": texture, "scale": scale});
    }

    /// Gives the last mesh's primitive a VEC4 float attribute (e.g. TANGENT), one a vertex.
    pub fn attribute_on_last_mesh(&mut self, semantic: &str, values: &[glam::Vec4]) {
        let bytes: Vec<u8> = (values.iter())
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let v = self.push_view(&bytes, Some(34962));
        self.accessors.push(json!({
            "bufferView": v, "componentType": 5126, "count": values.len(), "type": "VEC4"
        }));
        let a = self.accessors.len() - 1;
        let mesh = self.meshes.last_mut().expect("a mesh");
        mesh["primitives"][0]["attributes"][semantic] = json!(a);
    }

    fn push_view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        let mut view = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.buffer_views.push(view);
        self.buffer_views.len() - 1
    }

    /// Adds a triangle mesh in world space (on a node with the identity transform).
    pub fn mesh(&mut self, name: &str, positions: &[Vec3], indices: &[u32], material: usize) {
        self.mesh_uv(name, positions, None, indices, material);
    }

    /// [`Self::mesh`] with texture coordinates (TEXCOORD_0) per vertex.
    pub fn mesh_uv(
        &mut self,
        name: &str,
        positions: &[Vec3],
        uvs: Option<&[[f32; 2]]>,
        indices: &[u32],
        material: usize,
    ) {
        self.mesh_with(name, positions, uvs, None, indices, material);
    }

    /// [`Self::mesh_uv`] with vertex normals (NORMAL) too: smooth shading.
    pub fn mesh_with(
        &mut self,
        name: &str,
        positions: &[Vec3],
        uvs: Option<&[[f32; 2]]>,
        normals: Option<&[Vec3]>,
        indices: &[u32],
        material: usize,
    ) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in positions {
            for k in 0..3 {
                if p[k].is_finite() {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let pos_bytes: Vec<u8> = positions
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let idx_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let pv = self.push_view(&pos_bytes, Some(34962));
        let iv = self.push_view(&idx_bytes, Some(34963));
        self.accessors.push(json!({
            "bufferView": pv, "componentType": 5126, "count": positions.len(),
            "type": "VEC3", "min": lo, "max": hi
        }));
        self.accessors.push(json!({
            "bufferView": iv, "componentType": 5125, "count": indices.len(), "type": "SCALAR"
        }));
        let pa = self.accessors.len() - 2;
        let mut attributes = json!({"POSITION": pa});
        if let Some(uvs) = uvs {
            let bytes: Vec<u8> = uvs.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
            let v = self.push_view(&bytes, Some(34962));
            self.accessors.push(json!({
                "bufferView": v, "componentType": 5126, "count": uvs.len(), "type": "VEC2"
            }));
            attributes["TEXCOORD_0"] = json!(self.accessors.len() - 1);
        }
        if let Some(normals) = normals {
            let bytes: Vec<u8> = (normals.iter())
                .flat_map(|n| n.to_array())
                .flat_map(f32::to_le_bytes)
                .collect();
            let v = self.push_view(&bytes, Some(34962));
            self.accessors.push(json!({
                "bufferView": v, "componentType": 5126, "count": normals.len(), "type": "VEC3"
            }));
            attributes["NORMAL"] = json!(self.accessors.len() - 1);
        }
        self.triangles += indices.len() / 3;
        self.meshes.push(json!({
            "name": name,
            "primitives": [{"attributes": attributes, "indices": pa + 1, "material": material, "mode": 4}]
        }));
        self.nodes
            .push(raw(json!({"name": name, "mesh": self.meshes.len() - 1})));
    }

    /// A quad with corners in counter-clockwise order seen from its front.
    pub fn quad(&mut self, name: &str, c: [Vec3; 4], material: usize) {
        self.mesh(name, &c, &[0, 1, 2, 0, 2, 3], material);
    }

    /// An axis-aligned box with outward-facing (CCW from outside) faces.
    pub fn cuboid(&mut self, name: &str, lo: Vec3, hi: Vec3, material: usize) {
        let (p, i) = box_mesh(lo, hi);
        self.mesh(name, &p, &i, material);
    }

    pub fn point_light(&mut self, name: &str, position: Vec3, color: Vec3, intensity: f32) {
        self.lights.push(raw(json!({
            "name": name, "type": "point", "color": color.to_array(), "intensity": intensity
        })));
        self.nodes.push(raw(json!({
            "name": name, "translation": position.to_array(),
            "extensions": {"KHR_lights_punctual": {"light": self.lights.len() - 1}}
        })));
    }

    #[allow(clippy::too_many_arguments)]
    pub fn spot_light(
        &mut self,
        name: &str,
        position: Vec3,
        direction: Vec3,
        color: Vec3,
        intensity: f32,
        inner_cone: f32,
        outer_cone: f32,
    ) {
        self.lights.push(raw(json!({
            "name": name, "type": "spot", "color": color.to_array(), "intensity": intensity,
            "spot": {"innerConeAngle": inner_cone, "outerConeAngle": outer_cone}
        })));
        let rot = Quat::from_rotation_arc(Vec3::NEG_Z, direction.normalize());
        self.nodes.push(raw(json!({
            "name": name, "translation": position.to_array(), "rotation": rot.to_array(),
            "extensions": {"KHR_lights_punctual": {"light": self.lights.len() - 1}}
        })));
    }

    /// A directional light (the sun) travelling along `direction`, of irradiance
    /// `intensity × color` (glTF lux; W/m² to lightlearn).
    pub fn directional_light(&mut self, name: &str, direction: Vec3, color: Vec3, intensity: f32) {
        self.lights.push(raw(json!({
            "name": name, "type": "directional", "color": color.to_array(), "intensity": intensity
        })));
        let rot = Quat::from_rotation_arc(Vec3::NEG_Z, direction.normalize());
        self.nodes.push(raw(json!({
            "name": name, "rotation": rot.to_array(),
            "extensions": {"KHR_lights_punctual": {"light": self.lights.len() - 1}}
        })));
    }

    /// A perspective camera at `position` looking at `target` (world up +Y).
    pub fn camera(&mut self, position: Vec3, target: Vec3, yfov: f32) {
        let rot = look_rotation(position, target);
        self.cameras.push(json!({
            "type": "perspective",
            "perspective": {"yfov": yfov, "znear": 0.01}
        }));
        self.nodes.push(raw(json!({
            "name": "camera", "camera": self.cameras.len() - 1,
            "translation": position.to_array(), "rotation": rot.to_array()
        })));
    }

    /// Triangles in the meshes added so far.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// The index of the node added last (a mesh, light or camera).
    pub fn last_node(&self) -> usize {
        self.nodes.len() - 1
    }

    /// Animates `node`'s `path` ("translation": xyz keys, "rotation": xyzw keys) with
    /// LINEAR interpolation (rotations by slerp) at `times` (seconds, increasing). All
    /// channels belong to one animation, "animation".
    pub fn animate(&mut self, node: usize, path: &str, times: &[f32], values: &[Vec<f32>]) {
        let width = values.first().map_or(0, Vec::len);
        assert!(values.len() == times.len() && values.iter().all(|v| v.len() == width));
        let t_bytes: Vec<u8> = times.iter().flat_map(|t| t.to_le_bytes()).collect();
        let v_bytes: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let tv = self.push_view(&t_bytes, None);
        let vv = self.push_view(&v_bytes, None);
        let (lo, hi) = (times[0], times[times.len() - 1]);
        self.accessors.push(json!({
            "bufferView": tv, "componentType": 5126, "count": times.len(), "type": "SCALAR",
            "min": [lo], "max": [hi]
        }));
        self.accessors.push(json!({
            "bufferView": vv, "componentType": 5126, "count": values.len(),
            "type": if width == 4 { "VEC4" } else { "VEC3" }
        }));
        let a = self.accessors.len();
        self.anim_samplers
            .push(json!({"input": a - 2, "output": a - 1, "interpolation": "LINEAR"}));
        self.channels.push(json!({
            "sampler": self.anim_samplers.len() - 1, "target": {"node": node, "path": path}
        }));
    }

    /// A camera that moves through `keys` (time, position, target), LINEAR in position and
    /// by slerp in orientation; it rests at the first key.
    pub fn camera_path(&mut self, keys: &[(f32, Vec3, Vec3)], yfov: f32) {
        self.camera(keys[0].1, keys[0].2, yfov);
        let node = self.last_node();
        let times: Vec<f32> = keys.iter().map(|k| k.0).collect();
        let positions: Vec<Vec<f32>> = keys.iter().map(|k| k.1.to_array().to_vec()).collect();
        let rotations: Vec<Vec<f32>> = keys
            .iter()
            .map(|k| look_rotation(k.1, k.2).to_array().to_vec())
            .collect();
        self.animate(node, "translation", &times, &positions);
        self.animate(node, "rotation", &times, &rotations);
    }

    /// The glTF JSON, borrowing the builder's arrays (serialized in place, not copied).
    fn document(&self, buffer_uri: Option<String>) -> Document<'_> {
        let mut buffer = json!({"byteLength": self.padded_bin_len()});
        if let Some(uri) = buffer_uri {
            buffer["uri"] = json!(uri);
        }
        let textured = !self.textures.is_empty();
        let mut used = Vec::new();
        if !self.lights.is_empty() {
            used.push("KHR_lights_punctual");
        }
        for ext in ["KHR_materials_emissive_strength", "KHR_materials_specular"] {
            if self
                .materials
                .iter()
                .any(|m| m["extensions"].get(ext).is_some())
            {
                used.push(ext);
            }
        }
        Document {
            accessors: &self.accessors,
            animations: (!self.channels.is_empty()).then(|| {
                json!([{
                    "name": "animation", "channels": self.channels, "samplers": self.anim_samplers
                }])
            }),
            asset: json!({"version": "2.0", "generator": "lightlearn"}),
            buffer_views: &self.buffer_views,
            buffers: [buffer],
            cameras: (!self.cameras.is_empty()).then_some(self.cameras.as_slice()),
            extensions: (!self.lights.is_empty()).then_some(Extensions {
                lights: Lights {
                    lights: &self.lights,
                },
            }),
            extensions_used: used,
            images: if textured { Some(&self.images) } else { None },
            materials: &self.materials,
            meshes: &self.meshes,
            nodes: &self.nodes,
            samplers: if textured { Some(&self.samplers) } else { None },
            scene: 0,
            scenes: [SceneNodes {
                nodes: (0..self.nodes.len()).collect(),
            }],
            textures: if textured { Some(&self.textures) } else { None },
        }
    }

    fn padded_bin_len(&self) -> usize {
        self.bin.len().next_multiple_of(4)
    }

    fn padded_bin(&self) -> Vec<u8> {
        let mut b = self.bin.clone();
        while !b.len().is_multiple_of(4) {
            b.push(0);
        }
        b
    }

    /// Binary glTF (.glb).
    pub fn to_glb(&self) -> Vec<u8> {
        let mut json = serde_json::to_vec(&self.document(None)).expect("JSON of plain values");
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let bin = self.padded_bin();
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }

    /// Text glTF whose buffer lives in a separate file `bin_name` (returned as bytes).
    pub fn to_gltf_external(&self, bin_name: &str) -> (String, Vec<u8>) {
        let text = serde_json::to_string_pretty(&self.document(Some(bin_name.to_string())))
            .expect("JSON of plain values");
        (text, self.padded_bin())
    }

    /// Text glTF with the buffer embedded as a base64 `data:` URI.
    pub fn to_gltf_embedded(&self) -> String {
        use base64::Engine;
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(self.padded_bin())
        );
        serde_json::to_string_pretty(&self.document(Some(uri))).expect("JSON of plain values")
    }
}

/// Vertices and CCW-outward indices of an axis-aligned box.
pub fn box_mesh(lo: Vec3, hi: Vec3) -> (Vec<Vec3>, Vec<u32>) {
    let p = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { hi.x } else { lo.x },
                if i & 2 != 0 { hi.y } else { lo.y },
                if i & 4 != 0 { hi.z } else { lo.z },
            )
        })
        .collect();
    // Faces as quads (CCW seen from outside): -x, +x, -y, +y, -z, +z.
    let quads = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    let idx = quads
        .iter()
        .flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]])
        .collect();
    (p, idx)
}

/// The rotation of a glTF camera (looking down its −z, up +y) at `position` looking at
/// `target`, world up +Y.
fn look_rotation(position: Vec3, target: Vec3) -> Quat {
    let f = (target - position).normalize();
    let r = f.cross(Vec3::Y).normalize();
    let u = r.cross(f);
    Quat::from_mat3(&Mat3::from_cols(r, u, -f)).normalize()
}

fn raw(v: Value) -> Box<RawValue> {
    serde_json::value::to_raw_value(&v).expect("JSON of plain values")
}

/// A glTF document's top level, its fields in the order serde_json's maps sort keys (so the
/// bytes are those the builder wrote when it assembled a `Value`).
#[derive(serde::Serialize)]
struct Document<'a> {
    accessors: &'a [Value],
    #[serde(skip_serializing_if = "Option::is_none")]
    animations: Option<Value>,
    asset: Value,
    #[serde(rename = "bufferViews")]
    buffer_views: &'a [Value],
    buffers: [Value; 1],
    #[serde(skip_serializing_if = "Option::is_none")]
    cameras: Option<&'a [Value]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    extensions: Option<Extensions<'a>>,
    #[serde(rename = "extensionsUsed", skip_serializing_if = "Vec::is_empty")]
    extensions_used: Vec<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    images: Option<&'a [Value]>,
    materials: &'a [Value],
    meshes: &'a [Value],
    nodes: &'a [Box<RawValue>],
    #[serde(skip_serializing_if = "Option::is_none")]
    samplers: Option<&'a [Value]>,
    scene: u32,
    scenes: [SceneNodes; 1],
    #[serde(skip_serializing_if = "Option::is_none")]
    textures: Option<&'a [Value]>,
}

#[derive(serde::Serialize)]
struct Extensions<'a> {
    #[serde(rename = "KHR_lights_punctual")]
    lights: Lights<'a>,
}

#[derive(serde::Serialize)]
struct Lights<'a> {
    lights: &'a [Box<RawValue>],
}

#[derive(serde::Serialize)]
struct SceneNodes {
    nodes: Vec<usize>,
}
