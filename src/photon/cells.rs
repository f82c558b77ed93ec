//! Candidate lists per grid cell: the exact nearest point to most queries
//! in one hash probe and a short scan in SIMD lanes, instead of a kd-tree
//! descent.
//!
//! Final gathering looks up the nearest precomputed irradiance record at
//! every gather hit, the largest share of a photon-mapped render
//! (BENCHMARKS.md, issue 17). Gather hits land on the surfaces the records
//! lie on, so cells of a uniform grid that hold records answer most of
//! them.
//!
//! Each listed cell keeps every point that can be the nearest to a query in
//! it. Let `U` be the largest distance from some point `r` to the cell (at
//! a corner: distance is convex). A query `q` in the cell has its nearest
//! point within `|q - r| <= U`, so that point lies within `U` of the cell's
//! box: those are the candidates, with `r` the one that makes `U` least.
//! Of them, a point that another is nearer than everywhere in the box is
//! dropped (the difference of two squared distances is affine in `q`, so
//! its least over the box has a closed form). The answer is then the one
//! the kd-tree gives, to the bit: the same squared distances, in the same
//! order of operations, ties to the smaller index. The boxes, `U` and the
//! test of being beaten are widened by margins beyond what rounding in a
//! query's `f32` arithmetic can move.
//!
//! Queries outside the listed cells (none of the points in them, or lists
//! that would be long) go to the kd-tree.

use glam::{DVec3, Vec3, Vec4};
use rayon::prelude::*;

use crate::bounds::Bounds;

use super::cell_table::{key, points_by_cell, unkey, CellTable, KEY_AXIS_CELLS};

/// A cell is listed only if this many points or fewer can be its nearest.
const LONGEST_LIST: usize = 96;

/// How many of the points nearest a cell's centre are tried as beating
/// each other point everywhere in the cell.
const DOMINATORS: usize = 8;

/// Candidate lists per cell for the points of a
/// [`PointTree`](super::nearest::PointTree), by their slot in it.
pub(super) struct Cells {
    origin: Vec3,
    /// One over the cell's edge.
    inverse_size: f32,
    /// Each listed cell's range in `candidates`.
    table: CellTable,
    /// Per listed cell, its points by index (the order given to the tree),
    /// four to a group, the last group's spare lanes infinitely far.
    candidates: Vec<Group>,
}

/// Four candidates side by side, for distances in SIMD lanes: one cache line.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Group {
    x: Vec4,
    y: Vec4,
    z: Vec4,
    slots: [u32; 4],
}

impl Group {
    /// The group of up to four points, as (index, position, slot).
    fn new(points: &[(u32, Vec3, u32)]) -> Group {
        let lane = |i: usize| points.get(i).map_or((Vec3::INFINITY, u32::MAX), |&(_, p, slot)| (p, slot));
        let [a, b, c, d] = [lane(0), lane(1), lane(2), lane(3)];
        Group {
            x: Vec4::new(a.0.x, b.0.x, c.0.x, d.0.x),
            y: Vec4::new(a.0.y, b.0.y, c.0.y, d.0.y),
            z: Vec4::new(a.0.z, b.0.z, c.0.z, d.0.z),
            slots: [a.1, b.1, c.1, d.1],
        }
    }
}

/// The candidate nearest `q` in `groups` and its squared distance
/// (`(p - q).length_squared()` to the bit, in the same order of operations),
/// ties to the earliest.
#[inline]
pub(super) fn nearest_in(groups: &[Group], q: Vec3) -> (f32, u32) {
    let (qx, qy, qz) = (Vec4::splat(q.x), Vec4::splat(q.y), Vec4::splat(q.z));
    let mut best = Vec4::INFINITY;
    let mut at = Vec4::ZERO;
    let mut here = Vec4::new(0.0, 1.0, 2.0, 3.0);
    for g in groups {
        let (dx, dy, dz) = (g.x - qx, g.y - qy, g.z - qz);
        let d2 = dx * dx + dy * dy + dz * dz;
        let closer = d2.cmplt(best);
        best = Vec4::select(closer, d2, best);
        at = Vec4::select(closer, here, at);
        here += Vec4::splat(4.0);
    }
    let (mut d2, mut i) = (best.x, at.x);
    for (lane_d2, lane_at) in [(best.y, at.y), (best.z, at.z), (best.w, at.w)] {
        if lane_d2 < d2 || (lane_d2 == d2 && lane_at < i) {
            (d2, i) = (lane_d2, lane_at);
        }
    }
    let i = i as usize;
    (d2, groups[i / 4].slots[i % 4])
}

