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
//! 27, each a likely miss of the cache (BENCHMARKS.md).
//!
//! Where the cells around a query hold many photons (in a caustic's focus),
//! its `k` nearest lie well within the radius: finer grids, each of half
//! the radius of the one above, hold the photons of such places, and the
//! first whose cells around the query hold few enough is scanned with its
//! own radius. If its ball holds `k` photons or more, the `k` nearest are
//! among them; if not, the grid above it is scanned (where that is not too
//! many either). The kd-tree answers the rest. In the focus of the ring's
//! cardioid half the caustic estimates are such, and took two thirds of
//! their time in the kd-tree (BENCHMARKS.md).
//!
//! The answer is the kd-tree's: the same photons, the same squared
//! distances (`(p - q).length_squared()`, the order of kiddo's sum), nearest
//! first; among photons at exactly equal distances the smaller index first.

use glam::{IVec3, UVec3, Vec3};

use crate::bounds::Bounds;

use super::cell_table::{key, points_by_cell, unkey, CellTable};
use super::runs;

/// The most photons the cells around a query may hold for the grid to
/// answer (beyond, a finer grid's or the kd-tree).
const MOST_SCANNED: usize = 1024;

/// The most photons scanned in the grid above the first fine enough one,
/// where that one's ball holds fewer than `k` (beyond, the kd-tree
/// answers). In the ring's render kiddo's searches there took about 7 us
/// each, and a scan takes about a nanosecond a photon.
const MOST_SCANNED_ABOVE: usize = 8192;

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

/// Each finer grid's radius, in the radius of the one above it.
const FINER_RADIUS: f32 = 0.5;

/// The most finer grids below the first (radii down to 1/64 of its).
const MOST_FINER: usize = 6;

/// The most photons the finer grids hold in all, in the map's photons: the
/// example scenes' take 1.8 to 2.0 times (their caustics' photons, at up to
/// five finer radii; BENCHMARKS.md).
pub(crate) const FINER_PHOTONS: usize = 3;

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
    /// The photons of the cells here from which a query goes down (those
    /// whose cells around hold more than [`MOST_SCANNED`]: see
    /// [`near_dense_cells`]), in cells of half the radius. Where photons
    /// are dense their `k` nearest lie much nearer than the radius, and a
    /// finer grid's ball that holds `k` or more holds them all.
    finer: Option<Box<Grid>>,
}

/// What a query's ball reaches in a grid.
// (A value on the stack of one search, never stored: boxing its cells
// would allocate for every search.)
#[allow(clippy::large_enum_variant)]
enum Around {
    /// A query not a number.
    NotANumber,
    /// No photon within the grid's radius (far outside the cells, or in
    /// empty ones).
    Nothing,
    /// The ranges of the cells it reaches that hold photons, and how many
    /// photons they hold in all.
    Cells { ranges: [std::ops::Range<usize>; 27], count: usize, photons: usize },
}

impl Grid {
    /// The grid for searches up to `radius` over `positions` (their indices
    /// in the order given), or `None` if the radius is not positive and
    /// finite or the coordinates are too many cells from the origin for
    /// rounding to leave each point in its cell or the next.
    pub(super) fn new(positions: &[Vec3], radius: f32) -> Option<Grid> {
        Grid::level(positions, None, radius, 0, FINER_PHOTONS * positions.len())
    }

