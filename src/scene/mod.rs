//! The scene as the renderer sees it: world-space triangles, materials, lights and a camera.
//!
//! Everything is flattened at load time (node transforms applied, winding normalised to
//! counter-clockwise = front), so the BVH builder, the light list and the CPU reference all
//! read the same plain arrays.

pub mod animated;
pub mod animation;
pub mod families;
pub mod frame;
pub mod gltf_camera;
pub mod gltf_check;
mod gltf_data;
mod gltf_light;
pub use gltf_data::percent_decode;
pub mod gltf_load;
mod gltf_material;
mod gltf_mesh;
pub(crate) mod gltf_parse;
mod gltf_tangents;
mod gltf_warn;
pub mod gltf_write;

use anyhow::bail;
use glam::Vec3;

/// Rec. 709 luminance: the scalar "power" of a colour used by the power sampler.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// glTF baseColorFactor (rgb): the diffuse albedo of the dielectric part and F0 of the
    /// metal part.
    pub base_color: Vec3,
    /// glTF metallicFactor in [0, 1] (default 1).
    pub metallic: f32,
    /// glTF roughnessFactor in [0, 1] (default 1); GGX α = roughness².
    pub roughness: f32,
    /// KHR_materials_specular specularFactor (default 1): the weight of the dielectric's
    /// specular layer. 0 with metallic 0 is a pure Lambertian material (what our scene
    /// writer emits for `GltfBuilder::material`).
    pub specular: f32,
    /// KHR_materials_specular specularColorFactor (default 1): scales the dielectric F0 (0.04).
    pub specular_color: Vec3,
    /// Emitted radiance (emissiveFactor × KHR_materials_emissive_strength).
    pub emission: Vec3,
    /// Emits from both faces (glTF `doubleSided`); otherwise only from the CCW front face.
    pub double_sided: bool,
    /// Index into `Scene::textures` of the base-colour texture (multiplies `base_color`).
    pub base_color_texture: Option<u32>,
    /// Index into `Scene::textures` of the emissive texture (multiplies `emission`; glTF
    /// `emissiveTexture`, sRGB). It reads the triangles' one coordinate set
    /// (`Scene::triangle_uv`), so it shares the base-colour texture's set where both are given.
    pub emissive_texture: Option<u32>,
    /// Index into `Scene::textures` of the metallic-roughness texture (glTF
    /// `metallicRoughnessTexture`, linear: its green channel multiplies `roughness`, its blue
    /// `metallic`). It reads the triangles' one coordinate set, as the emissive texture does.
    pub metallic_roughness_texture: Option<u32>,
    /// Index into `Scene::textures` of the normal texture (glTF `normalTexture`, linear: a
    /// tangent-space normal, +X along the tangent, +Y along cross(normal, tangent) × its
    /// sign), on the triangles' one coordinate set; its frames are `Scene::triangle_tangents`.
    pub normal_texture: Option<u32>,
    /// glTF `normalTexture.scale`: the texture's X and Y are multiplied by it.
    pub normal_scale: f32,
    /// glTF alphaMode MASK's `alphaCutoff` (None: opaque): where the alpha (`alpha` × the
    /// base-colour texture's alpha) is below it the surface is not there.
    pub alpha_cutoff: Option<f32>,
    /// glTF baseColorFactor's alpha.
    pub alpha: f32,
}

impl Material {
    /// No specular layer at all: the BRDF is base colour / π.
    pub fn is_lambertian(&self) -> bool {
        self.metallic == 0.0 && self.specular == 0.0
    }
}

/// [`Scene::emitted_luminance`]'s floor: a textured emitter's power is never below this
/// fraction of the untextured one's.
pub const EMISSIVE_MEAN_MIN: f32 = 1e-3;

/// How texture coordinates outside [0, 1] wrap (glTF sampler wrapS / wrapT).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat = 0,
    ClampToEdge = 1,
    MirroredRepeat = 2,
}

/// A decoded texture: RGBA8 texels, row by row from the top (the row of texture coordinate
/// v = 0), sampled bilinearly; colour (base colour, emission) sRGB-coded and decoded to linear
/// in the kernel, data (metallic-roughness) `linear` and read as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// The texels as the kernels read them (sRGB-coded), row 0 first: RGBA8 in one
    /// little-endian word a texel, or with `wide` RGBA16 in two (R | G << 16, B | A << 16).
    pub words: Vec<u32>,
    /// 16 bits a channel (a 16-bit PNG): cut to 8 bits they came out up to 9 % dark in the
    /// darkest tones (an audit against Mitsuba 3, 2026-12-07).
    pub wide: bool,
    /// The sampler's magFilter is NEAREST: one texel, no interpolation (else bilinear).
    pub nearest: bool,
    /// wrapS, wrapT.
    pub wrap: [Wrap; 2],
    /// The texels are data, not colour: no sRGB decoding (glTF's metallicRoughnessTexture).
    pub linear: bool,
}