impl Cells {
    /// Lists cells of edge `size` over `points` (in the tree's slot order,
    /// `index[slot]` the order given): every cell holding a point. `in_box`
    /// finds the slots of the points in a box (`lo`, `hi`, into a buffer it
    /// clears first). `None` when there is no grid worth having: no points,
    /// a size that is not positive and finite, cells so small against the
    /// coordinates that rounding could move a query out of its cell, or
    /// coordinates whose squares would leave `f32`'s normal range. The cells
    /// and lists depend only on the points, not on the threads.
    pub(super) fn new(
        points: &[Vec3],
        index: &[u32],
        size: f32,
        in_box: impl Fn(Vec3, Vec3, &mut Vec<u32>) + Sync,
    ) -> Option<Cells> {
        if points.is_empty() || !(size.is_finite() && size > 0.0) {
            return None;
        }
        let Bounds { min: lo, max: hi } = Bounds::of(points);
        let largest = lo.abs().max(hi.abs()).max_element();
        // With cells of at least a thousandth of the coordinates, the grid
        // spans a few thousand cells (far fewer than a key can tell apart),
        // and rounding misplaces a query by at most a few ten-thousandths of
        // one: within the thousandth `Cell` widens by. Squared distances
        // stay normal and finite.
        if !(largest.is_finite() && largest <= 1e15) || size < 1e-3 * largest || size < 1e-12 {
            return None;
        }
        let origin = lo - Vec3::splat(size);
        let inverse_size = 1.0 / size;
        let in_cells = points_by_cell(points, origin, inverse_size);
        let cells: Vec<&[(u64, u32)]> = in_cells.chunk_by(|a, b| a.0 == b.0).collect();
        let lists: Vec<Vec<Group>> = cells
            .par_iter()
            .map_init(
                || (Vec::new(), Vec::new()),
                |(boxed, near), cell| {
                    let corner = origin + unkey(cell[0].0).as_vec3() * size;
                    let slots = cell.iter().map(|&(_, slot)| slot);
                    // (The closure written in the call, where it is known
                    // to run once, may lend out the buffer it fills.)
                    Cell::new(corner, size, largest).candidates(
                        points,
                        index,
                        slots,
                        |lo, hi| {
                            in_box(lo, hi, boxed);
                            boxed.as_slice()
                        },
                        near,
                    )
                },
            )
            .collect();

        let mut ranges = Vec::new();
        let mut candidates = Vec::with_capacity(lists.iter().map(Vec::len).sum());
        for (cell, list) in cells.iter().zip(&lists) {
            if !list.is_empty() {
                ranges.push((cell[0].0, candidates.len() as u32, list.len() as u32));
                candidates.extend_from_slice(list);
            }
        }
        let table = CellTable::new(&ranges);
        Some(Cells { origin, inverse_size, table, candidates })
    }

    /// The candidates for a query at `q` (positions and slots, by index), or
    /// `None` when its cell is not listed.
    #[inline]
    pub(super) fn candidates(&self, q: Vec3) -> Option<&[Group]> {
        let g = (q - self.origin) * self.inverse_size;
        // (Also false for NaN.)
        if !(g.cmpge(Vec3::ZERO).all() && g.cmplt(Vec3::splat(KEY_AXIS_CELLS as f32)).all()) {
            return None;
        }
        self.table.get(key(g.as_uvec3())).map(|range| &self.candidates[range])
    }

    /// Every listed cell's key and its candidates' slots, in table order.
    #[cfg(test)]
    pub(super) fn listed(&self) -> Vec<(u64, Vec<u32>)> {
        let slots =
            |range: std::ops::Range<usize>| self.candidates[range].iter().flat_map(|g| g.slots).collect();
        self.table.cells().into_iter().map(|(key, range)| (key, slots(range))).collect()
    }
}

/// One cell's box, widened a little beyond its edges so that a query that
/// rounding puts in it lies in the box.
struct Cell {
    lo: Vec3,
    hi: Vec3,
    /// More than twice what rounding can change a squared distance by, in
    /// a query's `f32` arithmetic near the box.
    margin2: f32,
}

impl Cell {
    /// The cell from `corner` to `corner + size`, among points whose
    /// coordinates are at most `largest` in magnitude (`size` at least a
    /// thousandth of it: [`Cells::new`]).
    fn new(corner: Vec3, size: f32, largest: f32) -> Cell {
        let slack = Vec3::splat(1e-3 * size);
        // A difference of coordinates is off by at most an ulp of the
        // largest (2^-23 of it), a squared distance of a few cells' length
        // by some such ulps times that length, and a thousandth of a cell
        // squared beyond.
        let ulp = largest * f32::EPSILON;
        Cell {
            lo: corner - slack,
            hi: corner + Vec3::splat(size) + slack,
            margin2: 1e-3 * size * size + 64.0 * size * ulp,
        }
    }

