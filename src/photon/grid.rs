//! A uniform grid over a map's photons for its estimates where light is
//! thin: "the up to `k` photons nearest a point within a radius `r`", when
//! fewer than a thousand or so photons lie near it.
//!
//! Most caustic-map estimates are such: under the point-lit Cornell box 94%
//! of them find fewer than `k` photons within the radius (counted, issue
//! 17). A kd-tree walks down to them and back; here the photons of a cell
//! lie side by side, and a query scans the cells its ball of radius `r`
//! reaches. The cells are a little more than `2 r` wide, so the ball
//! reaches two along each axis (the query's, and the neighbour on the side
//! it is nearer): eight cells to look up, where cells as wide as `r` took
//! 27, each a likely miss of the cache (BENCHMARKS.md). Where the cells
//! around a query hold many photons (in a caustic's focus), the kd-tree
//! answers instead.
//!
//! The answer is the kd-tree's: the same photons, the same squared
//! distances (`(p - q).length_squared()`, the order of kiddo's sum), nearest
//! first; among photons at exactly equal distances the smaller index first.

use glam::{UVec3, Vec3};

use crate::bounds::Bounds;

use super::cell_table::{key, points_by_cell, unkey, CellTable};
use super::runs;

/// The most photons the cells around a query may hold for the grid to
/// answer (beyond, the kd-tree is faster).
const MOST_SCANNED: usize = 1024;

/// How far from the origin, in cells, a grid may reach (queries twice as
/// far): a point's place in cells is then off by at most a few thousandths
/// of a cell (a few ulps of 2^13), within the widening of
/// [`EDGE_PER_RADIUS`].
const AXIS_CELLS: f32 = (1 << 12) as f32;

/// A cell's edge, in the radius it answers for: a ball of radius `r` spans
/// at most two cells along an axis (but in a sliver, see [`REACH`]).
const EDGE_PER_RADIUS: f32 = 2.02;

/// How far, in cells, a query's ball reaches along each axis from its
/// centre: the radius (`1 / EDGE_PER_RADIUS`), and a hundredth of a cell
/// beyond for a photon and a query each put off by rounding.
const REACH: f32 = 1.0 / EDGE_PER_RADIUS + 0.01;

/// Photons by grid cell, for searches of radius up to `radius`.
pub(super) struct Grid {
    origin: Vec3,
    radius: f32,
    inverse_edge: f32,
    /// Each cell's range in `photons`.
    table: CellTable,
    /// Positions and indices, cell by cell, by index within a cell.
    photons: Vec<(Vec3, u32)>,
    /// Which cells hold photons, where the box of cells they fill is small
    /// enough to keep a bit a cell.
    occupied: Option<Occupied>,
}

impl Grid {
    /// The grid for searches up to `radius` over `positions` (their indices
    /// in the order given), or `None` if the radius is not positive and
    /// finite or the coordinates are too many cells from the origin for
    /// rounding to leave each point in its cell or the next.
    pub(super) fn new(positions: &[Vec3], radius: f32) -> Option<Grid> {
        let edge = radius * EDGE_PER_RADIUS;
        if positions.is_empty() || !(edge.is_finite() && edge > 0.0) || positions.len() >= u32::MAX as usize {
            return None;
        }
        let Bounds { min: lo, max: hi } = Bounds::of(positions);
        let origin = lo - Vec3::splat(2.0 * edge);
        let reach = origin.abs().max(hi.abs() + Vec3::splat(2.0 * edge)).max_element() / edge;
        if reach.is_nan() || reach >= AXIS_CELLS {
            return None;
        }
        let inverse_edge = 1.0 / edge;
        let keyed = points_by_cell(positions, origin, inverse_edge);
        let cells: Vec<&[(u64, u32)]> = keyed.chunk_by(|a, b| a.0 == b.0).collect();
        let mut ranges = Vec::with_capacity(cells.len());
        let mut photons = Vec::with_capacity(positions.len());
        for cell in cells {
            ranges.push((cell[0].0, photons.len() as u32, cell.len() as u32));
            photons.extend(cell.iter().map(|&(_, i)| (positions[i as usize], i)));
        }
        let table = CellTable::new(&ranges);
        let occupied = Occupied::new(ranges.iter().map(|&(key, ..)| unkey(key)));
        Some(Grid { origin, radius, inverse_edge, table, photons, occupied })
    }

