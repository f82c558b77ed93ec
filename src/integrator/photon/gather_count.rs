//! How many final-gathering rays a camera sample should send when a render
//! has a time budget: the count that buys the least error per second,
//! measured on the scene before the rounds begin.
//!
//! More gather rays remove the part of a pixel's noise that comes from
//! gathering and cost time that fewer camera samples then pay for. Which
//! wins depends on the scene: under a point light nearly all the noise is
//! gathering's and 16 rays a sample did best; under a small area light its
//! soft shadows and edges weigh more and 1 to 4 did (BENCHMARKS.md, "Gather
//! rays chosen per scene"). No fixed count suits both.
//!
//! The pilot renders a sparse set of pixels (one at a random place in each
//! cell of a grid), a few camera samples each with the render's own
//! sampler, twice (two seeds) at each of a few gather counts. Half the
//! squared difference of a pixel's two estimates is their variance, and
//! variance times seconds is what a count costs in error at a fixed budget
//! (variance falls as one over the time): the cheapest count wins. The
//! lights seen straight or through mirrors and glass are measured apart, at
//! many more pixels, by camera rays alone: their noise (a light's edges)
//! sits in a few pixels, which decide much of the error (at 256 x 256 on the
//! area-lit box, 4 gather rays gave half the error of 16) and which a
//! sparse pilot meets by chance or not at all. Where the render refines a
//! light's edge afterwards (`emission.rs`), its noise counts at the share
//! the refinement leaves of it ([`lights_variance`]).
//!
//! Tried first: a fit of `V1 + V2 / M` to independent samples' variances
//! (`V2 / M` from the spread of each sample's gather rays), which chose 4
//! rays under the point light where 16 did best: with Sobol points neither
//! part falls as one over the samples. The pilot costs a few percent of
//! the budget. Being timed, it makes the count depend on the machine, as a
//! time budget's sample count already does; renders without a budget keep
//! the setting.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::MapLight;
use crate::accel::Ray;
use crate::bsdf::{Bsdf, RadianceScale};
use crate::film::Sample;
use crate::integrator::emission::LightEdges;
use crate::integrator::pixels::average_over_pixel;
use crate::integrator::whitted::WhittedTracer;
use crate::integrator::{Context, SampleRange};
use crate::query::{Interaction, RayCount};
use crate::sampling::Rng;

/// The gather-ray counts the pilot tries, fewest first.
const CANDIDATES: [u32; 3] = [1, 4, 16];
/// Camera samples of each pilot pixel estimate.
const PILOT_SAMPLES: u32 = 8;
/// Pilot pixels per second of budget, and the fewest and most.
const PILOT_PIXELS_PER_SECOND: f64 = 128.0;
const PILOT_PIXELS: (u32, u32) = (128, 512);
/// Pixels whose lights seen the pilot measures, at most (one in eight of
/// a 256 x 256 image: as many camera samples as one at every pixel).
const LIGHT_PILOT_PIXELS: u32 = 8_192;
/// Seed offset of the pilot's random streams (apart from the render's).
const PILOT_SEED: u64 = 0x5eed_9a7e_0f91_1700;

/// What the pilot measured at one gather count.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Trial {
    /// Gather rays per camera sample.
    gather: u32,
    /// Variance of a pilot pixel's estimate.
    variance: f64,
    /// Seconds per camera sample.
    seconds: f64,
}

/// The count of the trial that leaves the least error for a budget (the
/// least variance times seconds); on a tie, the fewer rays.
fn best_count(trials: &[Trial]) -> u32 {
    let cost = |t: &Trial| t.variance * t.seconds;
    trials
        .iter()
        .fold(None, |best: Option<&Trial>, t| match best {
            Some(b) if cost(b) <= cost(t) => Some(b),
            _ => Some(t),
        })
        .map_or(CANDIDATES[0], |t| t.gather)
}

/// Pixels the pilot estimates at every gather count, for a budget of
/// `budget` seconds.
fn pilot_pixels_for(budget: f64) -> u32 {
    (budget * PILOT_PIXELS_PER_SECOND).clamp(PILOT_PIXELS.0 as f64, PILOT_PIXELS.1 as f64) as u32
}

