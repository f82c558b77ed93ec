//! Nearest-point search for the precomputed irradiance that final gathering
//! looks up at every gather hit: the hottest query of a photon-mapped render.
//!
//! A kd-tree specialised for that one question, "which of a few nearest
//! points", in a small fixed-size answer on the stack: balanced median splits
//! on the widest axis, the split planes in an implicit binary tree (node `i`
//! has children `2i + 1` and `2i + 2`, its points are a range found by
//! halving), and the points themselves in tree order so a leaf is a few
//! contiguous cache lines. It answers in about half the time of kiddo's
//! general `nearest_one` on the same points (BENCHMARKS.md, issue 17); the
//! photon maps' k-nearest estimates stay with kiddo.
//!
//! Ties in distance go to the point given first, so answers never depend on
//! how the tree happened to split.

use glam::Vec3;

use super::cells::Cells;
use crate::bounds::Bounds;

/// At most this many points in a leaf.
const LEAF: usize = 8;

/// Points in a kd-tree for nearest-point queries, each with a value `T`
/// kept beside it (in tree order, so reading the value of a point just found
/// touches memory near it).
pub struct PointTree<T> {
    /// The points, in tree order.
    points: Vec<Vec3>,
    /// For each point in tree order, its index in the order given.
    items: Vec<u32>,
    /// For each point in tree order, its value.
    values: Vec<T>,
    /// Per inner node (implicit numbering): the split value and its axis.
    splits: Vec<(f32, u8)>,
    /// Candidate lists per grid cell for [`PointTree::nearest_one`], if built.
    cells: Option<Cells>,
}

/// One point found: its squared distance from the query, its index in the
/// order given, and its place in the tree (for [`PointTree::value`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Found {
    /// Squared distance from the query.
    pub distance2: f32,
    /// Index of the point in the order given to [`PointTree::new`].
    pub index: u32,
    /// Where the point sits in the tree.
    pub slot: u32,
}

/// Up to `K` of the points nearest a query, nearest first.
#[derive(Debug, Clone, Copy)]
pub struct Nearest<const K: usize> {
    found: [Found; K],
    len: usize,
}

impl<const K: usize> Nearest<K> {
    fn new() -> Self {
        Nearest { found: [Found { distance2: f32::INFINITY, index: u32::MAX, slot: u32::MAX }; K], len: 0 }
    }

    /// The squared distance a point must beat to enter.
    fn bound(&self, max_distance2: f32) -> f32 {
        if self.len == K {
            self.found[K - 1].distance2
        } else {
            max_distance2
        }
    }

    /// Inserts in (distance, index) order when it belongs among the K.
    fn offer(&mut self, entry: Found) {
        let before = |a: Found, b: Found| {
            a.distance2 < b.distance2 || (a.distance2 == b.distance2 && a.index < b.index)
        };
        if self.len == K && !before(entry, self.found[K - 1]) {
            return;
        }
        let mut i = self.len.min(K - 1);
        while i > 0 && before(entry, self.found[i - 1]) {
            self.found[i] = self.found[i - 1];
            i -= 1;
        }
        self.found[i] = entry;
        self.len = (self.len + 1).min(K);
    }

    /// The points found, nearest first.
    pub fn as_slice(&self) -> &[Found] {
        &self.found[..self.len]
    }
}

impl<T: Copy> PointTree<T> {
    /// Builds the tree over `points` with their `values` (as many; fewer
    /// than 2^32), its halves in parallel: it depends only on the points and
    /// their order.
    pub fn new(points: &[Vec3], values: &[T]) -> PointTree<T> {
        assert_eq!(points.len(), values.len(), "a value per point");
        assert!(points.len() < u32::MAX as usize, "fewer than 2^32 points");
        let mut entries: Vec<Entry> = points.iter().zip(0..).map(|(&p, i)| (p, i)).collect();
        let mut splits = vec![(0.0, 0); inner_nodes(points.len())];
        for (node, split) in split(&mut entries, 0) {
            splits[node] = split;
        }
        PointTree {
            points: entries.iter().map(|e| e.0).collect(),
            values: entries.iter().map(|e| values[e.1 as usize]).collect(),
            items: entries.into_iter().map(|e| e.1).collect(),
            splits,
            cells: None,
        }
    }

