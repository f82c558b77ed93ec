//! The native intersector: a bounding volume hierarchy in pure Rust.
//!
//! - Build: binned surface area heuristic (SAH) over triangle centroids,
//!   12 bins on each axis, down to leaves of at most four triangles,
//!   subtrees built in parallel with rayon; the binary tree is then
//!   collapsed into nodes of up to eight children (like Embree's BVH8),
//!   opening the child of largest area first, large subtrees in parallel
//!   into their own parts of the node and leaf arrays (the same arrays
//!   whatever the threads).
//! - Layout: 256-byte nodes holding their eight children's boxes side by
//!   side, so one ray tests them four at a time in SIMD lanes; leaves
//!   holding their four triangles' vertices side by side (like Embree's
//!   `triangle4v`); both depth-first.
//! - Traversal: the children a ray enters, nearest first (by entry
//!   distance); slab tests widened by a floating-point error bound so no ray
//!   slips past a box it touches.
//! - Triangles: the watertight test of Woop, Benthin and Wald (JCGT 2013),
//!   a leaf's four at once, so rays through shared edges and vertices of a
//!   closed mesh never leak.
//!
//! Hits are reported exactly as Embree reports them (see [`Hit`]).

use std::ops::{Mul, Sub};

use glam::{UVec3, Vec3, Vec3A, Vec4};
use rayon::prelude::*;

use super::embree::TriangleView;
use super::{Hit, Intersector, Ray};
use crate::bounds::Bounds;

/// Most triangles in one leaf.
const MAX_LEAF: usize = 4;
/// SAH bins per axis.
const BINS: usize = 12;
/// Subtrees with more triangles than this are built on another thread.
const PARALLEL_BUILD: usize = 16 * 1024;
/// `gamma(3)` of Pharr et al.: the relative error bound of three rounded operations.
const GAMMA3: f32 = 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Children per node.
const WIDTH: usize = 8;
/// Groups of four children, one SIMD register per axis and bound each.
const GROUPS: usize = WIDTH / 4;

/// A node of up to eight children (256 bytes): their boxes as one lane per
/// child in groups of four, and for each child either an interior node or a
/// leaf's triangles.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    /// Per group of four children, per axis, the children's lower bounds.
    min: [[Vec4; 3]; GROUPS],
    /// Per group of four children, per axis, the children's upper bounds.
    max: [[Vec4; 3]; GROUPS],
    /// Per child: an interior child's node index, or a leaf's index.
    child: [u32; WIDTH],
    /// Per child: triangles in a leaf, 0 for an interior node.
    count: [u16; WIDTH],
    /// Children in use (the first ones); the other lanes are never entered.
    children: u8,
}

impl Node {
    /// A node with no children, whose lanes no ray enters.
    const UNUSED: Node = Node {
        min: [[Vec4::INFINITY; 3]; GROUPS],
        max: [[Vec4::NEG_INFINITY; 3]; GROUPS],
        child: [0; WIDTH],
        count: [0; WIDTH],
        children: 0,
    };
}

/// A triangle as the build reads it, vertices inline.
#[derive(Debug, Clone, Copy)]
struct Triangle {
    v: [Vec3; 3],
    geom_id: u32,
    prim_id: u32,
}

/// A leaf's triangles (up to four) side by side, one per SIMD lane, so a
/// ray's edge functions for all of them take one pass (176 bytes).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Leaf {
    /// Per vertex, per axis, one lane per triangle.
    v: [[Vec4; 3]; 3],
    geom_id: [u32; MAX_LEAF],
    prim_id: [u32; MAX_LEAF],
}

impl Leaf {
    /// No triangles.
    const EMPTY: Leaf = Leaf { v: [[Vec4::ZERO; 3]; 3], geom_id: [0; MAX_LEAF], prim_id: [0; MAX_LEAF] };

    /// The leaf holding `triangles` (at most four; unused lanes are zero
    /// and never tested).
    fn new(triangles: impl Iterator<Item = Triangle>) -> Leaf {
        let mut leaf = Leaf::EMPTY;
        for (lane, triangle) in triangles.enumerate() {
            for (vertex, v) in triangle.v.iter().enumerate() {
                for axis in 0..3 {
                    leaf.v[vertex][axis][lane] = v[axis];
                }
            }
            leaf.geom_id[lane] = triangle.geom_id;
            leaf.prim_id[lane] = triangle.prim_id;
        }
        leaf
    }

    /// The vertices of the triangle in `lane`.
    fn vertices(&self, lane: usize) -> [Vec3; 3] {
        self.v.map(|v| Vec3::new(v[0][lane], v[1][lane], v[2][lane]))
    }
}

/// A triangle during the build: its bounds, and where it came from (its
/// mesh and its index there); 32 bytes.
#[derive(Debug, Clone, Copy)]
struct BuildItem {
    /// The triangle's box, in `Vec3`s: 32 bytes an item where `Aabb` and a
    /// stored centroid took 64, and the build's passes over the items (two
    /// a level) are bound by memory.
    min: Vec3,
    max: Vec3,
    geom_id: u32,
    prim_id: u32,
}

const _: () = assert!(std::mem::size_of::<BuildItem>() == 32);

impl BuildItem {
    #[inline]
    fn bounds(&self) -> Aabb {
        Aabb { min: self.min.into(), max: self.max.into() }
    }

    /// The centre of the box, which the SAH bins sort by.
    #[inline]
    fn centroid(&self) -> Vec3A {
        let b = self.bounds();
        0.5 * (b.min + b.max)
    }
}

