//! Irradiance ahead of final gathering (Christensen 1999): at every
//! `stride`-th photon of a map in Morton order, the irradiance of its `k`
//! nearest photons and the gather guide of those that bounced before, so
//! that a gather ray's hit needs only the nearest record
//! ([`super::map::Precomputed`]).
//!
//! The k nearest come from range searches over runs of the photons
//! ([`Runs`]), each starting from the radius its neighbour along the curve
//! needed, not from the kd-tree: the precomputation can run while the tree is
//! built.

use glam::Vec3;
use rayon::prelude::*;

use super::disc::DiscShare;
use super::guide::GuideBins;
use super::map::{close_disc, Estimate, IrradianceRecord, Photon, Precomputed};
use super::runs::{unkey, Runs};
use crate::sampling::Frame;

/// Precomputed irradiance records made by one task in a row (a stretch of
/// the Morton curve, so that each search starts from its neighbour's radius).
const PRECOMPUTE_CHUNK: usize = 256;

/// How far beyond the last search's k-th photon (in squared radius) the next
/// search starts: 1.3 is 14% in radius, enough that the neighbour's
/// search usually finds its `k` photons in one pass.
const START_MARGIN: f32 = 1.3;

/// A k-nearest search's reusable state: the photons found (squared
/// distance, index), the range searches' keys for them, and the squared
/// radius the next search starts from (0: none yet).
#[derive(Default)]
struct Search {
    found: Vec<(f32, usize)>,
    keys: Vec<u64>,
    radius2: f32,
}

/// Irradiance records at every `stride`-th photon (in parallel; `None`
/// when there are no photons).
///
/// The photons lie along a Morton curve (see `PhotonMap::new`): every
/// `stride`-th of them spreads the records evenly over the lit surfaces,
/// and consecutive estimates search the same runs of photons, each
/// starting from the radius the one before needed (see [`nearest_from`]).
/// The records are made in fixed chunks of the curve, each in order from
/// its start, so they do not depend on how many threads share the chunks.
pub(super) fn precompute(
    photons: &[Photon],
    runs: &Runs,
    stride: usize,
    estimate: &Estimate,
) -> Option<Precomputed> {
    let stride = stride.max(1);
    let chosen: Vec<(usize, &Photon)> = photons.iter().enumerate().step_by(stride).collect();
    if chosen.is_empty() {
        return None;
    }
    let records: Vec<Vec<IrradianceRecord>> = chosen
        .par_chunks(PRECOMPUTE_CHUNK)
        .map(|chunk| {
            let mut search = Search::default();
            chunk
                .iter()
                .map(|&(index, photon)| {
                    let (p, n) = (photon.position, photon.normal);
                    nearest_from(runs, p, index, estimate.k, estimate.max_radius, &mut search);
                    let radius2 = close_disc(&mut search.found, estimate);
                    record_in(photons, p, n, radius2, &search.found)
                })
                .collect::<Vec<_>>()
        })
        .collect();
    Some(Precomputed::from_runs(records))
}

/// The irradiance record at `p` (normal `n`), with its gather guide,
/// from the photons of a disc of squared radius `radius2`: the
/// irradiance `sum power / (pi r^2)` over those lighting the surface
/// (see `PhotonMap::radiance`), the guide from those among them that
/// bounced before, both in one pass over the photons.
pub(super) fn record_in(
    photons: &[Photon],
    p: Vec3,
    n: Vec3,
    radius2: f32,
    found: &[(f32, usize)],
) -> IrradianceRecord {
    let (r, frame) = (radius2.sqrt(), Frame::new(n));
    let mut power = Vec3::ZERO;
    let mut bins = GuideBins::default();
    let mut disc = DiscShare::new(p, n, r);
    for &(_, i) in found {
        let photon = &photons[i];
        if photon.lights_surface(p, n, r) {
            power += photon.power;
            if photon.indirect {
                bins.add(frame.to_local(photon.incoming), photon.power.element_sum());
            }
        } else {
            disc.offer(photon.position, photon.normal);
        }
    }
    let guide = bins.guide();
    // Near a corner only part of the disc lies on this surface.
    let share = disc.share_among(found.iter().map(|&(_, i)| &photons[i]));
    let irradiance =
        if radius2 > 0.0 { power / (std::f32::consts::PI * radius2 * share) } else { Vec3::ZERO };
    IrradianceRecord { position: p, normal: n, irradiance, radius2, guide }
}

