//! Geometry previews: one centred ray per pixel showing shapes, not light.

use glam::Vec3;

use super::pixels::render_pixels;
use super::{Context, Integrator, Progress, Rendered};
use crate::config::RenderConfig;
use crate::film::Sample;

/// Which preview.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preview {
    /// Smooth normals as colours, `0.5 * (n + 1)`, dimmed by the angle to
    /// the viewer so shapes read clearly.
    Normals,
    /// Distance to the first hit: the eye bright, the scene's far side black.
    Depth,
}

impl Integrator for Preview {
    fn samples_per_pixel(&self, _: &RenderConfig) -> u32 {
        1
    }

    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered {
        let scene = ctx.scene();
        let c = ctx.config;
        // The depth preview maps distance from the eye to the scene's far side to 1..0.
        let b = scene.bounds();
        let far = (b.min - scene.camera.eye).length().max((b.max - scene.camera.eye).length());
        let (film, rays) = render_pixels(ctx, progress, |x, y, _, count| {
            let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, c.width, c.height);
            let Some(hit) = ctx.query.first_hit(&ray, count) else { return Sample::default() };
            let n = scene.meshes[hit.geom_id as usize].shading_normal(hit.prim_id, hit.u, hit.v);
            let picture = match self {
                Preview::Depth => Vec3::splat((1.0 - hit.t / far).clamp(0.0, 1.0)),
                Preview::Normals => 0.5 * (n + Vec3::ONE) * (0.3 + 0.7 * n.dot(-ray.dir).abs()),
            };
            // The picture is what the final image shows; it is not light, so
            // it goes to the component that is passed on as it is.
            let normal = if n.dot(ray.dir) > 0.0 { -n } else { n };
            Sample { emission: picture, normal, depth: hit.t, ..Sample::default() }
        });
        Rendered::new(film, rays, Vec::new())
    }
}