/// The binary tree before it is collapsed into nodes of eight.
enum BuildNode {
    Leaf {
        bounds: Bounds,
        first: usize,
        count: usize,
    },
    Interior {
        bounds: Bounds,
        children: Box<[BuildNode; 2]>,
        /// Nodes of eight this subtree collapses into, so the collapse can
        /// hand each subtree its own part of the node array in parallel.
        collapsed: usize,
        /// Leaves under this node, for the same reason.
        leaves: usize,
    },
}

impl BuildNode {
    fn interior(bounds: Bounds, children: [BuildNode; 2]) -> BuildNode {
        let (lanes, used) = lanes(&children);
        let collapsed = 1 + lanes[..used].iter().map(|lane| lane.collapsed()).sum::<usize>();
        let leaves = children.iter().map(BuildNode::leaves).sum();
        BuildNode::Interior { bounds, children: Box::new(children), collapsed, leaves }
    }

    /// Leaves in this subtree.
    fn leaves(&self) -> usize {
        match self {
            BuildNode::Leaf { .. } => 1,
            BuildNode::Interior { leaves, .. } => *leaves,
        }
    }

    fn bounds(&self) -> Bounds {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Interior { bounds, .. } => *bounds,
        }
    }

    /// Nodes of eight under this one as a child: none for a leaf.
    fn collapsed(&self) -> usize {
        match self {
            BuildNode::Leaf { .. } => 0,
            BuildNode::Interior { collapsed, .. } => *collapsed,
        }
    }
}

/// Memory and shape of a built BVH, for benchmarks and `info`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BvhStats {
    /// Nodes in the tree.
    pub nodes: usize,
    /// Triangles stored (degenerate ones are kept and never hit).
    pub triangles: usize,
    /// Bytes of nodes plus leaves (the triangles copied into them).
    pub bytes: usize,
    /// Longest root-to-leaf path.
    pub depth: usize,
}

/// The native BVH over a set of triangle meshes.
pub struct Bvh {
    nodes: Vec<Node>,
    /// Leaves in depth-first order; a node's leaf lane holds its index.
    leaves: Vec<Leaf>,
}

