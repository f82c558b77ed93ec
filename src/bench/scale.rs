//! How cost grows with mesh size (`caustix bench scale`): for a scene whose
//! teapots are re-tessellated at growing levels, the time to load it, to
//! build Embree's scene and the native BVH, their memory, the peak resident
//! memory with Embree, diffuse-ray throughput, and the time of a small
//! photon-mapped render.

use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

use super::plot::{log_log, Series};
use super::{peak_resident_bytes, reset_peak_resident, resident_bytes, RaySets};
use crate::accel::bvh::Bvh;
use crate::accel::embree::EmbreeIntersector;
use crate::accel::{BvhLayout, Intersector, Ray};
use crate::config::RenderConfig;
use crate::integrator::render;
use crate::scene::{Overrides, Scene};

/// What one mesh size cost.
#[derive(Debug, Clone)]
pub struct ScaleRow {
    /// Teapot subdivision level.
    pub level: u32,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Seconds to read and tessellate the scene.
    pub load_seconds: f64,
    /// Bytes of the scene's meshes (positions, normals, indices).
    pub mesh_bytes: usize,
    /// Seconds to build and commit Embree's scene.
    pub embree_seconds: f64,
    /// Resident bytes Embree's scene added.
    pub embree_bytes: usize,
    /// Peak resident bytes of loading and building with Embree.
    pub peak_with_embree: usize,
    /// Seconds to build the native BVH.
    pub native_seconds: f64,
    /// Bytes of the native BVH.
    pub native_bytes: usize,
    /// Diffuse rays per second through Embree (single queries), millions.
    pub embree_mrays: f64,
    /// Diffuse rays per second through the native BVH, millions.
    pub native_mrays: f64,
    /// Seconds of the photon-mapped render with Embree (photons included).
    pub render_seconds: f64,
}

/// Measures the scene at `path` with its teapots at each of `levels`.
/// Rays: a `rays_side`-square grid of camera rays, then one diffuse ray from
/// each hit. The render uses the scene's settings at `render_size`. Embree's
/// BVH is built in `layout`.
/// `report` sees each row when it is done.
pub fn measure(
    path: &Path,
    levels: &[u32],
    rays_side: u32,
    render_size: (u32, u32),
    layout: BvhLayout,
    report: &mut dyn FnMut(&ScaleRow),
) -> crate::Result<Vec<ScaleRow>> {
    let mut rows = Vec::new();
    for &level in levels {
        reset_peak_resident();
        let start = Instant::now();
        let scene = Scene::load_with(path, &Overrides { teapot_subdivisions: Some(level) })?;
        let load_seconds = start.elapsed().as_secs_f64();
        let mesh_bytes = scene.meshes.iter().map(|m| m.bytes()).sum();

        let before = resident_bytes();
        let start = Instant::now();
        let embree = EmbreeIntersector::build_with_layout(&scene.triangle_views(), layout)?;
        let embree_seconds = start.elapsed().as_secs_f64();
        let embree_bytes = resident_bytes().saturating_sub(before);
        let peak_with_embree = peak_resident_bytes();

        let sets = RaySets::new(&scene, &embree, rays_side, rays_side);
        let embree_mrays = diffuse_mrays(&embree, &sets.diffuse);

        let (width, height) = render_size;
        let settings = RenderConfig { width, height, ..scene.config.clone() };
        let start = Instant::now();
        render(&scene, &embree, &settings, &|_| {})?;
        let render_seconds = start.elapsed().as_secs_f64();
        drop(embree);

        let start = Instant::now();
        let native = Bvh::build(&scene.triangle_views());
        let native_seconds = start.elapsed().as_secs_f64();
        let native_bytes = native.stats().bytes;
        let native_mrays = diffuse_mrays(&native, &sets.diffuse);

        let row = ScaleRow {
            level,
            triangles: scene.triangle_count(),
            load_seconds,
            mesh_bytes,
            embree_seconds,
            embree_bytes,
            peak_with_embree,
            native_seconds,
            native_bytes,
            embree_mrays,
            native_mrays,
            render_seconds,
        };
        report(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// Millions of closest-hit queries per second over `rays`, best of 2.
fn diffuse_mrays(accel: &dyn Intersector, rays: &[Ray]) -> f64 {
    use rayon::prelude::*;
    let seconds = (0..2)
        .map(|_| {
            let start = Instant::now();
            let hits: usize = rays
                .par_chunks(1024)
                .map(|c| c.iter().filter(|r| accel.intersect(r).is_some()).count())
                .sum();
            std::hint::black_box(hits);
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    rays.len() as f64 / seconds / 1e6
}

fn mib(bytes: usize) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

/// The rows as a Markdown table.
pub fn table(rows: &[ScaleRow]) -> String {
    let mut out = String::from(
        "| triangles | load s | mesh MiB | B/triangle | Embree build s | Embree +MiB | peak with Embree MiB \
         | native build s | native MiB | Embree Mrays/s | native Mrays/s | render s |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {:.2} | {:.1} | {:.1} | {:.2} | {:.1} | {:.1} | {:.2} | {:.1} | {:.2} | {:.2} | {:.2} |",
            r.triangles,
            r.load_seconds,
            mib(r.mesh_bytes),
            r.mesh_bytes as f64 / r.triangles.max(1) as f64,
            r.embree_seconds,
            mib(r.embree_bytes),
            mib(r.peak_with_embree),
            r.native_seconds,
            mib(r.native_bytes),
            r.embree_mrays,
            r.native_mrays,
            r.render_seconds
        );
    }
    out
}

/// The rows as CSV, with a header.
pub fn csv(rows: &[ScaleRow]) -> String {
    let mut out = String::from(
        "level,triangles,load_s,mesh_bytes,embree_build_s,embree_bytes,peak_with_embree_bytes,\
         native_build_s,native_bytes,embree_mrays,native_mrays,render_s\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{:.4},{},{:.4},{},{},{:.4},{},{:.4},{:.4},{:.4}",
            r.level,
            r.triangles,
            r.load_seconds,
            r.mesh_bytes,
            r.embree_seconds,
            r.embree_bytes,
            r.peak_with_embree,
            r.native_seconds,
            r.native_bytes,
            r.embree_mrays,
            r.native_mrays,
            r.render_seconds
        );
    }
    out
}

/// Seconds against triangles, log-log: load, the two builds, the render.
pub fn plot(rows: &[ScaleRow], path: &Path) -> crate::Result<()> {
    let curve = |name: &str, seconds: fn(&ScaleRow) -> f64| Series {
        name: name.to_string(),
        points: rows.iter().map(|r| (r.triangles as f64, seconds(r))).collect(),
    };
    let series = [
        curve("load", |r| r.load_seconds),
        curve("Embree build", |r| r.embree_seconds),
        curve("native BVH build", |r| r.native_seconds),
        curve("render", |r| r.render_seconds),
    ];
    log_log(path, "cost against mesh size", "triangles", "seconds", &series)
}
