//! A KHR_lights_punctual light of a glTF node: point and spot lights become [`Light`]s,
//! directional ones [`Directional`]s; zero intensity and empty cones are skipped with a
//! warning; `range` is the caller's to count (one warning for the file).

use anyhow::{bail, Result};
use glam::{DMat4, DVec3, DVec4, Vec3};

use super::{Directional, Light};

/// The light `light` on node `node` (its label) with world transform `world` in file `name`: the light (its
/// position still at the origin: the caller moves it into the scene's frame), its world
/// position and its label ("light K ('name')"); None where it is skipped (with a warning).
pub fn read_light(
    light: &gltf::khr_lights_punctual::Light,
    world: DMat4,
    node: &str,
    name: &str,
    warn: &mut dyn FnMut(String),
) -> Result<Option<(Light, DVec3, String)>> {
    let Some((label, intensity)) = label_and_intensity(light, name, warn)? else {
        return Ok(None);
    };
    let position = world.transform_point3(DVec3::ZERO);
    let direction = (world * DVec4::new(0.0, 0.0, -1.0, 0.0))
        .truncate()
        .as_vec3();
    match light.kind() {
        gltf::khr_lights_punctual::Kind::Point => Ok(Some((
            Light::Point {
                position: Vec3::ZERO,
                intensity,
            },
            position,
            label,
        ))),
        gltf::khr_lights_punctual::Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            if direction.length_squared() == 0.0 {
                // The node and the way out named, as the camera's message does (an audit,
                // 2026-12-07: a spot keyed to scale 0 named neither).
                bail!("'{name}': {label}, a spot, sits on {node} whose transform is degenerate (a scale of 0, here or on a parent, at this time for an animation), so it has no direction; give the node a non-zero scale");
            }
            let outer = outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2);
            let inner = inner_cone_angle.clamp(0.0, outer);
            // KHR_lights_punctual: 0 ≤ inner < outer ≤ π/2 (inner = outer is taken as a hard edge).
            if (outer, inner) != (outer_cone_angle, inner_cone_angle) {
                warn(format!(
                    "'{name}': {label} has cone angles inner {inner_cone_angle} / outer {outer_cone_angle} outside 0 ≤ inner ≤ outer ≤ π/2; rendered with inner {inner} / outer {outer}"
                ));
            }
            if outer == 0.0 {
                // An empty cone emits nothing: before, it reached the power check as "a
                // light's power rounds to 0", which named neither the light nor the cause.
                warn(format!("'{name}': {label} is a spot with an outer cone angle of 0, which lights nothing; skipped"));
                return Ok(None);
            }
            Ok(Some((
                Light::Spot {
                    position: Vec3::ZERO,
                    direction: direction.normalize(),
                    intensity,
                    cos_inner: inner.cos(),
                    cos_outer: outer.cos(),
                },
                position,
                label,
            )))
        }
        gltf::khr_lights_punctual::Kind::Directional => {
            unreachable!("read_directional reads directional lights")
        }
    }
}

/// A light's label ("light K ('name')") and `color × intensity`, checked finite and ≥ 0;
/// None where it is 0 (skipped, said): what every kind of punctual light reads first.
fn label_and_intensity(
    light: &gltf::khr_lights_punctual::Light,
    name: &str,
    warn: &mut dyn FnMut(String),
) -> Result<Option<(String, Vec3)>> {
    let label = format!("light {} ('{}')", light.index(), light.name().unwrap_or(""));
    let intensity = Vec3::from(light.color()) * light.intensity();
    if !intensity.is_finite() || intensity.min_element() < 0.0 {
        bail!("'{name}': {label} has a non-finite or negative color × intensity ({intensity}); use finite values ≥ 0");
    }
    if intensity.max_element() == 0.0 {
        warn(format!("'{name}': {label} has zero intensity; skipped"));
        return Ok(None);
    }
    Ok(Some((label, intensity)))
}

/// Whether `light` is directional (read by [`read_directional`], not [`read_light`]).
pub fn is_directional(light: &gltf::khr_lights_punctual::Light) -> bool {
    matches!(light.kind(), gltf::khr_lights_punctual::Kind::Directional)
}

/// The directional light `light` on node `node` with world transform `world` (its −Z is the
/// way the light travels; a scale or mirror of the node changes nothing but that direction);
/// None where its intensity is 0 (with a warning).
pub fn read_directional(
    light: &gltf::khr_lights_punctual::Light,
    world: DMat4,
    node: &str,
    name: &str,
    warn: &mut dyn FnMut(String),
) -> Result<Option<Directional>> {
    let Some((label, irradiance)) = label_and_intensity(light, name, warn)? else {
        return Ok(None);
    };
    let d = (world * DVec4::new(0.0, 0.0, -1.0, 0.0)).truncate();
    if !(d.length_squared() > 0.0 && d.is_finite()) {
        bail!("'{name}': {label}, a directional light, sits on {node} whose transform is degenerate (a scale of 0, here or on a parent, at this time for an animation), so it has no direction; give the node a non-zero scale");
    }
    Ok(Some(Directional {
        direction: d.normalize().as_vec3(),
        irradiance,
    }))
}