impl Bvh {
    /// Builds a BVH over `meshes`; mesh `i` gets geometry id `i`, as in Embree.
    /// Indices must be in range (the Embree wrapper checks the same input).
    pub fn build(meshes: &[TriangleView<'_>]) -> Bvh {
        // The triangles are read from the meshes where they are (no copy
        // of them all: fresh memory costs about 3 us a page here).
        let triangle = |geom_id: u32, prim_id: u32| {
            let mesh = &meshes[geom_id as usize];
            let v = mesh.indices()[prim_id as usize].map(|i| mesh.positions()[i as usize]);
            Triangle { v, geom_id, prim_id }
        };
        let mut items = Vec::with_capacity(meshes.iter().map(|m| m.indices().len()).sum());
        for (geom_id, mesh) in meshes.iter().enumerate() {
            items.par_extend((0..mesh.indices().len() as u32).into_par_iter().map(|prim_id| {
                let t = triangle(geom_id as u32, prim_id);
                let bounds = Aabb::EMPTY.grow(t.v[0].into()).grow(t.v[1].into()).grow(t.v[2].into());
                BuildItem { min: bounds.min.into(), max: bounds.max.into(), geom_id: geom_id as u32, prim_id }
            }));
        }
        if items.is_empty() {
            return Bvh { nodes: Vec::new(), leaves: Vec::new() };
        }
        let span = Span::of(&items);
        let root = build_node(&mut items, 0, span);
        let leaf = |first: usize, count: usize| {
            Leaf::new(items[first..first + count].iter().map(|item| triangle(item.geom_id, item.prim_id)))
        };
        let (nodes, leaves) = collapse(&root, &leaf);
        Bvh { nodes, leaves }
    }

    /// Size and shape of the tree.
    pub fn stats(&self) -> BvhStats {
        fn depth(nodes: &[Node], i: usize) -> usize {
            let n = &nodes[i];
            (0..n.children as usize)
                .map(|c| if n.count[c] > 0 { 1 } else { depth(nodes, n.child[c] as usize) })
                .max()
                .map_or(1, |d| 1 + d)
        }
        let leaf_lanes = |n: &Node| (0..n.children as usize).map(|c| n.count[c] as usize).sum::<usize>();
        BvhStats {
            nodes: self.nodes.len(),
            triangles: self.nodes.iter().map(leaf_lanes).sum(),
            bytes: self.nodes.len() * std::mem::size_of::<Node>()
                + self.leaves.len() * std::mem::size_of::<Leaf>(),
            depth: if self.nodes.is_empty() { 0 } else { depth(&self.nodes, 0) },
        }
    }

    /// Walks the tree, calling `visit` on each leaf (and its count of
    /// triangles) whose box the ray enters before `t_max`. `visit` returns
    /// the new `t_max` (smaller after a hit) or `None` to stop the walk at
    /// once.
    ///
    /// A node's eight boxes are tested four at a time. With `NEAREST_FIRST`
    /// (closest hits) the children entered go on the stack farthest first
    /// with their entry distances, so the nearest is walked next and
    /// subtrees behind a hit found meanwhile are skipped when popped.
    /// Without it (occlusion, where any hit ends the walk) they are walked
    /// in lane order: sorting them was 2-4% of a shadow ray's time.
    fn traverse<'s, const NEAREST_FIRST: bool>(
        &'s self,
        ray: &Ray,
        visit: impl FnMut(&'s Leaf, usize, f32) -> Option<f32>,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        thread_local! {
            // Each thread's traversal stack, kept between rays: no limit on
            // the tree's depth, and nothing to zero or allocate per ray (a
            // fixed array on the stack was zeroed for every ray, which cost
            // more than the box tests).
            static STACK: std::cell::RefCell<Vec<(u32, u16, f32)>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        STACK.with_borrow_mut(|stack| {
            stack.clear();
            self.walk::<NEAREST_FIRST>(ray, stack, visit);
        });
    }

    /// [`Bvh::traverse`] with a stack of pending children: (node or leaf
    /// index, triangles in a leaf or 0, entry distance).
    fn walk<'s, const NEAREST_FIRST: bool>(
        &'s self,
        ray: &Ray,
        stack: &mut Vec<(u32, u16, f32)>,
        mut visit: impl FnMut(&'s Leaf, usize, f32) -> Option<f32>,
    ) {
        let slab = SlabRay::new(ray);
        let mut t_max = ray.t_max;
        let mut current = (0u32, 0u16);
        loop {
            let (child, count) = current;
            if count > 0 {
                match visit(&self.leaves[child as usize], count as usize, t_max) {
                    Some(t) => t_max = t,
                    None => return,
                }
            } else {
                let node = &self.nodes[child as usize];
                let (mut entered, enter) = slab.enter(node, t_max);
                // The entered children (at most eight), nearest first by
                // insertion sort where that order is asked for.
                let mut order = [(0usize, 0f32); WIDTH];
                let mut n = 0;
                while entered != 0 {
                    let lane = entered.trailing_zeros() as usize;
                    entered &= entered - 1;
                    let mut i = n;
                    while NEAREST_FIRST && i > 0 && order[i - 1].1 > enter[lane] {
                        order[i] = order[i - 1];
                        i -= 1;
                    }
                    order[i] = (lane, enter[lane]);
                    n += 1;
                }
                if n > 0 {
                    // Walk the first now; stack the others, last first.
                    for &(lane, t) in order[1..n].iter().rev() {
                        stack.push((node.child[lane], node.count[lane], t));
                    }
                    let lane = order[0].0;
                    current = (node.child[lane], node.count[lane]);
                    continue;
                }
            }
            // Pop the nearest pending subtree still in front of the closest hit.
            loop {
                let Some((next, count, entry)) = stack.pop() else { return };
                if entry <= t_max {
                    current = (next, count);
                    break;
                }
            }
        }
    }
}

impl Intersector for Bvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let test = WatertightRay::new(ray);
        let mut best: Option<(f32, f32, f32, &Leaf, usize)> = None;
        self.traverse::<true>(ray, |leaf, count, t_max| {
            test.intersect_leaf(leaf, count, t_max, |lane, t, u, v| {
                best = Some((t, u, v, leaf, lane));
                true
            })
        });
        best.map(|(t, u, v, leaf, lane)| {
            let tri = leaf.vertices(lane);
            Hit {
                t,
                u,
                v,
                geom_id: leaf.geom_id[lane],
                prim_id: leaf.prim_id[lane],
                ng: (tri[1] - tri[0]).cross(tri[2] - tri[0]),
            }
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let test = WatertightRay::new(ray);
        let mut hit = false;
        self.traverse::<false>(ray, |leaf, count, t_max| {
            test.intersect_leaf(leaf, count, t_max, |_, _, _, _| {
                hit = true;
                false
            })
        });
        hit
    }

    fn name(&self) -> String {
        "native bvh".into()
    }
}

/// The per-ray part of the box test of a node's children, one child per
/// SIMD lane.
///
/// The slab distances are `(bound - origin) * inv`, whose rounding the
/// `gamma(3)` widening covers. (The cheaper `bound * inv - origin * inv`
/// cancels catastrophically when a bound is close to the origin's coordinate
/// and once let a ray aimed at a vertex of the bunny slip past its leaf's box.)
struct SlabRay {
    inv: [Vec4; 3],
    /// Axes where the direction is zero (so `inv` is infinite).
    parallel: [bool; 3],
    origin: [Vec4; 3],
}

impl SlabRay {
    fn new(ray: &Ray) -> SlabRay {
        let inv = ray.dir.recip();
        SlabRay {
            inv: [0, 1, 2].map(|a| Vec4::splat(inv[a])),
            parallel: [0, 1, 2].map(|a| !inv[a].is_finite()),
            origin: [0, 1, 2].map(|a| Vec4::splat(ray.origin[a])),
        }
    }

    /// Which of the node's children the ray enters between 0 and `t_max`,
    /// and where. The far distance is widened by `1 + 2 gamma(3)` to cover
    /// rounding (Pharr et al.). On an axis the ray is parallel to, a slab
    /// either contains the origin (no limit, even when the origin lies
    /// exactly in a face's plane, where `0 * inf` would be NaN) or the ray
    /// misses it.
    ///
    /// Returns a bit per child entered (bit `i` for child `i`) and each
    /// child's entry distance (meaningful where its bit is set).
    #[inline]
    fn enter(&self, node: &Node, t_max: f32) -> (u32, [f32; WIDTH]) {
        let used = Vec4::splat(node.children as f32);
        let mut entered = 0;
        let mut entry = [0.0; WIDTH];
        for group in 0..GROUPS {
            let first = (4 * group) as f32;
            let mut alive = Vec4::new(first, first + 1.0, first + 2.0, first + 3.0).cmplt(used);
            if !alive.any() {
                break;
            }
            let (mut near, mut far) = (Vec4::ZERO, Vec4::splat(t_max));
            for axis in 0..3 {
                let (min, max, origin) = (node.min[group][axis], node.max[group][axis], self.origin[axis]);
                if self.parallel[axis] {
                    alive &= origin.cmpge(min) & origin.cmple(max);
                } else {
                    let t0 = (min - origin) * self.inv[axis];
                    let t1 = (max - origin) * self.inv[axis];
                    near = near.max(t0.min(t1));
                    far = far.min(t0.max(t1));
                }
            }
            let far = far * (1.0 + 2.0 * GAMMA3);
            entered |= (alive & near.cmple(far)).bitmask() << (4 * group);
            near.write_to_slice(&mut entry[4 * group..4 * group + 4]);
        }
        (entered, entry)
    }
}

/// The per-ray part of the watertight test: the ray is sheared so that it
/// runs along +z, then each triangle is tested in 2D with edge functions
/// whose signs are consistent across shared edges.
///
/// A vertex `p` relative to the origin becomes `(p[kx] - sx p[kz], p[ky] -
/// sy p[kz], sz p[kz])` ([`shear`]), computed by the same functions one
/// triangle at a time and four at a time in SIMD lanes, so both give the
/// same bits.
struct WatertightRay {
    origin: [f32; 3],
    /// The axes the ray's direction maps to x, y and z.
    k: [usize; 3],
    /// The shear: `dir[kx] / dir[kz]`, `dir[ky] / dir[kz]`, `1 / dir[kz]`.
    s: [f32; 3],
    /// The origin and the shear, each in all four lanes, for
    /// [`WatertightRay::intersect_leaf`].
    origin4: [Vec4; 3],
    s4: [Vec4; 3],
}

impl WatertightRay {
    fn new(ray: &Ray) -> WatertightRay {
        let d = ray.dir;
        let a = d.abs();
        let kz = if a.x > a.y && a.x > a.z {
            0
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // Swapping keeps the winding (and so the sign of the edge functions).
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let s = [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]];
        WatertightRay {
            origin: ray.origin.to_array(),
            k: [kx, ky, kz],
            s,
            origin4: [0, 1, 2].map(|axis| Vec4::splat(ray.origin[axis])),
            s4: s.map(Vec4::splat),
        }
    }

