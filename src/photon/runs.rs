//! Range searches over photons already in Morton order, for the irradiance
//! precomputation: "every photon within this sphere", about 200 of them,
//! asked once per record (a quarter of a million times at 1M photons); and
//! for SPPM's gathering (`ranges.rs`), about 10 each, once per pixel a pass
//! (or once for a group of neighbouring pixels, [`Runs::within_each`]).
//!
//! The photons lie along a Morton curve (see `PhotonMap::new`), so every run
//! of [`RUN`] consecutive photons is a compact patch of surface. The runs are
//! the leaves of an implicit tree of boxes, four children to a node, built
//! bottom up in one pass: nothing is sorted or split, so building costs a
//! copy of the positions. A search walks the boxes the sphere touches and
//! tests each touched run's photons together: their coordinates are stored
//! axis by axis, and the squared distances of a whole run are one loop the
//! compiler turns into SIMD. kiddo's range search, which this replaces
//! there, tests one photon at a time (its SIMD distances need AVX2 enabled
//! at compile time) and was most of the precomputation's time
//! (BENCHMARKS.md, issue 17).

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use crate::bounds::Bounds;

/// Photons in a run: a leaf of the tree.
const RUN: usize = 32;

/// A run's coordinates, axis by axis; past the last photon, NaN (which no
/// comparison finds within any radius).
#[derive(Clone, Copy)]
struct Run {
    x: [f32; RUN],
    y: [f32; RUN],
    z: [f32; RUN],
}

impl Run {
    /// Each photon's squared distance to `q` (NaN past the last).
    fn distances2(&self, q: Vec3) -> [f32; RUN] {
        distances2(&self.x, &self.y, &self.z, q)
    }
}

/// The squared distances to `q` of a run's worth of points given axis by
/// axis, in the order of glam's `length_squared`, so that every search
/// here measures a photon's distance to the bit as the others do.
fn distances2(x: &[f32; RUN], y: &[f32; RUN], z: &[f32; RUN], q: Vec3) -> [f32; RUN] {
    let mut d2 = [0.0f32; RUN];
    for (i, d) in d2.iter_mut().enumerate() {
        let (dx, dy, dz) = (x[i] - q.x, y[i] - q.y, z[i] - q.z);
        *d = dx * dx + dy * dy + dz * dz;
    }
    d2
}

/// The middle of the box around the points of `queries` whose squared
/// radius is a number (`None` if none is): where a search for them all is
/// centred ([`Runs::within_each`]), and what decides whether it is worth it.
pub(super) fn middle(queries: &[(Vec3, f32)]) -> Option<Vec3> {
    let bounds = queries
        .iter()
        .filter(|(_, r2)| *r2 >= 0.0)
        .map(|&(q, _)| Bounds::EMPTY.grow(q))
        .reduce(Bounds::union)?;
    Some(0.5 * (bounds.min + bounds.max))
}

/// The tree over the runs, four children to a node: `levels[0]` holds the
/// boxes of the runs four at a time (node `i` covers runs `4i..4i + 4`),
/// each further level the boxes of the nodes below four at a time, up to
/// one node. A search tests a node's four boxes at once, in SIMD lanes
/// (with two children to a node it made twice as many visits, each a
/// mispredicted branch: the search's largest cost in SPPM's gathering).
pub(super) struct Runs {
    runs: Vec<Run>,
    /// Each run's box.
    boxes: Vec<Bounds>,
    levels: Vec<Vec<Node>>,
}

/// Four boxes, axis by axis, and which of them exist (the last node of a
/// level may have fewer than four children).
#[derive(Clone, Copy)]
struct Node {
    min: [Vec4; 3],
    max: [Vec4; 3],
    children: u32,
}

impl Node {
    fn new(boxes: &[Bounds]) -> Node {
        let lane = |i: usize| boxes.get(i).copied().unwrap_or(Bounds::EMPTY);
        let [a, b, c, d] = [lane(0), lane(1), lane(2), lane(3)];
        let axis = |p: [Vec3; 4], k: usize| Vec4::new(p[0][k], p[1][k], p[2][k], p[3][k]);
        let (min, max) = ([a.min, b.min, c.min, d.min], [a.max, b.max, c.max, d.max]);
        Node {
            min: [axis(min, 0), axis(min, 1), axis(min, 2)],
            max: [axis(max, 0), axis(max, 1), axis(max, 2)],
            children: boxes.len().min(4) as u32,
        }
    }

