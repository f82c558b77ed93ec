//! Rendering to a time budget in rounds of camera samples (the path
//! tracer, Whitted, photon mapping, and VCM with its special cases), each
//! round sized by the time the last one took per sample.
//!
//! Where light paths add to any pixel (VCM), every round takes whole
//! samples per pixel: one, then as many again each round (doubling), fewer
//! when the time left affords fewer. Where each pixel is its own (the
//! others), only the first two rounds do, one sample each. After that,
//! rounds follow the noise: a round's samples go half evenly to every pixel
//! and half in proportion to the standard deviation of the pixels around it
//! (for a fixed number of samples, shares in proportion to the deviation
//! leave the least summed variance), each pixel's estimated from how its
//! rounds' means differ. A light's edges, a mirror's highlights and glass
//! get many samples; a flat wall few. The last round takes as many samples
//! as the time left affords, however few that is per pixel.
//!
//! A pixel's own samples never decide how many it takes, only its eight
//! neighbours' (whose random numbers are their own), so each pixel's mean
//! stays unbiased. Deciding by a pixel's own spread darkened the path
//! tracer's Cornell box by 1.6% at 5 s and 3% at 1 s: a pixel whose early
//! samples missed the rare bright paths through the glass looked calm and
//! was left with few samples, one that caught them got many that diluted
//! them.
//!
//! Sample `i` of a pixel draws the same numbers as in a plain render, so
//! each pixel is the plain render of as many samples as it took (up to the
//! order of the sums; with the Sobol sampler).

use std::time::{Duration, Instant};

use super::{Context, Integrator, Progress, Rendered, SampleRange};
use crate::config::limits::MAX_SAMPLES;
use crate::film::{Film, Sample};
use crate::query::RayCount;
use crate::sampling::Rng;

/// Rounds of whole samples per pixel before rounds follow the noise.
const EVEN_ROUNDS: u32 = 2;

/// The share of a noise-following round's samples spread evenly over the
/// pixels: a pixel whose first rounds happened to agree still gets samples.
const EVEN_SHARE: f64 = 0.5;

/// The share of the time left that the last round plans to fill: its
/// samples may cost more than the round before's (other pixels). SPPM's
/// last part of a pass plans the same.
pub(super) const LAST_ROUND_SHARE: f64 = 0.9;

/// What the rounds so far hold for each pixel of the region, row by row.
struct Tally {
    /// The region's width.
    width: usize,
    /// The sum of its samples.
    sum: Vec<Sample>,
    /// How many samples it took.
    count: Vec<u32>,
    /// How many rounds took some.
    rounds: Vec<u32>,
    /// Over those rounds, `n m^2`: the samples the round took there times
    /// the square of their mean's luminance (for the spread between rounds).
    sum_sq: Vec<f64>,
}

impl Tally {
    fn new(width: usize, pixels: usize) -> Tally {
        Tally {
            width,
            sum: vec![Sample::default(); pixels],
            count: vec![0; pixels],
            rounds: vec![0; pixels],
            sum_sq: vec![0.0; pixels],
        }
    }

    /// Adds a round's film, whose pixel `i` is the mean of `taken(i)` samples.
    fn add(&mut self, film: &Film, taken: impl Fn(usize) -> u32) {
        for (i, mean) in film.pixels.iter().enumerate() {
            let n = taken(i);
            if n == 0 {
                continue;
            }
            self.sum[i] += *mean * n as f32;
            self.count[i] += n;
            self.rounds[i] += 1;
            self.sum_sq[i] += n as f64 * luminance(mean).powi(2);
        }
    }

    /// The [`deviation`] of pixel `i`'s samples, its rounds the groups.
    fn deviation(&self, i: usize) -> f64 {
        deviation(&self.sum[i], self.sum_sq[i], self.count[i], self.rounds[i])
    }

    /// `film`'s pixels set to each pixel's mean.
    fn average_into(&self, film: &mut Film) {
        for ((p, s), &n) in film.pixels.iter_mut().zip(&self.sum).zip(&self.count) {
            *p = *s * (1.0 / n.max(1) as f32);
        }
    }

    /// All samples taken.
    fn total(&self) -> u64 {
        self.count.iter().map(|&n| n as u64).sum()
    }
}