impl Texture {
    /// The linear colour (or data) at texture coordinate `uv`, as shaders/shared/texture.glsl
    /// `sample_texture` reads it (wrap modes, bilinear or nearest, sRGB decoded unless
    /// `linear`).
    pub fn sample(&self, uv: [f32; 2]) -> Vec3 {
        let wrap = |i: i64, n: u32, w: Wrap| -> u32 {
            let m = n as i64;
            match w {
                Wrap::ClampToEdge => i.clamp(0, m - 1) as u32,
                Wrap::MirroredRepeat => {
                    let p = i.rem_euclid(2 * m);
                    (if p < m { p } else { 2 * m - 1 - p }) as u32
                }
                Wrap::Repeat => i.rem_euclid(m) as u32,
            }
        };
        let decode = |c: f32| {
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        };
        let texel = |x: i64, y: i64| -> Vec3 {
            let i = (wrap(y, self.height, self.wrap[1]) * self.width
                + wrap(x, self.width, self.wrap[0])) as usize;
            let c = if self.wide {
                let (a, b) = (self.words[2 * i], self.words[2 * i + 1]);
                Vec3::new(
                    (a & 0xffff) as f32 / 65535.0,
                    (a >> 16) as f32 / 65535.0,
                    (b & 0xffff) as f32 / 65535.0,
                )
            } else {
                let w = self.words[i];
                Vec3::new(
                    (w & 0xff) as f32 / 255.0,
                    ((w >> 8) & 0xff) as f32 / 255.0,
                    ((w >> 16) & 0xff) as f32 / 255.0,
                )
            };
            if self.linear {
                c
            } else {
                Vec3::new(decode(c.x), decode(c.y), decode(c.z))
            }
        };
        let reduce = |u: f32, w: Wrap| {
            let u = if w == Wrap::ClampToEdge {
                u
            } else {
                u - 2.0 * (0.5 * u).floor()
            };
            u.clamp(-1.0, 3.0)
        };
        let (u, v) = (reduce(uv[0], self.wrap[0]), reduce(uv[1], self.wrap[1]));
        let (w, h) = (self.width as f32, self.height as f32);
        if self.nearest {
            return texel((u * w).floor() as i64, (v * h).floor() as i64);
        }
        let (px, py) = (u * w - 0.5, v * h - 0.5);
        let (fx, fy) = (px.floor(), py.floor());
        let (ax, ay) = (px - fx, py - fy);
        let (x, y) = (fx as i64, fy as i64);
        let row = |y: i64| texel(x, y).lerp(texel(x + 1, y), ax);
        row(y).lerp(row(y + 1), ay)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity `intensity` (W/sr, rgb) from a point.
    Point { position: Vec3, intensity: Vec3 },
    /// glTF spot light: intensity on the axis, smooth falloff between the cone angles.
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        cos_inner: f32,
        cos_outer: f32,
    },
    /// An emissive scene triangle (index into `Scene::triangles`).
    Triangle { triangle: u32 },
}

/// A directional light (glTF KHR_lights_punctual `directional`: the sun): parallel light of
/// irradiance `irradiance` (W/m² on a surface facing it, rgb: the file's `intensity × color`,
/// lux read as W/m² as candela are read as W/sr) travelling along `direction`. Not in
/// [`Scene::lights`]: no light sampler chooses it; every path vertex samples each one with a
/// shadow ray of its own (shaders/shared/next_event.glsl `sun_light`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Directional {
    /// Unit vector: the way the light travels (the node's −Z).
    pub direction: Vec3,
    pub irradiance: Vec3,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit up vector, orthogonal to `forward`.
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
}

impl Camera {
    /// Whether the kernels can render from this camera: a library user's `look_at` straight
    /// down along `up` gave a NaN camera that `Session::new` rendered black with `Ok` (an
    /// audit, 2026-12-07); `Session::set_camera` refused it.
    pub fn check(&self) -> anyhow::Result<()> {
        let v = [self.position, self.forward, self.up];
        if !v.iter().all(|x| x.is_finite())
            || self.forward.cross(self.up).length_squared() < 1e-12
            || !(self.yfov > 0.0 && self.yfov < std::f32::consts::PI)
        {
            anyhow::bail!("a camera needs a finite position, forward and up directions that are not parallel, and 0 < yfov < π");
        }
        Ok(())
    }

