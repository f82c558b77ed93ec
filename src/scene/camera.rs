//! The pinhole camera: an orthonormal basis from eye, look-at point and up
//! vector, and primary rays through the image plane.

use glam::Vec3;

use crate::accel::Ray;

/// A pinhole camera.
///
/// The basis is right-handed: `w` points from the look-at point back to the
/// eye (the camera looks along `-w`), `u = normalize(up x w)` points to the
/// image's right, and `v = w x u` to its top, so `u x v = w`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Position of the pinhole.
    pub eye: Vec3,
    /// Right.
    pub u: Vec3,
    /// Up in the image.
    pub v: Vec3,
    /// Backwards (away from the scene).
    pub w: Vec3,
    /// `tan(vertical fov / 2)`: half the image plane's height at distance 1.
    pub tan_half_fov: f32,
}

impl Camera {
    /// A camera at `eye` looking at `look_at`, with `up` roughly up and
    /// `vertical_fov_deg` the full vertical field of view in degrees.
    pub fn new(eye: Vec3, look_at: Vec3, up: Vec3, vertical_fov_deg: f32) -> Result<Camera, String> {
        let to_eye = eye - look_at;
        if !to_eye.is_finite() {
            return Err("the camera's eye and look_at are too far apart for 32-bit floats; \
                        bring look_at nearer along the same line"
                .to_string());
        }
        // Where the squared length overflows (a vector longer than about
        // 1.8e19: a look_at far off along the view is a fair way to give a
        // direction), scaled to its largest component first. (Always
        // scaling would move every camera's basis by a rounding, and so
        // every image.)
        let w = to_eye
            .try_normalize()
            .or_else(|| (to_eye / to_eye.abs().max_element()).try_normalize())
            .ok_or("the camera's eye and look_at are the same point; move one of them")?;
        let u = up.cross(w).try_normalize().ok_or(
            "the camera's up vector is zero or parallel to the viewing direction; choose an up that is not",
        )?;
        if !(vertical_fov_deg > 0.0 && vertical_fov_deg < 180.0) {
            return Err(format!(
                "the field of view must lie strictly between 0 and 180 degrees, found {vertical_fov_deg}"
            ));
        }
        let v = w.cross(u);
        let tan_half_fov = (0.5 * vertical_fov_deg.to_radians()).tan();
        Ok(Camera { eye, u, v, w, tan_half_fov })
    }