    /// The box around all four.
    fn bounds(&self) -> Bounds {
        let min = Vec3::new(self.min[0].min_element(), self.min[1].min_element(), self.min[2].min_element());
        let max = Vec3::new(self.max[0].max_element(), self.max[1].max_element(), self.max[2].max_element());
        Bounds { min, max }
    }

    /// Bit `i` set when child `i` exists and its box reaches within `r2`
    /// of `q`: the gap from `q` to the box, squared, as the scalar
    /// `(min - q).max(q - max).max(0).length_squared() <= r2` rounds it.
    #[inline]
    fn reaching(&self, q: Vec3, r2: f32) -> u32 {
        let gap = |k: usize| {
            let qk = Vec4::splat(q[k]);
            (self.min[k] - qk).max(qk - self.max[k]).max(Vec4::ZERO)
        };
        let (gx, gy, gz) = (gap(0), gap(1), gap(2));
        let d2 = gx * gx + gy * gy + gz * gz;
        d2.cmple(Vec4::splat(r2)).bitmask() & ((1 << self.children) - 1)
    }
}

impl Runs {
    /// The tree over the positions of `photons` (or any items with a
    /// `position`) in the order given (in parallel; the result does not
    /// depend on the threads).
    pub(super) fn new<T: Sync>(photons: &[T], position: impl Fn(&T) -> Vec3 + Sync) -> Runs {
        let runs: Vec<Run> = photons
            .par_chunks(RUN)
            .map(|chunk| {
                let mut run = Run { x: [f32::NAN; RUN], y: [f32::NAN; RUN], z: [f32::NAN; RUN] };
                for (i, photon) in chunk.iter().enumerate() {
                    let p = position(photon);
                    (run.x[i], run.y[i], run.z[i]) = (p.x, p.y, p.z);
                }
                run
            })
            .collect();
        // Each run's box from its own coordinates (a second pass over the
        // items would fetch every position again, scattered when `position`
        // looks them up elsewhere, as `ranges.rs` does).
        let boxes: Vec<Bounds> = runs
            .par_iter()
            .enumerate()
            .map(|(j, run)| {
                let len = (photons.len() - j * RUN).min(RUN);
                (0..len).fold(Bounds::EMPTY, |b, i| b.grow(Vec3::new(run.x[i], run.y[i], run.z[i])))
            })
            .collect();
        let mut levels: Vec<Vec<Node>> = vec![boxes.chunks(4).map(Node::new).collect()];
        while let Some(below) = levels.last().filter(|level| level.len() > 1) {
            let above =
                below.chunks(4).map(|four| Node::new(&four.iter().map(Node::bounds).collect::<Vec<_>>()));
            levels.push(above.collect());
        }
        Runs { runs, boxes, levels }
    }

    /// A first guess at the squared radius of a sphere holding `k`
    /// positions around position `index`: the squared half diagonal of its
    /// run's box, scaled from the run's photons to `k` (on a surface the
    /// count grows with the area). Searches grow a radius too small, and find
    /// the same photons from one too large.
    pub(super) fn start_radius2(&self, index: usize, k: usize) -> f32 {
        self.boxes
            .get(index / RUN)
            .map_or(0.0, |b| 0.25 * (b.max - b.min).length_squared() * k as f32 / RUN as f32)
    }

    /// Every position within squared distance `r2` of `q` (at most, as
    /// `(p - q).length_squared()` measures it), pushed onto `found` in no
    /// particular order as a [`key`]: ordering the keys orders the positions
    /// by distance, then by index (and compares integers, not floats).
    pub(super) fn within(&self, q: Vec3, r2: f32, found: &mut Vec<u64>) {
        if !self.runs.is_empty() {
            self.visit(self.levels.len() - 1, 0, q, r2, &mut |run| self.scan(run, q, r2, found));
        }
    }