    /// Tests the first `count` triangles of `leaf` in lane order, exactly as
    /// [`WatertightRay::intersect`] on each in turn would: each hit at or
    /// before `t_max` goes to `hit(lane, t, u, v)` and becomes the new
    /// `t_max`. Returns the last `t_max`, or `None` once `hit` returns false.
    ///
    /// The shear and the edge functions run in SIMD lanes, one triangle
    /// each; the few triangles they do not rule out are finished one by one.
    #[inline]
    fn intersect_leaf(
        &self,
        leaf: &Leaf,
        count: usize,
        mut t_max: f32,
        mut hit: impl FnMut(usize, f32, f32, f32) -> bool,
    ) -> Option<f32> {
        let shear4 = |v: &[Vec4; 3]| shear(v, &self.origin4, self.k, &self.s4);
        let (a, b, c) = (shear4(&leaf.v[0]), shear4(&leaf.v[1]), shear4(&leaf.v[2]));
        let [u, vv, w] = edge_functions(&a, &b, &c);
        let zero = Vec4::ZERO;
        let on_edge = u.cmpeq(zero) | vv.cmpeq(zero) | w.cmpeq(zero);
        let outside = (u.cmplt(zero) | vv.cmplt(zero) | w.cmplt(zero))
            & (u.cmpgt(zero) | vv.cmpgt(zero) | w.cmpgt(zero));
        // Lanes still in question: inside all edges, or on one (decided in
        // double precision by the scalar test).
        let mut open = (on_edge.bitmask() | !outside.bitmask()) & ((1 << count) - 1);
        while open != 0 {
            let lane = open.trailing_zeros() as usize;
            open &= open - 1;
            let found = if on_edge.test(lane) {
                self.intersect(&leaf.vertices(lane), t_max)
            } else {
                Self::distance(u[lane], vv[lane], w[lane], [a[2][lane], b[2][lane], c[2][lane]], t_max)
            };
            if let Some((t, bu, bv)) = found {
                if !hit(lane, t, bu, bv) {
                    return None;
                }
                t_max = t;
            }
        }
        Some(t_max)
    }

