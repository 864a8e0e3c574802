//! The preview's camera controller: fly (move along the view, strafe, rise; look by yaw and
//! pitch) and orbit (around a centre, keeping the distance). Plain data; the window code
//! feeds it input and asks it for a [`Camera`].

use glam::Vec3;

use crate::scene::Camera;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlyCamera {
    pub position: Vec3,
    /// Radians about +Y, 0 looking along −Z.
    pub yaw: f32,
    /// Radians above the horizon, within ±89°.
    pub pitch: f32,
    pub yfov: f32,
    /// Units per second.
    pub speed: f32,
}

const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;

impl FlyCamera {
    /// The controller at `camera`, moving at `speed` units per second.
    pub fn from_camera(camera: &Camera, speed: f32) -> FlyCamera {
        let f = camera.forward.normalize();
        FlyCamera {
            position: camera.position,
            yaw: (-f.x).atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            yfov: camera.yfov,
            speed,
        }
    }

    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(-sy * cp, sp, -cy * cp)
    }

    pub fn right(&self) -> Vec3 {
        self.forward().cross(Vec3::Y).normalize()
    }

    pub fn camera(&self) -> Camera {
        Camera::looking(self.position, self.forward(), Vec3::Y, self.yfov)
    }

    /// Moves by `amount` (forward, right, up) × speed × `dt` seconds.
    pub fn fly(&mut self, amount: Vec3, dt: f32) {
        let d = self.forward() * amount.x + self.right() * amount.y + Vec3::Y * amount.z;
        self.position += d * self.speed * dt;
    }

    /// Turns by (yaw, pitch) radians.
    pub fn look(&mut self, dyaw: f32, dpitch: f32) {
        self.yaw += dyaw;
        self.pitch = (self.pitch + dpitch).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Swings around `centre` by (yaw, pitch) radians, keeping the distance, and looks at it.
    pub fn orbit(&mut self, centre: Vec3, dyaw: f32, dpitch: f32) {
        let dist = (self.position - centre).length().max(1e-3);
        // Aim at the centre first, then swing: the view stays on the centre.
        let to = (centre - self.position) / dist;
        self.yaw = (-to.x).atan2(-to.z) + dyaw;
        self.pitch = (to.y.clamp(-1.0, 1.0).asin() + dpitch).clamp(-MAX_PITCH, MAX_PITCH);
        self.position = centre - self.forward() * dist;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_moves() {
        let cam = Camera::looking(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.3, -0.2, -1.0),
            Vec3::Y,
            0.8,
        );
        let fly = FlyCamera::from_camera(&cam, 2.0);
        let back = fly.camera();
        assert!(
            (back.forward - cam.forward).length() < 1e-5,
            "{:?} vs {:?}",
            back.forward,
            cam.forward
        );
        assert_eq!(back.position, cam.position);
        let mut f = fly;
        f.fly(Vec3::X, 0.5); // 1 unit forward
        assert!((f.position - (cam.position + cam.forward)).length() < 1e-5);
        let mut o = fly;
        let centre = Vec3::ZERO;
        let d0 = (o.position - centre).length();
        o.orbit(centre, 0.7, 0.2);
        assert!(((o.position - centre).length() - d0).abs() < 1e-4);
        let to = (centre - o.position).normalize();
        assert!(o.forward().dot(to) > 0.9999, "orbit looks at its centre");
        o.look(0.0, 10.0);
        assert!(o.pitch <= MAX_PITCH);
    }
}
