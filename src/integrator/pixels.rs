//! The parallel loop shared by the integrators that compute each pixel on
//! its own (Whitted, photon mapping, path tracing, previews): square tiles
//! handed to threads, one random stream per pixel, tiles written back by
//! position, so the image never depends on the thread count.

use std::ops::Range;

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
    let region = ctx.config.region();
    let mut film = Film::new(region.width(), region.height());
    let rays = render_pixels_into(ctx, progress, pixel, &mut Vec::new(), |i, sample| film.pixels[i] = sample);
    (film, rays)
}

/// [`render_pixels`], each pixel's sample handed to `store` with its index
/// in the region (row by row) instead of written to a new film, the tiles
/// rendered into `scratch` (any contents; left holding them): for the
/// integrators that add pass after pass into one sum, with the same
/// scratch every pass. (A new film and new tiles every pass made the
/// kernel hand out and clear fresh pages every pass: 5-10% of a
/// light-tracing render, BENCHMARKS.md.)
pub fn render_pixels_into(
    ctx: &Context,
    progress: &Progress,
    pixel: impl Fn(u32, u32, &mut Rng, &mut RayCount) -> Sample + Sync,
    scratch: &mut Vec<Sample>,
    mut store: impl FnMut(usize, Sample),
) -> RayCount {
    let width = ctx.config.width;
    let region = ctx.config.region();
    // Rounds after the first of a render to a time budget draw from other
    // streams (the first round's are the plain render's).
    let seed = |first: u32| ctx.config.seed.wrapping_add(first as u64 * 0x9E37_79B9_7F4A_7C15);
    // Each tile's pixels, row by row.
    let tiles: Vec<(Range<u32>, Range<u32>)> = (region.y0..region.y1)
        .step_by(TILE as usize)
        .flat_map(|y0| {
            (region.x0..region.x1)
                .step_by(TILE as usize)
                .map(move |x0| (x0..(x0 + TILE).min(region.x1), y0..(y0 + TILE).min(region.y1)))
        })
        .collect();
    // The tiles' samples one tile after another in `scratch`, each tile
    // its own part.
    scratch.resize(region.pixels() as usize, Sample::default());
    let mut parts = Vec::with_capacity(tiles.len());
    let mut rest = &mut scratch[..];
    for (xs, ys) in &tiles {
        let (part, tail) = rest.split_at_mut(xs.len() * ys.len());
        parts.push(part);
        rest = tail;
    }
    let counts: Vec<RayCount> = tiles
        .par_iter()
        .zip(parts)
        .map(|((xs, ys), part)| {
            let mut count = RayCount::default();
            let places = ys.clone().flat_map(|y| xs.clone().map(move |x| (x, y)));
            for ((x, y), slot) in places.zip(part.iter_mut()) {
                // The stream of the pixel's index in the whole image,
                // so a region renders the same pixels as the whole.
                let first = ctx.samples_at(x, y).first;
                let mut rng = Rng::new(seed(first), (y as u64) * width as u64 + x as u64);
                *slot = pixel(x, y, &mut rng, &mut count);
            }
            progress(part.len() as u64);
            count
        })
        .collect();

    let mut samples = scratch.iter();
    let mut total = RayCount::default();
    for ((xs, ys), count) in tiles.into_iter().zip(counts) {
        total += count;
        for y in ys {
            for x in xs.clone() {
                let index = (y - region.y0) as usize * region.width() as usize + (x - region.x0) as usize;
                store(index, *samples.next().expect("a sample for each pixel"));
            }
        }
    }
    total
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