/// About `wanted` pixels of the region of `ctx`: one at a random place in
/// each cell of a regular grid, so that thin features (a light's edges,
/// where the noise is the greatest) are met as often as they cover the
/// image, not never or in every row as a grid's fixed pixels would.
fn pilot_pixels(ctx: &Context, wanted: u32, seed: u64) -> Vec<(u32, u32)> {
    let region = ctx.config.region();
    let area = region.width() as f64 * region.height() as f64;
    let step = ((area / wanted.max(1) as f64).sqrt().ceil() as u32).max(1);
    let mut rng = Rng::new(seed, 0);
    let mut pixels = Vec::new();
    for y0 in (region.y0..region.y1).step_by(step as usize) {
        for x0 in (region.x0..region.x1).step_by(step as usize) {
            let (w, h) = (step.min(region.x1 - x0), step.min(region.y1 - y0));
            let (u, v) = (rng.uniform(), rng.uniform());
            let pick = |n: u32, u: f32| ((u * n as f32) as u32).min(n - 1);
            pixels.push((x0 + pick(w, u), y0 + pick(h, v)));
        }
    }
    pixels
}

/// Each pixel's estimate from `samples` camera samples drawn with seed
/// `seed`, each the light `radiance` finds along a camera ray, and the
/// seconds they took; their rays are added to `rays`.
fn estimates(
    ctx: &Context,
    pixels: &[(u32, u32)],
    (samples, seed): (u32, u64),
    radiance: impl Fn(&Context, &Ray, &mut Rng, &mut RayCount) -> Sample + Sync,
    rays: &mut RayCount,
) -> (Vec<Sample>, f64) {
    let config = crate::RenderConfig { seed, ..ctx.config.clone() };
    let pilot = Context { config: &config, samples: SampleRange { first: 0, count: samples }, ..*ctx };
    let started = Instant::now();
    let (values, counts): (Vec<Sample>, Vec<RayCount>) = pixels
        .par_iter()
        .map(|&(x, y)| {
            let mut rng = Rng::new(seed, y as u64 * config.width as u64 + x as u64);
            let mut count = RayCount::default();
            let value = average_over_pixel(&pilot, (x, y), &mut rng, |ray, rng| {
                radiance(&pilot, &ray, rng, &mut count)
            });
            (value, count)
        })
        .unzip();
    let seconds = started.elapsed().as_secs_f64();
    *rays += counts.into_iter().sum();
    (values, seconds)
}

/// Light seen straight along `ray`, or through mirrors and glass only:
/// the part of a photon-mapped sample no gather ray changes, and whose
/// noise (a light's edges, seen directly or in a mirror) sits in a few
/// pixels that a sparse pilot would miss.
/// `scale` is that of the refractions on the way ([`RadianceScale`]).
fn lights_seen(ctx: &Context, ray: &Ray, depth: u32, scale: RadianceScale, count: &mut RayCount) -> Vec3 {
    let sp = match ctx.query.first(ray, count) {
        None => return Vec3::ZERO,
        Some(Interaction::Emitter { radiance, .. }) => return radiance * scale.factor(),
        Some(Interaction::Surface(sp)) => sp,
    };
    if depth + 1 >= ctx.config.max_depth {
        return Vec3::ZERO;
    }
    let bsdf = Bsdf::new(ctx.query.material(&sp), &sp, ray.dir.normalize());
    bsdf.specular_branches()
        .map(|b| b.weight * lights_seen(ctx, &sp.spawn(b.wi), depth + 1, scale.after(&b), count))
        .sum()
}

/// A camera sample of the lights seen along `ray` ([`lights_seen`]), as emission.
fn lights_sample(ctx: &Context, ray: &Ray, _: &mut Rng, count: &mut RayCount) -> Sample {
    Sample { emission: lights_seen(ctx, ray, 0, RadianceScale::ONE, count), ..Sample::default() }
}

/// The variance of `part` of one estimate, from two independent ones of
/// each pixel: half their squared difference, summed over the channels (as
/// RMSE sums squared errors over them), times the share `kept(i)` of it
/// that the render keeps at pixel `i`, averaged over the pixels.
fn variance_of(
    a: &[Sample],
    b: &[Sample],
    kept: impl Fn(usize) -> f64,
    part: impl Fn(&Sample) -> Vec3,
) -> f64 {
    let sum: f64 = (a.iter().zip(b).enumerate())
        .map(|(i, (a, b))| kept(i) * (part(a) - part(b)).as_dvec3().length_squared() / 2.0)
        .sum();
    sum / a.len().max(1) as f64
}

