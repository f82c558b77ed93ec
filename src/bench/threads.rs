//! Thread scaling (`caustix bench threads`): the same work on 1, 2, ...
//! threads: Embree's BVH build, the native BVH build, photon tracing and
//! map building, and the whole render, with a check that every thread
//! count gives the same image, bit for bit.

use std::fmt::Write as _;
use std::time::Instant;

use crate::accel::bvh::Bvh;
use crate::accel::embree::EmbreeIntersector;
use crate::config::RenderConfig;
use crate::integrator::render;
use crate::photon::build_maps;
use crate::scene::Scene;

/// What one thread count took.
#[derive(Debug, Clone)]
pub struct ThreadRow {
    /// Worker threads (rayon's pool, and Embree's).
    pub threads: usize,
    /// Seconds to build and commit Embree's scene.
    pub embree_build: f64,
    /// Seconds to build the native BVH.
    pub native_build: f64,
    /// Seconds to trace the photons and build the maps.
    pub photons: f64,
    /// Seconds of the whole render (photons included).
    pub render: f64,
    /// Whether the image equals the first thread count's, bit for bit.
    pub same_image: bool,
}

/// Measures `scene` rendered with `settings` on each of `thread_counts`.
pub fn measure(
    scene: &Scene,
    settings: &RenderConfig,
    thread_counts: &[usize],
    report: &mut dyn FnMut(&ThreadRow),
) -> anyhow::Result<Vec<ThreadRow>> {
    let mut rows = Vec::new();
    let mut first_image: Option<Vec<[u32; 3]>> = None;
    for &threads in thread_counts {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let row = pool.install(|| -> crate::Result<ThreadRow> {
            let views = scene.triangle_views();
            let start = Instant::now();
            let embree = EmbreeIntersector::build(&views)?;
            let embree_build = start.elapsed().as_secs_f64();
            let start = Instant::now();
            drop(Bvh::build(&views));
            let native_build = start.elapsed().as_secs_f64();
            let start = Instant::now();
            let query = crate::query::SceneQuery::new(scene, &embree);
            let b = scene.bounds();
            drop(build_maps(
                &query,
                &settings.photons,
                settings.max_depth,
                settings.seed,
                settings.sampler,
                (b.max - b.min).length(),
            ));
            let photons = start.elapsed().as_secs_f64();
            let start = Instant::now();
            let rendered = render(scene, &embree, settings, &|_| {})?;
            let render_seconds = start.elapsed().as_secs_f64();
            let image: Vec<[u32; 3]> =
                rendered.film.beauty().pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
            let same_image = first_image.get_or_insert_with(|| image.clone()) == &image;
            Ok(ThreadRow { threads, embree_build, native_build, photons, render: render_seconds, same_image })
        })?;
        report(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// The rows as a Markdown table, with speed-ups over the first row.
pub fn table(rows: &[ThreadRow]) -> String {
    let mut t = String::from(
        "| threads | Embree build s | native build s | photons s | render s | speed-up (Embree, native, photons, render) | same image |\n\
         |---:|---:|---:|---:|---:|---|---|\n",
    );
    let Some(base) = rows.first() else { return t };
    for r in rows {
        let _ = writeln!(
            t,
            "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2}x, {:.2}x, {:.2}x, {:.2}x | {} |",
            r.threads,
            r.embree_build,
            r.native_build,
            r.photons,
            r.render,
            base.embree_build / r.embree_build,
            base.native_build / r.native_build,
            base.photons / r.photons,
            base.render / r.render,
            if r.same_image { "yes" } else { "NO" }
        );
    }
    t
}