    /// Lists candidates per grid cell of edge `size` so that
    /// [`PointTree::nearest_one`] answers most queries without a descent
    /// (`cells.rs`); answers stay the same. Does nothing where such cells
    /// cannot be trusted (a size tiny against the coordinates).
    pub fn list_cells(&mut self, size: f32)
    where
        T: Sync,
    {
        self.cells = None;
        self.cells =
            Cells::new(&self.points, &self.items, size, |lo, hi, inside| self.in_box(lo, hi, inside));
    }

    /// The point nearest `q`, ties to the smaller index (`None` only when
    /// there are no points): [`PointTree::nearest`] with one point and no
    /// bound, from the cell lists where they hold `q`.
    #[inline]
    pub fn nearest_one(&self, q: Vec3) -> Option<Found> {
        let Some(candidates) = self.cells.as_ref().and_then(|cells| cells.candidates(q)) else {
            return self.nearest::<1>(q, f32::INFINITY).as_slice().first().copied();
        };
        let best = super::cells::nearest_in(candidates, q);
        Some(Found { distance2: best.0, index: self.items[best.1 as usize], slot: best.1 })
    }

    /// Every point and its value, in the order given to [`PointTree::new`].
    pub fn in_given_order(&self) -> Vec<(Vec3, T)> {
        let mut slots = vec![0; self.items.len()];
        for (slot, &item) in self.items.iter().enumerate() {
            slots[item as usize] = slot;
        }
        slots.into_iter().map(|slot| (self.points[slot], self.values[slot])).collect()
    }

    /// The point in `slot` (as [`Found::slot`] gives it).
    pub fn point(&self, slot: u32) -> Vec3 {
        self.points[slot as usize]
    }

    /// The value of a point found.
    pub fn value(&self, found: &Found) -> &T {
        &self.values[found.slot as usize]
    }

    /// The value of the point in `slot` (as [`Found::slot`] gives it).
    pub fn value_in(&self, slot: u32) -> &T {
        &self.values[slot as usize]
    }

    /// The number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The up to `K` points nearest `q` within squared distance
    /// `max_distance2` (inclusive), nearest first; ties to the smaller index.
    pub fn nearest<const K: usize>(&self, q: Vec3, max_distance2: f32) -> Nearest<K> {
        let mut found = Nearest::<K>::new();
        if self.points.is_empty() || K == 0 {
            return found;
        }
        // Nodes still to visit: (node, first point, end, squared distance
        // from q to the node's side of its parent's split). Each entry is
        // from another level of the tree, which is balanced: fewer than 2^32
        // points in leaves of up to 8 make at most 29 levels. (The array is
        // zeroed on every query: 64 entries cost 7% more time than 32.)
        let mut stack = [(0u32, 0u32, 0u32, 0.0f32); 32];
        stack[0] = (0, 0, self.points.len() as u32, 0.0);
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (mut node, mut lo, mut hi, d2) = stack[depth];
            if d2 > found.bound(max_distance2) {
                continue;
            }
            while (hi - lo) as usize > LEAF {
                let mid = lo + (hi - lo) / 2;
                let (value, axis) = self.splits[node as usize];
                let diff = q[axis as usize] - value;
                let (left, right) = ((2 * node + 1, lo, mid), (2 * node + 2, mid, hi));
                let (near, far) = if diff < 0.0 { (left, right) } else { (right, left) };
                if diff * diff <= found.bound(max_distance2) {
                    stack[depth] = (far.0, far.1, far.2, diff * diff);
                    depth += 1;
                }
                (node, lo, hi) = near;
            }
            for i in lo as usize..hi as usize {
                let d2 = (self.points[i] - q).length_squared();
                if d2 <= found.bound(max_distance2) {
                    found.offer(Found { distance2: d2, index: self.items[i], slot: i as u32 });
                }
            }
        }
        found
    }

    /// The slots of every point in the box from `lo` to `hi` (inclusive),
    /// into `inside` (cleared first).
    fn in_box(&self, lo: Vec3, hi: Vec3, inside: &mut Vec<u32>) {
        inside.clear();
        if self.points.is_empty() {
            return;
        }
        // (node, first point, end); at most one entry per level waits, and
        // there are at most 29 levels (as in `nearest`).
        let mut stack = [(0usize, 0usize, 0usize); 32];
        stack[0] = (0, 0, self.points.len());
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (mut node, mut first, mut end) = stack[depth];
            while end - first > LEAF {
                let mid = first + (end - first) / 2;
                let (value, axis) = self.splits[node];
                let (left, right) = ((2 * node + 1, first, mid), (2 * node + 2, mid, end));
                // The left half's points are at most the split value, the
                // right half's at least it.
                match (lo[axis as usize] <= value, hi[axis as usize] >= value) {
                    (true, true) => {
                        stack[depth] = right;
                        depth += 1;
                        (node, first, end) = left;
                    }
                    (true, false) => (node, first, end) = left,
                    (false, true) => (node, first, end) = right,
                    (false, false) => break,
                }
            }
            if end - first <= LEAF {
                // Without a branch per point (inside or not is as good as a
                // coin toss at the box's faces): every point is written past
                // the last one inside, and that end moves past those inside.
                // (`n <= i < LEAF`, so `n % LEAF` is `n`: no bounds check.)
                let mut leaf = [0u32; LEAF];
                let mut n = 0;
                for (i, &p) in self.points[first..end].iter().enumerate() {
                    leaf[n % LEAF] = (first + i) as u32;
                    n += usize::from((p.cmpge(lo) & p.cmple(hi)).all());
                }
                inside.extend_from_slice(&leaf[..n]);
            }
        }
    }
}