/// The standard deviation of one sample's luminance from `groups` groups
/// of `count` samples in all: `sum` of the samples, and `sum_sq` of each
/// group's size times its mean luminance squared. The spread of the
/// groups' means about the mean, `sum n_g (m_g - m)^2 / (groups - 1)`, is
/// the variance of one sample (a group's mean varies by it over `n_g`);
/// groups of one sample each make it the sample variance. 0 with fewer than
/// two groups.
pub(super) fn deviation(sum: &Sample, sum_sq: f64, count: u32, groups: u32) -> f64 {
    if groups < 2 {
        return 0.0;
    }
    let n = count as f64;
    let mean = luminance(sum) / n;
    ((sum_sq - n * mean * mean).max(0.0) / (groups - 1) as f64).sqrt()
}

/// The luminance of a sample's total (the mean of its channels).
pub(super) fn luminance(sample: &Sample) -> f64 {
    sample.total().to_array().iter().map(|&c| c as f64).sum::<f64>() / 3.0
}

/// `total` samples split over the pixels of `tally` by [`split_by_noise`]
/// of their deviations, each continuing where the pixel's samples stopped.
fn allocate(tally: &Tally, total: u64, rng: &mut Rng) -> Vec<SampleRange> {
    let own: Vec<f64> = (0..tally.count.len()).map(|i| tally.deviation(i)).collect();
    split_by_noise(&own, tally.width, total, rng)
        .into_iter()
        .zip(&tally.count)
        .map(|(count, &first)| SampleRange { first, count: count.min(MAX_SAMPLES - first) })
        .collect()
}

/// `total` samples split over a grid of pixels `width` wide whose own
/// standard deviations are `own`: half evenly, half by the mean deviation
/// of the pixels around each, never its own (evenly where none is known
/// yet), each share rounded up or down at random so that the counts add up
/// to `total` on average.
pub(super) fn split_by_noise(own: &[f64], width: usize, total: u64, rng: &mut Rng) -> Vec<u32> {
    let pixels = own.len();
    let deviation = around(own, width);
    let spread: f64 = deviation.iter().sum();
    let even = if spread > 0.0 && spread.is_finite() { EVEN_SHARE } else { 1.0 };
    (0..pixels)
        .map(|i| {
            let by_noise = if even < 1.0 { deviation[i] / spread } else { 0.0 };
            let share = even / pixels as f64 + (1.0 - even) * by_noise;
            (total as f64 * share + rng.uniform() as f64).floor() as u32
        })
        .collect()
}

/// Each pixel's mean of `values` over its neighbours (up to eight, in a
/// grid `width` wide), not counting itself.
fn around(values: &[f64], width: usize) -> Vec<f64> {
    let height = values.len() / width.max(1);
    (0..values.len())
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let (mut sum, mut n) = (0.0, 0);
            for ny in y.saturating_sub(1)..(y + 2).min(height) {
                for nx in x.saturating_sub(1)..(x + 2).min(width) {
                    if (nx, ny) != (x, y) {
                        sum += values[ny * width + nx];
                        n += 1;
                    }
                }
            }
            if n > 0 {
                sum / n as f64
            } else {
                0.0
            }
        })
        .collect()
}