    /// A camera that looks at the centre of `[lo, hi]` from the front-above, far enough back
    /// that the bounding sphere fits in a 45° vertical field of view.
    pub fn framing(lo: Vec3, hi: Vec3) -> Camera {
        let centre = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        let yfov = 45f32.to_radians();
        let dir = Vec3::new(0.0, 0.35, 1.0).normalize();
        let distance = radius / (0.5 * yfov).sin();
        let position = centre + dir * distance;
        Camera::look_at(position, centre, Vec3::Y, yfov)
    }

    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, yfov: f32) -> Camera {
        Camera::looking(position, target - position, up, yfov)
    }

    /// A camera at `position` looking along `forward` (a direction, so its precision does
    /// not depend on how far the camera is from the origin: `look_at(p, p + forward)` turned
    /// every ray of a scene scaled by 8e6 off its target, a black image).
    pub fn looking(position: Vec3, forward: Vec3, up: Vec3, yfov: f32) -> Camera {
        let forward = forward.normalize();
        let right = forward.cross(up).normalize();
        Camera {
            position,
            forward,
            up: right.cross(forward),
            yfov,
        }
    }
}

/// A loaded scene. `triangles[i]` uses `materials[triangle_material[i]]`.
#[derive(Clone, Debug)]
pub struct Scene {
    pub triangles: Vec<[Vec3; 3]>,
    pub triangle_material: Vec<u32>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    /// Directional lights (the sun), apart from `lights`: no sampler chooses them.
    pub directional: Vec<Directional>,
    pub camera: Camera,
    pub textures: Vec<Texture>,
    /// Texture coordinates of each triangle's three corners (same order as `triangles`);
    /// empty when no material has a texture.
    pub triangle_uv: Vec<[[f32; 2]; 3]>,
    /// Shading normals of each triangle's three corners (glTF NORMAL, unit, world space; same
    /// order as `triangles`), interpolated across it where they differ from the triangle's own
    /// (smooth shading); zeros for a flat triangle. Empty when no triangle is smooth.
    pub triangle_normals: Vec<[Vec3; 3]>,
    /// Tangents of each triangle's three corners where its material has a normal texture
    /// (xyz unit, world space; w ±1, the bitangent's sign: cross(normal, tangent) × w), the
    /// file's TANGENT or computed from the texture coordinates; zeros where there is none.
    /// Such triangles keep their vertex normals in `triangle_normals` (the frame's normal).
    /// Empty when no material has a normal texture.
    pub triangle_tangents: Vec<[glam::Vec4; 3]>,
    /// Where the scene came from (file path or generator), for reports.
    pub source: String,
    /// The box the region grid covers when it is not the scene's own bounds: an animation's
    /// frames share one grid (the union over the animation), so that what a frame learned
    /// about a place is where the next frame looks for it.
    pub grid_box: Option<(Vec3, Vec3)>,
    /// The glTF camera's `aspectRatio`, where the file gives one: a film of another shape
    /// keeps the vertical field of view and shows another picture ([`Scene::aspect_warning`]).
    pub camera_aspect: Option<f32>,
}

impl Scene {
    /// "N lights", and "+ K directional" where there are directional lights, for messages.
    pub fn lights_summary(&self) -> String {
        match self.directional.len() {
            0 => format!("{} lights", self.lights.len()),
            k => format!("{} lights + {k} directional", self.lights.len()),
        }
    }

    /// A warning where the film's width ÷ height is not the camera's `aspectRatio` (by more
    /// than 1 %): the vertical field of view is kept, so a 16:9 camera on the default 4:3
    /// film lost a quarter of its width without a word (an audit, 2026-12-07). glTF asks a
    /// renderer to use the viewport's ratio where the file gives none, and says nothing of
    /// a viewport of another one; Blender sizes its render by the resolution too.
    pub fn aspect_warning(&self, width: u32, height: u32) -> Option<String> {
        let a = self.camera_aspect.filter(|a| a.is_finite() && *a > 0.0)?;
        let film = width as f32 / height as f32;
        if (film / a - 1.0).abs() <= 0.01 {
            return None;
        }
        let (wide, fix_w) = (film > a, (height as f32 * a).round().max(1.0));
        Some(format!(
            "'{}': its camera's aspectRatio is {a:.4} but the film is {width}×{height} ({film:.4}); the vertical field of view is kept, so the image shows {} than the file's camera; for its view give --width {fix_w} --height {height}",
            self.source,
            if wide { "more at the sides" } else { "less at the sides" }
        ))
    }

