//! The camera in f64: the interface contract's pinhole, or an orthographic view.
//!
//! ```text
//!   forward = normalize(target - eye)      right = normalize(forward x up)     up' = right x forward
//!   sx = 2 (px + 0.5) / width - 1          sy = 1 - 2 (py + 0.5) / height      (py = 0: top row)
//!   a = width / height
//!   perspective:  origin = eye                                  h = tan(fov_y / 2)
//!                 dir = normalize(forward + sx * h * a * right + sy * h * up')
//!   orthographic: origin = eye + sx * h * a * right + sy * h * up'    h = ortho_height / 2
//!                 dir = forward
//! ```
//!
//! The GPU gets `forward`, `right * h * a` and `up' * h` from here (rounded to f32) and forms
//! the same sums, so both sides build rays the same way. `t` (and the `Z` channel) is the
//! distance along the unit ray from its origin: from the eye, or from the image plane through
//! the eye.

use glam::DVec3;

use crate::scene::{CameraSettings, ImageSettings, Projection, Scene};
use crate::vocab::Placement;

/// The largest size a camera coordinate may have: the scene's rule, re-exported here beside
/// the rays it protects.
pub use crate::scene::MAX_COORDINATE;

/// A camera ready to generate rays for one image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub forward: DVec3,
    /// `right * h * a`: the offset to the image's right edge (at unit distance, perspective).
    pub right_scaled: DVec3,
    /// `up' * h`: the offset to the image's top edge (at unit distance, perspective).
    pub up_scaled: DVec3,
    /// Parallel rays from the image plane instead of rays from the eye.
    pub orthographic: bool,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    pub fn new(settings: &CameraSettings, image: &ImageSettings) -> Self {
        let forward = (settings.target - settings.eye).normalize();
        let right = forward.cross(settings.up).normalize();
        let up = right.cross(forward);
        let orthographic = settings.projection == Projection::Orthographic;
        let h = match settings.projection {
            Projection::Perspective => (settings.fov_y_deg.to_radians() * 0.5).tan(),
            Projection::Orthographic => settings.ortho_height * 0.5,
        };
        let a = image.width as f64 / image.height as f64;
        Camera {
            eye: settings.eye,
            forward,
            right_scaled: right * (h * a),
            up_scaled: up * h,
            orthographic,
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

    /// Origin and unit direction of the ray through the centre of pixel (px, py), py = 0 the
    /// top row.
    pub fn ray(&self, px: u32, py: u32) -> (DVec3, DVec3) {
        let sx = 2.0 * (px as f64 + 0.5) / self.width as f64 - 1.0;
        let sy = 1.0 - 2.0 * (py as f64 + 0.5) / self.height as f64;
        let offset = sx * self.right_scaled + sy * self.up_scaled;
        if self.orthographic {
            (self.eye + offset, self.forward)
        } else {
            (self.eye, (self.forward + offset).normalize())
        }
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
                ..Default::default()
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
        for (px, py) in [(0, 0), (6, 4), (3, 2), (5, 1)] {
            for cam in [cam, Camera { orthographic: true, ..cam }] {
                let g = cam.in_grid_frame(&pl);
                let ((ow, dw), (og, dg)) = (cam.ray(px, py), g.ray(px, py));
                assert!((pl.vector_to_world(dg) - dw).length() < 1e-12);
                // A point t along the grid-frame ray is the world point t along the world ray.
                let t = 2.5;
                let pw = pl.point_to_world(og + t * dg);
                assert!((pw - (ow + t * dw)).length() < 1e-12);
            }
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
                ..Default::default()
            },
            &ImageSettings { width: 3, height: 3 },
        );
        let dir = |px, py| cam.ray(px, py).1;
        assert!((dir(1, 1) - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        // fov 90: the top edge is at 45 degrees; the top row's centre at 2/3 of that tangent.
        let d = dir(1, 0);
        assert!(d.y > 0.0 && ((d.y / -d.z) - 2.0 / 3.0).abs() < 1e-12);
        let d = dir(2, 1);
        assert!(d.x > 0.0 && ((d.x / -d.z) - 2.0 / 3.0).abs() < 1e-12);
        assert!((0..3).all(|px| cam.ray(px, 2).0 == cam.eye));
    }

    #[test]
    fn orthographic_rays_are_parallel_and_start_on_the_eye_plane() {
        // 4 x 2 pixels over a view 2 high (so 4 wide): pixel centres 1 apart.
        let cam = Camera::new(
            &CameraSettings {
                eye: DVec3::new(0.0, 0.0, 5.0),
                projection: Projection::Orthographic,
                ortho_height: 2.0,
                ..Default::default()
            },
            &ImageSettings { width: 4, height: 2 },
        );
        let (o, d) = cam.ray(0, 0);
        assert_eq!(d, DVec3::new(0.0, 0.0, -1.0));
        assert!((o - DVec3::new(-1.5, 0.5, 5.0)).length() < 1e-12, "{o}");
        let (o, d) = cam.ray(3, 1);
        assert_eq!(d, DVec3::new(0.0, 0.0, -1.0));
        assert!((o - DVec3::new(1.5, -0.5, 5.0)).length() < 1e-12, "{o}");
    }
}
