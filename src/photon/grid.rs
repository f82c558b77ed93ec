//! Spheres (a centre and a radius each) hashed into a uniform grid: given a
//! point, the spheres that may contain it, in a few nanoseconds. Progressive
//! photon mapping finds the visible points a photon lands near; final
//! gathering finds the precomputed irradiance whose gathering disc covers a
//! gather ray's hit.

use glam::Vec3;
use rayon::prelude::*;

/// Spheres listed in every grid cell they touch (see [`SphereGrid::new`]),
/// so a query needs to look in its own cell only.
pub struct SphereGrid {
    cell: f32,
    /// `starts[b]..starts[b + 1]` index `items` for bucket `b`.
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl SphereGrid {
    /// Spheres `spheres[i]` (`None`: no sphere `i`) in cells of side `cell`.
    /// A sphere spanning more than `max_span` cells along an axis is listed
    /// only in the `max_span` cells per axis around its centre: queries
    /// farther out may miss it (callers that need every sphere pass a cell at
    /// least the largest radius and any `max_span` of 3 or more).
    pub fn new(spheres: &[Option<(Vec3, f32)>], cell: f32, max_span: i32) -> SphereGrid {
        let buckets = (spheres.len() * 2).max(1);
        if !(cell > 0.0 && cell.is_finite()) {
            return SphereGrid { cell: 1.0, starts: vec![0; buckets + 1], items: Vec::new() };
        }
        let half = (max_span.max(1) - 1) / 2;
        let mut entries: Vec<(u32, u32)> = spheres
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, sphere)| {
                let mut cells = Vec::new();
                if let Some((centre, radius)) = *sphere {
                    let at = Self::cell_of(centre, cell);
                    let lo = Self::cell_of(centre - Vec3::splat(radius), cell);
                    let hi = Self::cell_of(centre + Vec3::splat(radius), cell);
                    let clip = |axis: usize| {
                        (
                            lo[axis].max(at[axis].saturating_sub(half)),
                            hi[axis].min(at[axis].saturating_add(half)),
                        )
                    };
                    let ((x0, x1), (y0, y1), (z0, z1)) = (clip(0), clip(1), clip(2));
                    for z in z0..=z1 {
                        for y in y0..=y1 {
                            for x in x0..=x1 {
                                cells.push((Self::bucket([x, y, z], buckets), i as u32));
                            }
                        }
                    }
                }
                cells
            })
            .collect();
        // Two cells of one sphere may share a bucket: list it once.
        entries.par_sort_unstable();
        entries.dedup();
        let mut starts = vec![0u32; buckets + 1];
        for &(b, _) in &entries {
            starts[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            starts[b + 1] += starts[b];
        }
        SphereGrid { cell, starts, items: entries.into_iter().map(|e| e.1).collect() }
    }

    /// Whether no sphere was listed.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    fn cell_of(p: Vec3, cell: f32) -> [i32; 3] {
        (p / cell).floor().to_array().map(|c| c as i32)
    }

    fn bucket(c: [i32; 3], buckets: usize) -> u32 {
        let h = (c[0] as u32).wrapping_mul(73_856_093)
            ^ (c[1] as u32).wrapping_mul(19_349_663)
            ^ (c[2] as u32).wrapping_mul(83_492_791);
        (h as usize % buckets) as u32
    }

    /// The spheres that may contain `p`, by index, each once, in index order.
    pub fn near(&self, p: Vec3) -> &[u32] {
        let b = Self::bucket(Self::cell_of(p, self.cell), self.starts.len() - 1) as usize;
        &self.items[self.starts[b] as usize..self.starts[b + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn grid_finds_exactly_the_spheres_in_reach() {
        let mut rng = Rng::new(3, 4);
        let spheres: Vec<Option<(Vec3, f32)>> = (0..2000)
            .map(|i| {
                let centre = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
                let radius = 0.02 + 0.1 * rng.uniform();
                (i % 7 != 0).then_some((centre, radius))
            })
            .collect();
        let largest = spheres.iter().flatten().map(|s| s.1).fold(0.0, f32::max);
        let grid = SphereGrid::new(&spheres, largest, 3);
        let mut total = 0;
        for k in 0..2000 {
            // Half anywhere, half within 0.05 per axis of a sphere's centre (mostly in its reach).
            let jitter = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5;
            let q = match spheres[k] {
                Some((centre, _)) if k % 2 == 0 => centre + 0.1 * jitter,
                _ => jitter * 4.4,
            };
            let in_reach = |i: usize| spheres[i].is_some_and(|(c, r)| (c - q).length() <= r);
            let mut found: Vec<usize> =
                grid.near(q).iter().map(|&i| i as usize).filter(|&i| in_reach(i)).collect();
            let listed = found.len();
            found.dedup();
            assert_eq!(found.len(), listed, "a sphere listed twice would count a photon twice");
            assert!(found.windows(2).all(|w| w[0] < w[1]), "in index order");
            let brute: Vec<usize> = (0..spheres.len()).filter(|&i| in_reach(i)).collect();
            assert_eq!(found, brute, "at {q}");
            total += found.len();
        }
        assert!(total > 500, "the queries must reach spheres: {total}");
    }

    #[test]
    fn wide_spheres_are_listed_near_their_centre_only() {
        // Many empty slots, so that buckets rarely collide.
        let mut spheres = vec![None; 1000];
        spheres[0] = Some((Vec3::ZERO, 100.0));
        spheres[1] = Some((Vec3::splat(0.5), 0.4));
        let grid = SphereGrid::new(&spheres, 1.0, 3);
        assert_eq!(grid.near(Vec3::splat(0.5)), &[0, 1]);
        assert!(!grid.near(Vec3::splat(50.0)).contains(&0), "clipped to 3 cells per axis");
    }
}