/// Renders in rounds (see the module's notes) until the time budget,
/// counted from `start`, would not fit another. Photon maps are built once
/// for all rounds.
pub(super) fn render_to_time(
    integrator: &dyn Integrator,
    ctx: &Context,
    budget: Duration,
    start: Instant,
    progress: &Progress,
) -> Rendered {
    let built = match ctx.photon_maps {
        Some(_) => None,
        None => integrator.photon_maps(ctx),
    };
    let ctx = Context { photon_maps: ctx.photon_maps.or(built.as_ref()), ..*ctx };
    let tuned = integrator.tuned_for_time(&ctx);
    let ctx = match &tuned {
        Some(tuned) => Context { config: &tuned.config, ..ctx },
        None => ctx,
    };
    let region = ctx.config.region();
    let pixels = region.pixels();
    let mut tally = Tally::new(region.width() as usize, pixels as usize);
    let mut first: Option<Rendered> = None;
    // The photons' rays where the maps were traced for this render, and
    // what measuring the settings traced.
    let mut rays = built.as_ref().map_or(RayCount::default(), |maps| maps.stats.rays);
    if let Some(tuned) = &tuned {
        rays += tuned.rays;
    }
    // Where the stochastic rounding of noise-following rounds draws from.
    let mut rng = Rng::new(ctx.config.seed, 0x726f_756e_6473);
    let (mut rounds, mut even_spp, mut next) = (0u32, 0u32, pixels);
    // Whether the round about to run is planned as the last: the one that
    // takes what the time left affords (not a chain of ever smaller ones).
    let mut last = false;
    loop {
        let round_start = Instant::now();
        let even = (rounds < EVEN_ROUNDS || !integrator.pixels_sample_alone()) && next % pixels == 0;
        let ranges = (!even).then(|| allocate(&tally, next, &mut rng));
        let rendered = match &ranges {
            None => {
                let count = (next / pixels) as u32;
                let round = Context { samples: SampleRange { first: even_spp, count }, ..ctx };
                let rendered = integrator.render(&round, progress);
                tally.add(&rendered.film, |_| count);
                even_spp += count;
                rendered
            }
            Some(ranges) => {
                let round = Context { pixel_samples: Some(ranges), ..ctx };
                let rendered = integrator.render(&round, progress);
                tally.add(&rendered.film, |i| ranges[i].count);
                rendered
            }
        };
        let taken = match &ranges {
            None => next,
            Some(ranges) => ranges.iter().map(|r| r.count as u64).sum(),
        };
        let per_sample = round_start.elapsed().as_secs_f64() / taken.max(1) as f64;
        rays += rendered.stats.rays;
        first.get_or_insert(rendered);
        rounds += 1;
        if last {
            break;
        }
        let done = tally.total();
        // What the lights' edges will take after the render, at `samples`
        // samples in all, and what each further sample adds to that.
        let edges =
            |samples: u64| ctx.light_edges.map_or(0.0, |e| e.seconds_after(samples as f64 / pixels as f64));
        let edges_per_sample = (edges(done + pixels) - edges(done)) / pixels as f64;
        let left = budget.as_secs_f64() - start.elapsed().as_secs_f64() - edges(done);
        let affordable = left / (per_sample + edges_per_sample).max(1e-12);
        // As many again as taken so far, or what the time left affords;
        // a round too small to matter (under a sample for every 64 pixels)
        // is not worth its start.
        if integrator.pixels_sample_alone() {
            last = affordable < done as f64;
            next = if last { (affordable * LAST_ROUND_SHARE).floor() as u64 } else { done };
        } else {
            // Whole samples per pixel, as many as the time left affords.
            let most = (MAX_SAMPLES as u64 * pixels).saturating_sub(done);
            next = (affordable.floor() as u64).min(done).min(most) / pixels * pixels;
        }
        let headroom = tally.count.iter().any(|&n| n < MAX_SAMPLES);
        if next < (pixels / 64).max(1) || !headroom {
            break;
        }
        if let (Some(snapshot), Some(first)) = (ctx.snapshot, &first) {
            let mut film = first.film.clone();
            tally.average_into(&mut film);
            snapshot(&film, (done / pixels) as u32);
        }
    }
    let mut rendered = first.expect("at least one round");
    tally.average_into(&mut rendered.film);
    let (least, most) = tally.count.iter().fold((u32::MAX, 0), |(lo, hi), &n| (lo.min(n), hi.max(n)));
    let mean = tally.total() as f64 / pixels as f64;
    rendered.stats.rays = rays;
    rendered.stats.samples_per_pixel = mean.round() as u32;
    rendered.stats.notes.push(if least == most {
        format!(
            "time budget {} s: {} per pixel in {}",
            super::budget_seconds(budget.as_secs_f32()),
            super::counted(least.into(), "sample", "samples"),
            super::counted(rounds.into(), "round", "rounds")
        )
    } else {
        format!(
            "time budget {} s: {mean:.1} samples per pixel on average ({least} to {most}, more where \
             the pixels around are noisier) in {}",
            super::budget_seconds(budget.as_secs_f32()),
            super::counted(rounds.into(), "round", "rounds")
        )
    });
    rendered.stats.pixel_samples = Some(tally.count);
    rendered.stats.notes.extend(tuned.map(|tuned| tuned.note));
    rendered
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(v: f32) -> Sample {
        Sample { direct: glam::Vec3::splat(v), ..Sample::default() }
    }

    #[test]
    fn the_spread_of_round_means_estimates_a_samples_deviation() {
        // Rounds of 1, 1, 2, 4, ... samples whose values are 0 or 2 with
        // equal chance (deviation 1): each round's mean is the mean of its
        // own draws.
        let mut rng = Rng::new(1, 1);
        let mut tally = Tally::new(1, 1);
        let mut n = 1;
        for round in 0..12 {
            let draws: f32 = (0..n).map(|_| if rng.uniform() < 0.5 { 0.0 } else { 2.0 }).sum();
            let film = Film { width: 1, height: 1, pixels: vec![grey(draws / n as f32)] };
            tally.add(&film, |_| n);
            n = if round == 0 { 1 } else { tally.count[0] };
        }
        let deviation = tally.deviation(0);
        assert!((deviation - 1.0).abs() < 0.5, "{deviation}");
        // A pixel whose rounds agree has none; one round says nothing.
        let mut flat = Tally::new(2, 2);
        for _ in 0..3 {
            let film = Film { width: 2, height: 1, pixels: vec![grey(0.5), grey(0.5)] };
            flat.add(&film, |i| if i == 0 { 4 } else { 0 });
        }
        assert_eq!((flat.deviation(0), flat.deviation(1)), (0.0, 0.0));
    }

    #[test]
    fn samples_go_by_the_neighbours_spread_and_all_get_some_on_average() {
        // A row of three: pixel 0 noisy (its rounds disagree), 1 and 2 flat.
        let mut tally = Tally::new(3, 3);
        for a in [0.0, 2.0, 0.5] {
            tally.add(&Film { width: 3, height: 1, pixels: vec![grey(a), grey(1.0), grey(1.0)] }, |_| 2);
        }
        let mut rng = Rng::new(3, 3);
        let mut taken = [0u64; 3];
        for _ in 0..1000 {
            let ranges = allocate(&tally, 90, &mut rng);
            assert!(ranges.iter().all(|r| r.first == 6));
            for (t, r) in taken.iter_mut().zip(&ranges) {
                *t += r.count as u64;
            }
        }
        // Half evenly (15 each); half by the neighbours' spread: all 45 to
        // pixel 1, the only one beside the noisy pixel, none to the noisy
        // pixel itself (its own samples must not decide its count).
        let mean = taken.map(|t| t as f64 / 1000.0);
        assert!((mean[0] - 15.0).abs() < 0.5 && (mean[2] - 15.0).abs() < 0.5, "{mean:?}");
        assert!((mean[1] - 60.0).abs() < 0.5, "{mean:?}");
        // Nothing known yet: evenly, 0.3 samples a pixel on average.
        let fresh = Tally::new(10, 10);
        let mut sum = 0u64;
        for _ in 0..1000 {
            sum += allocate(&fresh, 3, &mut rng).iter().map(|r| r.count as u64).sum::<u64>();
        }
        assert!((sum as f64 / 1000.0 - 3.0).abs() < 0.2, "{sum}");
    }

    #[test]
    fn rounds_that_follow_the_noise_keep_each_pixel_unbiased() {
        // Heavy-tailed samples, as a path tracer's rare bright paths through
        // glass: 100 with chance 1%, else 0 (mean 1). Rounds of 1, 1, then
        // noise-following ones doubling the samples, over a row of 16
        // pixels, 2000 times: the pixels' mean must stay 1. A pixel whose
        // own spread decided its count would come out far darker.
        let mut draws = Rng::new(8, 8);
        let mut shares = Rng::new(9, 9);
        let (width, trials) = (16usize, 2000);
        let mut sum = 0.0;
        for _ in 0..trials {
            let mut tally = Tally::new(width, width);
            let mut round = |tally: &mut Tally, counts: &[u32]| {
                let pixels = counts
                    .iter()
                    .map(|&n| {
                        let hits = (0..n).filter(|_| draws.uniform() < 0.01).count();
                        grey(100.0 * hits as f32 / n.max(1) as f32)
                    })
                    .collect();
                tally.add(&Film { width: width as u32, height: 1, pixels }, |i| counts[i]);
            };
            round(&mut tally, &[1; 16]);
            round(&mut tally, &[1; 16]);
            for _ in 0..5 {
                let counts: Vec<u32> =
                    allocate(&tally, tally.total(), &mut shares).iter().map(|r| r.count).collect();
                round(&mut tally, &counts);
            }
            let mut film = Film { width: width as u32, height: 1, pixels: vec![Sample::default(); width] };
            tally.average_into(&mut film);
            sum += film.pixels.iter().map(luminance).sum::<f64>();
        }
        let mean = sum / (trials * width) as f64;
        // About 64 samples a pixel: the mean's standard error is about 0.007.
        assert!((mean - 1.0).abs() < 0.03, "{mean}");
    }
}