    /// The largest squared distance from `p` to the box (at a corner), and
    /// a margin for rounding.
    fn reach2(&self, p: Vec3) -> f32 {
        (p - self.lo).abs().max((p - self.hi).abs()).length_squared() * 1.002 + self.margin2
    }

    /// The squared distance from `p` to the box (0 inside).
    fn distance2(&self, p: Vec3) -> f32 {
        (self.lo - p).max(p - self.hi).max(Vec3::ZERO).length_squared()
    }

    /// The points that can be nearest to a query in the box, by index, in
    /// groups of four (none when more than [`LONGEST_LIST`]): those within
    /// reach of the box from the points `inside` it or near it (see the
    /// module's comment), less those another point is nearer than everywhere
    /// in it. `in_box(lo, hi)` gives the slots of the points in a box.
    /// `near` is a buffer reused from cell to cell: with three passes over
    /// the points in the box instead of six, one buffer instead of four
    /// vectors made a cell, and `in_box`'s leaves scanned without a branch,
    /// the lists build in a quarter less time (BENCHMARKS.md).
    fn candidates<'a>(
        &self,
        points: &[Vec3],
        index: &[u32],
        inside: impl Iterator<Item = u32>,
        in_box: impl FnOnce(Vec3, Vec3) -> &'a [u32],
        near: &mut Vec<(u64, Vec3, u32)>,
    ) -> Vec<Group> {
        let centre = 0.5 * (self.lo + self.hi);
        let reach2 = inside.map(|slot| self.reach2(points[slot as usize])).fold(f32::INFINITY, f32::min);
        let reach = Vec3::splat(reach2.sqrt() * 1.001);
        // Each point within reach, keyed by its squared distance to the
        // centre, then slot (for floats not negative, the bits order as the
        // values): only a point nearer the centre can be nearer than another
        // everywhere in the box. A point outside the cell may reach all of
        // it sooner, which narrows the reach.
        near.clear();
        let mut narrowed2 = reach2;
        for &slot in in_box(self.lo - reach, self.hi + reach) {
            let p = points[slot as usize];
            if self.distance2(p) <= reach2 {
                narrowed2 = narrowed2.min(self.reach2(p));
                let key = u64::from((p - centre).length_squared().to_bits()) << 32 | u64::from(slot);
                near.push((key, p, slot));
            }
        }
        near.retain(|&(_, p, _)| self.distance2(p) <= narrowed2);
        // The few nearest the centre first, in order.
        if near.len() > DOMINATORS {
            near.select_nth_unstable_by_key(DOMINATORS, |entry| entry.0);
        }
        let dominators = DOMINATORS.min(near.len());
        near[..dominators].sort_unstable_by_key(|entry| entry.0);
        // Only the few nearest the centre are tried as beating the others:
        // they beat almost all that are beaten, and a point kept that could
        // go costs a lane, never an answer. `d` is nearer than `p` everywhere
        // in the box when `|q - p|^2 - |q - d|^2`, affine in `q` with
        // gradient `2 (d - p)`, is positive at its least over the box: its
        // value at the centre less `2 h . |d - p|` (`h` the half edges).
        // In f64 and by a margin, so that rounding in a query cannot
        // disagree.
        let (lo, hi) = (self.lo.as_dvec3(), self.hi.as_dvec3());
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let margin = f64::from(self.margin2);
        let exact = |p: Vec3| (p.as_dvec3(), (p.as_dvec3() - mid).length_squared());
        let mut ahead = [(DVec3::ZERO, 0.0); DOMINATORS];
        for (slot, &(_, p, _)) in ahead.iter_mut().zip(&near[..dominators]) {
            *slot = exact(p);
        }
        let beaten = |(p, p_centre2): (DVec3, f64), (d, d_centre2): (DVec3, f64)| {
            p_centre2 - d_centre2 - 2.0 * half.dot((d - p).abs()) > margin
        };
        let mut list: Vec<(u32, Vec3, u32)> = Vec::new();
        for (i, &(_, p, slot)) in near.iter().enumerate() {
            let exact_p = exact(p);
            if !ahead[..i.min(dominators)].iter().any(|&d| beaten(exact_p, d)) {
                if list.len() == LONGEST_LIST {
                    return Vec::new();
                }
                list.push((index[slot as usize], p, slot));
            }
        }
        list.sort_unstable_by_key(|&(by_index, _, _)| by_index);
        list.chunks(4).map(Group::new).collect()
    }
}
