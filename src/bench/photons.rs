//! Photon maps at scale (`caustix bench photons`): for growing photon
//! counts, the time to trace them, the memory each stored photon takes (its
//! record and its share of the kd-tree), the kd-tree build time, and the
//! rate of k-nearest-neighbour queries on one thread and on all of them.
//!
//! The points and queries can be written out (`dump`) so that the C++
//! nanoflann bench (`scripts/bench-nanoflann.sh`) answers the very same
//! queries.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;

use super::resident_bytes;
use crate::accel::Intersector;
use crate::photon::map::{Photon, PhotonMap};
use crate::photon::{trace, Pass};
use crate::sampling::SamplerKind;
use crate::scene::Scene;

/// What one photon count cost.
#[derive(Debug, Clone)]
pub struct PhotonRow {
    /// Photons emitted.
    pub emitted: u32,
    /// Photons stored (one per diffuse bounce).
    pub stored: usize,
    /// Seconds to trace them (all threads).
    pub trace_seconds: f64,
    /// Bytes per stored photon of its record.
    pub record_bytes: usize,
    /// Resident bytes per stored photon the kd-tree added.
    pub tree_bytes_per_photon: f64,
    /// Seconds to build the kd-tree (serial, so the tree never depends on
    /// the thread count).
    pub build_seconds: f64,
    /// Neighbours per query.
    pub k: usize,
    /// Queries run.
    pub queries: usize,
    /// k-nearest queries per second on one thread, millions.
    pub mqueries_one_thread: f64,
    /// k-nearest queries per second on all threads, millions.
    pub mqueries_all_threads: f64,
    /// Sum of the squared distances of all neighbours found.
    pub distance_sum: f64,
}

/// Traces `counts` global photons in `scene` and measures each map. Queries
/// sit at the positions of every n-th stored photon (where a renderer asks:
/// on surfaces), `queries` of them. `dump` writes the largest map's points
/// and queries for the nanoflann bench.
pub fn measure(
    scene: &Scene,
    accel: &dyn Intersector,
    counts: &[u32],
    k: usize,
    queries: usize,
    dump: Option<&Path>,
    report: &mut dyn FnMut(&PhotonRow),
) -> crate::Result<Vec<PhotonRow>> {
    let mut rows = Vec::new();
    for (i, &emitted) in counts.iter().enumerate() {
        let start = Instant::now();
        let query = crate::query::SceneQuery::new(scene, accel);
        let (photons, _) =
            trace(&query, Pass::Global { keep_direct: true }, emitted, 16, 0, SamplerKind::default());
        let trace_seconds = start.elapsed().as_secs_f64();
        let stored = photons.len();
        let step = (stored / queries.max(1)).max(1);
        let points: Vec<[f32; 3]> =
            photons.iter().step_by(step).take(queries).map(|p| p.position.to_array()).collect();
        if let (Some(path), true) = (dump, i + 1 == counts.len()) {
            write_dump(path, &photons, &points, k).map_err(|e| crate::Error::io(path, e))?;
        }

        let before = resident_bytes();
        let start = Instant::now();
        let map = PhotonMap::new(photons);
        let build_seconds = start.elapsed().as_secs_f64();
        // The map owns the photon records it was given; the rest is the tree.
        let tree_bytes = resident_bytes().saturating_sub(before);

        // The sum of the squared distances found: a checksum to hold
        // against nanoflann's answers to the same queries.
        let distances = |q: &[f32; 3]| -> f64 {
            let found = map.nearest(glam::Vec3::from_array(*q), k, f32::INFINITY);
            found.iter().map(|&(d, _)| d as f64).sum()
        };
        let rate = |seconds: f64| points.len() as f64 / seconds / 1e6;
        let start = Instant::now();
        let distance_sum: f64 = points.iter().map(distances).sum();
        let one_thread = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let parallel: Vec<f64> = points.par_iter().map(distances).collect();
        let all_threads = start.elapsed().as_secs_f64();
        assert_eq!(
            distance_sum,
            parallel.iter().sum::<f64>(),
            "the same neighbours whatever the thread count"
        );

        let row = PhotonRow {
            emitted,
            stored,
            trace_seconds,
            record_bytes: std::mem::size_of::<Photon>(),
            tree_bytes_per_photon: tree_bytes as f64 / stored.max(1) as f64,
            build_seconds,
            k,
            queries: points.len(),
            mqueries_one_thread: rate(one_thread),
            mqueries_all_threads: rate(all_threads),
            distance_sum,
        };
        report(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// Little-endian: `u64` point count, the points as `f32` triples, `u64`
/// query count, the queries, `u32` k.
fn write_dump(path: &Path, photons: &[Photon], queries: &[[f32; 3]], k: usize) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    out.write_all(&(photons.len() as u64).to_le_bytes())?;
    for p in photons {
        for c in p.position.to_array() {
            out.write_all(&c.to_le_bytes())?;
        }
    }
    out.write_all(&(queries.len() as u64).to_le_bytes())?;
    for q in queries.iter().flatten() {
        out.write_all(&q.to_le_bytes())?;
    }
    out.write_all(&(k as u32).to_le_bytes())?;
    out.flush()
}

/// The rows as a Markdown table.
pub fn table(rows: &[PhotonRow]) -> String {
    let mut t = String::from(
        "| emitted | stored | trace s | record B/photon | kd-tree B/photon | build s | k | queries | Mq/s 1 thread | Mq/s all threads |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            t,
            "| {} | {} | {:.2} | {} | {:.1} | {:.2} | {} | {} | {:.3} | {:.3} |",
            r.emitted,
            r.stored,
            r.trace_seconds,
            r.record_bytes,
            r.tree_bytes_per_photon,
            r.build_seconds,
            r.k,
            r.queries,
            r.mqueries_one_thread,
            r.mqueries_all_threads
        );
    }
    t
}
