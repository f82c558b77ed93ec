//! Rendering: the camera, images, and the shading modes available so far.
//!
//! `Preview` modes trace one primary ray per sample through the chosen
//! [`Intersector`] and show geometry (smooth normals or depth): they exercise
//! the whole path from scene file to Embree to image.

pub mod camera;
pub mod image;

use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::Intersector;
use crate::scene::Scene;
use image::Image;

/// What a preview render shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Preview {
    /// Smooth shading normals mapped to colours, `0.5 * (n + 1)`, dimmed by
    /// the angle to the viewer so shapes read clearly.
    Normals,
    /// Distance to the first hit, near bright, far dark.
    Depth,
}

/// Numbers for the summary line of a render.
#[derive(Debug, Clone, Copy)]
pub struct RenderStats {
    /// Wall-clock time of the render.
    pub elapsed: Duration,
    /// Rays traced.
    pub rays: u64,
}

/// Renders a preview image of `scene` at `width x height`, one centred ray
/// per pixel. `progress` is called once per finished row.
pub fn render_preview(
    scene: &Scene,
    accel: &dyn Intersector,
    mode: Preview,
    width: u32,
    height: u32,
    progress: &(dyn Fn() + Sync),
) -> (Image, RenderStats) {
    let start = Instant::now();
    // Depth is scaled by the scene's size as seen from the eye.
    let b = scene.bounds();
    let far = (b.min - scene.camera.eye)
        .length()
        .max((b.max - scene.camera.eye).length());
    let rows: Vec<Vec<Vec3>> = (0..height)
        .into_par_iter()
        .map(|y| {
            let row = (0..width)
                .map(|x| {
                    let ray = scene
                        .camera
                        .ray(x as f32 + 0.5, y as f32 + 0.5, width, height);
                    let Some(hit) = accel.intersect(&ray) else {
                        return Vec3::ZERO;
                    };
                    match mode {
                        Preview::Normals => {
                            let mesh = &scene.meshes[hit.geom_id as usize];
                            let n = mesh.shading_normal(hit.prim_id, hit.u, hit.v);
                            let facing = n.dot(-ray.dir).abs();
                            0.5 * (n + Vec3::ONE) * (0.3 + 0.7 * facing)
                        }
                        Preview::Depth => Vec3::splat((1.0 - hit.t / far).clamp(0.0, 1.0)),
                    }
                })
                .collect();
            progress();
            row
        })
        .collect();
    let image = Image::from_rows(width, height, rows);
    let stats = RenderStats {
        elapsed: start.elapsed(),
        rays: width as u64 * height as u64,
    };
    (image, stats)
}
