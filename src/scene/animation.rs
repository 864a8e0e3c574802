//! glTF 2.0 animations (core spec §3.11): node translation / rotation / scale channels with
//! STEP, LINEAR (quaternions by slerp) and CUBICSPLINE interpolation. Every animation of the
//! file plays at once; [`Animations::pose`] gives each animated node's local TRS at a time,
//! which the loader (`gltf_load`) composes into world transforms as it flattens the scene.
//!
//! Outside a channel's keys its first or last value holds (glTF §3.11.4: "clamped").

use std::collections::BTreeMap;

use anyhow::{bail, Result};
use glam::{Quat, Vec3, Vec4};

/// Key times beyond this many seconds are refused (glTF stores them as f32, whose steps
/// there are a second). Frame times are f64: as f32, an animation keyed at 9e6 s showed
/// frames 0–11 at one time and 12–30 at the next at 24 fps (an audit, 2026-12-06).
pub const MAX_TIME: f32 = 1e7;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Step,
    Linear,
    CubicSpline,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
}

/// One animated property of one node: key times and values (xyz, or a quaternion xyzw).
/// CUBICSPLINE keys hold three values each: in-tangent, value, out-tangent.
#[derive(Clone, Debug)]
pub struct Channel {
    pub node: usize,
    pub property: Property,
    pub interpolation: Interpolation,
    pub times: Vec<f32>,
    pub values: Vec<Vec4>,
    /// "animation 0 ('walk') channel 2", for messages.
    pub label: String,
}

impl Channel {
    /// Checks the keys: finite, strictly increasing times; one value per key (three for
    /// CUBICSPLINE); finite values; rotations of non-zero length.
    pub fn check(&self, file: &str) -> Result<()> {
        let at = format!("'{file}': {}", self.label);
        if self.times.is_empty() {
            bail!("{at} has no keyframes; give its sampler at least one input time");
        }
        if let Some(i) = self.times.iter().position(|t| !t.is_finite()) {
            bail!("{at}: key time {i} is not a finite number; fix the sampler's input");
        }
        if let Some(i) = self.times.iter().position(|t| t.abs() > MAX_TIME) {
            bail!(
                "{at}: key time {i} ({}) is beyond ±{MAX_TIME} s; fix the sampler's input",
                self.times[i]
            );
        }
        if let Some(i) = self.times.windows(2).position(|w| w[1] <= w[0]) {
            bail!(
                "{at}: key times must increase strictly, but time {} ({}) follows {}; fix the sampler's input",
                i + 1,
                self.times[i + 1],
                self.times[i]
            );
        }
        let per_key = if self.interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        if self.values.len() != per_key * self.times.len() {
            bail!(
                "{at}: {} keys need {} output values{}, but the sampler's output has {}; fix the sampler's output accessor",
                self.times.len(),
                per_key * self.times.len(),
                if per_key == 3 { " (in-tangent, value, out-tangent each)" } else { "" },
                self.values.len()
            );
        }
        if let Some(i) = self.values.iter().position(|v| !v.is_finite()) {
            bail!("{at}: output value {i} is not finite (NaN or Inf); fix the keyframe");
        }
        if self.property == Property::Rotation {
            let keys = self.values.iter().skip(per_key / 2).step_by(per_key);
            if let Some(i) = keys.clone().position(|q| q.length_squared() < 1e-12) {
                bail!("{at}: rotation key {i} is a zero quaternion; use a unit quaternion");
            }
        }
        Ok(())
    }

