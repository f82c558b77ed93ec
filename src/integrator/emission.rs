//! Lights seen through the camera, sampled apart where they show an edge.
//!
//! A pixel that a light covers in part (the light's edge, its small image
//! in a mirror or through glass) is light or dark at each camera sample, so
//! at a few samples a pixel it is far too bright or too dark: on the
//! area-lit Cornell box at 16 samples a pixel those pixels held 83% of
//! photon mapping's squared error (BENCHMARKS.md, issue 16). There a camera
//! sample is dear (one that misses the light gathers photons or traces a
//! path) where what the light needs is cheap: one ray, and one more at each
//! mirror or glass surface on the way.
//!
//! So after a render, the pixels whose neighbourhood shows an edge of a
//! light take [`EXTRA_PER_SAMPLE`] times as many samples of the emission
//! component alone as the render took a pixel (on average), averaged with
//! each pixel's own by count. Which pixels, a first look decides:
//! [`FIRST_LOOK`] samples a pixel, of random numbers of their own and not
//! counted in the image (so the choice does not bias it), and a pixel is
//! refined when what those samples found over its 3 x 3 neighbourhood is
//! not all the same. The first look covers a region of the image and one
//! pixel around it, so a tile of the image chooses as the whole image does.
//!
//! A render to a time budget looks first and leaves the refinement its
//! time, as the first look measured it ([`LightEdges::seconds_after`]): its
//! rounds already send more camera samples where the pixels around are
//! noisy, but at a few seconds the lights' edges were still most of SPPM's
//! fireflies and a tenth of its error (BENCHMARKS.md, issue 16).

use std::time::Instant;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::Context;
use crate::accel::Ray;
use crate::bsdf::{Bsdf, RadianceScale};
use crate::config::Region;
use crate::film::Film;
use crate::light::Light;
use crate::query::{Interaction, RayCount};
use crate::sampling::{Rng, SamplerKind};

/// The weight below which a specular lobe is followed at random.
const FAINT: f32 = 0.1;

/// Samples a pixel of the first look.
const FIRST_LOOK: u32 = 4;

/// A refined pixel's emission samples per camera sample of the render.
const EXTRA_PER_SAMPLE: u32 = 8;

/// The fewest and the most emission samples a refined pixel takes.
const MIN_EXTRA: u32 = 64;
const MAX_EXTRA: u32 = 16_384;

/// Where the Sobol streams of the first look and of the refinement start:
/// past any pixel's index and past the other streams' (SPPM's at 1 << 48).
const FIRST_LOOK_STREAM: u64 = 5 << 48;
const EXTRA_STREAM: u64 = 6 << 48;

/// The pixels of a region where a light's edge shows, found by a first
/// look, and what their emission samples cost.
pub struct LightEdges {
    /// The region the first look covered (one pixel around it aside).
    region: Region,
    /// Indices into `region`'s pixels, in order.
    pixels: Vec<usize>,
    /// Rays the first look traced.
    look_rays: RayCount,
    /// Wall-clock seconds an emission sample of these pixels takes (their
    /// rays per sample in the first look, at the first look's time per ray).
    seconds_per_sample: f64,
    /// Wall-clock seconds the first look took.
    look_seconds: f64,
}

impl LightEdges {
    /// Looks at the config's region for pixels whose neighbourhood shows a
    /// light's edge: `None` where the scene has no area light to see.
    pub fn find(ctx: &Context) -> Option<LightEdges> {
        let config = ctx.config;
        // Point and spot lights are not seen.
        if !ctx.scene().lights.iter().any(|light| matches!(light, Light::Area { .. })) {
            return None;
        }
        let start = Instant::now();
        let region = config.region();
        // The first look: the region and a pixel around it, within the image.
        let around = Region {
            x0: region.x0.saturating_sub(1),
            y0: region.y0.saturating_sub(1),
            x1: (region.x1 + 1).min(config.width),
            y1: (region.y1 + 1).min(config.height),
        };
        let (looked, counts): (Vec<(f32, f32)>, Vec<RayCount>) = (0..around.pixels() as usize)
            .into_par_iter()
            .map(|i| {
                let mut count = RayCount::default();
                let (x, y) = around.pixel(i);
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for s in 0..FIRST_LOOK {
                    let e = sample(ctx, (x, y), FIRST_LOOK_STREAM, s, &mut count).element_sum();
                    (lo, hi) = (lo.min(e), hi.max(e));
                }
                ((lo, hi), count)
            })
            .unzip();
        let width = around.width() as usize;
        let at = |x: u32, y: u32| (y - around.y0) as usize * width + (x - around.x0) as usize;
        let differs = |x: u32, y: u32| {
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for ny in y.saturating_sub(1).max(around.y0)..(y + 2).min(around.y1) {
                for nx in x.saturating_sub(1).max(around.x0)..(x + 2).min(around.x1) {
                    let (l, h) = looked[at(nx, ny)];
                    (lo, hi) = (lo.min(l), hi.max(h));
                }
            }
            hi > lo
        };
        let pixels: Vec<usize> = (0..region.pixels() as usize)
            .filter(|&i| {
                let (x, y) = region.pixel(i);
                differs(x, y)
            })
            .collect();
        let rays = |c: &RayCount| (c.closest + c.shadow) as f64;
        let look_rays: RayCount = counts.iter().copied().sum();
        let look_seconds = start.elapsed().as_secs_f64();
        let seconds_per_ray = look_seconds / rays(&look_rays).max(1.0);
        let edge_rays: f64 = pixels
            .iter()
            .map(|&i| {
                let (x, y) = region.pixel(i);
                rays(&counts[at(x, y)])
            })
            .sum();
        let rays_per_sample = edge_rays / (pixels.len().max(1) as f64 * FIRST_LOOK as f64);
        let seconds_per_sample = seconds_per_ray * rays_per_sample;
        Some(LightEdges { region, pixels, look_rays, seconds_per_sample, look_seconds })
    }

