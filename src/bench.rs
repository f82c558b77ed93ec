//! Ray-throughput benchmarks: how many rays per second each way of asking
//! for hits delivers on a scene, for three kinds of rays a renderer traces.
//!
//! - primary: one camera ray per pixel in scanline order (coherent);
//! - shadow: from each primary hit to the first light (`occluded`);
//! - diffuse: from each primary hit in a cosine-distributed direction
//!   (incoherent, like photon and final-gathering rays).
//!
//! Every measurement is the best of several runs, all threads busy.

pub mod error;
pub mod photons;
pub mod plot;
pub mod scale;
pub mod threads;

use std::time::Instant;

use rayon::prelude::*;

use crate::accel::bvh::Bvh;
use crate::accel::embree::{EmbreeIntersector, RawRays};
use crate::accel::{Hit, Intersector, Ray};
use crate::light::Light;
use crate::query::SurfacePoint;
use crate::sampling::{around, cosine_hemisphere, Rng};
use crate::scene::{Overrides, Scene};

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
pub const METHODS: [&str; 4] = ["embree single", "embree batch", "embree direct", "native"];

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

/// Loads `path`, builds both intersectors, measures every method on every
/// ray set, and returns the report as Markdown (what `caustix bench rays` prints).
pub fn ray_report(
    path: &std::path::Path,
    overrides: &Overrides,
    width: u32,
    height: u32,
    repeats: usize,
) -> crate::Result<String> {
    use std::fmt::Write;
    let mib = |bytes: usize| bytes as f64 / (1024.0 * 1024.0);

    let start = Instant::now();
    let scene = Scene::load_with(path, overrides)?;
    let load = start.elapsed().as_secs_f64();
    let mesh_bytes: usize = scene.meshes.iter().map(|m| m.bytes()).sum();

    let before = resident_bytes();
    let start = Instant::now();
    let embree = EmbreeIntersector::build(&scene.triangle_views())?;
    let embree_build = start.elapsed().as_secs_f64();
    let embree_bytes = resident_bytes().saturating_sub(before);

    let start = Instant::now();
    let native = Bvh::build(&scene.triangle_views());
    let native_build = start.elapsed().as_secs_f64();
    let stats = native.stats();

    let sets = RaySets::new(&scene, &embree, width, height);
    let results = measure(&embree, &native, &sets, repeats);

    let mut out = String::new();
    let w = &mut out;
    // Writing to a String cannot fail.
    let _ =
        writeln!(w, "scene {}: {} triangles, loaded in {load:.2} s", path.display(), scene.triangle_count());
    let _ =
        writeln!(w, "threads: {}, rays per task: {CHUNK}, best of {repeats}", rayon::current_num_threads());
    let _ = writeln!(
        w,
        "mesh (positions + normals + indices): {:.1} MiB; {}: build {embree_build:.3} s, +{:.1} MiB resident; \
         native bvh: build {native_build:.3} s, {:.1} MiB ({} nodes, depth {})",
        mib(mesh_bytes),
        embree.name(),
        mib(embree_bytes),
        mib(stats.bytes),
        stats.nodes,
        stats.depth
    );
    let _ = writeln!(w, "embree batch: {}", EmbreeIntersector::BATCH_CALL);
    let _ = writeln!(w);
    let header = METHODS.map(|m| format!("{m} (Mrays/s)")).join(" | ");
    let _ = writeln!(w, "| rays | count | {header} | native / embree single |");
    let _ = writeln!(w, "|---|---:|{}---:|", "---:|".repeat(METHODS.len()));
    for r in &results {
        let cells = r.mrays.map(|m| m.map_or("n/a".to_string(), |v| format!("{v:.2}")));
        let ratio = match (r.mrays[3], r.mrays[0]) {
            (Some(n), Some(e)) => format!("{:.2}", n / e),
            _ => "n/a".into(),
        };
        let _ = writeln!(w, "| {} | {} | {} | {ratio} |", r.kind, r.rays, cells.join(" | "));
        let counts: Vec<usize> = r.hits.iter().flatten().copied().collect();
        if counts.iter().any(|&c| c != counts[0]) {
            let _ = writeln!(w, "|   hits differ between methods: {:?} |", r.hits);
        }
    }
    let _ = writeln!(w);
    let _ = writeln!(w, "peak resident memory: {:.1} MiB", mib(peak_resident_bytes()));
    Ok(out)
}

/// Resident memory of this process in bytes (Linux; 0 elsewhere).
pub fn resident_bytes() -> usize {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<usize>().ok())
        .map_or(0, |pages| pages * 4096)
}

/// Starts measuring [`peak_resident_bytes`] afresh from the current
/// resident size (Linux: writes 5 to `/proc/self/clear_refs`; elsewhere
/// nothing).
pub fn reset_peak_resident() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
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