    /// Every index the scene holds points at something it holds: a hand-built or edited
    /// scene with a triangle light past the triangles panicked in `GpuScene::upload` (an
    /// audit of the library, 2026-12-07). The glTF loader makes only such scenes.
    pub fn check_indices(&self) -> anyhow::Result<()> {
        let n = self.triangles.len();
        if self.triangle_material.len() != n
            || !(self.triangle_uv.is_empty() || self.triangle_uv.len() == n)
        {
            anyhow::bail!("the scene has {n} triangles but {} triangle materials and {} triangle texture coordinates; give one a triangle (no coordinates: none)", self.triangle_material.len(), self.triangle_uv.len());
        }
        if let Some((t, m)) = (self.triangle_material.iter().enumerate())
            .find(|(_, &m)| m as usize >= self.materials.len())
        {
            anyhow::bail!(
                "triangle {t} has material {m}, but the scene has {} materials",
                self.materials.len()
            );
        }
        for (i, l) in self.lights.iter().enumerate() {
            if let Light::Triangle { triangle } = l {
                if *triangle as usize >= n {
                    anyhow::bail!(
                        "light {i} is triangle {triangle}, but the scene has {n} triangles"
                    );
                }
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            for t in [
                m.base_color_texture,
                m.emissive_texture,
                m.metallic_roughness_texture,
                m.normal_texture,
            ]
            .into_iter()
            .flatten()
            {
                if t as usize >= self.textures.len() {
                    anyhow::bail!(
                        "material {i} has texture {t}, but the scene has {} textures",
                        self.textures.len()
                    );
                }
                if self.triangle_uv.is_empty() {
                    anyhow::bail!("material {i} has a texture, but the scene's triangles have no texture coordinates");
                }
            }
        }
        if !(self.triangle_normals.is_empty() || self.triangle_normals.len() == n) {
            anyhow::bail!(
                "the scene has {n} triangles but {} triangle normals; give one a triangle (flat: zeros), or none",
                self.triangle_normals.len()
            );
        }
        // All three unit, or all three zero (flat): the kernel tests the first corner alone.
        let usable = |c: &[Vec3; 3]| {
            c.iter().all(|v| *v == Vec3::ZERO)
                || c.iter()
                    .all(|v| v.is_finite() && (v.length() - 1.0).abs() < 1e-3)
        };
        if let Some(t) = self.triangle_normals.iter().position(|c| !usable(c)) {
            anyhow::bail!(
                "triangle {t} has normals {:?}; give three unit normals (or three zeros: flat)",
                self.triangle_normals[t]
            );
        }
        if !(self.triangle_tangents.is_empty() || self.triangle_tangents.len() == n) {
            anyhow::bail!(
                "the scene has {n} triangles but {} triangle tangents; give one a triangle (none: zeros), or none",
                self.triangle_tangents.len()
            );
        }
        // All three unit with a sign of ±1, or all zero (no frame: the kernel tests the
        // first corner alone).
        let frame = |c: &[glam::Vec4; 3]| {
            c.iter().all(|v| *v == glam::Vec4::ZERO)
                || c.iter().all(|v| {
                    v.is_finite() && (v.truncate().length() - 1.0).abs() < 1e-3 && v.w.abs() == 1.0
                })
        };
        if let Some(t) = self.triangle_tangents.iter().position(|c| !frame(c)) {
            anyhow::bail!(
                "triangle {t} has tangents {:?}; give three unit tangents with w ±1 (or three zeros: none)",
                self.triangle_tangents[t]
            );
        }
        Ok(())
    }

    /// Axis-aligned bounds of all triangles and punctual lights.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in &self.triangles {
            for v in t {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
        for l in &self.lights {
            if let Light::Point { position, .. } | Light::Spot { position, .. } = l {
                lo = lo.min(*position);
                hi = hi.max(*position);
            }
        }
        (lo, hi)
    }

    /// The box the region grid covers: [`Scene::grid_box`], else the bounds.
    pub fn grid_bounds(&self) -> (Vec3, Vec3) {
        self.grid_box.unwrap_or_else(|| self.bounds())
    }

    /// The luminance a triangle emits (`e`, its material's emission) times its emissive
    /// texture, averaged over 16 points spread over the triangle (its 4 × 4 sub-triangles'
    /// centroids), at least [`EMISSIVE_MEAN_MIN`] of `e`'s luminance; `e`'s luminance without
    /// a texture. Only the lights' power (every sampler's pmf) takes it, so an estimate is
    /// enough: the floor keeps a triangle whose points all fell on black texels samplable, so
    /// no light is left to BSDF rays alone. The colour is multiplied before the luminance
    /// (a blue factor over a blue texture had 1/14 of its power: an audit, 2026-12-07).
    pub fn emitted_luminance(&self, triangle: u32, e: Vec3) -> f32 {
        let m = &self.materials[self.triangle_material[triangle as usize] as usize];
        let (Some(t), Some(uv)) = (
            m.emissive_texture
                .and_then(|i| self.textures.get(i as usize)),
            self.triangle_uv.get(triangle as usize),
        ) else {
            return luminance(e);
        };
        const N: u32 = 4;
        let (mut sum, mut count) = (0.0f32, 0u32);
        for i in 0..N {
            for j in 0..N - i {
                // Sub-triangles (i, j) pointing up, and down where there is room.
                let mut points = vec![((i as f32 + 1.0 / 3.0), (j as f32 + 1.0 / 3.0))];
                if i + j + 1 < N {
                    points.push((i as f32 + 2.0 / 3.0, j as f32 + 2.0 / 3.0));
                }
                for (bi, bj) in points {
                    let (b1, b2) = (bi / N as f32, bj / N as f32);
                    let b0 = 1.0 - b1 - b2;
                    let at = |k: usize| b0 * uv[0][k] + b1 * uv[1][k] + b2 * uv[2][k];
                    sum += luminance(e * t.sample([at(0), at(1)]));
                    count += 1;
                }
            }
        }
        (sum / count as f32).max(EMISSIVE_MEAN_MIN * luminance(e))
    }

    /// Emitted radiance of a triangle light (its emissive texture not applied).
    pub fn triangle_emission(&self, triangle: u32) -> (Vec3, bool) {
        let m = &self.materials[self.triangle_material[triangle as usize] as usize];
        (m.emission, m.double_sided)
    }

    /// Each light's power and their sum must be f32 numbers, neither 0 nor past the range
    /// (`labels`: the punctual lights' names, which come first in `lights`; `across`: the
    /// scene's size in the file's units). Errors name the light and the file `name`. The
    /// caller has refused a scene without lights; powers are ≥ 0 (emission and intensity are
    /// checked first), so with none of them 0 the sum is not 0 either.
    pub(crate) fn check_light_power(
        &self,
        name: &str,
        labels: &[String],
        across: f64,
    ) -> anyhow::Result<()> {
        // Emission of any size renders (the kernels work in normalised units, see
        // lights::emission_scale), as long as each light's power and their sum are f32 numbers.
        // The punctual lights come first in self.lights, in labels' order; a light is
        // named by its glTF index and name (an audit found "a punctual light" in a file of
        // 20,000 of them).
        let what = |i: usize, l: &Light| match l {
            Light::Triangle { triangle } => format!(
                "material {} of emissive triangle {triangle}",
                self.triangle_material[*triangle as usize]
            ),
            _ => labels
                .get(i)
                .cloned()
                .unwrap_or_else(|| "a punctual light".to_string()),
        };
        let mut total = 0f64;
        for (i, l) in self.lights.iter().enumerate() {
            let p = self.light_power(l);
            total += p as f64;
            if !p.is_finite() {
                bail!("'{name}': {} emits more power than 32-bit floats hold; lower its emissiveStrength/intensity (the image scales with it)", what(i, l));
            }
            // Rescaling (scene_frame) can take a punctual intensity below f32's range, and a
            // spot's cone can be too narrow for its solid angle to be a float.
            if p == 0.0 {
                bail!("'{name}': the power of {} rounds to 0 in 32-bit floats once the scene is brought to the renderer's scale (it is {:.3e} units across); {}", what(i, l), across, if matches!(l, Light::Triangle { .. }) { "raise its emission, or scale the scene" } else { "raise its intensity (a spot: or widen its cone), or scale the scene" });
            }
        }
        if total > f32::MAX as f64 / 16.0 {
            bail!("'{name}': its lights emit {total:.3e} W in total, more than 32-bit floats can render; lower the emission (the image scales with it)");
        }
        Ok(())
    }

    /// Total emitted power of a light as luminance (W): what the `power` sampler is
    /// proportional to.
    pub fn light_power(&self, light: &Light) -> f32 {
        match *light {
            Light::Point { intensity, .. } => 4.0 * std::f32::consts::PI * luminance(intensity),
            Light::Spot {
                intensity,
                cos_inner,
                cos_outer,
                ..
            } => {
                // Integral of the glTF falloff ((c - c_o)/(c_i - c_o))² over the sphere:
                // full intensity inside the inner cone, (c_i - c_o)/3 for the ramp.
                let solid = 2.0
                    * std::f32::consts::PI
                    * ((1.0 - cos_inner) + (cos_inner - cos_outer).max(0.0) / 3.0);
                luminance(intensity) * solid
            }
            Light::Triangle { triangle } => {
                let [a, b, c] = self.triangles[triangle as usize];
                let area = 0.5 * (b - a).cross(c - a).length();
                let (e, two) = self.triangle_emission(triangle);
                let sides = if two { 2.0 } else { 1.0 };
                std::f32::consts::PI * area * self.emitted_luminance(triangle, e) * sides
            }
        }
    }
}

/// Below this width in cos θ a spot's ramp is a step at the outer cone (a wider one is
/// finite in f32: 1/d ≤ 1e12; shaders/shared/lights.glsl has the same constant).
pub const SPOT_HARD_EDGE: f32 = 1e-12;

/// glTF spot falloff: 1 inside the inner cone, 0 outside the outer cone, a squared linear
/// ramp in cos θ between, over the cones the file gives. The extension's sample code widens
/// a ramp narrower than 1e-3 in cos θ to 1e-3 inside the outer cone (only to avoid a
/// division by zero); that took 25 % of a narrow spot's light (0.0795/0.08 rad; Mitsuba 3
/// and the exact ramp agree, an audit of 2026-12-06) and 0.6 % of a hard-edged one at 0.45
/// rad, where pbrt-v4 and Cycles take the cones as given. A spot whose cones meet is a step.
pub fn spot_falloff(cos_theta: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let d = cos_inner - cos_outer;
    if d <= SPOT_HARD_EDGE {
        return if cos_theta > cos_outer { 1.0 } else { 0.0 };
    }
    let scale = 1.0 / d;
    let a = ((cos_theta - cos_outer) * scale).clamp(0.0, 1.0);
    a * a
}

#[cfg(test)]
mod tests {
    use super::{spot_falloff, Texture, Wrap};