    /// The emission samples each of these pixels takes after a render of
    /// `samples` camera samples a pixel (on average).
    pub fn extra_for(samples: f64) -> u32 {
        (samples * EXTRA_PER_SAMPLE as f64).clamp(MIN_EXTRA as f64, MAX_EXTRA as f64) as u32
    }

    /// The wall-clock seconds [`LightEdges::refine`] should take after a
    /// render of `samples` camera samples a pixel (on average): what a
    /// render to a time budget leaves for it.
    pub fn seconds_after(&self, samples: f64) -> f64 {
        self.pixels.len() as f64 * Self::extra_for(samples) as f64 * self.seconds_per_sample
    }

    /// Whether pixel `(x, y)` of the image takes the refinement.
    pub fn refines(&self, (x, y): (u32, u32)) -> bool {
        let r = self.region;
        let inside = (r.x0..r.x1).contains(&x) && (r.y0..r.y1).contains(&y);
        inside
            && self
                .pixels
                .binary_search(&((y - r.y0) as usize * r.width() as usize + (x - r.x0) as usize))
                .is_ok()
    }

    /// The share of its emission's variance a refined pixel keeps: at least
    /// [`EXTRA_PER_SAMPLE`] emission samples join each of its camera
    /// samples (more where the render takes fewer than 8 a pixel).
    pub fn variance_kept() -> f64 {
        1.0 / (1 + EXTRA_PER_SAMPLE) as f64
    }

    /// The wall-clock seconds the first look took.
    pub fn look_seconds(&self) -> f64 {
        self.look_seconds
    }

    /// The emission samples each of these pixels takes after a render to a
    /// time budget of `samples` camera samples a pixel (on average), with
    /// `seconds` of the budget left: [`LightEdges::extra_for`] as the
    /// render planned, fewer if the time left affords fewer, but never
    /// fewer than [`MIN_EXTRA`]. The render's rounds (or passes) leave
    /// [`LightEdges::seconds_after`] for this, which counts at least that
    /// many; a last round that takes longer than planned (a small round
    /// costs more a sample: it starts and ends its threads all the same)
    /// must not take them. At 1 s on the area-lit Cornell box such a round
    /// left the light's edge row 7 of its 64, and half the seeds showed
    /// that row's pixels at twice their brightness (BENCHMARKS.md).
    pub fn extra_after(&self, samples: f64, seconds: f64) -> u32 {
        let each = self.pixels.len() as f64 * self.seconds_per_sample;
        let within = (seconds / each.max(1e-12)).clamp(0.0, MAX_EXTRA as f64) as u32;
        Self::extra_for(samples).min(within.max(MIN_EXTRA))
    }

