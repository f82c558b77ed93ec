//! Range searches of any radius over positions, answered in the order the
//! positions were given: SPPM's gathering, where every visible point looks
//! for the photons within its own radius.
//!
//! Each pixel's radius shrinks at its own pace, so the radii of one pass
//! differ by an order of magnitude: wide in dim places, narrow in caustics.
//! Searching from the visible points' side makes each search as wide as
//! its own radius. (Searching from the photons' side, in a grid over the
//! points whose cells must be as wide as the largest radius, a photon
//! tested about a hundred points to find ten, each a read scattered over
//! the points: a quarter of an SPPM render, BENCHMARKS.md.) Neighbouring
//! pixels' visible points mostly find the same photons, so a group of them
//! can be answered by one search around them all (`within_each`).

use glam::Vec3;
use rayon::prelude::*;

use super::map::{index_of, morton_order};
use super::runs::{middle, unkey, Near, Runs};

/// Positions along a Morton curve, in runs searched by spheres
/// (`runs.rs`), with each one's index in the order given.
pub struct RangeSearch {
    /// Per position in curve order, its index in the order given.
    given: Vec<u32>,
    runs: Runs,
}

impl RangeSearch {
    /// The search over the positions of `items` (in parallel; the result
    /// does not depend on the threads). Panics beyond 2^32 items.
    pub fn new<T: Sync>(items: &[T], position: impl Fn(&T) -> Vec3 + Sync) -> RangeSearch {
        let order = morton_order(items, &position);
        let runs = Runs::new(&order, |&key| position(&items[index_of(key)]));
        let given = order.par_iter().map(|&key| index_of(key) as u32).collect();
        RangeSearch { given, runs }
    }

    /// The indices (in the order given) of every item whose position `p` has
    /// `(p - q).length_squared() <= r2`, in increasing order, into `found`
    /// (cleared first); `keys` is a buffer the search reuses.
    pub fn within(&self, q: Vec3, r2: f32, keys: &mut Vec<u64>, found: &mut Vec<u32>) {
        keys.clear();
        self.runs.within(q, r2, keys);
        found.clear();
        found.extend(keys.iter().map(|&key| self.given[unkey(key).1]));
        found.sort_unstable();
    }

    /// What [`within`](RangeSearch::within) finds for each of `queries` (a
    /// centre and a squared radius), into the `found` of the same index, by
    /// one search around them all (see `Runs::within_each`): for queries
    /// close together, such as neighbouring pixels' visible points.
    pub fn within_each(&self, queries: &[(Vec3, f32)], buffers: &mut GroupBuffers, found: &mut [Vec<u32>]) {
        if buffers.keys.len() < queries.len() {
            buffers.keys.resize_with(queries.len(), Vec::new);
        }
        let keys = &mut buffers.keys[..queries.len()];
        self.runs.within_each(queries, &mut buffers.near, keys);
        for (keys, found) in keys.iter().zip(found.iter_mut()) {
            found.clear();
            found.extend(keys.iter().map(|&key| self.given[unkey(key).1]));
            found.sort_unstable();
        }
    }
}

/// Whether range searches around `queries` (centres and squared radii) are
/// worth one [`RangeSearch::within_each`] around them all: whether there
/// are several, all within twice the largest radius of the middle of their
/// box, so that the sphere around them all is at most three times as wide
/// as the widest (not so where neighbouring pixels' points span an edge
/// between near and far surfaces, or where the radii are much smaller than
/// the distances between the points).
pub fn close_together(queries: &[(Vec3, f32)]) -> bool {
    let Some(centre) = middle(queries) else { return false };
    let widest = queries.iter().map(|&(_, r2)| r2).fold(0.0f32, f32::max);
    queries.len() > 1 && queries.iter().all(|&(q, _)| (q - centre).length_squared() <= 4.0 * widest)
}

/// Buffers a thread's [`RangeSearch::within_each`] reuses.
#[derive(Default)]
pub struct GroupBuffers {
    near: Near,
    keys: Vec<Vec<u64>>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn queries_are_searched_together_only_when_close() {
        let at = |x: f32, r: f32| (Vec3::new(x, 0.0, 0.0), r * r);
        assert!(!close_together(&[]));
        assert!(!close_together(&[at(0.0, 1.0)]), "one query is searched alone");
        assert!(close_together(&[at(0.0, 0.5), at(1.0, 0.5)]), "within the widest radius of the middle");
        assert!(close_together(&[at(0.0, 0.1), at(1.0, 0.25)]), "within twice the widest radius");
        assert!(!close_together(&[at(0.0, 0.1), at(1.0, 0.2)]), "beyond twice the widest radius");
    }

    #[test]
    fn finds_exactly_the_positions_within_in_the_order_given() {
        // On a plane (many equal distances, points exactly on a sphere's
        // edge) and in a volume; radii from none found to all; counts that
        // leave the last run partly filled, and one and none.
        let mut rng = Rng::new(21, 22);
        for n in [0, 1, 33, 2500] {
            let positions: Vec<Vec3> = (0..n)
                .map(|i| match i % 2 {
                    0 => Vec3::new((i % 50) as f32 * 0.02, 0.0, (i / 50) as f32 * 0.02),
                    _ => Vec3::new(rng.uniform(), rng.uniform() * 0.1, rng.uniform()),
                })
                .collect();
            let search = RangeSearch::new(&positions, |p| *p);
            let (mut keys, mut found) = (Vec::new(), Vec::new());
            let mut buffers = GroupBuffers::default();
            for j in 0..40 {
                let q = match positions.get(j * 7) {
                    Some(&p) if j % 2 == 0 => p,
                    _ => Vec3::new(rng.uniform(), rng.uniform() * 0.1, rng.uniform()),
                };
                let radii = [0.0, 0.0004, 0.01, 0.1, f32::INFINITY];
                for r2 in radii {
                    search.within(q, r2, &mut keys, &mut found);
                    let brute: Vec<u32> = (0..n as u32)
                        .filter(|&i| (positions[i as usize] - q).length_squared() <= r2)
                        .collect();
                    assert_eq!(found, brute, "{n} positions, r2 {r2}, at {q}");
                }
                // The same queries at once, moved a little apart.
                let queries: Vec<(Vec3, f32)> = radii
                    .iter()
                    .enumerate()
                    .map(|(k, &r2)| (q + Vec3::splat(0.003 * k as f32), r2))
                    .collect();
                let mut all_found = vec![Vec::new(); queries.len()];
                search.within_each(&queries, &mut buffers, &mut all_found);
                for (&(q, r2), found_together) in queries.iter().zip(&all_found) {
                    search.within(q, r2, &mut keys, &mut found);
                    assert_eq!(found_together, &found, "{n} positions, r2 {r2}, at {q}, together");
                }
            }
        }
    }
}
