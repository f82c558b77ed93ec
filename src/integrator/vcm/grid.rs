//! A uniform hash grid over one pass's light vertices, for merging: which
//! of them lie within the merging radius of a camera vertex.

use glam::{IVec3, Vec3};

/// Points hashed into cells twice as wide as the radius, so the sphere
/// around any query point touches at most two cells per axis.
pub struct Grid {
    origin: Vec3,
    inverse_cell: f32,
    radius2: f32,
    /// `starts[b]..starts[b + 1]` index `points` for bucket `b`.
    starts: Vec<u32>,
    /// The points with their indices, bucket by bucket (side by side, so a
    /// bucket is read in one sweep).
    points: Vec<(Vec3, u32)>,
}

impl Grid {
    /// The grid over `positions` for queries of `radius` (positive).
    pub fn new(positions: Vec<Vec3>, radius: f32) -> Grid {
        let origin = positions.iter().fold(Vec3::INFINITY, |m, p| m.min(*p));
        let buckets = positions.len().next_power_of_two().max(1);
        let mut grid = Grid {
            origin,
            inverse_cell: 0.5 / radius,
            radius2: radius * radius,
            starts: vec![0; buckets + 1],
            points: vec![(Vec3::ZERO, 0); positions.len()],
        };
        // A counting sort by bucket: the same grid whatever the threads.
        let keys: Vec<usize> = positions.iter().map(|&p| grid.bucket(grid.cell_of(p))).collect();
        for &b in &keys {
            grid.starts[b + 1] += 1;
        }
        for b in 0..buckets {
            grid.starts[b + 1] += grid.starts[b];
        }
        let mut next = grid.starts.clone();
        for (i, (&b, &p)) in keys.iter().zip(&positions).enumerate() {
            grid.points[next[b] as usize] = (p, i as u32);
            next[b] += 1;
        }
        grid
    }

    /// Calls `visit` with the index of every point within the radius of `p`
    /// (each once).
    pub fn visit(&self, p: Vec3, mut visit: impl FnMut(usize)) {
        if self.points.is_empty() {
            return;
        }
        let r = 0.5 / self.inverse_cell;
        let lo = self.cell_of(p - Vec3::splat(r));
        let hi = self.cell_of(p + Vec3::splat(r)).min(lo.saturating_add(IVec3::splat(2)));
        // Different cells may share a bucket: visit each bucket once. (Two
        // cells per axis, three where rounding puts the sphere's ends at
        // cell boundaries.)
        let mut seen = [usize::MAX; 27];
        let mut n = 0;
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let b = self.bucket(IVec3::new(x, y, z));
                    if seen[..n].contains(&b) {
                        continue;
                    }
                    seen[n] = b;
                    n += 1;
                    for &(q, i) in &self.points[self.starts[b] as usize..self.starts[b + 1] as usize] {
                        if (q - p).length_squared() <= self.radius2 {
                            visit(i as usize);
                        }
                    }
                }
            }
        }
    }

    fn cell_of(&self, p: Vec3) -> IVec3 {
        // Saturating conversions: a point far outside maps to an edge cell,
        // and the distance test still decides.
        ((p - self.origin) * self.inverse_cell).floor().as_ivec3()
    }

    fn bucket(&self, c: IVec3) -> usize {
        let h = (c.x as u32).wrapping_mul(73_856_093)
            ^ (c.y as u32).wrapping_mul(19_349_663)
            ^ (c.z as u32).wrapping_mul(83_492_791);
        h as usize & (self.starts.len() - 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn finds_exactly_the_points_within_the_radius() {
        let mut rng = Rng::new(3, 0);
        let points: Vec<Vec3> =
            (0..2000).map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())).collect();
        let radius = 0.07;
        let grid = Grid::new(points.clone(), radius);
        for _ in 0..200 {
            let q = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2 - 0.1;
            let mut found = Vec::new();
            grid.visit(q, |i| found.push(i));
            found.sort_unstable();
            let expected: Vec<usize> =
                (0..points.len()).filter(|&i| (points[i] - q).length_squared() <= radius * radius).collect();
            assert_eq!(found, expected);
        }
        let empty = Grid::new(Vec::new(), 1.0);
        empty.visit(Vec3::ZERO, |_| panic!("nothing to find"));
    }
}