    /// For each of `queries` (a centre and a squared radius), what
    /// [`within`](Runs::within) finds, into the `found` of the same index
    /// (cleared first), in no particular order: the same keys, by one
    /// search of a sphere around them all, whose photons are then tested
    /// against each query. For queries close together (neighbouring
    /// pixels' visible points), that walks the tree and scans the runs
    /// once instead of once each. `near` is a buffer the searches reuse.
    pub(super) fn within_each(&self, queries: &[(Vec3, f32)], near: &mut Near, found: &mut [Vec<u64>]) {
        for f in found.iter_mut() {
            f.clear();
        }
        near.clear();
        // Queries that reach nothing (a NaN radius) are left out of the sphere.
        let Some(centre) = middle(queries).filter(|_| !self.runs.is_empty()) else { return };
        let reach = queries
            .iter()
            .filter(|(_, r2)| *r2 >= 0.0)
            .map(|&(q, r2)| (q - centre).length() + r2.sqrt())
            .fold(0.0f32, f32::max);
        // Wider by far more than the rounding of any distance here (all of
        // it relative), so that every photon a query finds lies within it.
        let reach2 = (reach * (1.0 + 1e-4)).powi(2);
        self.visit(self.levels.len() - 1, 0, centre, reach2, &mut |run| {
            self.collect_near(run, centre, reach2, near)
        });
        near.pad();
        for (&(q, r2), found) in queries.iter().zip(found.iter_mut()) {
            near.within(q, r2, found);
        }
    }

    /// The photons of run `index` within `r2` of `q`, into `near`
    /// (without a branch per photon, as [`Runs::scan`]).
    fn collect_near(&self, index: usize, q: Vec3, r2: f32, near: &mut Near) {
        let run = &self.runs[index];
        let base = index * RUN;
        let d2 = run.distances2(q);
        let (mut x, mut y, mut z, mut at) = ([0.0f32; RUN], [0.0f32; RUN], [0.0f32; RUN], [0u32; RUN]);
        let mut n = 0;
        for (i, &d) in d2.iter().enumerate() {
            let slot = n % RUN;
            (x[slot], y[slot], z[slot], at[slot]) = (run.x[i], run.y[i], run.z[i], (base + i) as u32);
            n += usize::from(d <= r2);
        }
        near.x.extend_from_slice(&x[..n]);
        near.y.extend_from_slice(&y[..n]);
        near.z.extend_from_slice(&z[..n]);
        near.index.extend_from_slice(&at[..n]);
    }

    /// The positions within a sphere around `q` that holds its `k` nearest
    /// (or reaches `max_r2`), into `found` as [`within`](Runs::within) gives
    /// them, by range searches whose squared radius starts at `r2` and grows.
    pub(super) fn holding_k(&self, q: Vec3, k: usize, mut r2: f32, max_r2: f32, found: &mut Vec<u64>) {
        loop {
            found.clear();
            self.within(q, r2, found);
            let count = found.len();
            // (Written so that a NaN radius ends the loop too.)
            let reached_cap = r2.partial_cmp(&max_r2) != Some(std::cmp::Ordering::Less);
            if count >= k || reached_cap {
                break;
            }
            // Too few: on a surface the count grows with the area, so aim a
            // little past `k` positions, at least doubling the area.
            let wanted = (k as f32 * 1.25) / count.max(1) as f32;
            r2 = (r2 * wanted.clamp(2.0, 16.0)).min(max_r2);
        }
    }

    /// The up to `k` positions nearest `q` within `max_radius`, as
    /// (squared distance, index), nearest first, ties to the smaller index:
    /// what a k-nearest search of a kd-tree over the same positions finds.
    /// The first range search reaches a sixteenth of `max_radius` squared,
    /// whatever was asked before, so answers depend on the query alone.
    pub(super) fn nearest(&self, q: Vec3, k: usize, max_radius: f32) -> Vec<(f32, usize)> {
        if k == 0 {
            return Vec::new();
        }
        let max_r2 = max_radius * max_radius;
        let mut keys = Vec::new();
        self.holding_k(q, k, max_r2 / 16.0, max_r2, &mut keys);
        nearest_first(keys, k)
    }