/// The number of inner nodes of the implicit tree over `n` points: the
/// largest node number used, plus one.
fn inner_nodes(n: usize) -> usize {
    fn largest(node: usize, n: usize) -> usize {
        if n <= LEAF {
            return 0;
        }
        let half = n / 2;
        (node + 1).max(largest(2 * node + 1, half)).max(largest(2 * node + 2, n - half))
    }
    largest(0, n)
}

/// A point with its index in the order given, as the build moves them.
type Entry = (Vec3, u32);

/// Points from which a subtree's two halves are built in parallel.
const PARALLEL_FROM: usize = 4096;

/// Splits `entries` (points with their index) at the median of their
/// widest axis, ties by index, and recurses into both halves (in parallel
/// when large); returns every split made, with its node. The points move
/// with their index (no indirection), so the median selection reads
/// contiguous memory.
fn split(entries: &mut [Entry], node: usize) -> Vec<(usize, (f32, u8))> {
    let mut splits = Vec::new();
    if entries.len() >= PARALLEL_FROM {
        let (here, left, right) = split_once(entries);
        let (left, right) = rayon::join(|| split(left, 2 * node + 1), || split(right, 2 * node + 2));
        splits.push((node, here));
        splits.extend(left);
        splits.extend(right);
    } else {
        split_serially(entries, node, &mut splits);
    }
    splits
}

/// [`split`] on one thread, the splits pushed onto `splits`.
fn split_serially(entries: &mut [Entry], node: usize, splits: &mut Vec<(usize, (f32, u8))>) {
    if entries.len() <= LEAF {
        return;
    }
    let (here, left, right) = split_once(entries);
    splits.push((node, here));
    split_serially(left, 2 * node + 1, splits);
    split_serially(right, 2 * node + 2, splits);
}

