//! Grid cells by key in an open-addressing hash table, for the two grids
//! over photons and records (`grid.rs`, `cells.rs`): each cell's key maps
//! to the range of its contents in an array the grid keeps.

use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// Cells per axis that a key can tell apart (21 bits each).
pub(super) const KEY_AXIS_CELLS: u32 = 1 << 21;

const EMPTY: u64 = u64::MAX;

/// One cell: its key and its contents' range.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    key: u64,
    start: u32,
    len: u32,
}

/// Cells' ranges by key; a power of two long, at most half full.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct CellTable {
    entries: Vec<Entry>,
}

impl CellTable {
    /// The table of `cells`, as (key, start, length); keys unique.
    pub(super) fn new(cells: &[(u64, u32, u32)]) -> CellTable {
        let mut entries =
            vec![Entry { key: EMPTY, start: 0, len: 0 }; (2 * cells.len()).next_power_of_two().max(2)];
        let mask = entries.len() - 1;
        for &(key, start, len) in cells {
            let mut at = hash(key) & mask;
            while entries[at].key != EMPTY {
                at = (at + 1) & mask;
            }
            entries[at] = Entry { key, start, len };
        }
        CellTable { entries }
    }

    /// The range of the cell with this key, if listed.
    #[inline]
    pub(super) fn get(&self, key: u64) -> Option<std::ops::Range<usize>> {
        let mask = self.entries.len() - 1;
        let mut at = hash(key) & mask;
        loop {
            let entry = self.entries[at];
            if entry.key == key {
                return Some(entry.start as usize..(entry.start + entry.len) as usize);
            }
            if entry.key == EMPTY {
                return None;
            }
            at = (at + 1) & mask;
        }
    }

    /// Every cell's key and range, in table order.
    #[cfg(test)]
    pub(super) fn cells(&self) -> Vec<(u64, std::ops::Range<usize>)> {
        let listed = self.entries.iter().filter(|e| e.key != EMPTY);
        listed.map(|e| (e.key, e.start as usize..(e.start + e.len) as usize)).collect()
    }
}

/// Each point's cell key, with the point's index, in key order (then by
/// index): the cells of edge `1 / inverse_edge` from `origin` (below every
/// point). Made in parallel; the pairs are unique, so their order is the
/// same whatever the threads.
pub(super) fn points_by_cell(points: &[Vec3], origin: Vec3, inverse_edge: f32) -> Vec<(u64, u32)> {
    let mut keyed: Vec<(u64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, &p)| (key(((p - origin) * inverse_edge).floor().as_uvec3()), i as u32))
        .collect();
    keyed.par_sort_unstable();
    keyed
}

/// A cell's key (each coordinate below [`KEY_AXIS_CELLS`]).
pub(super) fn key(cell: UVec3) -> u64 {
    cell.x as u64 | (cell.y as u64) << 21 | (cell.z as u64) << 42
}

/// The cell of a key.
pub(super) fn unkey(k: u64) -> UVec3 {
    let mask = (1 << 21) - 1;
    UVec3::new((k & mask) as u32, (k >> 21 & mask) as u32, (k >> 42 & mask) as u32)
}

/// Spreads a key's bits over the table (a multiplicative hash, top bits).
fn hash(k: u64) -> usize {
    (k.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as usize
}