/// The `k` photons nearest `p` within `max_radius` (as `PhotonMap::nearest`
/// finds them), into `search.found`, the `k`-th (when there are `k`) last
/// and the others in no particular order, by range searches: a sphere around
/// `p` whose squared radius starts at `search.radius2` (set by the last
/// search nearby) or, in a chunk's first search, at a guess from the photons
/// in a run beside photon `near`, and grows until it holds `k` photons or
/// reaches `max_radius`; then the `k` nearest are selected from it. The
/// photons found are the `k` nearest, ties broken by index, however the
/// sphere started; their order depends on the start (so sums over them
/// round differently), which depends only on the searches before in the
/// same fixed sequence, never on threads. A range search visits each photon
/// in it once, where a k-nearest search keeps a heap: at `k = 100` the
/// precomputation took 1.6x as long with kiddo's k-nearest search
/// (BENCHMARKS.md).
fn nearest_from(runs: &Runs, p: Vec3, near: usize, k: usize, max_radius: f32, search: &mut Search) {
    search.found.clear();
    if k == 0 {
        return;
    }
    let max_r2 = max_radius * max_radius;
    let start = if search.radius2 > 0.0 { search.radius2 } else { runs.start_radius2(near, k) };
    // (Written so that a NaN or zero guess starts from the cap.)
    let start = if start > 0.0 { start.min(max_r2) } else { max_r2 };
    runs.holding_k(p, k, start, max_r2, &mut search.keys);
    // The k nearest, the k-th last; ties broken by index, as the keys
    // order. (Not sorted: sorting them cost a fifth of the precomputation.)
    if search.keys.len() >= k {
        search.keys.select_nth_unstable(k - 1);
        search.keys.truncate(k);
    }
    search.found.extend(search.keys.iter().map(|&key| unkey(key)));
    // The next search, nearby, starts a little beyond this one's k-th
    // photon, so that it usually needs a single pass.
    if let Some(&(farthest, _)) = search.found.last() {
        if search.found.len() == k && farthest > 0.0 {
            search.radius2 = farthest * START_MARGIN;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::map::PhotonMap;
    use crate::sampling::Rng;

    #[test]
    fn range_searches_find_the_k_nearest_whatever_their_start() {
        // Half the photons on a lattice (many exactly equal distances), half
        // random; searches started from far too small, about right, and far
        // too large radii, with and without a radius cap, must all find
        // exactly the brute force's k nearest, ties broken by index.
        let mut rng = Rng::new(5, 6);
        let photons = Photon::on_lattice_and_scattered(4000, 40, &mut rng);
        let map = PhotonMap::new(photons);
        let runs = Runs::new(map.photons(), |photon| photon.position);
        for _ in 0..40 {
            let q = Vec3::new(rng.uniform(), 0.0, rng.uniform());
            for (k, max_radius) in [(1, 10.0), (20, 10.0), (200, 10.0), (200, 0.05), (4001, 10.0)] {
                let mut brute: Vec<(f32, usize)> = map
                    .photons()
                    .iter()
                    .enumerate()
                    .map(|(i, p)| ((p.position - q).length_squared(), i))
                    .filter(|&(d2, _)| d2 <= max_radius * max_radius)
                    .collect();
                brute.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                brute.truncate(k);
                for start in [0.0, 1e-8, 1e-3, 0.5, 100.0] {
                    let mut search = Search { radius2: start, ..Search::default() };
                    nearest_from(&runs, q, 0, k, max_radius, &mut search);
                    let mut found = search.found.clone();
                    if found.len() == k {
                        // The k-th last, as `close_disc` needs.
                        assert_eq!(found.last(), brute.last(), "k {k}, cap {max_radius}, start {start}");
                    }
                    found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    assert_eq!(found, brute, "k {k}, cap {max_radius}, start {start}");
                }
            }
        }
    }
}