    /// The ray through image position `(x, y)` in pixels, measured from the
    /// top-left corner of a `width x height` image (`(0.5, 0.5)` is the centre
    /// of the top-left pixel). The direction is unit length.
    pub fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let scale = 2.0 * self.tan_half_fov / height as f32;
        let sx = scale * (x - 0.5 * width as f32);
        let sy = scale * (0.5 * height as f32 - y);
        Ray::new(self.eye, (sx * self.u + sy * self.v - self.w).normalize())
    }

    /// Distance from the pinhole to the image plane in pixels, for an image
    /// `height` pixels high: a pixel there is a unit square.
    pub fn image_distance(&self, height: u32) -> f32 {
        0.5 * height as f32 / self.tan_half_fov
    }

    /// Where `p` appears on a `width x height` image, in pixels from the
    /// top-left corner as [`Camera::ray`] takes them (the inverse of it), with
    /// the cosine between the view axis and the direction from the eye to
    /// `p`; `None` when `p` is behind the camera or outside the image.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<(glam::Vec2, f32)> {
        let to = p - self.eye;
        let depth = -to.dot(self.w);
        let length = to.length();
        if !(depth > 0.0 && length > 0.0) {
            return None;
        }
        let scale = self.image_distance(height) / depth;
        let x = 0.5 * width as f32 + to.dot(self.u) * scale;
        let y = 0.5 * height as f32 - to.dot(self.v) * scale;
        let inside = (0.0..width as f32).contains(&x) && (0.0..height as f32).contains(&y);
        inside.then_some((glam::Vec2::new(x, y), depth / length))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal_and_right_handed() {
        let cases = [
            (Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO, Vec3::Y),
            (Vec3::new(3.0, -2.0, 1.0), Vec3::new(0.5, 0.5, -4.0), Vec3::new(0.1, 1.0, 0.3)),
            (Vec3::new(0.0, 10.0, 0.1), Vec3::ZERO, Vec3::Z),
        ];
        for (eye, at, up) in cases {
            let c = Camera::new(eye, at, up, 40.0).unwrap();
            for (a, b) in [(c.u, c.v), (c.v, c.w), (c.w, c.u)] {
                assert!(a.dot(b).abs() < 1e-6);
            }
            for e in [c.u, c.v, c.w] {
                assert!((e.length() - 1.0).abs() < 1e-6);
            }
            assert!(c.u.cross(c.v).abs_diff_eq(c.w, 1e-6), "not right-handed");
            assert!(c.w.abs_diff_eq((eye - at).normalize(), 1e-6));
            // Up in the image is on the side of the given up vector.
            assert!(c.v.dot(up) > 0.0);
        }
    }

    #[test]
    fn centre_ray_looks_at_target_and_fov_spans_the_image() {
        let c = Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 90.0).unwrap();
        let r = c.ray(50.0, 50.0, 100, 100);
        assert!(r.dir.abs_diff_eq(-Vec3::Z, 1e-6));
        // Top edge of a 90-degree view is 45 degrees up; x grows to the right (+x).
        let top = c.ray(50.0, 0.0, 100, 100).dir;
        assert!((top.y - top.z.abs()).abs() < 1e-5 && top.y > 0.0);
        assert!(c.ray(100.0, 50.0, 100, 100).dir.x > 0.0);
    }

    #[test]
    fn projection_inverts_the_camera_ray() {
        let c = Camera::new(Vec3::new(1.0, 2.0, 5.0), Vec3::new(0.2, 0.1, -1.0), Vec3::Y, 50.0).unwrap();
        let (w, h) = (160, 90);
        for (x, y) in [(0.5, 0.5), (80.0, 45.0), (159.2, 3.7), (12.0, 88.9)] {
            let ray = c.ray(x, y, w, h);
            let (pixel, cos) = c.project(ray.at(7.5), w, h).unwrap();
            assert!((pixel.x - x).abs() < 1e-3 && (pixel.y - y).abs() < 1e-3, "{pixel} vs ({x}, {y})");
            assert!((cos - ray.dir.dot(-c.w)).abs() < 1e-6);
        }
        // A pixel is a unit square at the image distance: the ray through
        // the centre is perpendicular to it there.
        let centre = c.ray(80.0, 45.0, w, h).dir;
        let next = c.ray(81.0, 45.0, w, h).dir;
        let d = c.image_distance(h);
        assert!(((next / next.dot(centre) - centre) * d).length() - 1.0 < 1e-3);
        assert!(c.project(c.eye + c.w, w, h).is_none(), "behind the camera");
        assert!(c.project(c.ray(-1.0, 10.0, w, h).at(3.0), w, h).is_none(), "left of the image");
    }

    #[test]
    fn a_look_at_far_off_gives_its_direction() {
        for far in [1e3, 1e20, 1e30, 3e38] {
            let c = Camera::new(Vec3::new(0.0, 1.0, 3.0), Vec3::new(0.0, 1.0, -far), Vec3::Y, 40.0).unwrap();
            assert!(c.w.abs_diff_eq(Vec3::Z, 1e-6) && c.u.abs_diff_eq(Vec3::X, 1e-6), "{far}: {c:?}");
        }
        let tilted = Camera::new(Vec3::ZERO, Vec3::new(1e25, 0.0, -1e25), Vec3::Y, 40.0).unwrap();
        assert!(tilted.w.abs_diff_eq(Vec3::new(-1.0, 0.0, 1.0).normalize(), 1e-6), "{tilted:?}");
        // Beyond the floats: refused, and not as "the same point".
        let err =
            Camera::new(Vec3::new(0.0, 0.0, 3e38), Vec3::new(0.0, 0.0, -3e38), Vec3::Y, 40.0).unwrap_err();
        assert!(err.contains("too far apart"), "{err}");
    }

    #[test]
    fn degenerate_cameras_are_rejected() {
        assert!(Camera::new(Vec3::ONE, Vec3::ONE, Vec3::Y, 40.0).is_err());
        assert!(Camera::new(Vec3::Y, Vec3::ZERO, Vec3::Y, 40.0).is_err());
        assert!(Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 180.0).is_err());
        assert!(Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 0.0).is_err());
    }
}
