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

use crate::scene::{CameraSettings, ImageSettings, Scene};
use crate::vocab::Placement;

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

    /// The scene's camera in its grid's own frame ([`Placement`]): what every method traces.
    /// With an identity placement this is exactly [`Camera::new`].
    pub fn for_scene(scene: &Scene) -> Self {
        Camera::new(&scene.camera, &scene.image).in_grid_frame(&scene.field.placement)
    }

    /// This camera seen from the grid's frame. The ray basis is moved as vectors (not rebuilt
    /// from `up` with a cross product), so a mirroring placement mirrors the rays too and every
    /// pixel's ray is the world ray, expressed in the grid's frame: same length units, same
    /// `t` along it.
    pub fn in_grid_frame(&self, placement: &Placement) -> Self {
        if placement.is_identity() {
            return *self;
        }
        Camera {
            eye: placement.point_to_grid(self.eye),
            forward: placement.vector_to_grid(self.forward),
            right_scaled: placement.vector_to_grid(self.right_scaled),
            up_scaled: placement.vector_to_grid(self.up_scaled),
            ..*self
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
    fn a_placed_grid_sees_the_world_rays_in_its_own_frame() {
        let cam = Camera::new(
            &CameraSettings {
                eye: DVec3::new(0.3, -2.0, 5.0),
                target: DVec3::new(0.1, 0.2, 0.0),
                up: DVec3::Y,
                fov_y_deg: 50.0,
            },
            &ImageSettings { width: 7, height: 5 },
        );
        // A rotation about a tilted axis, then a mirror of x: det -1.
        let rot = glam::DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
        let axes = rot * glam::DMat3::from_diagonal(DVec3::new(-1.0, 1.0, 1.0));
        let pl = Placement::from_axes(
            DVec3::new(1.0, 2.0, 3.0),
            axes.to_cols_array_2d().map(DVec3::from),
        )
        .unwrap();
        assert!(pl.mirrors());
        let g = cam.in_grid_frame(&pl);
        for (px, py) in [(0, 0), (6, 4), (3, 2), (5, 1)] {
            let (dw, dg) = (cam.ray_dir(px, py), g.ray_dir(px, py));
            assert!((pl.vector_to_world(dg) - dw).length() < 1e-12);
            // A point t along the grid-frame ray is the world point t along the world ray.
            let t = 2.5;
            let pw = pl.point_to_world(g.eye + t * dg);
            assert!((pw - (cam.eye + t * dw)).length() < 1e-12);
        }
        assert_eq!(cam.in_grid_frame(&Placement::IDENTITY), cam);
    }

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
