//! glTF 2.0 loading (.gltf with external or `data:` buffers, and .glb).
//!
//! Conventions (also in the README):
//! - KHR_lights_punctual `intensity × color` is radiant intensity in W/sr (directional lights:
//!   irradiance in W/m²); `range` is ignored (physically based falloff only).
//! - Emission `emissiveFactor × KHR_materials_emissive_strength` is radiance, emitted from the
//!   counter-clockwise front face, from both faces when the material is `doubleSided`. Every
//!   triangle with non-zero emission is an area light.
//! - Point and line primitives are skipped with a warning (an error if nothing else is left);
//!   triangle strips and fans are converted to triangles.
//! - Materials: glTF metallic-roughness (Lambert + GGX; the diffuse base coupled to the
//!   layer as in shaders/shared/bsdf.glsl, which says why) with KHR_materials_specular factors; metallic-roughness, normal and specular textures are
//!   ignored with a warning.
//! - The first camera in the scene is used, else a default camera that frames the scene.

use std::path::Path;

use anyhow::{anyhow, bail, Result};
use glam::{DMat4, DQuat, DVec3, Quat, Vec3};

use super::animation::{Animations, Pose};
pub use super::frame::{Frame, NATIVE_SIZES};
use super::gltf_camera::{read_camera, Clip, View};
use super::gltf_check::guarded;
use super::gltf_data::{load_buffers, Images};
use super::gltf_light::read_light;
use super::gltf_material::MaterialTable;
use super::gltf_mesh::Meshes;
use super::{Camera, Light, Scene};

pub use super::gltf_mesh::MAX_TRIANGLES;

/// Load a glTF/GLB file in its own pose (animations not applied). Warnings (skipped
/// primitives, unsupported lights) go to `warn`.
pub fn load(path: &Path, warn: &mut dyn FnMut(String)) -> Result<Scene> {
    open(path, warn)?.scene(&Pose::default(), None, warn)
}

/// Load from bytes; `name` is used in messages and `base` resolves relative buffer URIs.
pub fn load_bytes(
    bytes: &[u8],
    name: &str,
    base: &Path,
    warn: &mut dyn FnMut(String),
) -> Result<Scene> {
    open_bytes(bytes, name, base, warn)?.scene(&Pose::default(), None, warn)
}

/// Reads and parses a glTF/GLB file (and its buffers and animations).
pub fn open(path: &Path, warn: &mut dyn FnMut(String)) -> Result<Document> {
    // A scene file larger than this is not a scene (the largest generated, 10^6 lights, is
    // ~0.2 GB); a FIFO or device is refused before it is opened (reading one blocked).
    let bytes = crate::io::read_regular(path, 1 << 34).map_err(|e| {
        anyhow!(
            "cannot read scene file '{}': {e}. Check the path (run `lightlearn render --help` for usage).",
            path.display()
        )
    })?;
    let name = path.display().to_string();
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    open_bytes(&bytes, &name, &base, warn)
}

pub use super::gltf_data::input_files;

/// Parses a glTF/GLB file from bytes; `name` is used in messages and `base` resolves
/// relative buffer URIs.
pub fn open_bytes(
    bytes: &[u8],
    name: &str,
    base: &Path,
    warn: &mut dyn FnMut(String),
) -> Result<Document> {
    guarded(name, || {
        let (gltf, dropped) = super::gltf_parse::parse(bytes, name).map_err(|e| {
            anyhow!(
                "'{name}' is not a valid glTF 2.0 file (.gltf or .glb): {e}. \
                 Export it again or check it with the Khronos glTF validator."
            )
        })?;
        if let Some(w) = dropped {
            warn(w);
        }
        super::gltf_check::check(gltf.as_json(), name)?;
        for w in super::gltf_warn::unsupported_features(&gltf.document, name)
            .into_iter()
            .chain(super::gltf_warn::matrix_with_trs(gltf.as_json(), name))
            .chain(super::gltf_warn::undeclared_extensions(
                bytes,
                &gltf.document,
                name,
            ))
        {
            warn(w);
        }
        for node in gltf.document.nodes() {
            if let gltf::scene::Transform::Decomposed { rotation, .. } = node.transform() {
                if !super::gltf_check::rotation_is_unit(rotation) {
                    let len = super::gltf_check::rotation_length(rotation);
                    warn(format!("'{name}': {} has a rotation quaternion of length {len}, not 1; normalized (export it again to silence this)", node_label(&node)));
                }
            }
        }
        let buffers = load_buffers(&gltf, name, base)?;
        if let Some(w) = super::gltf_mesh::reversed_normals_warning(&gltf.document, &buffers, name)
        {
            warn(w);
        }
        let animations = Animations::read(&gltf.document, &buffers, name, warn)?;
        // An animated node's matrix is split into TRS for the channels to replace
        // (walk below), which drops any shear: glTF forbids the pair (§3.7.3.1); said,
        // not silent (a left note of 2026-12-07).
        for n in animations.animated_nodes() {
            if let Some(node) = gltf.document.nodes().nth(n) {
                if let gltf::scene::Transform::Matrix { .. } = node.transform() {
                    warn(format!("'{name}': {} is animated but has a matrix, which glTF forbids (animated nodes use translation, rotation, scale); in an animation the matrix is split into those for the channels to replace, dropping any shear (export it with TRS to silence this)", node_label(&node)));
                }
            }
        }
        Ok(Document {
            gltf,
            buffers,
            name: name.to_string(),
            base: base.to_path_buf(),
            animations,
        })
    })
}