/// Splits `entries` (more than [`LEAF`]) at the median of their widest
/// axis, ties by index: the split (value and axis) and the two halves.
fn split_once(entries: &mut [Entry]) -> ((f32, u8), &mut [Entry], &mut [Entry]) {
    let axis = entries.iter().fold(Bounds::EMPTY, |b, e| b.grow(e.0)).widest_axis();
    let mid = entries.len() / 2;
    entries.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]).then(a.1.cmp(&b.1)));
    let here = (entries[mid].0[axis], axis as u8);
    let (left, right) = entries.split_at_mut(mid);
    (here, left, right)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// The `k` nearest by brute force: (squared distance, index), ties by index.
    fn brute(points: &[Vec3], q: Vec3, k: usize, max_d2: f32) -> Vec<(f32, u32)> {
        let mut all: Vec<(f32, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| ((*p - q).length_squared(), i as u32))
            .filter(|&(d2, _)| d2 <= max_d2)
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        all.truncate(k);
        all
    }

    #[test]
    fn the_tree_does_not_depend_on_the_threads() {
        let mut rng = Rng::new(6, 2);
        let points: Vec<Vec3> = (0..50_000).map(|_| Vec3::new(rng.uniform(), 0.0, rng.uniform())).collect();
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| PointTree::new(&points, &points))
        };
        let (one, two) = (build(1), build(2));
        assert_eq!((&one.points, &one.items, &one.values), (&two.points, &two.items, &two.values));
        assert_eq!(one.splits, two.splits);
    }

    /// Points on the faces of a unit box (many sharing a coordinate
    /// exactly, as photons on a floor do), on a lattice on the floor (equal
    /// distances), some twice, scaled by `scale` and moved by `offset`.
    fn on_faces(n: usize, rng: &mut Rng, scale: f32, offset: Vec3) -> Vec<Vec3> {
        let mut points: Vec<Vec3> = (0..n)
            .map(|i| {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                let p = match i % 4 {
                    0 => Vec3::new(p.x, 0.0, p.z),
                    1 => Vec3::new(1.0, p.y, p.z),
                    2 => Vec3::new((i / 4 % 20) as f32 / 20.0, 0.0, (i / 80 % 20) as f32 / 20.0),
                    _ => p,
                };
                p * scale + offset
            })
            .collect();
        points[n - 1] = points[7];
        points
    }

    #[test]
    fn the_cells_answer_as_the_tree() {
        let mut rng = Rng::new(9, 3);
        // Cells of about two points' spacing on the floor (0.05), and cells
        // so large that few lists are short enough to keep.
        for (scale, offset, size) in [
            (1.0, Vec3::ZERO, 0.05),
            (1.0, Vec3::ZERO, 0.12),
            (1.0, Vec3::splat(-3.0), 0.3),
            (1e-6, Vec3::splat(1e-6), 0.05e-6),
            (1e4, Vec3::new(2e4, 0.0, -1e4), 0.05e4),
        ] {
            let points = on_faces(6000, &mut rng, scale, offset);
            let mut tree = PointTree::new(&points, &points);
            tree.list_cells(size);
            assert!(tree.cells.is_some(), "cells at scale {scale}");
            let mut from_cells = 0;
            for j in 0..20_000 {
                let q = match j % 5 {
                    // At a point, at the middle of lattice points (ties), on
                    // a face, anywhere near the box, far off.
                    0 => points[j % points.len()],
                    1 => Vec3::new((j % 20) as f32 + 0.5, 0.0, (j / 20 % 20) as f32) / 20.0 * scale + offset,
                    2 => Vec3::new(rng.uniform(), 0.0, rng.uniform()) * scale + offset,
                    3 => {
                        (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2 - 0.1) * scale + offset
                    }
                    _ => Vec3::splat(rng.uniform() * 50.0) * scale + offset,
                };
                let tree_says = tree.nearest::<1>(q, f32::INFINITY).as_slice()[0];
                assert_eq!(tree.nearest_one(q), Some(tree_says), "q {q} at scale {scale}, cell size {size}");
                from_cells += tree.cells.as_ref().unwrap().candidates(q).is_some() as usize;
            }
            // At two spacings, most queries but those off the faces are
            // answered from the cells.
            if size == 0.05 * scale {
                assert!(from_cells > 12_000, "{from_cells} of 20000 from the cells at scale {scale}");
            }
        }
        // No points, and a query that is not a number.
        let mut empty = PointTree::<Vec3>::new(&[], &[]);
        empty.list_cells(0.1);
        assert_eq!(empty.nearest_one(Vec3::ZERO), None);
        let mut tree = PointTree::new(&[Vec3::ZERO], &[0]);
        tree.list_cells(0.1);
        assert_eq!(tree.nearest_one(Vec3::NAN), None);
    }

    #[test]
    fn no_cells_where_rounding_could_misplace_a_query() {
        let mut rng = Rng::new(9, 4);
        // Cells a ten-thousandth of the coordinates, and sizes that are no size.
        let points = on_faces(100, &mut rng, 1.0, Vec3::splat(1e4));
        for size in [1.0, 0.0, -1.0, f32::NAN, f32::INFINITY] {
            let mut tree = PointTree::new(&points, &points);
            tree.list_cells(size);
            assert!(tree.cells.is_none(), "size {size}");
            assert_eq!(tree.nearest_one(points[3]).unwrap().distance2, 0.0);
        }
    }

    #[test]
    fn the_cells_do_not_depend_on_the_threads() {
        let mut rng = Rng::new(9, 5);
        let points = on_faces(20_000, &mut rng, 1.0, Vec3::ZERO);
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut tree = PointTree::new(&points, &points);
                tree.list_cells(0.08);
                tree.cells.unwrap().listed()
            })
        };
        let one = build(1);
        assert!(one.len() > 100);
        assert_eq!(one, build(2));
    }

    #[test]
    fn a_box_holds_what_brute_force_finds() {
        // Points on a plane (many on a box's face exactly) and in a volume;
        // boxes from empty to all, and leaves whose points are all inside,
        // none or some (the leaf scan writes every point, keeping those in).
        let mut rng = Rng::new(8, 3);
        for n in [0usize, 1, 8, 9, 100, 5000] {
            let points: Vec<Vec3> = (0..n)
                .map(|i| match i % 2 {
                    0 => Vec3::new((i % 20) as f32 * 0.05, 0.0, (i / 20 % 20) as f32 * 0.05),
                    _ => Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()),
                })
                .collect();
            let tree = PointTree::new(&points, &vec![(); n]);
            let mut inside = vec![7];
            for j in 0..100 {
                let (a, b) = (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()), Vec3::splat(0.05));
                let (lo, hi) = match j % 4 {
                    0 => (Vec3::splat(-1.0), Vec3::splat(2.0)),
                    1 => (a, a - b),
                    2 => (Vec3::new(0.25, 0.0, 0.25), Vec3::new(0.5, 0.0, 0.5)),
                    _ => (a - b * (j % 7) as f32, a + b * (j % 5) as f32),
                };
                tree.in_box(lo, hi, &mut inside);
                let mut found: Vec<u32> = inside.iter().map(|&slot| tree.items[slot as usize]).collect();
                found.sort_unstable();
                let brute: Vec<u32> = (0..n as u32)
                    .filter(|&i| points[i as usize].cmpge(lo).all() && points[i as usize].cmple(hi).all())
                    .collect();
                assert_eq!(found, brute, "n {n}, box {lo} to {hi}");
            }
        }
    }

    #[test]
    fn finds_what_brute_force_finds() {
        let mut rng = Rng::new(5, 1);
        // (From 4096 points the halves are built in parallel.)
        for n in [0usize, 1, 7, 8, 9, 17, 100, 3000, 10_000] {
            // Points on the faces of a box, many sharing a coordinate exactly
            // (as photons on a floor do), and some exact duplicates.
            let mut points: Vec<Vec3> = (0..n)
                .map(|i| {
                    let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                    match i % 3 {
                        0 => Vec3::new(p.x, 0.0, p.z),
                        1 => Vec3::new(1.0, p.y, p.z),
                        _ => p,
                    }
                })
                .collect();
            if n > 10 {
                points[n - 1] = points[3];
                points[n - 2] = points[3];
            }
            let tree = PointTree::new(&points, &points);
            assert_eq!(tree.len(), n);
            let given: Vec<(Vec3, Vec3)> = points.iter().map(|&p| (p, p)).collect();
            assert_eq!(tree.in_given_order(), given);
            for j in 0..200 {
                let q = if j % 4 == 0 && n > 0 {
                    points[j % n]
                } else {
                    Vec3::new(rng.uniform() * 1.2 - 0.1, rng.uniform() * 0.2, rng.uniform())
                };
                let max_d2 = if j % 2 == 0 { f32::INFINITY } else { 0.01 };
                for k in [1, 8] {
                    let found: Vec<(f32, u32)> = match k {
                        1 => tree
                            .nearest::<1>(q, max_d2)
                            .as_slice()
                            .iter()
                            .map(|f| (f.distance2, f.index))
                            .collect(),
                        _ => tree
                            .nearest::<8>(q, max_d2)
                            .as_slice()
                            .iter()
                            .map(|f| (f.distance2, f.index))
                            .collect(),
                    };
                    assert_eq!(found, brute(&points, q, k, max_d2), "n {n} q {q} k {k}");
                    // Each point found carries its own value.
                    for f in match k {
                        1 => tree.nearest::<1>(q, max_d2).as_slice().to_vec(),
                        _ => tree.nearest::<8>(q, max_d2).as_slice().to_vec(),
                    } {
                        assert_eq!(*tree.value(&f), points[f.index as usize]);
                    }
                }
            }
        }
    }
}
