//! Light tracing's last step: where the pinhole camera sees a point on a
//! surface, and how densely its pixels sample the surface there. Light
//! subpaths (VCM's `light` mode and its connections) and SPPM's caustic
//! photons seen directly both add their light to the film this way, with
//! the correction light carried from the lights takes on shading normals
//! ([`SurfacePoint::adjoint_shading`]).

use glam::Vec3;

use super::Context;
use crate::query::{RayCount, SurfacePoint};

/// A point as the camera sees it, occlusion not yet tested.
pub(crate) struct CameraView {
    /// The pixel it lands in, as an index into the rendered region (row by row).
    pub pixel: usize,
    /// Unit direction from the point to the eye.
    pub to_eye: Vec3,
    /// Squared distance from the point to the eye.
    distance2: f32,
    /// Image-plane area (in pixels) per unit solid angle seen from the eye
    /// in the point's direction.
    image_per_solid_angle: f32,
}

impl CameraView {
    /// Where the camera sees `p`: `None` when it lies behind the camera or
    /// outside the region being rendered.
    pub fn of(ctx: &Context, p: Vec3) -> Option<CameraView> {
        let c = ctx.config;
        let camera = &ctx.scene().camera;
        let (at, cos_camera) = camera.project(p, c.width, c.height)?;
        let region = c.region();
        let (x, y) = (at.x as u32, at.y as u32);
        if !(region.x0..region.x1).contains(&x) || !(region.y0..region.y1).contains(&y) {
            return None;
        }
        let to_eye = camera.eye - p;
        let distance2 = to_eye.length_squared();
        // A pixel is a unit square on the image plane; its distance from
        // the pinhole along this direction turns solid angle into area.
        let to_image_plane = camera.image_distance(c.height) / cos_camera;
        Some(CameraView {
            pixel: (y - region.y0) as usize * region.width() as usize + (x - region.x0) as usize,
            to_eye: to_eye / distance2.sqrt(),
            distance2,
            image_per_solid_angle: to_image_plane * to_image_plane / cos_camera,
        })
    }

    /// The camera's density of this point per unit area of its surface
    /// (pixels of image per unit area), where the surface's normal makes
    /// cosine `cos` with [`CameraView::to_eye`]: the light a point sends
    /// the eye, times this, is what it adds to its pixel (a box filter).
    pub fn area_pdf(&self, cos: f32) -> f32 {
        self.image_per_solid_angle * cos / self.distance2
    }

    /// Whether the eye sees the surface point `sp` (this view's point)
    /// unblocked; one shadow ray, counted in `rays`.
    pub fn unblocked(&self, ctx: &Context, sp: &SurfacePoint, rays: &mut RayCount) -> bool {
        !ctx.query.occluded(&sp.spawn_to(ctx.scene().camera.eye), rays)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Region, RenderConfig};

    /// A wall square to the view: each pixel's centre, found by the
    /// camera's own ray, lands back in its pixel, and the camera's density
    /// there is one over the area the pixel covers on the wall (its four
    /// corners' rays, met with the wall, make a quadrilateral), also in a
    /// region of the image and off the view's axis.
    #[test]
    fn a_pixel_sees_its_own_footprint() {
        let scene = crate::scene::test_scenes::wall_facing_the_camera();
        let accel = crate::accel::build(crate::accel::Backend::Native, &scene.triangle_views()).unwrap();
        let region = Region { x0: 10, y0: 5, x1: 50, y1: 40 };
        let config = RenderConfig { width: 64, height: 48, region: Some(region), ..scene.config.clone() };
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        let camera = &scene.camera;
        // Where the ray through image position (x, y) meets the wall (at
        // the depth of the wall's centre: the scene is placed about the camera).
        let wall_z = camera.eye.z - 3.0;
        let on_wall = |x: f32, y: f32| {
            let ray = camera.ray(x, y, config.width, config.height);
            ray.origin + ray.dir * ((wall_z - ray.origin.z) / ray.dir.z)
        };
        for (x, y) in [(10, 5), (31, 22), (49, 39), (12, 38)] {
            let (fx, fy) = (x as f32, y as f32);
            let centre = on_wall(fx + 0.5, fy + 0.5);
            let view = CameraView::of(&ctx, centre).expect("inside the region");
            assert_eq!(view.pixel, (y - 5) * 40 + (x - 10), "pixel ({x}, {y})");
            let corners =
                [on_wall(fx, fy), on_wall(fx + 1.0, fy), on_wall(fx + 1.0, fy + 1.0), on_wall(fx, fy + 1.0)];
            let footprint = 0.5 * (corners[2] - corners[0]).cross(corners[3] - corners[1]).length();
            let pdf = view.area_pdf(view.to_eye.z);
            assert!((pdf * footprint - 1.0).abs() < 1e-3, "pixel ({x}, {y}): {pdf} against 1 / {footprint}");
        }
        // Outside the region, or behind the eye: not seen.
        assert!(CameraView::of(&ctx, on_wall(5.5, 20.5)).is_none());
        assert!(CameraView::of(&ctx, on_wall(30.5, 45.5)).is_none());
        assert!(CameraView::of(&ctx, camera.eye + Vec3::Z).is_none());
    }
}
