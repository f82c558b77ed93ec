//! A uniform hash grid over the visible points, for finding the points a
//! photon lands within reach of.

use glam::Vec3;
use rayon::prelude::*;

use super::VisiblePoint;

/// Visible points hashed into a uniform grid whose cells are as wide as the
/// largest radius: each point is listed in every cell its sphere touches, so
/// a photon needs to look in its own cell only.
pub struct Grid {
    cell: f32,
    /// `starts[b]..starts[b + 1]` index `points` for bucket `b`.
    starts: Vec<u32>,
    points: Vec<u32>,
}

impl Grid {
    pub fn new(visible: &[Option<VisiblePoint>]) -> Grid {
        let cell = visible.iter().flatten().map(|vp| vp.radius).fold(0.0, f32::max);
        let buckets = (visible.len() * 2).max(1);
        if cell <= 0.0 {
            return Grid { cell, starts: vec![0; buckets + 1], points: Vec::new() };
        }
        let mut entries: Vec<(u32, u32)> = visible
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, vp)| {
                let mut cells = Vec::new();
                if let Some(vp) = vp {
                    let lo = Self::cell_of(vp.p - Vec3::splat(vp.radius), cell);
                    let hi = Self::cell_of(vp.p + Vec3::splat(vp.radius), cell);
                    for z in lo[2]..=hi[2] {
                        for y in lo[1]..=hi[1] {
                            for x in lo[0]..=hi[0] {
                                cells.push((Self::bucket([x, y, z], buckets), i as u32));
                            }
                        }
                    }
                }
                cells
            })
            .collect();
        // Two cells of one point may share a bucket: list it once.
        entries.par_sort_unstable();
        entries.dedup();
        let mut starts = vec![0u32; buckets + 1];
        for &(b, _) in &entries {
            starts[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            starts[b + 1] += starts[b];
        }
        Grid { cell, starts, points: entries.into_iter().map(|e| e.1).collect() }
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
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

    /// The visible points that may be within their radius of `p`.
    pub fn near(&self, p: Vec3) -> &[u32] {
        let b = Self::bucket(Self::cell_of(p, self.cell), self.starts.len() - 1) as usize;
        &self.points[self.starts[b] as usize..self.starts[b + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn grid_finds_exactly_the_points_in_reach() {
        let mut rng = Rng::new(3, 4);
        let points: Vec<Option<VisiblePoint>> = (0..2000)
            .map(|i| {
                (i % 7 != 0).then(|| VisiblePoint {
                    p: Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0,
                    n: Vec3::Y,
                    wo: Vec3::Y,
                    material: 0,
                    weight: Vec3::ONE,
                    radius: 0.02 + 0.1 * rng.uniform(),
                })
            })
            .collect();
        let grid = Grid::new(&points);
        let mut total = 0;
        for k in 0..2000 {
            // Half anywhere, half within 0.05 per axis of a point (mostly in its reach).
            let jitter = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5;
            let q = match points[k] {
                Some(vp) if k % 2 == 0 => vp.p + 0.1 * jitter,
                _ => jitter * 4.4,
            };
            let in_reach = |i: usize| points[i].is_some_and(|vp| (vp.p - q).length() <= vp.radius);
            let mut found: Vec<usize> =
                grid.near(q).iter().map(|&i| i as usize).filter(|&i| in_reach(i)).collect();
            found.sort_unstable();
            let listed = found.len();
            found.dedup();
            assert_eq!(found.len(), listed, "a point listed twice would gather a photon twice");
            let brute: Vec<usize> = (0..points.len()).filter(|&i| in_reach(i)).collect();
            assert_eq!(found, brute, "at {q}");
            total += found.len();
        }
        assert!(total > 500, "the queries must reach points: {total}");
    }
}
