//! The pinhole camera of the interface contract, in f64.
//!
//! ```text
//!   forward = normalize(target - eye)      right = normalize(forward x up)     up' = right x forward
//!   dir(px, py) = normalize(forward + sx * h * a * right + sy * h * up')
//!   sx = 2 (px + 0.5) / width - 1          sy = 1 - 2 (py + 0.5) / height      (py = 0: top row)
//!   h = tan(fov_y / 2)                     a = width / height
//! ```
//!
//! The GPU gets `forward`, `right * h * a` and `up' * h` from here (rounded to f32) and forms
//! the same sum, so both sides build rays the same way.

use glam::DVec3;

use crate::scene::{CameraSettings, ImageSettings};

/// A camera ready to generate rays for one image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub forward: DVec3,
    /// `right * h * a`: the offset to the image's right edge at unit distance.
    pub right_scaled: DVec3,
    /// `up' * h`: the offset to the image's top edge at unit distance.
    pub up_scaled: DVec3,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    pub fn new(settings: &CameraSettings, image: &ImageSettings) -> Self {
        let forward = (settings.target - settings.eye).normalize();
        let right = forward.cross(settings.up).normalize();
        let up = right.cross(forward);
        let h = (settings.fov_y_deg.to_radians() * 0.5).tan();
        let a = image.width as f64 / image.height as f64;
        Camera {
            eye: settings.eye,
            forward,
            right_scaled: right * (h * a),
            up_scaled: up * h,
            width: image.width,
            height: image.height,
        }
    }

    /// Unit direction of the ray through the centre of pixel (px, py), py = 0 the top row.
    pub fn ray_dir(&self, px: u32, py: u32) -> DVec3 {
        let sx = 2.0 * (px as f64 + 0.5) / self.width as f64 - 1.0;
        let sy = 1.0 - 2.0 * (py as f64 + 0.5) / self.height as f64;
        (self.forward + sx * self.right_scaled + sy * self.up_scaled).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_at_target_and_top_row_looks_up() {
        let cam = Camera::new(
            &CameraSettings {
                eye: DVec3::new(0.0, 0.0, 5.0),
                target: DVec3::ZERO,
                up: DVec3::Y,
                fov_y_deg: 90.0,
            },
            &ImageSettings { width: 3, height: 3 },
        );
        assert!((cam.ray_dir(1, 1) - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        // fov 90: the top edge is at 45 degrees; the top row's centre at 2/3 of that tangent.
        let d = cam.ray_dir(1, 0);
        assert!(d.y > 0.0 && ((d.y / -d.z) - 2.0 / 3.0).abs() < 1e-12);
        let d = cam.ray_dir(2, 1);
        assert!(d.x > 0.0 && ((d.x / -d.z) - 2.0 / 3.0).abs() < 1e-12);
    }
}