/// The variance the lights seen at `pixels` leave in an estimate of
/// [`PILOT_SAMPLES`] camera samples (for the trials' sums), from two such
/// estimates, seeds `seed` and the next; rays traced are added to `rays`.
///
/// Measured with the render's own samples, as the trials are, not as one
/// sample's variance over their count: the samples of a pixel are spread
/// evenly over it, and across a light's edge their mean's variance falls
/// faster than one over their number. Counted from one sample at every
/// pixel, the lights' part was 2-3x what it is and drowned the gathering's:
/// at 1 s on the area-lit box the pilot chose 1 ray in two seeds of six,
/// where 4 rays left a quarter less error (BENCHMARKS.md).
///
/// Where the render refines a light's edge afterwards (`emission.rs`), the
/// emission samples there leave a ninth of the variance or less: counted
/// whole, the edges' noise made the pilot choose 1 ray on the area-lit box,
/// where 4 left 6-22% less error at 2-8 s (BENCHMARKS.md).
fn lights_variance(ctx: &Context, pixels: &[(u32, u32)], seed: u64, rays: &mut RayCount) -> f64 {
    let (a, _) = estimates(ctx, pixels, (PILOT_SAMPLES, seed), lights_sample, rays);
    let (b, _) = estimates(ctx, pixels, (PILOT_SAMPLES, seed.wrapping_add(1)), lights_sample, rays);
    let kept = |i: usize| match ctx.light_edges {
        Some(edges) if edges.refines(pixels[i]) => LightEdges::variance_kept(),
        _ => 1.0,
    };
    variance_of(&a, &b, kept, |s| s.emission)
}

