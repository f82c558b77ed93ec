//! Rendering: camera, integrators, and the parallel tile loop that turns a
//! scene into images.
//!
//! Every pixel owns a random stream derived from its index, and tiles are
//! written back by position, so an image is bit-identical whatever the
//! number of threads.

pub mod camera;
pub mod image;
pub mod path;
pub mod sppm;
pub mod surface;
pub mod whitted;

use std::ops::{AddAssign, Mul};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::Intersector;
use crate::photon::{build_maps, PhotonSettings, PhotonStats};
use crate::sampling::Rng;
use crate::scene::Scene;
use image::Image;
use whitted::{RayCount, Whitted};

/// Which integrator computes the pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// Photon mapping: Whitted ray tracing plus caustics from the caustic
    /// map and indirect light from the global map (by final gathering, or
    /// shown directly when there are no gather rays).
    Photon,
    /// Stochastic progressive photon mapping: passes of camera paths and
    /// photons with a shrinking radius, converging to the exact image.
    Sppm,
    /// Whitted ray tracing: direct light, mirrors, refraction with Fresnel.
    Whitted,
    /// The unbiased reference: path tracing with next-event estimation and
    /// multiple importance sampling for area lights.
    Path,
    /// Geometry preview: smooth normals as colours, `0.5 * (n + 1)`, dimmed by
    /// the angle to the viewer so shapes read clearly.
    Normals,
    /// Geometry preview: distance to the first hit, near bright, far dark.
    Depth,
}

/// Everything that controls a render besides the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Camera samples per pixel (stratified, jittered).
    pub samples: u32,
    /// Longest chain of rays from the camera (1 = camera rays only).
    pub max_depth: u32,
    /// Shadow-ray samples per area light at each shading point.
    pub light_samples: u32,
    /// Constant ambient radiance times the diffuse colour: the seed report's
    /// classic look, off (zero) by default.
    pub ambient: Vec3,
    /// Specular branches carrying less than this fraction of the camera
    /// ray's weight are not followed.
    pub min_throughput: f32,
    /// Seed of every random stream.
    pub seed: u64,
    /// The integrator.
    pub integrator: Integrator,
    /// Photon counts and estimates (for [`Integrator::Photon`]).
    pub photons: PhotonSettings,
}

impl RenderSettings {
    /// The settings a scene file asks for.
    pub fn from_scene(scene: &Scene) -> RenderSettings {
        let r = &scene.render;
        RenderSettings {
            width: scene.image.width,
            height: scene.image.height,
            samples: scene.image.samples,
            max_depth: r.max_depth,
            light_samples: r.light_samples,
            ambient: r.ambient,
            min_throughput: 1e-4,
            seed: 0,
            integrator: r.integrator,
            photons: scene.photons.clone(),
        }
    }
}

/// Radiance at a pixel split by how the light got there. The final image is
/// the sum; each part can be written as its own image (an AOV).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct Components {
    /// Lights seen directly, and direct light at the first surface hit.
    pub direct: Vec3,
    /// Everything reaching the camera through mirror reflection or refraction.
    pub specular: Vec3,
    /// Caustics at the first surface hit: light focused onto it by mirrors
    /// and glass (the caustic map).
    pub caustic: Vec3,
    /// Indirect light at the first surface hit: light that bounced off a
    /// diffuse surface before (the global map, or final gathering).
    pub global: Vec3,
}

impl Components {
    /// Names accepted by `--aov`, in output order.
    pub const NAMES: [&'static str; 5] = ["direct", "specular", "caustic", "global", "final"];

    /// The sum of all parts.
    pub fn total(&self) -> Vec3 {
        self.direct + self.specular + self.caustic + self.global
    }

    /// Radiance emitted by a light and seen after `depth` specular bounces.
    pub fn emitted(radiance: Vec3, depth: u32) -> Components {
        if depth == 0 {
            Components { direct: radiance, ..Default::default() }
        } else {
            Components { specular: radiance, ..Default::default() }
        }
    }

    /// The part called `name` (one of [`Components::NAMES`]).
    pub fn get(&self, name: &str) -> Option<Vec3> {
        match name {
            "direct" => Some(self.direct),
            "specular" => Some(self.specular),
            "caustic" => Some(self.caustic),
            "global" => Some(self.global),
            "final" => Some(self.total()),
            _ => None,
        }
    }
}

impl AddAssign for Components {
    fn add_assign(&mut self, o: Components) {
        self.direct += o.direct;
        self.specular += o.specular;
        self.caustic += o.caustic;
        self.global += o.global;
    }
}

impl Mul<f32> for Components {
    type Output = Components;
    fn mul(self, k: f32) -> Components {
        Components {
            direct: self.direct * k,
            specular: self.specular * k,
            caustic: self.caustic * k,
            global: self.global * k,
        }
    }
}

/// Numbers for the summary line of a render.
#[derive(Debug, Clone)]
pub struct RenderStats {
    /// Wall-clock time of the render.
    pub elapsed: Duration,
    /// Rays traced to their closest hit.
    pub rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// Photon tracing, if the integrator uses photons.
    pub photons: Option<PhotonStats>,
}

/// A finished render: per-pixel components, row-major from the top left.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The pixels.
    pub pixels: Vec<Components>,
    /// Time and work.
    pub stats: RenderStats,
}

impl Rendered {
    /// The image of one component (`"final"` for the whole).
    pub fn image(&self, name: &str) -> Option<Image> {
        let pixels = self.pixels.iter().map(|c| c.get(name)).collect::<Option<Vec<Vec3>>>()?;
        Some(Image { width: self.width, height: self.height, pixels })
    }
}