    /// Hands `leaf` each run below `node` of `level` whose box reaches
    /// within `r2` of `q`, in their order (a NaN radius reaches nothing):
    /// the runs a search scans, and the order it pushes their photons, are
    /// those of any tree over the same runs' boxes.
    fn visit(&self, level: usize, node: usize, q: Vec3, r2: f32, leaf: &mut impl FnMut(usize)) {
        let mut reaching = self.levels[level][node].reaching(q, r2);
        while reaching != 0 {
            let child = 4 * node + reaching.trailing_zeros() as usize;
            reaching &= reaching - 1;
            match level {
                0 => leaf(child),
                _ => self.visit(level - 1, child, q, r2, leaf),
            }
        }
    }

    /// The photons of run `index` within `r2` of `q`.
    fn scan(&self, index: usize, q: Vec3, r2: f32, found: &mut Vec<u64>) {
        let d2 = self.runs[index].distances2(q);
        // Written without a branch per photon (whether one lies within is
        // as good as a coin toss near the sphere's edge): every photon is
        // written past the last one within, and that end moves past those
        // within. (`n <= i`, so `n % RUN` is `n`: no bounds check.)
        let base = index * RUN;
        let mut within = [0u64; RUN];
        let mut n = 0;
        for (i, &d) in d2.iter().enumerate() {
            within[n % RUN] = key(d, base + i);
            n += usize::from(d <= r2);
        }
        found.extend_from_slice(&within[..n]);
    }
}

/// The photons near a group of queries, coordinates axis by axis, with
/// their places along the curve: what [`Runs::within_each`] tests each
/// query against, a run's worth at a time (see [`Near::pad`]).
#[derive(Default)]
pub(super) struct Near {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    index: Vec<u32>,
}

impl Near {
    fn clear(&mut self) {
        self.x.clear();
        self.y.clear();
        self.z.clear();
        self.index.clear();
    }

    /// Fills the last run's worth with NaN coordinates, which no
    /// comparison finds within any radius, as past a run's last photon.
    fn pad(&mut self) {
        let whole = self.x.len().next_multiple_of(RUN);
        self.x.resize(whole, f32::NAN);
        self.y.resize(whole, f32::NAN);
        self.z.resize(whole, f32::NAN);
        self.index.resize(whole, 0);
    }

    /// Those within `r2` of `q`, as keys into `found` (once padded); each
    /// distance as [`Runs::scan`] computes it, to the bit.
    fn within(&self, q: Vec3, r2: f32, found: &mut Vec<u64>) {
        let (x, y, z) =
            (self.x.as_chunks::<RUN>().0, self.y.as_chunks::<RUN>().0, self.z.as_chunks::<RUN>().0);
        let chunks = x.iter().zip(y).zip(z).zip(self.index.as_chunks::<RUN>().0);
        for (((x, y), z), index) in chunks {
            let d2 = distances2(x, y, z, q);
            let mut keys = [0u64; RUN];
            let mut n = 0;
            for (&d, &index) in d2.iter().zip(index) {
                keys[n % RUN] = key(d, index as usize);
                n += usize::from(d <= r2);
            }
            found.extend_from_slice(&keys[..n]);
        }
    }
}

/// A squared distance (not negative, not NaN) and an index below 2^32 in
/// one integer that orders like the pair: for such floats the order of their
/// bits is the order of their values.
pub(super) fn key(distance2: f32, index: usize) -> u64 {
    (u64::from(distance2.to_bits()) << 32) | index as u64
}

/// The `k` least of `keys` (all of them if fewer), least first, as
/// (squared distance, index): nearest first, ties to the smaller index.
pub(super) fn nearest_first(mut keys: Vec<u64>, k: usize) -> Vec<(f32, usize)> {
    if keys.len() > k {
        if k > 0 {
            keys.select_nth_unstable(k - 1);
        }
        keys.truncate(k);
    }
    keys.sort_unstable();
    keys.into_iter().map(unkey).collect()
}