    /// `(t, u, v)` with Embree's barycentrics, if the triangle is hit at
    /// `0 < t <= t_max`.
    #[inline]
    fn intersect(&self, v: &[Vec3; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        let [a, b, c] = v.map(|v| shear(&v.to_array(), &self.origin, self.k, &self.s));
        let [mut u, mut vv, mut w] = edge_functions(&a, &b, &c);
        // Exactly on an edge in single precision: decide in double.
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            let wide = |p: [f32; 3]| p.map(f64::from);
            [u, vv, w] = edge_functions(&wide(a), &wide(b), &wide(c)).map(|e| e as f32);
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        Self::distance(u, vv, w, [a[2], b[2], c[2]], t_max)
    }

    /// The end of the test, for a ray inside (or on) all three edges: the
    /// hit's `(t, u, v)` from the edge functions and the sheared vertices'
    /// `z`, if `0 < t <= t_max`.
    #[inline]
    fn distance(u: f32, vv: f32, w: f32, z: [f32; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        let t_scaled = u * z[0] + vv * z[1] + w * z[2];
        // t = t_scaled / det must lie in (0, t_max]; compare without dividing.
        let sign = det.signum();
        if t_scaled * sign <= 0.0 || t_scaled * sign > t_max * det.abs() {
            return None;
        }
        let inv = 1.0 / det;
        Some((t_scaled * inv, vv * inv, w * inv))
    }
}

/// A vertex `p` relative to the ray's `origin`, sheared so that the ray runs
/// along +z: `(p[kx] - sx p[kz], p[ky] - sy p[kz], sz p[kz])` with `k` the
/// axes and `s` the shear. For one vertex (`f32`) or four at once (`Vec4`),
/// by the same operations in the same order.
#[inline(always)]
fn shear<T: Copy + Sub<Output = T> + Mul<Output = T>>(
    p: &[T; 3],
    origin: &[T; 3],
    k: [usize; 3],
    s: &[T; 3],
) -> [T; 3] {
    let [kx, ky, kz] = k;
    let (px, py, pz) = (p[kx] - origin[kx], p[ky] - origin[ky], p[kz] - origin[kz]);
    [px - s[0] * pz, py - s[1] * pz, s[2] * pz]
}

/// The edge functions of sheared vertices `a`, `b`, `c` in 2D: U weights
/// vertex 0, V vertex 1, W vertex 2 (in `f32`, `f64` or four lanes).
#[inline(always)]
fn edge_functions<T: Copy + Sub<Output = T> + Mul<Output = T>>(a: &[T; 3], b: &[T; 3], c: &[T; 3]) -> [T; 3] {
    [c[0] * b[1] - c[1] * b[0], a[0] * c[1] - a[1] * c[0], b[0] * a[1] - b[1] * a[0]]
}

/// A box in SIMD lanes, for the build's many unions.
#[derive(Debug, Clone, Copy)]
struct Aabb {
    min: Vec3A,
    max: Vec3A,
}

impl Aabb {
    const EMPTY: Aabb = Aabb { min: Vec3A::INFINITY, max: Vec3A::NEG_INFINITY };

    fn grow(self, p: Vec3A) -> Aabb {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    fn union(self, other: Aabb) -> Aabb {
        Aabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    fn bounds(self) -> Bounds {
        Bounds { min: self.min.into(), max: self.max.into() }
    }
}

/// What a set of build items spans: the union of their boxes, and the box
/// of their centroids (which the SAH bins divide).
#[derive(Debug, Clone, Copy)]
struct Span {
    bounds: Aabb,
    centroids: Aabb,
}

impl Span {
    const EMPTY: Span = Span { bounds: Aabb::EMPTY, centroids: Aabb::EMPTY };

    fn add(self, item: &BuildItem) -> Span {
        Span { bounds: self.bounds.union(item.bounds()), centroids: self.centroids.grow(item.centroid()) }
    }

    fn union(self, other: Span) -> Span {
        Span { bounds: self.bounds.union(other.bounds), centroids: self.centroids.union(other.centroids) }
    }

    /// The span of `items`, in parallel (unions of boxes are exact, so the
    /// result does not depend on how the work was split).
    fn of(items: &[BuildItem]) -> Span {
        items.par_iter().fold(|| Span::EMPTY, |s, i| s.add(i)).reduce(|| Span::EMPTY, Span::union)
    }
}

/// Builds the subtree over `items` (which span `span`), the first of which
/// is triangle `first` in leaf order.
///
/// One pass over the items bins them on all three axes at once (each bin
/// keeping its items' box and count); a second partitions them by the
/// cheapest split and gathers the two sides' spans (boxes and centroid
/// boxes) for their own builds.
fn build_node(items: &mut [BuildItem], first: usize, span: Span) -> BuildNode {
    let (bounds, centroids) = (span.bounds.bounds(), span.centroids);
    // A leaf whenever four triangles or fewer remain: a leaf's four are
    // tested at once, so splitting them saves no triangle tests, only adds
    // boxes (Embree's SAH counts leaves in blocks of four the same way).
    if items.len() <= MAX_LEAF {
        return BuildNode::Leaf { bounds, first, count: items.len() };
    }
    let extent = centroids.max - centroids.min;
    let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), BINS as f32 / extent, Vec3A::ZERO);
    // An item's bin on each axis, the three at once (the float-to-integer
    // conversion saturates: a centroid on the lower edge goes to bin 0).
    let bins_of = |c: Vec3A| ((c - centroids.min) * scale).as_uvec3().min(UVec3::splat(BINS as u32 - 1));
    let mut bins = [[(Aabb::EMPTY, 0usize); BINS]; 3];
    for item in items.iter() {
        let bin = bins_of(item.centroid());
        for (axis, axis_bins) in bins.iter_mut().enumerate() {
            let bin = &mut axis_bins[bin[axis] as usize];
            *bin = (bin.0.union(item.bounds()), bin.1 + 1);
        }
    }

    // Find the cheapest binned split over all three axes.
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, last bin on the left)
    for (axis, bins) in bins.iter().enumerate() {
        if extent[axis] <= 0.0 {
            continue;
        }
        // Sweep from the right to get the right-hand areas and counts.
        let mut right = [(0.0f32, 0usize); BINS];
        let mut acc = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = (acc.0.union(bins[i].0), acc.1 + bins[i].1);
            right[i] = (acc.0.bounds().half_area(), acc.1);
        }
        let mut left = (Aabb::EMPTY, 0);
        for split in 0..BINS - 1 {
            left = (left.0.union(bins[split].0), left.1 + bins[split].1);
            let (right_area, right_count) = right[split + 1];
            if left.1 == 0 || right_count == 0 {
                continue;
            }
            let cost = left.0.bounds().half_area() * left.1 as f32 + right_area * right_count as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, split));
            }
        }
    }

    let Some((_, axis, split)) = best else {
        // All centroids coincide: no split separates them.
        return median_split(items, first, bounds);
    };
    let (mid, left_span, right_span) =
        partition(items, |item| bins_of(item.centroid())[axis] as usize <= split);
    let (left, right) = items.split_at_mut(mid);
    let children = if left.len() + right.len() > PARALLEL_BUILD {
        let (l, r) =
            rayon::join(|| build_node(left, first, left_span), || build_node(right, first + mid, right_span));
        [l, r]
    } else {
        [build_node(left, first, left_span), build_node(right, first + mid, right_span)]
    };
    BuildNode::interior(bounds, children)
}

/// Splits items with identical centroids into halves by count.
fn median_split(items: &mut [BuildItem], first: usize, bounds: Bounds) -> BuildNode {
    let mid = items.len() / 2;
    let (left, right) = items.split_at_mut(mid);
    let (left_span, right_span) = (Span::of(left), Span::of(right));
    let children = [build_node(left, first, left_span), build_node(right, first + mid, right_span)];
    BuildNode::interior(bounds, children)
}