    /// [`Grid::new`] over `positions`, whose photons' indices are
    /// `indices` (`None`: their places in `positions`), the grid `levels`
    /// below the first, with finer grids below it of at most `budget`
    /// photons in all.
    fn level(
        positions: &[Vec3],
        indices: Option<&[u32]>,
        radius: f32,
        levels: usize,
        budget: usize,
    ) -> Option<Grid> {
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
        let mut in_cells = Vec::with_capacity(positions.len());
        let index = |i: u32| indices.map_or(i, |indices| indices[i as usize]);
        for cell in cells {
            ranges.push((cell[0].0, in_cells.len() as u32, cell.len() as u32));
            in_cells.extend(cell.iter().map(|&(_, i)| (positions[i as usize], index(i))));
        }
        let table = CellTable::new(&ranges);
        let occupied = Occupied::new(ranges.iter().map(|&(key, ..)| unkey(key)));
        let finer = (levels < MOST_FINER)
            .then(|| near_dense_cells(&ranges, &table, &in_cells))
            .filter(|(near, _)| !near.is_empty() && near.len() <= budget)
            .and_then(|(near, indices)| {
                Grid::level(&near, Some(&indices), radius * FINER_RADIUS, levels + 1, budget - near.len())
            })
            .map(Box::new);
        Some(Grid { origin, radius, inverse_edge, table, photons: in_cells, occupied, finer })
    }

    /// Whether the grid keeps a bit for each cell of the box its photons fill.
    #[cfg(test)]
    pub(super) fn keeps_occupied_bits(&self) -> bool {
        self.occupied.is_some()
    }

    /// The radius and photons of this grid and the finer ones below it,
    /// coarsest first.
    #[cfg(test)]
    pub(super) fn levels(&self) -> Vec<(f32, usize)> {
        std::iter::successors(Some(self), |grid| grid.finer.as_deref())
            .map(|grid| (grid.radius, grid.photons.len()))
            .collect()
    }

    /// Whether the cells around `q` hold too many photons to scan (finer
    /// ones, or the kd-tree, answer there).
    #[cfg(test)]
    pub(super) fn is_dense_at(&self, q: Vec3) -> bool {
        matches!(self.around(q), Around::Cells { photons, .. } if photons > MOST_SCANNED)
    }

    /// The up to `k` photons nearest `q` within `max_radius`, as (squared
    /// distance, index), nearest first; `None` when the grid cannot answer
    /// (a radius beyond the one it was made for, a query not a number, or
    /// too many photons around it, in every finer grid too).
    pub(super) fn nearest(&self, q: Vec3, k: usize, max_radius: f32) -> Option<Vec<(f32, usize)>> {
        if max_radius.is_nan() || max_radius > self.radius || k == 0 {
            return None;
        }
        let around = self.around(q);
        match &around {
            Around::NotANumber => None,
            Around::Nothing => Some(Vec::new()),
            Around::Cells { ranges, count, photons } if *photons <= MOST_SCANNED => {
                Some(runs::nearest_first(self.within(&ranges[..*count], q, max_radius), k))
            }
            Around::Cells { .. } => self.nearest_where_dense(q, k, max_radius, around),
        }
    }

    /// [`Grid::nearest`] where the cells around `q` hold too many photons
    /// to scan. The first finer grid whose cells around `q` hold few enough
    /// is scanned; if its ball around `q` holds `k` photons or more, the
    /// `k` nearest are among them (as they are if `max_radius` is within its
    /// radius: its ball is then the whole search). If it holds fewer, the
    /// grid above it (twice the radius, and likely more than `k` in its
    /// ball) is scanned, if it holds at most [`MOST_SCANNED_ABOVE`]. Else
    /// `None`: the kd-tree answers. `around`: what `q`'s ball reaches here.
    fn nearest_where_dense(
        &self,
        q: Vec3,
        k: usize,
        max_radius: f32,
        around: Around,
    ) -> Option<Vec<(f32, usize)>> {
        let mut above = (self, around);
        while let Some(grid) = above.0.finer.as_deref() {
            let around = grid.around(q);
            let Around::Cells { photons, .. } = around else { return None };
            if photons > MOST_SCANNED {
                above = (grid, around);
                continue;
            }
            for (grid, around) in [(grid, around), above] {
                let Around::Cells { ranges, count, photons } = around else { return None };
                if photons > MOST_SCANNED_ABOVE {
                    return None;
                }
                let found = grid.within(&ranges[..count], q, grid.radius.min(max_radius));
                if found.len() >= k || max_radius <= grid.radius {
                    return Some(runs::nearest_first(found, k));
                }
            }
            return None;
        }
        None
    }