    /// Whether the grid keeps a bit for each cell of the box its photons fill.
    #[cfg(test)]
    pub(super) fn keeps_occupied_bits(&self) -> bool {
        self.occupied.is_some()
    }

    /// The up to `k` photons nearest `q` within `max_radius`, as (squared
    /// distance, index), nearest first; `None` when the grid cannot answer
    /// (a radius beyond the one it was made for, a query not a number, or
    /// too many photons around it).
    pub(super) fn nearest(&self, q: Vec3, k: usize, max_radius: f32) -> Option<Vec<(f32, usize)>> {
        if max_radius.is_nan() || max_radius > self.radius || k == 0 {
            return None;
        }
        // A query more than a cell below every photon along an axis, or
        // thousands of cells above, has none within the radius (and the
        // cells of those far off would hash wrongly): the answer is known
        // without a search (the kd-tree's descent found nothing there).
        let g = (q - self.origin) * self.inverse_edge;
        if !(g.cmpge(Vec3::ONE).all() && g.cmplt(Vec3::splat(2.0 * AXIS_CELLS)).all()) {
            return (!g.is_nan()).then(Vec::new);
        }
        // The cells the ball reaches: two along an axis, three where the
        // query is within a hundredth of a cell of a cell's middle.
        let (low, mut high) =
            ((g - Vec3::splat(REACH)).floor().as_uvec3(), (g + Vec3::splat(REACH)).floor().as_uvec3());
        if let Some(occupied) = &self.occupied {
            // Past the box of occupied cells there are none to look up.
            high = high.min(occupied.cells - UVec3::ONE);
        }
        let mut ranges: [std::ops::Range<usize>; 27] = Default::default();
        let mut count = 0;
        let mut scanned = 0;
        for z in low.z..=high.z {
            for y in low.y..=high.y {
                for x in low.x..=high.x {
                    let cell = UVec3::new(x, y, z);
                    // (A lookup in the table, empty cell or not, is likely
                    // a miss of the cache; the bits seldom are.)
                    if self.occupied.as_ref().is_some_and(|occupied| !occupied.has(cell)) {
                        continue;
                    }
                    if let Some(range) = self.table.get(key(cell)) {
                        scanned += range.len();
                        ranges[count] = range;
                        count += 1;
                    }
                }
            }
        }
        if scanned > MOST_SCANNED {
            return None;
        }
        if count == 0 {
            // (Most queries far from a caustic: no allocation.)
            return Some(Vec::new());
        }
        let r2 = max_radius * max_radius;
        let mut found: Vec<u64> = Vec::with_capacity(k.min(64));
        for range in &ranges[..count] {
            for &(p, i) in &self.photons[range.clone()] {
                let d2 = (p - q).length_squared();
                if d2 <= r2 {
                    found.push(runs::key(d2, i as usize));
                }
            }
        }
        Some(runs::nearest_first(found, k))
    }
}

/// A bit for each cell of the box from cell 0 to the last occupied one
/// along each axis: whether it holds photons.
struct Occupied {
    /// The box's size in cells.
    cells: UVec3,
    bits: Vec<u64>,
}

/// The most cells [`Occupied`] keeps bits for (2 MiB).
const MOST_OCCUPIED_BITS: u64 = 1 << 24;

impl Occupied {
    /// The bits of the cells `full`, or `None` if their box has more than
    /// [`MOST_OCCUPIED_BITS`] cells.
    fn new(full: impl Iterator<Item = UVec3> + Clone) -> Option<Occupied> {
        let cells = full.clone().fold(UVec3::ZERO, UVec3::max) + UVec3::ONE;
        let count = cells.as_u64vec3().element_product();
        if count > MOST_OCCUPIED_BITS {
            return None;
        }
        let mut occupied = Occupied { cells, bits: vec![0; count.div_ceil(64) as usize] };
        for cell in full {
            let i = occupied.index(cell);
            occupied.bits[i / 64] |= 1 << (i % 64);
        }
        Some(occupied)
    }

    /// The bit of a cell within the box.
    fn index(&self, cell: UVec3) -> usize {
        ((cell.z as usize * self.cells.y as usize) + cell.y as usize) * self.cells.x as usize
            + cell.x as usize
    }

    /// Whether a cell within the box holds photons.
    fn has(&self, cell: UVec3) -> bool {
        let i = self.index(cell);
        self.bits[i / 64] >> (i % 64) & 1 != 0
    }
}