    /// The channel's value at time `t` (a rotation comes back normalised).
    pub fn sample(&self, t: f64) -> Vec4 {
        let n = self.times.len();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |k: usize| {
            if cubic {
                self.values[3 * k + 1]
            } else {
                self.values[k]
            }
        };
        let unit = |v: Vec4| {
            if self.property == Property::Rotation {
                v.normalize()
            } else {
                v
            }
        };
        if n == 1 || !t.is_finite() || t <= self.times[0] as f64 {
            return unit(value(0));
        }
        if reached(self.times[n - 1], t) {
            return unit(value(n - 1));
        }
        // The key interval holding t: times[k] <= t < times[k + 1]; where it lies in it in
        // f64 (t is not an f32 far from 0).
        let k = self.times.partition_point(|&x| reached(x, t)) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let dt = t1 - t0;
        let s = ((t - t0 as f64) / (t1 as f64 - t0 as f64)).clamp(0.0, 1.0) as f32;
        match self.interpolation {
            Interpolation::Step => unit(value(k)),
            Interpolation::Linear => {
                if self.property == Property::Rotation {
                    let q = slerp(quat(value(k)), quat(value(k + 1)), s);
                    Vec4::from(q.to_array())
                } else {
                    value(k).lerp(value(k + 1), s)
                }
            }
            Interpolation::CubicSpline => {
                // glTF 2.0 Appendix C: Hermite spline with tangents scaled by the interval.
                let (v0, b0) = (self.values[3 * k + 1], self.values[3 * k + 2]);
                let (a1, v1) = (self.values[3 * (k + 1)], self.values[3 * (k + 1) + 1]);
                let (s2, s3) = (s * s, s * s * s);
                let p = (2.0 * s3 - 3.0 * s2 + 1.0) * v0
                    + (s3 - 2.0 * s2 + s) * dt * b0
                    + (-2.0 * s3 + 3.0 * s2) * v1
                    + (s3 - s2) * dt * a1;
                if self.property == Property::Rotation && p.length_squared() < 1e-12 {
                    // Keys q and -q with flat tangents cancel halfway: the same rotation
                    // either way, so take the shorter arc between them.
                    return Vec4::from(slerp(quat(v0), quat(v1), s).to_array());
                }
                unit(p)
            }
        }
    }
}

/// Whether time `t` has reached `key`: a key is an f32, which rounds k/24 s up as often as
/// down, so a frame's exact f64 time would fall just short of a key it sits on (a STEP
/// channel then showed each such key a frame late). Within half the key's f32 step (at
/// most a millisecond: a microsecond until 2026-12-07, which keys past 16 s outgrow, a
/// review found) counts as on it.
fn reached(key: f32, t: f64) -> bool {
    let step = (f32::from_bits(key.abs().to_bits() + 1) - key.abs()) as f64;
    key as f64 - t <= (0.5 * step).min(1e-3)
}

fn quat(v: Vec4) -> Quat {
    Quat::from_vec4(v).normalize()
}

/// Spherical linear interpolation along the shorter arc (glTF 2.0 Appendix C: keys in
/// opposite hemispheres are the same rotations, so the second is negated first).
pub fn slerp(a: Quat, b: Quat, s: f32) -> Quat {
    let mut d = a.dot(b);
    let b = if d < 0.0 {
        d = -d;
        -b
    } else {
        b
    };
    if d > 0.9995 {
        // Nearly parallel: the chord and the arc agree to f32 precision.
        return Quat::from_vec4(Vec4::from(a).lerp(Vec4::from(b), s)).normalize();
    }
    let theta = d.clamp(-1.0, 1.0).acos();
    let sin = theta.sin();
    let (wa, wb) = (((1.0 - s) * theta).sin() / sin, (s * theta).sin() / sin);
    Quat::from_vec4(Vec4::from(a) * wa + Vec4::from(b) * wb).normalize()
}

/// The animated local transform parts of the nodes at one time; parts not animated keep the
/// node's own.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pose {
    pub nodes: BTreeMap<usize, NodePose>,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodePose {
    pub translation: Option<Vec3>,
    pub rotation: Option<Quat>,
    pub scale: Option<Vec3>,
}

impl NodePose {
    /// The node's local TRS with these parts replaced.
    pub fn apply(&self, (t, r, s): (Vec3, Quat, Vec3)) -> (Vec3, Quat, Vec3) {
        (
            self.translation.unwrap_or(t),
            self.rotation.unwrap_or(r),
            self.scale.unwrap_or(s),
        )
    }
}

/// Every channel of every animation in a file.
#[derive(Clone, Debug, Default)]
pub struct Animations {
    pub channels: Vec<Channel>,
    /// Names of the animations, in file order.
    pub names: Vec<String>,
}

impl Animations {
    pub fn is_empty(&self) -> bool {
        self.channels.is_empty()
    }

    /// The time span the animations cover: (first key, last key) over all channels.
    pub fn span(&self) -> Option<(f32, f32)> {
        let lo = self.channels.iter().map(|c| c.times[0]).reduce(f32::min)?;
        let hi = self
            .channels
            .iter()
            .map(|c| *c.times.last().unwrap_or(&lo))
            .reduce(f32::max)?;
        Some((lo, hi))
    }

    /// Each animated node's local TRS parts at time `t`.
    pub fn pose(&self, t: f64) -> Pose {
        let mut pose = Pose::default();
        for c in &self.channels {
            let v = c.sample(t);
            let p = pose.nodes.entry(c.node).or_default();
            match c.property {
                Property::Translation => p.translation = Some(v.truncate()),
                Property::Scale => p.scale = Some(v.truncate()),
                Property::Rotation => p.rotation = Some(quat(v)),
            }
        }
        pose
    }