/// Moves the items for which `goes_left` holds to the front; returns how
/// many, and the spans of the two sides.
fn partition(items: &mut [BuildItem], goes_left: impl Fn(&BuildItem) -> bool) -> (usize, Span, Span) {
    let (mut mid, mut left, mut right) = (0, Span::EMPTY, Span::EMPTY);
    for i in 0..items.len() {
        if goes_left(&items[i]) {
            left = left.add(&items[i]);
            items.swap(i, mid);
            mid += 1;
        } else {
            right = right.add(&items[i]);
        }
    }
    (mid, left, right)
}

/// The children of the node of eight that stands for a binary node with
/// children `two`, and how many of the eight are used: `two`, with the
/// interior one of largest area replaced by its own two while fewer than
/// eight (of equal areas, the last).
fn lanes(two: &[BuildNode; 2]) -> ([&BuildNode; WIDTH], usize) {
    let mut lanes = [&two[1]; WIDTH];
    lanes[0] = &two[0];
    let mut used = 2;
    while used < WIDTH {
        let largest = (0..used)
            .filter(|&i| matches!(lanes[i], BuildNode::Interior { .. }))
            .max_by(|&a, &b| lanes[a].bounds().half_area().total_cmp(&lanes[b].bounds().half_area()));
        let Some(i) = largest else { break };
        let BuildNode::Interior { children: pair, .. } = lanes[i] else { unreachable!("filtered") };
        lanes.copy_within(i + 1..used, i + 2);
        lanes[i] = &pair[0];
        lanes[i + 1] = &pair[1];
        used += 1;
    }
    (lanes, used)
}

/// The nodes of eight for the tree under `root`, depth first: each node,
/// then its children's subtrees in lane order; and the leaves, in the order
/// the nodes name them, each made by `leaf(first, count)` from the build's
/// leaf-order triangles.
fn collapse(root: &BuildNode, leaf: &(impl Fn(usize, usize) -> Leaf + Sync)) -> (Vec<Node>, Vec<Leaf>) {
    let mut nodes = vec![Node::UNUSED; root.collapsed().max(1)];
    let mut leaves = vec![Leaf::EMPTY; root.leaves()];
    let root_lanes = match root {
        BuildNode::Leaf { .. } => ([root; WIDTH], 1),
        BuildNode::Interior { children, .. } => lanes(children),
    };
    collapse_into(
        root_lanes,
        Parts { nodes: &mut nodes, node_base: 0, leaves: &mut leaves, leaf_base: 0 },
        leaf,
    );
    (nodes, leaves)
}

/// The parts of the node and leaf arrays one collapsed subtree fills, and
/// the indices of their first entries in the whole arrays.
struct Parts<'a> {
    nodes: &'a mut [Node],
    node_base: usize,
    leaves: &'a mut [Leaf],
    leaf_base: usize,
}