/// The squared distance and index of a [`key`].
pub(super) fn unkey(key: u64) -> (f32, usize) {
    (f32::from_bits((key >> 32) as u32), (key & 0xffff_ffff) as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn a_search_for_many_queries_finds_what_each_finds_alone() {
        // Groups of queries close together and far apart, with radii of
        // none, small, large, infinite and NaN, over points on a plane and
        // in a volume, and over none.
        let mut rng = Rng::new(31, 32);
        let mut near = Near::default();
        for n in [0, 1, 40, 3000] {
            let points: Vec<Vec3> = (0..n)
                .map(|i| {
                    let y = if i % 2 == 0 { 0.0 } else { rng.uniform() * 0.1 };
                    Vec3::new(rng.uniform(), y, rng.uniform())
                })
                .collect();
            let runs = Runs::new(&points, |p| *p);
            // The radii of each group: an infinite one finds everything.
            let groups: [&[f32]; 3] = [
                &[0.0, 1e-4, 0.003, 0.05, 0.02],
                &[0.003, f32::NAN, 0.004, 0.002],
                &[1e-4, f32::INFINITY, 0.01],
            ];
            for (spread, radii) in [0.0, 0.01, 0.2, 2.0].into_iter().flat_map(|s| groups.map(|g| (s, g))) {
                let middle = Vec3::new(rng.uniform(), 0.0, rng.uniform());
                let queries: Vec<(Vec3, f32)> = radii
                    .iter()
                    .map(|&r2| {
                        let q =
                            middle + spread * (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5);
                        (q, r2)
                    })
                    .collect();
                let mut found = vec![Vec::new(); queries.len()];
                runs.within_each(&queries, &mut near, &mut found);
                for ((q, r2), mut keys) in queries.iter().zip(found) {
                    let mut alone = Vec::new();
                    runs.within(*q, *r2, &mut alone);
                    alone.sort_unstable();
                    keys.sort_unstable();
                    assert_eq!(keys, alone, "{n} points, spread {spread}, r2 {r2}");
                }
            }
        }
    }

    #[test]
    fn range_searches_find_exactly_the_points_within() {
        // Counts that leave the last run partly filled, and one and none;
        // points on a plane (many equal distances) and in a volume; radii from
        // none found to all.
        let mut rng = Rng::new(11, 12);
        for n in [0, 1, 31, 32, 33, 1000, 4321] {
            let points: Vec<Vec3> = (0..n)
                .map(|i| {
                    let y = if i % 2 == 0 { 0.0 } else { rng.uniform() };
                    Vec3::new(rng.uniform(), y, rng.uniform())
                })
                .collect();
            let runs = Runs::new(&points, |p| *p);
            for _ in 0..30 {
                let q = Vec3::new(rng.uniform(), rng.uniform() * 0.2, rng.uniform());
                for r2 in [0.0, 1e-4, 0.01, 0.1, 5.0, f32::INFINITY] {
                    let mut keys = Vec::new();
                    runs.within(q, r2, &mut keys);
                    let found: Vec<(f32, usize)> = keys.into_iter().map(unkey).collect();
                    // Pushed run by run in order, each run's photons in
                    // order: the order the precomputation's sums follow.
                    assert!(found.windows(2).all(|w| w[0].1 < w[1].1), "{n} points, r2 {r2}: out of order");
                    let brute: Vec<(f32, usize)> = points
                        .iter()
                        .enumerate()
                        .map(|(i, p)| ((*p - q).length_squared(), i))
                        .filter(|&(d2, _)| d2 <= r2)
                        .collect();
                    assert_eq!(found, brute, "{n} points, r2 {r2}");
                    // Keys order as the pairs do.
                    let mut by_key: Vec<u64> = found.iter().map(|&(d2, i)| key(d2, i)).collect();
                    by_key.sort_unstable();
                    let mut by_pair = found.clone();
                    by_pair.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    assert_eq!(by_key.into_iter().map(unkey).collect::<Vec<_>>(), by_pair);
                }
            }
        }
    }
}
