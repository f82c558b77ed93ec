//! Ray-throughput benchmarks: how many rays per second each way of asking
//! for hits delivers on a scene, for three kinds of rays a renderer traces.
//!
//! - primary: one camera ray per pixel in scanline order (coherent);
//! - shadow: from each primary hit to the first light (`occluded`);
//! - diffuse: from each primary hit in a cosine-distributed direction
//!   (incoherent, like photon and final-gathering rays).
//!
//! Every measurement is the best of several runs, all threads busy.

use std::time::Instant;

use rayon::prelude::*;

use crate::accel::bvh::Bvh;
use crate::accel::embree::{EmbreeIntersector, RawRays};
use crate::accel::{Hit, Intersector, Ray};
use crate::light::Light;
use crate::render::surface::SurfacePoint;
use crate::sampling::{around, cosine_hemisphere, Rng};
use crate::scene::Scene;

/// Rays handed over per task (and per batch call).
const CHUNK: usize = 1024;

/// The three ray sets of a scene.
pub struct RaySets {
    /// Camera rays.
    pub primary: Vec<Ray>,
    /// Shadow rays from primary hits to the first light.
    pub shadow: Vec<Ray>,
    /// Cosine-distributed rays leaving primary hits.
    pub diffuse: Vec<Ray>,
}

impl RaySets {
    /// Builds the sets for a `width x height` view of `scene`, finding the
    /// primary hits with `accel`.
    pub fn new(scene: &Scene, accel: &dyn Intersector, width: u32, height: u32) -> RaySets {
        let primary: Vec<Ray> = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, width, height))
            .collect();
        let light_at = match scene.lights.first() {
            Some(Light::Point { position, .. } | Light::Spot { position, .. }) => *position,
            Some(Light::Area { center, .. }) => *center,
            None => {
                let b = scene.bounds();
                0.5 * (b.min + b.max) + glam::Vec3::Y * (b.max.y - b.min.y)
            }
        };
        let mut shadow = Vec::new();
        let mut diffuse = Vec::new();
        let mut rng = Rng::new(1, 0);
        for ray in &primary {
            let Some(hit) = accel.intersect(ray) else { continue };
            let sp = SurfacePoint::new(scene, ray, &hit);
            shadow.push(sp.spawn_to(light_at));
            diffuse.push(sp.spawn(around(sp.ns, cosine_hemisphere(rng.uniform2()))));
        }
        RaySets { primary, shadow, diffuse }
    }
}

/// One line of results: millions of rays per second for each method.
#[derive(Debug, Clone)]
pub struct Throughput {
    /// Which rays.
    pub kind: &'static str,
    /// How many.
    pub rays: usize,
    /// Million rays per second, per method, in [`METHODS`] order (`None`: not applicable).
    pub mrays: [Option<f64>; 4],
    /// Hits (or occluded rays) per method, to check they agree.
    pub hits: [Option<usize>; 4],
}

/// The ways of tracing that are measured.
pub const METHODS: [&str; 4] = ["embree single", "embree stream", "embree direct", "native"];

/// Seconds of the fastest of `repeats` runs of `f`.
fn best_of(repeats: usize, mut f: impl FnMut()) -> f64 {
    (0..repeats.max(1))
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn count_hits(accel: &dyn Intersector, rays: &[Ray]) -> usize {
    rays.par_chunks(CHUNK).map(|c| c.iter().filter(|r| accel.intersect(r).is_some()).count()).sum()
}

fn count_hits_batched(accel: &dyn Intersector, rays: &[Ray]) -> usize {
    rays.par_chunks(CHUNK)
        .map(|c| {
            let mut hits: Vec<Option<Hit>> = vec![None; c.len()];
            accel.intersect_batch(c, &mut hits);
            hits.iter().filter(|h| h.is_some()).count()
        })
        .sum()
}

fn count_occluded(accel: &dyn Intersector, rays: &[Ray]) -> usize {
    rays.par_chunks(CHUNK).map(|c| c.iter().filter(|r| accel.occluded(r)).count()).sum()
}

fn count_occluded_batched(accel: &dyn Intersector, rays: &[Ray]) -> usize {
    rays.par_chunks(CHUNK)
        .map(|c| {
            let mut o = vec![false; c.len()];
            accel.occluded_batch(c, &mut o);
            o.iter().filter(|&&x| x).count()
        })
        .sum()
}

/// Measures every method on every ray set.
pub fn measure(embree: &EmbreeIntersector, native: &Bvh, sets: &RaySets, repeats: usize) -> Vec<Throughput> {
    let mut out = Vec::new();
    let mrays = |rays: usize, seconds: f64| Some(rays as f64 / seconds / 1e6);
    for (kind, rays, shadow) in
        [("primary", &sets.primary, false), ("shadow", &sets.shadow, true), ("diffuse", &sets.diffuse, false)]
    {
        let mut result = Throughput { kind, rays: rays.len(), mrays: [None; 4], hits: [None; 4] };
        let single: fn(&dyn Intersector, &[Ray]) -> usize = if shadow { count_occluded } else { count_hits };
        let batched: fn(&dyn Intersector, &[Ray]) -> usize =
            if shadow { count_occluded_batched } else { count_hits_batched };
        for (i, (accel, run)) in
            [(embree as &dyn Intersector, single), (embree, batched)].into_iter().enumerate()
        {
            let mut hits = 0;
            let seconds = best_of(repeats, || hits = run(accel, rays));
            result.mrays[i] = mrays(rays.len(), seconds);
            result.hits[i] = Some(hits);
        }
        if !shadow {
            let mut raw = RawRays::new(rays);
            let seconds = best_of(repeats, || {
                raw.reset(rays);
                embree.intersect_raw(&mut raw);
            });
            // The reset (a copy) is inside the timing, which favours the wrapper slightly.
            result.mrays[2] = mrays(rays.len(), seconds);
            result.hits[2] = Some(raw.hits());
        }
        let mut hits = 0;
        let seconds = best_of(repeats, || hits = single(native, rays));
        result.mrays[3] = mrays(rays.len(), seconds);
        result.hits[3] = Some(hits);
        out.push(result);
    }
    out
}

/// Resident memory of this process in bytes (Linux; 0 elsewhere).
pub fn resident_bytes() -> usize {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<usize>().ok())
        .map_or(0, |pages| pages * 4096)
}

/// Peak resident memory of this process in bytes (Linux; 0 elsewhere).
pub fn peak_resident_bytes() -> usize {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
            line.split_whitespace().nth(1)?.parse::<usize>().ok()
        })
        .map_or(0, |kib| kib * 1024)
}