/// Writes the node of eight with `children` (the first `used`) to the
/// first of `out.nodes`, their subtrees' nodes after it and their leaves to
/// `out.leaves`; both parts are exactly as long as they need. Large
/// subtrees are written in parallel, each into its own parts, so the arrays
/// are the same whatever the threads.
fn collapse_into(
    (children, used): ([&BuildNode; WIDTH], usize),
    out: Parts,
    leaf: &(impl Fn(usize, usize) -> Leaf + Sync),
) {
    let parallel = out.nodes.len() > PARALLEL_BUILD / MAX_LEAF;
    let Some((record, mut nodes)) = out.nodes.split_first_mut() else { unreachable!("sized by `collapsed`") };
    let mut leaves = out.leaves;
    *record = Node { children: used as u8, ..Node::UNUSED };
    let mut subtrees: [Option<(&[BuildNode; 2], Parts)>; WIDTH] = std::array::from_fn(|_| None);
    let (mut next_node, mut next_leaf) = (out.node_base + 1, out.leaf_base);
    for (lane, child) in children[..used].iter().enumerate() {
        let b = child.bounds();
        let (group, slot) = (lane / 4, lane % 4);
        for axis in 0..3 {
            record.min[group][axis][slot] = b.min[axis];
            record.max[group][axis][slot] = b.max[axis];
        }
        match child {
            BuildNode::Leaf { first, count, .. } => {
                let (slot, tail) = std::mem::take(&mut leaves).split_first_mut().expect("sized by `leaves`");
                leaves = tail;
                *slot = leaf(*first, *count);
                record.child[lane] = next_leaf as u32;
                record.count[lane] = *count as u16;
                next_leaf += 1;
            }
            BuildNode::Interior { children: two, collapsed, leaves: below, .. } => {
                let (node_part, node_tail) = std::mem::take(&mut nodes).split_at_mut(*collapsed);
                let (leaf_part, leaf_tail) = std::mem::take(&mut leaves).split_at_mut(*below);
                (nodes, leaves) = (node_tail, leaf_tail);
                record.child[lane] = next_node as u32;
                let parts =
                    Parts { nodes: node_part, node_base: next_node, leaves: leaf_part, leaf_base: next_leaf };
                subtrees[lane] = Some((two, parts));
                next_node += collapsed;
                next_leaf += below;
            }
        }
    }
    let write = |(two, parts): (&[BuildNode; 2], Parts)| collapse_into(lanes(two), parts, leaf);
    if parallel {
        subtrees.into_par_iter().flatten().for_each(write);
    } else {
        subtrees.into_iter().flatten().for_each(write);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_are_four_cache_lines() {
        assert_eq!(std::mem::size_of::<Node>(), 256);
    }

    #[test]
    fn watertight_test_reports_embree_barycentrics() {
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        for dir in [-Vec3::Z, Vec3::Z] {
            let origin = Vec3::new(0.25, 0.5, -2.0 * dir.z);
            let (t, u, w) = WatertightRay::new(&Ray::new(origin, dir)).intersect(&v, f32::INFINITY).unwrap();
            assert!((t - 2.0).abs() < 1e-6 && (u - 0.25).abs() < 1e-6 && (w - 0.5).abs() < 1e-6);
        }
        let miss = Ray::new(Vec3::new(0.6, 0.6, 1.0), -Vec3::Z);
        assert!(WatertightRay::new(&miss).intersect(&v, f32::INFINITY).is_none());
        let behind = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::Z);
        assert!(WatertightRay::new(&behind).intersect(&v, f32::INFINITY).is_none());
        let short = Ray { t_max: 0.5, ..Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z) };
        assert!(WatertightRay::new(&short).intersect(&v, short.t_max).is_none());
    }

    #[test]
    fn a_leaf_answers_as_its_triangles_one_at_a_time() {
        // Four triangles of a fan around the origin on z = 0, sharing edges
        // and the centre vertex, plus a tilted one across them: rays aimed
        // at vertices and along edges put edge functions exactly at zero
        // (the double-precision path), others at random points.
        let fan = [Vec3::X, Vec3::Y, -Vec3::X, -Vec3::Y, Vec3::X];
        let mut triangles: Vec<[Vec3; 3]> = (0..4).map(|i| [Vec3::ZERO, fan[i], fan[i + 1]]).collect();
        triangles.push([Vec3::new(-1.0, 0.0, -0.5), Vec3::new(1.0, 0.0, 0.5), Vec3::new(0.0, 1.0, 0.0)]);
        let mut state = 7u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut targets =
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, -Vec3::X, Vec3::new(0.5, 0.5, 0.0), Vec3::new(0.5, 0.0, 0.0)];
        targets.extend((0..400).map(|_| Vec3::new(next(), next(), 0.0)));
        let (mut hits, mut on_vertices) = (0, 0);
        for (i, target) in targets.iter().enumerate() {
            for first in 0..2 {
                for count in 1..=MAX_LEAF {
                    let chosen = &triangles[first..first + count];
                    let leaf = Leaf::new(chosen.iter().map(|&v| Triangle { v, geom_id: 0, prim_id: 0 }));
                    let from =
                        if i % 2 == 0 { Vec3::new(0.0, 0.0, 3.0) } else { Vec3::new(next(), next(), -3.0) };
                    let ray = Ray::new(from, *target - from);
                    let test = WatertightRay::new(&ray);
                    // One at a time, each with the t_max the hits before left.
                    let mut expected = Vec::new();
                    let mut t_max = ray.t_max;
                    for (lane, v) in chosen.iter().enumerate() {
                        if let Some((t, u, w)) = test.intersect(v, t_max) {
                            expected.push((lane, t.to_bits(), u.to_bits(), w.to_bits()));
                            t_max = t;
                        }
                    }
                    let mut found = Vec::new();
                    let end = test.intersect_leaf(&leaf, count, ray.t_max, |lane, t, u, w| {
                        found.push((lane, t.to_bits(), u.to_bits(), w.to_bits()));
                        true
                    });
                    assert_eq!(found, expected, "ray {i}, triangles {first}..{}", first + count);
                    assert_eq!(end, Some(t_max));
                    // Stopped at the first hit: nothing after it is tested.
                    let mut stopped = Vec::new();
                    let end = test.intersect_leaf(&leaf, count, ray.t_max, |lane, _, _, _| {
                        stopped.push(lane);
                        false
                    });
                    assert_eq!(stopped, expected.first().map(|e| e.0).into_iter().collect::<Vec<_>>());
                    assert_eq!(end.is_none(), !expected.is_empty());
                    hits += expected.len();
                    on_vertices += usize::from(i < 6 && !expected.is_empty());
                }
            }
        }
        assert!(
            hits > 1000 && on_vertices > 10,
            "{hits} hits, {on_vertices} rays at vertices and edges that hit"
        );
    }

    #[test]
    fn shared_edge_is_hit_by_exactly_one_side_or_both() {
        // Two triangles sharing the diagonal of the unit square: a ray straight
        // through a point on the diagonal must hit at least one.
        let (a, b) =
            ([Vec3::ZERO, Vec3::X, Vec3::ONE.with_z(0.0)], [Vec3::ZERO, Vec3::ONE.with_z(0.0), Vec3::Y]);
        for k in 1..100 {
            let x = k as f32 / 100.0;
            let ray = Ray::new(Vec3::new(x, x, 1.0), Vec3::new(0.0, 0.0, -1.0));
            let test = WatertightRay::new(&ray);
            assert!(test.intersect(&a, 9.0).is_some() || test.intersect(&b, 9.0).is_some(), "leak at {x}");
        }
    }

    #[test]
    fn the_tree_is_the_same_whatever_the_threads() {
        // Enough small scattered triangles that the build and the collapse
        // both split their work across threads.
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut positions = Vec::new();
        for _ in 0..3 * 40_000 {
            let corner = Vec3::new(next(), next(), next()) * 100.0;
            positions.push(corner);
            positions.push(corner + Vec3::new(next(), next(), 0.0));
            positions.push(corner + Vec3::new(0.0, next(), next()));
        }
        let indices: Vec<[u32; 3]> =
            (0..positions.len() as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| Bvh::build(&[TriangleView::new(&positions, &indices)]))
        };
        let (one, two) = (build(1), build(2));
        assert!(
            one.nodes.len() > PARALLEL_BUILD / MAX_LEAF,
            "{} nodes: too few to split the collapse",
            one.nodes.len()
        );
        assert_eq!(one.nodes.len(), two.nodes.len());
        for (a, b) in one.nodes.iter().zip(&two.nodes) {
            assert_eq!((a.child, a.count, a.children), (b.child, b.count, b.children));
            for (group, axis) in (0..GROUPS).flat_map(|g| (0..3).map(move |a| (g, a))) {
                assert_eq!(
                    a.min[group][axis].to_array().map(f32::to_bits),
                    b.min[group][axis].to_array().map(f32::to_bits)
                );
                assert_eq!(
                    a.max[group][axis].to_array().map(f32::to_bits),
                    b.max[group][axis].to_array().map(f32::to_bits)
                );
            }
        }
        let ids = |bvh: &Bvh| bvh.leaves.iter().flat_map(|l| l.prim_id).collect::<Vec<_>>();
        assert_eq!(ids(&one), ids(&two));
        // Every interior lane points past its node, and every node is reached once.
        let mut reached = vec![0u32; one.nodes.len()];
        reached[0] = 1;
        for (i, node) in one.nodes.iter().enumerate() {
            for lane in 0..node.children as usize {
                if node.count[lane] == 0 {
                    assert!(node.child[lane] as usize > i);
                    reached[node.child[lane] as usize] += 1;
                }
            }
        }
        assert!(reached.iter().all(|&r| r == 1));
        // Every leaf is named by one lane and holds one to four triangles.
        let mut named = vec![0u32; one.leaves.len()];
        for node in &one.nodes {
            for lane in 0..node.children as usize {
                if node.count[lane] > 0 {
                    assert!((1..=MAX_LEAF as u16).contains(&node.count[lane]));
                    named[node.child[lane] as usize] += 1;
                }
            }
        }
        assert!(named.iter().all(|&n| n == 1));
        assert_eq!(one.stats().triangles, indices.len());
    }

    #[test]
    fn bvh_finds_the_nearest_of_many() {
        // A stack of 1000 parallel unit squares at z = 0..999.
        let positions: Vec<Vec3> = (0..1000)
            .flat_map(|z| {
                let z = z as f32;
                [
                    Vec3::new(0.0, 0.0, z),
                    Vec3::new(1.0, 0.0, z),
                    Vec3::new(1.0, 1.0, z),
                    Vec3::new(0.0, 1.0, z),
                ]
            })
            .collect();
        let indices: Vec<[u32; 3]> = (0..1000u32)
            .flat_map(|q| [[4 * q, 4 * q + 1, 4 * q + 2], [4 * q, 4 * q + 2, 4 * q + 3]])
            .collect();
        let bvh = Bvh::build(&[TriangleView::new(&positions, &indices)]);
        let stats = bvh.stats();
        assert_eq!(stats.triangles, 2000);
        assert!(stats.depth < 40, "depth {}", stats.depth);
        let hit = bvh.intersect(&Ray::new(Vec3::new(0.3, 0.6, 500.5), -Vec3::Z)).unwrap();
        assert_eq!(hit.t, 0.5);
        assert_eq!(hit.prim_id / 2, 500);
        let up = bvh.intersect(&Ray::new(Vec3::new(0.3, 0.6, -3.0), Vec3::Z)).unwrap();
        assert_eq!((up.t, up.prim_id / 2), (3.0, 0));
        assert!(bvh.occluded(&Ray::new(Vec3::new(0.3, 0.6, 500.5), Vec3::Z)));
        assert!(!bvh.occluded(&Ray { t_max: 0.4, ..Ray::new(Vec3::new(0.3, 0.6, 500.5), Vec3::Z) }));
        assert!(bvh.intersect(&Ray::new(Vec3::new(1.5, 0.5, 0.5), -Vec3::Z)).is_none());
    }

    #[test]
    fn rays_lying_in_a_box_face_plane_are_inside_the_slab() {
        // One child, the box [0, 1] x [0, 1] x [2, 3], in the first lane;
        // the other lanes are unused and must never be entered.
        let mut node = Node { children: 1, ..Node::UNUSED };
        node.count[0] = 1;
        for (axis, (lo, hi)) in [(0.0, 1.0), (0.0, 1.0), (2.0, 3.0)].into_iter().enumerate() {
            node.min[0][axis][0] = lo;
            node.max[0][axis][0] = hi;
        }
        let first_lane = |ray: &Ray| {
            let (entered, enter) = SlabRay::new(ray).enter(&node, ray.t_max);
            assert_eq!(entered & !1, 0, "an unused lane was entered");
            (entered & 1 != 0).then_some(enter[0])
        };
        let dir = Vec3::new(1.0, 0.5, 0.0);
        for z in [2.0, 2.5, 3.0] {
            // Parallel to the z faces, in or between their planes.
            assert_eq!(first_lane(&Ray::new(Vec3::new(-1.0, 0.0, z), dir)), Some(1.0), "z = {z}");
        }
        assert_eq!(first_lane(&Ray::new(Vec3::new(-1.0, 0.0, 3.5), dir)), None);
        assert_eq!(first_lane(&Ray { t_max: 0.5, ..Ray::new(Vec3::new(-1.0, 0.0, 2.0), dir) }), None);
        // Starting inside: entered at 0.
        assert_eq!(first_lane(&Ray::new(Vec3::new(0.5, 0.5, 2.5), -Vec3::ONE)), Some(0.0));
    }

    #[test]
    fn empty_and_degenerate_input() {
        let empty = Bvh::build(&[]);
        assert!(empty.intersect(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
        // Many triangles at one spot: no SAH split exists, the build still ends.
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let indices = vec![[0u32, 1, 2]; 100];
        let bvh = Bvh::build(&[TriangleView::new(&positions, &indices)]);
        assert!(bvh.stats().nodes > 1);
        assert!(bvh.intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z)).is_some());
    }
}
