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
//! So after a render of a fixed number of samples a pixel, the pixels whose
//! neighbourhood shows an edge of a light take [`EXTRA_PER_SAMPLE`] times
//! as many samples of the emission component alone, averaged with the
//! render's own. Which pixels, a first look decides: [`FIRST_LOOK`] samples
//! a pixel, of random numbers of their own and not counted in the image (so
//! the choice does not bias it), and a pixel is refined when what those
//! samples found over its 3 x 3 neighbourhood is not all the same. The
//! first look covers a region of the image and one pixel around it, so a
//! tile of the image chooses as the whole image does.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::Context;
use crate::accel::Ray;
use crate::bsdf::Bsdf;
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

/// Refines the emission of the pixels of `film` (the config's region, each
/// the mean of `samples` camera samples spread over the pixel) where a
/// light's edge shows. Returns the note for the stats, or `None` when no
/// pixel needed it. Rays traced are added to `rays`.
pub(super) fn refine(ctx: &Context, film: &mut Film, samples: u32, rays: &mut RayCount) -> Option<String> {
    let config = ctx.config;
    // Point and spot lights are not seen.
    if !ctx.scene().lights.iter().any(|light| matches!(light, Light::Area { .. })) {
        return None;
    }
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
    let differs = |x: u32, y: u32| {
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for ny in y.saturating_sub(1).max(around.y0)..(y + 2).min(around.y1) {
            for nx in x.saturating_sub(1).max(around.x0)..(x + 2).min(around.x1) {
                let (l, h) = looked[(ny - around.y0) as usize * width + (nx - around.x0) as usize];
                (lo, hi) = (lo.min(l), hi.max(h));
            }
        }
        hi > lo
    };
    let extra = (samples.saturating_mul(EXTRA_PER_SAMPLE)).clamp(MIN_EXTRA, MAX_EXTRA);
    let refined: Vec<RayCount> = film
        .pixels
        .par_iter_mut()
        .enumerate()
        .filter_map(|(i, pixel)| {
            let (x, y) = region.pixel(i);
            if !differs(x, y) {
                return None;
            }
            let mut count = RayCount::default();
            let sum: Vec3 = (0..extra).map(|s| sample(ctx, (x, y), EXTRA_STREAM, s, &mut count)).sum();
            pixel.emission = (pixel.emission * samples as f32 + sum) / (samples + extra) as f32;
            Some(count)
        })
        .collect();
    for c in counts.into_iter().chain(refined.iter().copied()) {
        *rays += c;
    }
    (!refined.is_empty()).then(|| {
        format!("lights' edges: {} pixels took {extra} more samples of the lights they see", refined.len())
    })
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
    emission_along(ctx, ray, 0, Vec3::ONE, &mut rng, count)
}

/// The light seen along `ray` directly or through mirrors and glass (the
/// `emission` component of every integrator), `weight` the weight the ray
/// carries from the camera and `depth` the rays before it. At each surface
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
    weight: Vec3,
    rng: &mut Rng,
    count: &mut RayCount,
) -> Vec3 {
    let query = &ctx.query;
    let sp = match query.first(&ray, count) {
        None => return Vec3::ZERO,
        Some(Interaction::Emitter { radiance, .. }) => return weight * radiance,
        Some(Interaction::Surface(sp)) => sp,
    };
    if depth + 1 >= ctx.config.max_depth {
        return Vec3::ZERO;
    }
    let bsdf = Bsdf::new(query.material(&sp), &sp, ray.dir.normalize());
    let mut sum = Vec3::ZERO;
    for (lobe, dir) in bsdf.specular_branches() {
        let mut carried = weight * lobe;
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
        sum += emission_along(ctx, sp.spawn(dir), depth + 1, carried, rng, count);
    }
    sum
}