    /// Gives each pixel of `film` (the region's) where an edge shows
    /// `extra` samples of the emission component alone, averaged with the
    /// render's own by count: pixel `i` of the region took `samples(i)`
    /// camera samples spread over the pixel. Returns the note for the
    /// stats, or `None` when no pixel needed it. Rays traced, the first
    /// look's among them, are added to `rays`.
    pub fn refine(
        &self,
        ctx: &Context,
        film: &mut Film,
        samples: &dyn Fn(usize) -> u32,
        extra: u32,
        rays: &mut RayCount,
    ) -> Option<String> {
        *rays += self.look_rays;
        if self.pixels.is_empty() || extra == 0 {
            return None;
        }
        let region = self.region;
        let refined: Vec<RayCount> = self
            .pixels
            .par_iter()
            .map(|&i| {
                let (x, y) = region.pixel(i);
                let mut count = RayCount::default();
                let sum: Vec3 = (0..extra).map(|s| sample(ctx, (x, y), EXTRA_STREAM, s, &mut count)).sum();
                (i, sum, count)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .map(|(i, sum, count)| {
                let pixel = &mut film.pixels[i];
                let n = samples(i);
                pixel.emission = (pixel.emission * n as f32 + sum) / (n + extra) as f32;
                count
            })
            .collect();
        *rays += refined.iter().copied().sum();
        Some(format!(
            "lights' edges: {} pixels took {extra} more samples of the lights they see",
            refined.len()
        ))
    }
}

/// Refines the emission of the pixels of `film` (the config's region, each
/// the mean of `samples` camera samples spread over the pixel) where a
/// light's edge shows. Returns the note for the stats, or `None` when no
/// pixel needed it. Rays traced are added to `rays`.
pub(super) fn refine(ctx: &Context, film: &mut Film, samples: u32, rays: &mut RayCount) -> Option<String> {
    let edges = LightEdges::find(ctx)?;
    edges.refine(ctx, film, &|_| samples, LightEdges::extra_for(samples as f64), rays)
}

/// One sample of the light seen through pixel `(x, y)`: sample `index` of
/// the pixel's stream `stream` (with the Sobol sampler; else a stream of
/// the pixel's own per `stream` and index).
fn sample(ctx: &Context, (x, y): (u32, u32), stream: u64, index: u32, count: &mut RayCount) -> Vec3 {
    let config = ctx.config;
    let pixel = y as u64 * config.width as u64 + x as u64;
    let mut rng = match config.sampler {
        SamplerKind::Sobol => Rng::sobol(config.seed, pixel + stream, index),
        SamplerKind::Independent => Rng::new(config.seed ^ stream, pixel << 20 ^ index as u64),
    };
    let jitter: Vec2 = rng.uniform2();
    let ray = ctx.scene().camera.ray(x as f32 + jitter.x, y as f32 + jitter.y, config.width, config.height);
    emission_along(ctx, ray, 0, (Vec3::ONE, RadianceScale::ONE), &mut rng, count)
}

/// The light seen along `ray` directly or through mirrors and glass (the
/// `emission` component of every integrator), `weight` the weight the ray
/// carries from the camera with the scale of its refractions, and `depth`
/// the rays before it. At each surface
/// it follows every specular lobe (mirror, and glass's reflection and
/// refraction, as Whitted's recursion does: a lobe chosen at random made
/// the light's images through glass noisier than the renders' own); a lobe
/// carrying less than [`FAINT`] goes on at random, with its weight raised
/// by the chance, so the mean stays exact. Nothing past a surface with no
/// specular lobe.
fn emission_along(
    ctx: &Context,
    ray: Ray,
    depth: u32,
    (weight, scale): (Vec3, RadianceScale),
    rng: &mut Rng,
    count: &mut RayCount,
) -> Vec3 {
    let query = &ctx.query;
    let sp = match query.first(&ray, count) {
        None => return Vec3::ZERO,
        Some(Interaction::Emitter { radiance, .. }) => return weight * radiance * scale.factor(),
        Some(Interaction::Surface(sp)) => sp,
    };
    if depth + 1 >= ctx.config.max_depth {
        return Vec3::ZERO;
    }
    let bsdf = Bsdf::new(query.material(&sp), &sp, ray.dir.normalize());
    let mut sum = Vec3::ZERO;
    for branch in bsdf.specular_branches() {
        let mut carried = weight * branch.weight;
        let most = carried.max_element();
        if most <= 0.0 {
            continue;
        }
        if most < FAINT {
            if rng.uniform() * FAINT >= most {
                continue;
            }
            carried *= FAINT / most;
        }
        let on = (carried, scale.after(&branch));
        sum += emission_along(ctx, sp.spawn(branch.wi), depth + 1, on, rng, count);
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refined_pixel_is_found_by_its_place_in_the_image() {
        // A tile's region; pixels 0 and 13 of it (10 wide) take the refinement.
        let region = Region { x0: 10, y0: 5, x1: 20, y1: 9 };
        let edges = LightEdges {
            region,
            pixels: vec![0, 13],
            look_rays: RayCount::default(),
            seconds_per_sample: 0.0,
            look_seconds: 0.0,
        };
        assert!(edges.refines((10, 5)) && edges.refines((13, 6)));
        for outside_or_not in [(11, 5), (13, 5), (9, 5), (10, 9), (20, 6), (3, 6)] {
            assert!(!edges.refines(outside_or_not), "{outside_or_not:?}");
        }
    }
}