/// A parsed and checked glTF file: every pose of it is flattened from this.
pub struct Document {
    gltf: gltf::Gltf,
    buffers: Vec<Vec<u8>>,
    name: String,
    base: std::path::PathBuf,
    pub animations: Animations,
}

impl Document {
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The scene with the animated nodes in `pose`, in `frame` (None: the scene's own, from
    /// its bounds in this pose). A sequence of poses renders in one frame, so that regions
    /// and learned statistics stay where they were.
    pub fn scene(
        &self,
        pose: &Pose,
        frame: Option<Frame>,
        warn: &mut dyn FnMut(String),
    ) -> Result<Scene> {
        guarded(&self.name, || self.flatten(pose, frame, warn))
    }

    /// World bounds (f64) of the scene in `pose`, from the meshes' POSITION bounds (glTF
    /// requires min/max there; where absent, the vertices are read) transformed as boxes,
    /// and the punctual lights: conservative, and cheap for a large scene.
    pub fn pose_bounds(&self, pose: &Pose) -> Result<(DVec3, DVec3)> {
        guarded(&self.name, || {
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            self.walk(pose, &mut |node, world| {
                if let Some(mesh) = node.mesh() {
                    for prim in mesh.primitives() {
                        let (blo, bhi) = match accessor_box(&prim) {
                            Some(b) => b,
                            None => {
                                let reader = prim
                                    .reader(|b| self.buffers.get(b.index()).map(|v| v.as_slice()));
                                let mut b = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                                for p in reader.read_positions().into_iter().flatten() {
                                    let p = Vec3::from(p).as_dvec3();
                                    b = (b.0.min(p), b.1.max(p));
                                }
                                b
                            }
                        };
                        if !blo.is_finite() || !bhi.is_finite() {
                            continue;
                        }
                        for c in 0..8 {
                            let corner = DVec3::new(
                                if c & 1 == 0 { blo.x } else { bhi.x },
                                if c & 2 == 0 { blo.y } else { bhi.y },
                                if c & 4 == 0 { blo.z } else { bhi.z },
                            );
                            let p = world.transform_point3(corner);
                            lo = lo.min(p);
                            hi = hi.max(p);
                        }
                    }
                }
                // A directional light has no place (a sun's node far out would widen the
                // animation's grid for nothing).
                if node
                    .light()
                    .is_some_and(|l| !super::gltf_light::is_directional(&l))
                {
                    let p = world.transform_point3(DVec3::ZERO);
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                Ok(())
            })?;
            Ok((lo, hi))
        })
    }

    /// Depth-first over the node hierarchy with accumulated world transforms (the pose's
    /// TRS for animated nodes), in document order.
    fn walk(
        &self,
        pose: &Pose,
        visit: &mut dyn FnMut(&gltf::Node, DMat4) -> Result<()>,
    ) -> Result<()> {
        let name = &self.name;
        let doc = &self.gltf.document;
        let gltf_scene = doc
            .default_scene()
            .or_else(|| doc.scenes().next())
            .ok_or_else(|| anyhow!("'{name}' has no scene (glTF `scenes` is empty); add a scene that lists the root nodes"))?;
        // The stack is filled in reverse, so triangles and lights keep the file's order.
        let mut stack: Vec<(gltf::Node, DMat4)> =
            gltf_scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
        stack.reverse();
        let mut visited = 0usize;
        while let Some((node, parent)) = stack.pop() {
            // gltf_check::check_node_tree refused cycles and shared children, so each node
            // comes once; this only guards that. (A fixed 1 000 000 here refused a flat file
            // of more nodes, `scene strings --lights 1000000`, as "too deep or cyclic": an
            // audit, 2026-12-06.)
            visited += 1;
            if visited > doc.nodes().len() {
                bail!("'{name}': the node hierarchy is not a tree (a node is reached twice); give each node one parent");
            }
            let local = match pose.nodes.get(&node.index()) {
                Some(p) => {
                    let (t, r, s) = node.transform().decomposed();
                    let (t, r, s) = p.apply((Vec3::from(t), Quat::from_array(r), Vec3::from(s)));
                    DMat4::from_scale_rotation_translation(
                        s.as_dvec3(),
                        DQuat::from_array(r.to_array().map(f64::from)).normalize(),
                        t.as_dvec3(),
                    )
                }
                None => match node.transform() {
                    // A rotation of another length than 1 (warned about on open): normalized,
                    // where its matrix would skew.
                    gltf::scene::Transform::Decomposed {
                        translation,
                        rotation,
                        scale,
                    } if !super::gltf_check::rotation_is_unit(rotation) => {
                        DMat4::from_scale_rotation_translation(
                            DVec3::from_array(scale.map(f64::from)),
                            DQuat::from_array(rotation.map(f64::from)).normalize(),
                            DVec3::from_array(translation.map(f64::from)),
                        )
                    }
                    t => DMat4::from_cols_array_2d(&t.matrix().map(|c| c.map(f64::from))),
                },
            };
            let world = parent * local;
            if !world.is_finite() {
                bail!(
                    "'{name}': {} has a non-finite transform (NaN or Inf); fix its matrix/TRS",
                    node_label(&node)
                );
            }
            visit(&node, world)?;
            let first_child = stack.len();
            stack.extend(node.children().map(|c| (c, world)));
            stack[first_child..].reverse();
        }
        Ok(())
    }

    fn flatten(
        &self,
        pose: &Pose,
        frame: Option<Frame>,
        warn: &mut dyn FnMut(String),
    ) -> Result<Scene> {
        let name = self.name.as_str();
        let buffers = &self.buffers;
        let base = self.base.as_path();
        let mut scene = Scene {
            triangles: Vec::new(),
            triangle_material: Vec::new(),
            materials: Vec::new(),
            lights: Vec::new(),
            directional: Vec::new(),
            camera: Camera::framing(Vec3::ZERO, Vec3::ONE),
            textures: Vec::new(),
            triangle_uv: Vec::new(),
            triangle_normals: Vec::new(),
            triangle_tangents: Vec::new(),
            source: name.to_string(),
            grid_box: None,
            camera_aspect: None,
        };
        let mut table = MaterialTable::new(Images {
            buffers,
            base,
            file: name,
        });
        let mut camera: Option<View> = None;
        // The camera's znear and zfar in world units, which only a warning reads.
        let mut clip: Option<Clip> = None;
        // World positions in f64 until the scene's origin is known (below): a scene far from its
        // file's origin (a node translation of 1e7) keeps full f32 precision around itself.
        let mut meshes = Meshes::default();
        let mut light_positions: Vec<DVec3> = Vec::new();
        // The punctual lights' names ("light K ('name')"), in the order of light_positions.
        let mut light_labels: Vec<String> = Vec::new();
        let mut lights_with_range = 0usize;

        self.walk(pose, &mut |node, world| {
            if let Some(mesh) = node.mesh() {
                meshes.add(&mesh, world, buffers, name, &mut table, warn)?;
            }

            if camera.is_none() {
                if let Some(cam) = node.camera() {
                    if let Some((view, planes)) = read_camera(&cam, node, world, name, warn)? {
                        camera = Some(view);
                        clip = Some(planes);
                    }
                }
            }

            if let Some(light) = node.light().filter(super::gltf_light::is_directional) {
                // Parallel light: the scene's frame (a shift and a scale) changes neither its
                // direction nor its irradiance.
                let sun = super::gltf_light::read_directional(
                    &light,
                    world,
                    &node_label(node),
                    name,
                    warn,
                )?;
                scene.directional.extend(sun);
            } else if let Some(light) = node.light() {
                lights_with_range += light.range().is_some() as usize;
                if let Some((l, position, label)) =
                    read_light(&light, world, &node_label(node), name, warn)?
                {
                    light_positions.push(position);
                    light_labels.push(label);
                    scene.lights.push(l);
                }
            }

            Ok(())
        })?;
        let Meshes {
            triangles,
            triangle_uv,
            triangle_normals,
            triangle_tangents,
            triangle_material,
            skipped_primitives,
            lost_to_position,
            lost_emitters,
            hidden_emitters,
        } = meshes;
        scene.triangle_uv = triangle_uv;
        scene.triangle_material = triangle_material;
        scene.textures = table.textures;
        let materials = table.materials;

        if lights_with_range > 0 {
            warn(format!(
            "'{name}': {lights_with_range} lights set `range`; lightlearn ignores it (inverse-square falloff only)"
        ));
        }
        scene.camera_aspect = clip.and_then(|c| c.aspect);
        if let (Some(c), Some((position, forward, _, yfov))) = (&clip, &camera) {
            if let Some(w) = c.unapplied(name, *position, *forward, *yfov, &triangles) {
                warn(w);
            }
        }
        let (lo0, hi0) = super::frame::bounds64(&triangles, &light_positions);
        let frame = frame.unwrap_or_else(|| Frame::of(lo0, hi0));
        for (l, p) in scene.lights.iter_mut().zip(&light_positions) {
            if let Light::Point {
                position,
                intensity,
            }
            | Light::Spot {
                position,
                intensity,
                ..
            } = l
            {
                *position = frame.to_local(*p);
                // Irradiance I / d² stays what it was when lengths are × unit.
                *intensity *= (frame.unit * frame.unit) as f32;
            }
        }
        // Triangles in f32 about the origin; one that rounds to zero area is dropped with its
        // material and texture coordinates.
        let extent = (hi0 - lo0).max_element();
        let local = frame
            .triangles(&triangles, extent, |i| {
                materials[scene.triangle_material[i] as usize]
                    .emission
                    .max_element()
                    > 0.0
            })
            .map_err(|i| anyhow!("'{name}': triangle {i} lies beyond the range of 32-bit floats ({:?}); scale the scene down", triangles[i][0]))?;
        let uv = std::mem::take(&mut scene.triangle_uv);
        if !uv.is_empty() {
            scene.triangle_uv = (local.kept.iter())
                .map(|&i| uv.get(i).copied().unwrap_or([[0.0; 2]; 3]))
                .collect();
        }
        if !triangle_normals.is_empty() {
            scene.triangle_normals = (local.kept.iter())
                .map(|&i| triangle_normals.get(i).copied().unwrap_or([Vec3::ZERO; 3]))
                .collect();
        }
        if !triangle_tangents.is_empty() {
            scene.triangle_tangents = (local.kept.iter())
                .map(|&i| (triangle_tangents.get(i).copied()).unwrap_or([glam::Vec4::ZERO; 3]))
                .collect();
        }
        scene.triangle_material = local
            .kept
            .iter()
            .map(|&i| scene.triangle_material[i])
            .collect();
        scene.triangles.extend(local.triangles);
        let collapsed_emitters = local.collapsed_emitters + lost_emitters;
        let total = triangles.len() + lost_to_position;
        let notes: Vec<String> = [
            (local.collapsed > 0).then(|| {
                // The extent they were measured against: an animation's frame spans all its
                // poses, and the message gave this pose's own (an audit, 2026-12-07).
                let span = frame.span(extent);
                let beside = if let (Some(t), true) = (frame.far_pose, span > 1.5 * extent) {
                    format!("the {span:.3e} units the animation's poses span together (its pose at t = {t} s reaches farthest; this pose: {extent:.3e})")
                } else {
                    format!("the scene's extent of {extent:.3e} units")
                };
                format!(
                    "{} of {total} triangles are too small to keep in 32-bit floats beside {beside} (an object or light far out of scale with the rest?)",
                    local.collapsed
                )
            }),
            (lost_to_position > 0).then(|| format!(
                "{lost_to_position} of {total} triangles lose their area where their node's transform puts them: floating point cannot hold their size that far out (a translation far out of range?)"
            )),
        ]
        .into_iter()
        .flatten()
        .collect();
        let collapse_note = (!notes.is_empty()).then(|| notes.join("; "));
        let out_of_scale = |what: &str| {
            match &collapse_note {
            Some(note) => anyhow!("'{name}' has no {what} left: {note}; bring every node's scale and position within a few orders of magnitude"),
            None => anyhow!("'{name}' has no {what}"),
        }
        };
        if let Some(note) = &collapse_note {
            if scene.triangles.is_empty() {
                return Err(out_of_scale("triangles"));
            }
            warn(format!("'{name}': {note}; they are left out"));
        }
        if scene.triangles.is_empty() {
            let extra = if skipped_primitives > 0 {
                format!(" ({skipped_primitives} point/line primitives were skipped)")
            } else {
                String::new()
            };
            // Triangles the file has, each rounded to a sliver beside an extent they span
            // themselves (a floor with one vertex at 3e38): not "no triangles" (an audit,
            // 2026-12-06).
            if !triangles.is_empty() {
                bail!("'{name}': all {} of its triangles round to zero area in 32-bit floats beside the scene's extent of {extent:.3e} units (a vertex or node far out of scale with the rest?); bring every position within a few orders of magnitude", triangles.len());
            }
            // Which scene, where there are several: `"scene": 1` naming an empty one gave the
            // same words as a file without meshes (an audit, 2026-12-06).
            let doc = &self.gltf.document;
            let which = match doc.default_scene() {
                Some(sc) if doc.scenes().len() > 1 => format!(
                    " in scene {} ('{}'), the one its `scene` names (the file has {})",
                    sc.index(),
                    sc.name().unwrap_or(""),
                    doc.scenes().len()
                ),
                _ => String::new(),
            };
            bail!("'{name}' has no triangles{which}{extra}; lightlearn needs triangle meshes to render");
        }

        // Every emissive triangle is an area light.
        for (i, &m) in scene.triangle_material.iter().enumerate() {
            if materials[m as usize].emission.max_element() > 0.0 {
                scene.lights.push(Light::Triangle { triangle: i as u32 });
            }
        }
        scene.materials = materials;
        if scene.textures.is_empty() {
            scene.triangle_uv = Vec::new();
        } else {
            scene
                .triangle_uv
                .resize(scene.triangles.len(), [[0.0; 2]; 3]);
        }
        if scene.lights.is_empty() {
            // Blame the scale only where emitting triangles were lost to it.
            if collapsed_emitters > 0 {
                return Err(out_of_scale("lights"));
            }
            if hidden_emitters > 0 {
                bail!(
                    "'{name}' has no lights in this pose: its {hidden_emitters} emitting triangles are scaled to nothing (a node scale of 0, or an animation keyed to one); a render needs one: give those nodes a non-zero scale (at this time, for an animation)"
                );
            }
            if !scene.directional.is_empty() {
                bail!(
                    "'{name}' has only directional lights ({}); lightlearn's light samplers need at least one point, spot or emissive light beside them: add one",
                    scene.directional.len()
                );
            }
            bail!(
            "'{name}' has no lights: add KHR_lights_punctual point/spot lights or give a material a non-zero emissiveFactor"
        );
        }
        scene.check_light_power(name, &light_labels, (hi0 - lo0).length())?;
        let (lo, hi) = scene.bounds();
        scene.camera = match camera {
            Some((position, forward, up, yfov)) => Camera::looking(
                frame.to_local(position),
                forward.as_vec3(),
                up.as_vec3(),
                yfov,
            ),
            None => Camera::framing(lo, hi),
        };
        Ok(scene)
    }
}

/// A primitive's POSITION bounds from its accessor's min/max, where given.
fn accessor_box(prim: &gltf::Primitive) -> Option<(DVec3, DVec3)> {
    let acc = prim.get(&gltf::Semantic::Positions)?;
    let read = |v: Option<gltf::json::Value>| -> Option<DVec3> {
        let a = v?;
        let a = a.as_array()?;
        if a.len() != 3 {
            return None;
        }
        Some(DVec3::new(a[0].as_f64()?, a[1].as_f64()?, a[2].as_f64()?))
    };
    Some((read(acc.min())?, read(acc.max())?))
}

fn node_label(node: &gltf::Node) -> String {
    format!("node {} ('{}')", node.index(), node.name().unwrap_or(""))
}
