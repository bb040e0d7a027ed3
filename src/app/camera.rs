//! Orbit camera: yaw/pitch around a target, distance, vertical field of view.

use glam::{Mat4, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    /// Rotation about the world up axis (+Y), radians.
    pub yaw: f32,
    /// Elevation, radians, clamped to (-pi/2, pi/2).
    pub pitch: f32,
    pub distance: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Scene radius used for clipping planes.
    pub radius: f32,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        OrbitCamera {
            target: Vec3::ZERO,
            yaw: 2.55,
            pitch: 0.35,
            distance: 3.0,
            fov_y: 35f32.to_radians(),
            radius: 1.0,
        }
    }
}

impl OrbitCamera {
    /// Unit vector from the target towards the eye.
    pub fn back(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * sy, sp, cp * cy)
    }

    pub fn eye(&self) -> Vec3 {
        self.target + self.back() * self.distance
    }

    /// Camera right and up vectors in world space.
    pub fn basis(&self) -> (Vec3, Vec3) {
        let back = self.back();
        let right = Vec3::Y.cross(back).normalize_or(Vec3::X);
        let up = back.cross(right);
        (right, up)
    }

    /// Frames the bounding box: looks at its center from a distance where the
    /// bounding sphere fits in the view.
    pub fn fit(&mut self, bbox: (Vec3, Vec3)) {
        let center = 0.5 * (bbox.0 + bbox.1);
        let radius = (0.5 * (bbox.1 - bbox.0).length()).max(1e-6);
        self.target = center;
        self.radius = radius;
        self.distance = radius / (0.5 * self.fov_y).sin() * 1.05;
    }

    /// Rotates by a drag of (dx, dy) pixels.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.008;
        self.pitch = (self.pitch + dy * 0.008).clamp(-1.55, 1.55);
    }

    /// Moves the target by a drag of (dx, dy) pixels in a viewport of the given height.
    pub fn pan(&mut self, dx: f32, dy: f32, viewport_height: f32) {
        let (right, up) = self.basis();
        let world_per_px =
            2.0 * self.distance * (0.5 * self.fov_y).tan() / viewport_height.max(1.0);
        self.target += (-dx * right + dy * up) * world_per_px;
    }

    /// Multiplies the distance by `factor` (< 1 zooms in).
    pub fn zoom(&mut self, factor: f32) {
        self.distance = (self.distance * factor).clamp(self.radius * 1e-3, self.radius * 1e3);
    }

    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye(), self.target, self.basis().1)
    }

    pub fn projection(&self, aspect: f32) -> Mat4 {
        let near = (self.distance - 2.0 * self.radius)
            .max(self.distance * 1e-3)
            .max(1e-5);
        let far = self.distance + 4.0 * self.radius;
        glam::camera::rh::proj::directx::perspective(self.fov_y, aspect.max(1e-3), near, far)
    }

    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// Direction towards the key light: above-left of the viewer.
    pub fn light_dir(&self) -> Vec3 {
        let (right, up) = self.basis();
        (self.back() * 1.0 + up * 0.6 - right * 0.4).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_centers_the_box() {
        let mut c = OrbitCamera::default();
        c.fit((Vec3::splat(-2.0), Vec3::splat(4.0)));
        let vp = c.view_proj(1.0);
        let p = vp.project_point3(Vec3::splat(1.0));
        assert!(p.x.abs() < 1e-4 && p.y.abs() < 1e-4);
        assert!(p.z > 0.0 && p.z < 1.0);
        // every box corner is inside the frustum
        for i in 0..8 {
            let q = Vec3::new(
                if i & 1 == 0 { -2.0 } else { 4.0 },
                if i & 2 == 0 { -2.0 } else { 4.0 },
                if i & 4 == 0 { -2.0 } else { 4.0 },
            );
            let s = vp.project_point3(q);
            assert!(
                s.x.abs() <= 1.0 && s.y.abs() <= 1.0 && (0.0..=1.0).contains(&s.z),
                "{s}"
            );
        }
    }

    #[test]
    fn orbit_keeps_distance() {
        let mut c = OrbitCamera::default();
        let d0 = (c.eye() - c.target).length();
        c.orbit(100.0, -40.0);
        assert!(((c.eye() - c.target).length() - d0).abs() < 1e-4);
    }
}