/// Runs the pilot for photon mapping with the maps of `light`, sized for a
/// budget of `budget` seconds; returns the gather rays per sample to render
/// with, a note saying why, and the rays the pilot traced.
pub(super) fn choose(ctx: &Context, light: &MapLight, budget: f64) -> (u32, String, RayCount) {
    let mut rays = RayCount::default();
    let started = Instant::now();
    let seed = ctx.config.seed.wrapping_add(PILOT_SEED);
    // The lights seen, at many pixels: cheap, camera rays and specular
    // chains only.
    let lights_pixels = pilot_pixels(ctx, LIGHT_PILOT_PIXELS, seed);
    let lights = lights_variance(ctx, &lights_pixels, seed, &mut rays);
    // All the rest, at a sparse set of pixels, at each count.
    let pixels = pilot_pixels(ctx, pilot_pixels_for(budget), seed);
    let samples = pixels.len().max(1) as f64 * PILOT_SAMPLES as f64;
    let trials: Vec<Trial> = CANDIDATES
        .iter()
        .map(|&gather| {
            let light = MapLight { gather_per_sample: gather, ..*light };
            let tracer = light.tracer(ctx);
            let traced = |ctx: &Context, ray: &Ray, rng: &mut Rng, count: &mut RayCount| {
                WhittedTracer { ctx, ..tracer }.radiance(ray, 0, (Vec3::ONE, RadianceScale::ONE), rng, count)
            };
            let (a, time_a) = estimates(ctx, &pixels, (PILOT_SAMPLES, seed), traced, &mut rays);
            let (b, time_b) =
                estimates(ctx, &pixels, (PILOT_SAMPLES, seed.wrapping_add(1)), traced, &mut rays);
            let rest = variance_of(&a, &b, |_| 1.0, |s| s.total() - s.emission);
            Trial { gather, variance: lights + rest, seconds: (time_a + time_b) / (2.0 * samples) }
        })
        .collect();
    let best = best_count(&trials);
    let tried: Vec<String> = trials
        .iter()
        .map(|t| format!("{} rays {:.3e} x {:.2} us", t.gather, t.variance, t.seconds * 1e6))
        .collect();
    let note = format!(
        "gather rays: {best} per camera sample for the time budget (pilot of {:.2} s at {} pixels, lights seen at \
         {}; variance x time a sample: {})",
        started.elapsed().as_secs_f64(),
        pixels.len(),
        lights_pixels.len(),
        tried.join(", ")
    );
    (best, note, rays)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pilot's rays count with the render's: at least a camera ray for
    /// each of its samples (two estimates of `PILOT_SAMPLES` of the lights
    /// seen at each pixel it looks at, and at each of its pixels for each
    /// count it tries).
    #[test]
    fn the_pilot_counts_its_rays() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-point.toml");
        let scene = crate::Scene::load(&file).unwrap();
        let accel = crate::accel::build(crate::accel::Backend::Native, &scene.triangle_views()).unwrap();
        let mut config =
            crate::RenderConfig { width: 24, height: 16, time: Some(2.0), ..scene.config.clone() };
        config.photons.global_photons = 2_000;
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        let maps = super::super::maps_for_tests(&ctx);
        let ctx = Context { photon_maps: Some(&maps), ..ctx };
        let texels = super::super::RecordTexels::for_maps(&ctx, &maps);
        let (_, _, rays) = choose(&ctx, &MapLight::new(&ctx, &maps, texels.as_ref()), 2.0);
        let seed = config.seed.wrapping_add(PILOT_SEED);
        let seen = pilot_pixels(&ctx, LIGHT_PILOT_PIXELS, seed).len() as u64;
        let tried = pilot_pixels(&ctx, pilot_pixels_for(2.0), seed).len() as u64;
        let camera_rays = 2 * (seen + CANDIDATES.len() as u64 * tried) * PILOT_SAMPLES as u64;
        assert!(seen == 24 * 16 && tried > 0, "{seen}, {tried}");
        assert!(rays.closest >= camera_rays, "{rays:?} for {camera_rays} camera rays");
    }

    /// The area-lit Cornell box at 48 x 48, with a budget as the pilot has
    /// one (one camera sample a pixel is then spread over it, not through
    /// its centre).
    fn small_area_lit_box() -> (crate::Scene, crate::RenderConfig) {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
        let scene = crate::Scene::load(&file).unwrap();
        let config = crate::RenderConfig { width: 48, height: 48, time: Some(2.0), ..scene.config.clone() };
        (scene, config)
    }

    #[test]
    fn the_pilot_counts_a_refined_edges_noise_as_the_refinement_leaves_it() {
        // The area-lit box's light, seen directly: its edge's pixels
        // differ from seed to seed. Where the render refines them after,
        // the pilot counts a ninth of their variance, no more elsewhere.
        let (scene, config) = small_area_lit_box();
        let accel = crate::accel::build(crate::accel::Backend::Native, &scene.triangle_views()).unwrap();
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        let edges = LightEdges::find(&ctx).expect("an area light");
        let pixels = pilot_pixels(&ctx, LIGHT_PILOT_PIXELS, 7);
        let refined: Vec<(u32, u32)> = pixels.iter().copied().filter(|&p| edges.refines(p)).collect();
        let others: Vec<(u32, u32)> = pixels.iter().copied().filter(|&p| !edges.refines(p)).collect();
        assert!(!refined.is_empty() && !others.is_empty(), "{} refined", refined.len());
        let with = Context { light_edges: Some(&edges), ..ctx };
        let variance = |ctx: &Context, pixels: &[(u32, u32)]| {
            lights_variance(ctx, pixels, 7, &mut RayCount::default()) * pixels.len() as f64
        };
        let (whole, kept) = (variance(&ctx, &refined), variance(&with, &refined));
        assert!(whole > 0.0, "the edge's pixels agree");
        assert!((kept - whole / 9.0).abs() <= 1e-9 * whole, "{kept} against {whole}");
        assert_eq!(variance(&ctx, &others), variance(&with, &others));
        // Over all of them: the sum of the two parts.
        let all = variance(&with, &pixels);
        assert!((all - kept - variance(&ctx, &others)).abs() <= 1e-9 * all, "{all}");
    }

    #[test]
    fn the_lights_variance_is_that_of_the_renders_own_samples() {
        // Across the area light's edge the samples of a pixel, spread evenly
        // over it, make a mean whose variance falls faster than one over
        // their number. The pilot's two estimates must measure what the
        // spread of many independent ones shows, not one sample's variance
        // over their number (ten times as much here).
        let (scene, config) = small_area_lit_box();
        let accel = crate::accel::build(crate::accel::Backend::Native, &scene.triangle_views()).unwrap();
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        let pixels = pilot_pixels(&ctx, LIGHT_PILOT_PIXELS, 7);
        // The pilot's measure, averaged over eight pilots (one's two
        // estimates are within 40% of the spread on their own).
        let pilot = (0..8).map(|k| lights_variance(&ctx, &pixels, 1000 + 2 * k, &mut RayCount::default()));
        let pilot = pilot.sum::<f64>() / 8.0;
        // Each pixel's variance among `RUNS` estimates of `samples` each,
        // summed over the channels, averaged over the pixels.
        const RUNS: u64 = 24;
        let spread = |samples: u32| {
            let runs: Vec<Vec<Sample>> = (0..RUNS)
                .map(|k| {
                    estimates(&ctx, &pixels, (samples, 100 + k), lights_sample, &mut RayCount::default()).0
                })
                .collect();
            let per_pixel = |i: usize| {
                let mean = runs.iter().map(|r| r[i].emission.as_dvec3()).sum::<glam::DVec3>() / RUNS as f64;
                let squares: f64 =
                    runs.iter().map(|r| (r[i].emission.as_dvec3() - mean).length_squared()).sum();
                squares / (RUNS - 1) as f64
            };
            (0..pixels.len()).map(per_pixel).sum::<f64>() / pixels.len() as f64
        };
        let (of_estimates, of_one) = (spread(PILOT_SAMPLES), spread(1) / PILOT_SAMPLES as f64);
        assert!(
            of_estimates > 0.0 && (pilot / of_estimates - 1.0).abs() < 0.3,
            "{pilot} against {of_estimates}"
        );
        assert!(of_one > 3.0 * of_estimates, "{of_one} against {of_estimates}");
    }

    #[test]
    fn the_best_count_leaves_the_least_variance_for_the_time() {
        let t = |gather, variance, seconds| Trial { gather, variance, seconds };
        // Point-light-like: sixteen rays cut the variance tenfold for 2.5x the time.
        assert_eq!(best_count(&[t(1, 0.1, 2.0), t(4, 0.03, 3.0), t(16, 0.01, 5.0)]), 16);
        // Area-light-like: more rays barely help.
        assert_eq!(best_count(&[t(1, 0.25, 2.0), t(4, 0.24, 3.0), t(16, 0.235, 7.0)]), 1);
        // In between.
        assert_eq!(best_count(&[t(1, 0.2, 2.0), t(4, 0.08, 3.0), t(16, 0.06, 7.0)]), 4);
        // No variance anywhere (no indirect light): the fewest rays.
        assert_eq!(best_count(&[t(1, 0.0, 2.0), t(4, 0.0, 3.0), t(16, 0.0, 7.0)]), 1);
        assert_eq!(best_count(&[]), CANDIDATES[0]);
    }

    #[test]
    fn the_variance_of_one_of_two_estimates_is_half_their_squared_difference() {
        let light = |emission: Vec3, direct: Vec3| Sample { emission, direct, ..Sample::default() };
        let a = [light(Vec3::new(1.0, 0.0, 0.0), Vec3::ZERO), light(Vec3::ZERO, Vec3::ONE)];
        let b = [light(Vec3::new(3.0, 0.0, 0.0), Vec3::ONE), light(Vec3::new(0.0, 2.0, 2.0), Vec3::ONE)];
        // Emission: (4 / 2 + 8 / 2) / 2 pixels.
        assert!((variance_of(&a, &b, |_| 1.0, |s| s.emission) - 3.0).abs() < 1e-12);
        // Direct: (3 / 2 + 0) / 2 pixels.
        assert!((variance_of(&a, &b, |_| 1.0, |s| s.direct) - 0.75).abs() < 1e-12);
        // The first pixel's emission refined afterwards: (4 / 2 / 9 + 8 / 2) / 2.
        assert!((variance_of(&a, &b, |i| [1.0 / 9.0, 1.0][i], |s| s.emission) - 19.0 / 9.0).abs() < 1e-12);
    }
}