    /// The nodes some channel moves.
    pub fn animated_nodes(&self) -> Vec<usize> {
        let mut n: Vec<usize> = self.channels.iter().map(|c| c.node).collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    /// Reads and checks the animations of a parsed file. Morph-target weights are not
    /// supported (a warning); a second channel on the same node property overrides the
    /// first (a warning).
    pub fn read(
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
        file: &str,
        warn: &mut dyn FnMut(String),
    ) -> Result<Animations> {
        use gltf::animation::util::ReadOutputs;
        let mut out = Animations::default();
        let mut seen: BTreeMap<(usize, Property), String> = BTreeMap::new();
        for anim in doc.animations() {
            let name = anim.name().unwrap_or("").to_string();
            for (ci, ch) in anim.channels().enumerate() {
                let label = format!("animation {} ('{name}') channel {ci}", anim.index());
                // Before anything reads them: the parser cannot read weights of every type
                // (an UNSIGNED_INT one reached its `unreachable!`: a review, 2026-12-06).
                if ch.target().property() == gltf::animation::Property::MorphTargetWeights {
                    warn(format!("'{file}': {label} animates morph-target weights, which lightlearn does not support; ignored"));
                    continue;
                }
                // Sparse keys out of range were dropped as in meshes (a review, 2026-12-06).
                for a in [ch.sampler().input(), ch.sampler().output()] {
                    super::gltf_data::check_sparse(&a, buffers, &format!("'{file}': {label}"))?;
                }
                check_types(&ch).map_err(|e| anyhow::anyhow!("'{file}': {label}: {e}"))?;
                let reader = ch.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
                let times: Vec<f32> = match reader.read_inputs() {
                    Some(t) => t.collect(),
                    None => bail!("'{file}': {label}: its input (key times) accessor cannot be read (missing or outside its buffer); fix the sampler"),
                };
                let unreadable = || {
                    anyhow::anyhow!("'{file}': {label}: its output (key values) accessor cannot be read (missing, outside its buffer, or of the wrong type); fix the sampler")
                };
                let v3 = |it: &mut dyn Iterator<Item = [f32; 3]>| {
                    it.map(|v| Vec3::from(v).extend(0.0)).collect::<Vec<_>>()
                };
                let (property, values) = match reader.read_outputs().ok_or_else(unreadable)? {
                    ReadOutputs::Translations(it) => (Property::Translation, v3(&mut { it })),
                    ReadOutputs::Scales(it) => (Property::Scale, v3(&mut { it })),
                    ReadOutputs::Rotations(r) => (
                        Property::Rotation,
                        r.into_f32().map(Vec4::from).collect::<Vec<_>>(),
                    ),
                    ReadOutputs::MorphTargetWeights(_) => continue,
                };
                let interpolation = match ch.sampler().interpolation() {
                    gltf::animation::Interpolation::Step => Interpolation::Step,
                    gltf::animation::Interpolation::Linear => Interpolation::Linear,
                    gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
                };
                let channel = Channel {
                    node: ch.target().node().index(),
                    property,
                    interpolation,
                    times,
                    values,
                    label: label.clone(),
                };
                channel.check(file)?;
                // glTF asks for times ≥ 0; rendered as keyed (frame 0 at the first key),
                // said (an audit, 2026-12-07: silent).
                if channel.times[0] < 0.0 {
                    warn(format!("'{file}': {label} starts at a negative key time ({} s), which glTF does not allow; rendered as keyed (frame 0 is the first key)", channel.times[0]));
                }
                if let Some(first) = seen.insert((channel.node, property), label.clone()) {
                    warn(format!("'{file}': {label} animates the same {property:?} of node {} as {first}; the later one is used", channel.node));
                    out.channels
                        .retain(|c| (c.node, c.property) != (channel.node, property));
                }
                out.channels.push(channel);
            }
            out.names.push(name);
        }
        Ok(out)
    }
}

/// The accessor types glTF 2.0 allows for an animation sampler (§5.6, "animation.sampler"):
/// key times SCALAR float; translations and scales VEC3 float; rotations VEC4 float or
/// normalized (U)BYTE/(U)SHORT; weights SCALAR, the same. The gltf crate reads an accessor of
/// another type as if it were the right one (a VEC4 translation re-sliced as VEC3, a SHORT
/// one read as floats), and a camera ended elsewhere with exit 0 (an audit, 2026-12-06).
fn check_types(ch: &gltf::animation::Channel) -> std::result::Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    use gltf::animation::Property as Path;
    let sampler = ch.sampler();
    let spell = |a: &gltf::Accessor| {
        let normalized = if a.normalized() { "normalized " } else { "" };
        let kind = match a.data_type() {
            DataType::I8 => "BYTE",
            DataType::U8 => "UNSIGNED_BYTE",
            DataType::I16 => "SHORT",
            DataType::U16 => "UNSIGNED_SHORT",
            DataType::U32 => "UNSIGNED_INT",
            DataType::F32 => "FLOAT",
        };
        format!(
            "{} {normalized}{kind}",
            format!("{:?}", a.dimensions()).to_uppercase()
        )
    };
    let input = sampler.input();
    if (input.dimensions(), input.data_type()) != (Dimensions::Scalar, DataType::F32) {
        return Err(format!(
            "its input (key times) accessor {} is {}; glTF requires SCALAR FLOAT; fix the sampler",
            input.index(),
            spell(&input)
        ));
    }
    let output = sampler.output();
    let float = output.data_type() == DataType::F32;
    let normalized_int = output.normalized()
        && matches!(
            output.data_type(),
            DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16
        );
    let path = match ch.target().property() {
        Path::Translation => "translation",
        Path::Rotation => "rotation",
        Path::Scale => "scale",
        Path::MorphTargetWeights => "weights",
    };
    let (ok, wanted) = match ch.target().property() {
        Path::Translation | Path::Scale => (
            output.dimensions() == Dimensions::Vec3 && float,
            "VEC3 FLOAT",
        ),
        Path::Rotation => (
            output.dimensions() == Dimensions::Vec4 && (float || normalized_int),
            "VEC4 FLOAT or normalized BYTE, UNSIGNED_BYTE, SHORT, UNSIGNED_SHORT",
        ),
        // Skipped before this check (`Animations::read`).
        Path::MorphTargetWeights => (true, ""),
    };
    if ok {
        Ok(())
    } else {
        Err(format!(
            "its output (key values) accessor {} is {} for a {path} channel; glTF requires {wanted}; fix the sampler",
            output.index(),
            spell(&output),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(
        property: Property,
        interpolation: Interpolation,
        times: &[f32],
        values: &[[f32; 4]],
    ) -> Channel {
        Channel {
            node: 0,
            property,
            interpolation,
            times: times.to_vec(),
            values: values.iter().map(|v| Vec4::from(*v)).collect(),
            label: "animation 0 ('t') channel 0".into(),
        }
    }

    /// Far from time 0 an f32 time has steps of a second: frames 1/24 s apart must still
    /// move (in f32 an animation keyed at 9e6 s showed frames 0–11 at one time and 12–30 at
    /// the next).
    #[test]
    fn a_time_far_from_zero_interpolates() {
        let c = channel(
            Property::Translation,
            Interpolation::Linear,
            &[9.0e6, 9.0e6 + 4.0],
            &[[0.0; 4], [4.0, 0.0, 0.0, 0.0]],
        );
        for k in 1..24 {
            let x = c.sample(9.0e6 + k as f64 / 24.0).x;
            assert!((x - k as f32 / 24.0).abs() < 1e-5, "frame {k}: {x}");
        }
    }

    /// STEP keys at k/24 s (f32, rounded up about as often as down) are reached by frame k's
    /// exact time k/24, not a frame late; the last key too.
    #[test]
    fn step_keys_are_reached_on_their_frame() {
        let times: Vec<f32> = (0..=48).map(|k| k as f32 / 24.0).collect();
        let values: Vec<[f32; 4]> = (0..=48).map(|k| [k as f32, 0.0, 0.0, 0.0]).collect();
        let c = channel(Property::Translation, Interpolation::Step, &times, &values);
        for k in 0..=48u32 {
            assert_eq!(c.sample(k as f64 / 24.0).x, k as f32, "frame {k}");
        }
    }

    #[test]
    fn linear_and_step_translation_by_hand() {
        let c = channel(
            Property::Translation,
            Interpolation::Linear,
            &[1.0, 3.0],
            &[[0.0, 2.0, 4.0, 0.0], [4.0, 2.0, 0.0, 0.0]],
        );
        assert_eq!(c.sample(2.0), Vec4::new(2.0, 2.0, 2.0, 0.0));
        assert_eq!(c.sample(1.5), Vec4::new(1.0, 2.0, 3.0, 0.0));
        // Clamped outside the keys.
        assert_eq!(c.sample(0.0), Vec4::new(0.0, 2.0, 4.0, 0.0));
        assert_eq!(c.sample(9.0), Vec4::new(4.0, 2.0, 0.0, 0.0));
        let s = Channel {
            interpolation: Interpolation::Step,
            ..c
        };
        assert_eq!(s.sample(2.9), Vec4::new(0.0, 2.0, 4.0, 0.0));
        assert_eq!(s.sample(3.0), Vec4::new(4.0, 2.0, 0.0, 0.0));
    }

    #[test]
    fn slerp_by_hand_and_across_hemispheres() {
        // Identity to 90° about y: halfway is 45° about y.
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let h = slerp(a, b, 0.5);
        let want = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(h.dot(want).abs() > 1.0 - 1e-6, "{h:?}");
        // A third of the way: 30°, not the chord's angle.
        let t = slerp(a, b, 1.0 / 3.0);
        let (axis, angle) = t.to_axis_angle();
        assert!(
            (angle - 30f32.to_radians()).abs() < 1e-5 && axis.y > 0.999,
            "{angle}"
        );
        // -b is the same rotation as b: the shorter arc gives the same halfway rotation,
        // not one through 180° - 45°.
        let h2 = slerp(a, -b, 0.5);
        assert!(h2.dot(want).abs() > 1.0 - 1e-6, "{h2:?}");
        let c = channel(
            Property::Rotation,
            Interpolation::Linear,
            &[0.0, 1.0],
            &[a.to_array(), (-b).to_array()],
        );
        let v = quat(c.sample(0.5));
        assert!(v.dot(want).abs() > 1.0 - 1e-6);
    }

    #[test]
    fn cubic_spline_with_tangents_by_hand() {
        // Keys at t = 0 (value 0, out-tangent 2) and t = 2 (in-tangent -1, value 1), in x.
        // At s = 1/2 (t = 1): h00 = 1/2, h10 = 1/8, h01 = 1/2, h11 = -1/8, dt = 2:
        // 0.5·0 + 0.125·2·2 + 0.5·1 + (-0.125)·2·(-1) = 0.5 + 0.5 + 0.25 = 1.25.
        let c = channel(
            Property::Translation,
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &[
                [9.0, 0.0, 0.0, 0.0], // in-tangent of key 0: unused
                [0.0, 0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0, 0.0],
                [-1.0, 0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
                [9.0, 0.0, 0.0, 0.0], // out-tangent of the last key: unused
            ],
        );
        assert!((c.sample(1.0).x - 1.25).abs() < 1e-6, "{}", c.sample(1.0).x);
        // s = 1/4 (t = 0.5): h00 = 27/32, h10 = 9/64, h01 = 5/32, h11 = -3/64:
        // 0 + 9/64·2·2 + 5/32 + 3/64·2 = 36/64 + 10/64 + 6/64 = 52/64.
        assert!((c.sample(0.5).x - 52.0 / 64.0).abs() < 1e-6);
        assert_eq!(c.sample(2.0).x, 1.0);
        assert_eq!(c.sample(-1.0).x, 0.0);
    }

    #[test]
    fn malformed_channels_are_named() {
        let bad_times = channel(
            Property::Translation,
            Interpolation::Linear,
            &[0.0, 1.0, 1.0],
            &[[0.0; 4]; 3],
        );
        let e = bad_times.check("a.gltf").unwrap_err().to_string();
        assert!(
            e.contains("channel 0") && e.contains("increase strictly"),
            "{e}"
        );
        let count = channel(
            Property::Scale,
            Interpolation::CubicSpline,
            &[0.0, 1.0],
            &[[1.0; 4]; 2],
        );
        let e = count.check("a.gltf").unwrap_err().to_string();
        assert!(e.contains("need 6 output values"), "{e}");
        let nan = channel(
            Property::Translation,
            Interpolation::Step,
            &[0.0, 1.0],
            &[[0.0; 4], [f32::NAN, 0.0, 0.0, 0.0]],
        );
        assert!(nan
            .check("a.gltf")
            .unwrap_err()
            .to_string()
            .contains("not finite"));
        let nan_t = channel(
            Property::Translation,
            Interpolation::Step,
            &[0.0, f32::NAN],
            &[[0.0; 4]; 2],
        );
        assert!(nan_t
            .check("a.gltf")
            .unwrap_err()
            .to_string()
            .contains("key time 1"));
        let zero_q = channel(
            Property::Rotation,
            Interpolation::Linear,
            &[0.0],
            &[[0.0; 4]],
        );
        assert!(zero_q
            .check("a.gltf")
            .unwrap_err()
            .to_string()
            .contains("zero quaternion"));
    }
}