    /// The cells a ball of this grid's radius around `q` reaches.
    fn around(&self, q: Vec3) -> Around {
        // A query more than a cell below every photon along an axis, or
        // thousands of cells above, has none within the radius (and the
        // cells of those far off would hash wrongly): the answer is known
        // without a search (the kd-tree's descent found nothing there).
        let g = (q - self.origin) * self.inverse_edge;
        if g.is_nan() {
            return Around::NotANumber;
        }
        if !(g.cmpge(Vec3::ONE).all() && g.cmplt(Vec3::splat(2.0 * AXIS_CELLS)).all()) {
            return Around::Nothing;
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
        let mut photons = 0;
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
                        photons += range.len();
                        ranges[count] = range;
                        count += 1;
                    }
                }
            }
        }
        if count == 0 {
            return Around::Nothing;
        }
        Around::Cells { ranges, count, photons }
    }

    /// The photons of the cells `ranges` within `radius` of `q`, as keys
    /// of their squared distance and index ([`runs::key`]).
    fn within(&self, ranges: &[std::ops::Range<usize>], q: Vec3, radius: f32) -> Vec<u64> {
        let r2 = radius * radius;
        let mut found: Vec<u64> = Vec::with_capacity(64);
        for range in ranges {
            for &(p, i) in &self.photons[range.clone()] {
                let d2 = (p - q).length_squared();
                if d2 <= r2 {
                    found.push(runs::key(d2, i as usize));
                }
            }
        }
        found
    }
}

/// The photons a finer grid needs, of a grid whose cells are `ranges`
/// (key, start, length) in `table` over `photons`: those in the cells from
/// which a query can go to the finer grid (their positions, and their
/// indices); none when no query can.
///
/// A query's ball of this grid's radius reaches its own cell and one more
/// along each axis (`REACH`; along an axis where it is within a hundredth
/// of its cell's middle, one more each way), and it goes to the finer grid
/// only if those cells hold more than [`MOST_SCANNED`] photons. The finer
/// ball, of half the radius, reaches only cells next to each of those (its
/// own, along an axis where it is near the middle), so the 27 cells around
/// each hold all of those photons: too many. Every photon the finer ball
/// can find is in such a cell, and is kept. The finer grid's cells reach
/// beyond its ball: photons there that are left out are none it could
/// find, and leaving them out of its counts only makes it the likelier to
/// answer. At the finer grid the same holds of the next (its ball's cells
/// hold all their photons, by the same reasoning a grid up).
fn near_dense_cells(
    ranges: &[(u64, u32, u32)],
    table: &CellTable,
    photons: &[(Vec3, u32)],
) -> (Vec<Vec3>, Vec<u32>) {
    use std::collections::HashSet;
    let around = |cell: IVec3| {
        (-1..=1)
            .flat_map(move |z| (-1..=1).flat_map(move |y| (-1..=1).map(move |x| cell + IVec3::new(x, y, z))))
    };
    let count = |cell: IVec3| {
        (cell.min_element() >= 0)
            .then(|| table.get(key(cell.as_uvec3())))
            .flatten()
            .map_or(0, |range| range.len())
    };
    // The cells whose 27 could hold too many: next to a heavy one.
    let heavy = ranges.iter().filter(|&&(_, _, len)| len as usize * 27 > MOST_SCANNED);
    let candidates: HashSet<IVec3> = heavy.flat_map(|&(cell, ..)| around(unkey(cell).as_ivec3())).collect();
    let keep: HashSet<u64> = candidates
        .into_iter()
        .filter(|&cell| cell.min_element() >= 0 && around(cell).map(count).sum::<usize>() > MOST_SCANNED)
        .map(|cell| key(cell.as_uvec3()))
        .collect();
    ranges
        .iter()
        .filter(|(cell, ..)| keep.contains(cell))
        .flat_map(|&(_, start, len)| &photons[start as usize..][..len as usize])
        .copied()
        .unzip()
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