    /// A colour texture's texels are sRGB-decoded, a data texture's (`linear`) read as
    /// stored: the kernel's texture.glsl `texel` does the same.
    #[test]
    fn data_textures_are_read_as_stored() {
        let mut t = Texture {
            width: 1,
            height: 1,
            words: vec![128 | 64 << 8 | 255 << 16],
            wide: false,
            nearest: false,
            wrap: [Wrap::Repeat; 2],
            linear: true,
        };
        let v = t.sample([0.3, 0.7]);
        assert_eq!(v, glam::Vec3::new(128.0, 64.0, 255.0) / 255.0);
        t.linear = false;
        let c = t.sample([0.3, 0.7]);
        assert!((c.x - 0.2158).abs() < 1e-3 && (c.y - 0.0513).abs() < 1e-3 && c.z == 1.0);
    }

    /// The ramp is the file's: halfway through a narrow one (cones 0.07 and 0.08 rad, 7.5e-4
    /// apart in cos θ) the falloff is ((c − c_o)/(c_i − c_o))², which the extension's 1e-3
    /// widening made 0.15 instead of 0.27; cones that meet are a step at the outer one.
    #[test]
    fn narrow_and_hard_spots_keep_their_cones() {
        let (ci, co) = (0.07f64.cos(), 0.08f64.cos());
        let c = 0.075f64.cos();
        let want = ((c - co) / (ci - co)).powi(2);
        let got = spot_falloff(c as f32, ci as f32, co as f32) as f64;
        assert!((got - want).abs() < 2e-3, "{got} vs {want}");
        assert_eq!(spot_falloff(ci as f32, ci as f32, co as f32), 1.0);
        let edge = 0.45f32.cos();
        assert_eq!(spot_falloff(0.4499f32.cos(), edge, edge), 1.0);
        assert_eq!(spot_falloff(0.4501f32.cos(), edge, edge), 0.0);
        assert_eq!(spot_falloff(edge, edge, edge), 0.0);
    }
}
