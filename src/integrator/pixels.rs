//! The parallel loop shared by the integrators that compute each pixel on
//! its own (Whitted, photon mapping, path tracing, previews): square tiles
//! handed to threads, one random stream per pixel, tiles written back by
//! position, so the image never depends on the thread count.

use rayon::prelude::*;

use super::{Context, Progress};
use crate::accel::Ray;
use crate::film::{Film, Sample};
use crate::query::RayCount;
use crate::sampling::{stratified, Rng, SamplerKind};

/// Side of the square tiles handed to threads.
const TILE: u32 = 16;

/// Computes every pixel with `pixel(x, y, rng, count)`, where `rng` is the
/// pixel's own stream; returns the film and the rays counted. `progress`
/// hears after each tile how many pixels it finished.
pub fn render_pixels(
    ctx: &Context,
    progress: &Progress,
    pixel: impl Fn(u32, u32, &mut Rng, &mut RayCount) -> Sample + Sync,
) -> (Film, RayCount) {
    let width = ctx.config.width;
    let region = ctx.config.region();
    // Rounds after the first of a render to a time budget draw from other
    // streams (the first round's are the plain render's).
    let seed = |first: u32| ctx.config.seed.wrapping_add(first as u64 * 0x9E37_79B9_7F4A_7C15);
    let tiles: Vec<(u32, u32)> = (region.y0..region.y1)
        .step_by(TILE as usize)
        .flat_map(|y0| (region.x0..region.x1).step_by(TILE as usize).map(move |x0| (x0, y0)))
        .collect();
    let rendered: Vec<((u32, u32), Vec<Sample>, RayCount)> = tiles
        .into_par_iter()
        .map(|(x0, y0)| {
            let mut count = RayCount::default();
            let mut pixels = Vec::with_capacity((TILE * TILE) as usize);
            for y in y0..(y0 + TILE).min(region.y1) {
                for x in x0..(x0 + TILE).min(region.x1) {
                    // The stream of the pixel's index in the whole image,
                    // so a region renders the same pixels as the whole.
                    let first = ctx.samples_at(x, y).first;
                    let mut rng = Rng::new(seed(first), (y as u64) * width as u64 + x as u64);
                    pixels.push(pixel(x, y, &mut rng, &mut count));
                }
            }
            progress(pixels.len() as u64);
            ((x0, y0), pixels, count)
        })
        .collect();

    let mut film = Film::new(region.width(), region.height());
    let mut total = RayCount::default();
    for ((x0, y0), tile, count) in rendered {
        total += count;
        let tile_width = (x0 + TILE).min(region.x1) - x0;
        for (i, c) in tile.into_iter().enumerate() {
            film.set(x0 - region.x0 + i as u32 % tile_width, y0 - region.y0 + i as u32 / tile_width, c);
        }
    }
    (film, total)
}

/// Averages `radiance` over a pixel's camera rays: the samples
/// `ctx.samples_at` the pixel (none: a black sample; a render of a single
/// sample goes through the centre).
/// With the independent sampler they are stratified and jittered and share
/// the pixel's stream `rng`; with Sobol, sample `i` draws everything (its
/// position first) from its own low-discrepancy stream ([`Rng::sobol`]).
pub fn average_over_pixel(
    ctx: &Context,
    (x, y): (u32, u32),
    rng: &mut Rng,
    mut radiance: impl FnMut(Ray, &mut Rng) -> Sample,
) -> Sample {
    let c = ctx.config;
    let range = ctx.samples_at(x, y);
    if range.count == 0 {
        return Sample::default();
    }
    // One sample in all (not one round of many): the pixel's centre.
    let single = range.first == 0 && range.count == 1 && c.time.is_none();
    let camera_ray = |offset: glam::Vec2| {
        let offset = if single { glam::Vec2::splat(0.5) } else { offset };
        ctx.scene().camera.ray(x as f32 + offset.x, y as f32 + offset.y, c.width, c.height)
    };
    let mut sum = Sample::default();
    // The pixel's Sobol stream, restarted at each sample.
    let mut stream: Option<Rng> = None;
    for i in range.first..range.first + range.count {
        sum += match c.sampler {
            SamplerKind::Independent => {
                let offset =
                    if single { glam::Vec2::ZERO } else { stratified(i - range.first, range.count, rng) };
                radiance(camera_ray(offset), rng)
            }
            SamplerKind::Sobol => {
                let sample = match &mut stream {
                    Some(sample) => {
                        sample.restart(i);
                        sample
                    }
                    None => stream.insert(Rng::sobol_kept(c.seed, y as u64 * c.width as u64 + x as u64, i)),
                };
                let offset = sample.uniform2();
                radiance(camera_ray(offset), sample)
            }
        };
    }
    sum * (1.0 / range.count as f32)
}