/// Averages `radiance` over a pixel's camera rays: `settings.samples`
/// stratified, jittered samples (a single sample goes through the centre).
pub fn average_over_pixel(
    scene: &Scene,
    settings: &RenderSettings,
    (x, y): (u32, u32),
    rng: &mut Rng,
    mut radiance: impl FnMut(crate::accel::Ray, &mut Rng) -> Components,
) -> Components {
    let mut sum = Components::default();
    for i in 0..settings.samples {
        let offset = if settings.samples == 1 {
            glam::Vec2::splat(0.5)
        } else {
            crate::sampling::stratified(i, settings.samples, rng)
        };
        let ray = scene.camera.ray(x as f32 + offset.x, y as f32 + offset.y, settings.width, settings.height);
        sum += radiance(ray, rng);
    }
    sum * (1.0 / settings.samples as f32)
}

/// Side of the square tiles handed to threads.
const TILE: u32 = 16;

/// Renders `scene` with `settings`. `progress` is called after each tile
/// with the number of pixels it finished.
pub fn render(
    scene: &Scene,
    accel: &dyn Intersector,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Rendered {
    let start = Instant::now();
    if settings.integrator == Integrator::Sppm {
        return render_progressive(scene, accel, settings, progress);
    }
    let (width, height) = (settings.width, settings.height);
    let maps =
        (settings.integrator == Integrator::Photon).then(|| build_maps(scene, accel, &settings.photons));
    let whitted = Whitted { scene, accel, settings, maps: maps.as_ref() };
    let path = path::PathTracer { scene, accel, settings };
    // The depth preview maps distance from the eye to the scene's far side to 1..0.
    let b = scene.bounds();
    let far = (b.min - scene.camera.eye).length().max((b.max - scene.camera.eye).length());
    let rays = AtomicU64::new(0);
    let shadow_rays = AtomicU64::new(0);
    let tiles: Vec<(u32, u32)> = (0..height.div_ceil(TILE))
        .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let rendered: Vec<((u32, u32), Vec<Components>)> = tiles
        .into_par_iter()
        .map(|(x0, y0)| {
            let mut count = RayCount::default();
            let mut pixels = Vec::with_capacity((TILE * TILE) as usize);
            for y in y0..(y0 + TILE).min(height) {
                for x in x0..(x0 + TILE).min(width) {
                    let mut rng = Rng::new(settings.seed, (y as u64) * width as u64 + x as u64);
                    pixels.push(match settings.integrator {
                        Integrator::Whitted | Integrator::Photon => whitted.pixel(x, y, &mut rng, &mut count),
                        Integrator::Path => path.pixel(x, y, &mut rng, &mut count),
                        preview => preview_pixel(scene, accel, preview, far, (x, y), settings, &mut count),
                    });
                }
            }
            rays.fetch_add(count.closest, Ordering::Relaxed);
            shadow_rays.fetch_add(count.shadow, Ordering::Relaxed);
            progress(pixels.len() as u64);
            ((x0, y0), pixels)
        })
        .collect();

    let mut pixels = vec![Components::default(); width as usize * height as usize];
    for ((x0, y0), tile) in rendered {
        let tile_width = (x0 + TILE).min(width) - x0;
        for (i, c) in tile.into_iter().enumerate() {
            let (x, y) = (x0 + i as u32 % tile_width, y0 + i as u32 / tile_width);
            pixels[(y * width + x) as usize] = c;
        }
    }
    let stats = RenderStats {
        elapsed: start.elapsed(),
        rays: rays.into_inner(),
        shadow_rays: shadow_rays.into_inner(),
        photons: maps.map(|m| m.stats),
    };
    Rendered { width, height, pixels, stats }
}

/// How many units of work [`render`] reports through `progress` in all:
/// pixels, times passes for progressive photon mapping.
pub fn work_units(settings: &RenderSettings) -> u64 {
    let pixels = settings.width as u64 * settings.height as u64;
    match settings.integrator {
        Integrator::Sppm => pixels * settings.photons.sppm.passes as u64,
        _ => pixels,
    }
}

/// [`render`] for [`Integrator::Sppm`]: all passes, then the image.
fn render_progressive(
    scene: &Scene,
    accel: &dyn Intersector,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Rendered {
    let start = Instant::now();
    let mut run = sppm::Progressive::new(scene, accel, settings);
    for _ in 0..settings.photons.sppm.passes {
        run.run_pass();
        progress(settings.width as u64 * settings.height as u64);
    }
    run.rendered(start.elapsed())
}

/// One centred ray per pixel, showing geometry (in the `direct` component).
/// `far` is the distance that the depth preview shows as black.
fn preview_pixel(
    scene: &Scene,
    accel: &dyn Intersector,
    mode: Integrator,
    far: f32,
    (x, y): (u32, u32),
    settings: &RenderSettings,
    count: &mut RayCount,
) -> Components {
    let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, settings.width, settings.height);
    count.closest += 1;
    let Some(hit) = accel.intersect(&ray) else { return Components::default() };
    let colour = match mode {
        Integrator::Depth => Vec3::splat((1.0 - hit.t / far).clamp(0.0, 1.0)),
        _ => {
            let n = scene.meshes[hit.geom_id as usize].shading_normal(hit.prim_id, hit.u, hit.v);
            0.5 * (n + Vec3::ONE) * (0.3 + 0.7 * n.dot(-ray.dir).abs())
        }
    };
    Components { direct: colour, ..Default::default() }
}
