//! A scene's lights, with a tree over the area lights' panels so that a ray
//! finds the panels it crosses without testing every light.
//!
//! Lights are not in the intersector's geometry: every ray is tested
//! against the area lights on its way ([`Light::crossing`]: a front emits,
//! a back ends the ray), and every shadow ray too (lights are opaque
//! panels). Tested one by one, a scene of 256 small ceiling lights spent
//! 78% of a path-traced render in those tests, 65,536 a shading point
//! (BENCHMARKS.md, issue 17). The tree answers the same questions as the
//! scan, to the bit: the same light, the same ray parameter, the same
//! side; its boxes are padded far beyond rounding, so it only ever skips
//! lights the scan would have found no crossing with.

use std::cell::Cell;
use std::ops::Deref;

use glam::Vec3;

use crate::accel::Ray;
use crate::bounds::Bounds;
use crate::light::{Light, Side};
use crate::light_choice_tree::{ChoiceTree, TABLE_UP_TO};

/// Up to this many area lights, a ray tests each (the tree would not pay).
const SCAN_UP_TO: usize = 4;

/// Area lights a leaf of the tree holds, at most.
const LEAF: usize = 2;

/// A scene's lights, in the order the scene file gives them, read as a
/// slice. Built once ([`Lights::new`]); the tree is never stale because the
/// list cannot change.
#[derive(Debug, Clone, Default)]
pub struct Lights {
    all: Vec<Light>,
    /// Over the area lights, when there are more than [`SCAN_UP_TO`].
    tree: Option<PanelTree>,
    /// For choosing among the lights at a point, when there are more than
    /// [`TABLE_UP_TO`].
    choice: Option<ChoiceTree>,
}

impl Lights {
    /// The lights `all`, with the tree over their panels if it pays.
    pub fn new(all: Vec<Light>) -> Lights {
        let panels: Vec<u32> = (0..all.len() as u32).filter(|&i| !all[i as usize].is_delta()).collect();
        let tree = (panels.len() > SCAN_UP_TO).then(|| PanelTree::new(&all, panels));
        let choice = (all.len() > TABLE_UP_TO).then(|| ChoiceTree::new(&all));
        Lights { all, tree, choice }
    }

    /// The tree for choosing among many lights, if there are that many.
    pub fn choice_tree(&self) -> Option<&ChoiceTree> {
        self.choice.as_ref()
    }

    /// The index of `light` in the list, if it is one of them (from its
    /// address: a search would weigh as much as every light again).
    pub fn index_of(&self, light: &Light) -> Option<usize> {
        let offset = (light as *const Light as usize).wrapping_sub(self.all.as_ptr() as usize);
        let index = offset / std::mem::size_of::<Light>();
        self.all.get(index).filter(|l| std::ptr::eq(*l, light)).map(|_| index)
    }

    /// The nearest area light whose panel `ray` crosses before `ray.t_max`:
    /// the light, the ray parameter, and the side. Of lights crossed at the
    /// same parameter, the first in the list.
    pub fn nearest_crossing(&self, ray: &Ray) -> Option<(&Light, f32, Side)> {
        let found = match &self.tree {
            None => scan_nearest(&self.all, ray),
            Some(tree) => tree.nearest(&self.all, ray),
        };
        found.map(|(i, t, side)| (&self.all[i], t, side))
    }

    /// Whether `ray` crosses any area light's panel before `ray.t_max`.
    pub fn any_crossing(&self, ray: &Ray) -> bool {
        match &self.tree {
            None => self.all.iter().any(|light| light.crossing(ray).is_some()),
            Some(tree) => tree.any(&self.all, ray),
        }
    }
}

impl Deref for Lights {
    type Target = [Light];
    fn deref(&self) -> &[Light] {
        &self.all
    }
}

impl<'a> IntoIterator for &'a Lights {
    type Item = &'a Light;
    type IntoIter = std::slice::Iter<'a, Light>;
    fn into_iter(self) -> Self::IntoIter {
        self.all.iter()
    }
}

/// [`Lights::nearest_crossing`] by testing every light: its index.
fn scan_nearest(lights: &[Light], ray: &Ray) -> Option<(usize, f32, Side)> {
    lights
        .iter()
        .enumerate()
        .filter_map(|(i, light)| light.crossing(ray).map(|(t, side)| (i, t, side)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// A bounding-volume tree over area lights' panels, of up to four
/// children a node, whose boxes a ray is tested against together: a
/// binary tree's two levels in one (a lamp of 1,280 triangle lights spent
/// a third of a path-traced render testing boxes one by one).
#[derive(Debug, Clone)]
struct PanelTree {
    /// The root first.
    nodes: Vec<WideNode>,
    /// Light indices, each leaf's a run of them.
    order: Vec<u32>,
}

/// A node's children's boxes, by axis and child, and what each child is.
#[derive(Debug, Clone)]
struct WideNode {
    min: [[f32; WIDTH]; 3],
    max: [[f32; WIDTH]; 3],
    children: [Child; WIDTH],
}

/// Children a node of the tree has at most.
const WIDTH: usize = 4;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Child {
    /// No child in this place.
    Empty,
    /// Another node, by its index.
    Node(u32),
    /// A leaf: a run of `order`, its start and length.
    Leaf(u32, u32),
}

/// A node of the binary tree that [`PanelTree::new`] builds first.
#[derive(Debug, Clone)]
struct Node {
    /// Around the panels below, padded ([`padded_box`]).
    bounds: Bounds,
    /// A leaf's run of `order` starts here.
    first: u32,
    /// An inner node's second child (its first is the next node).
    second: u32,
    /// How many lights the leaf holds; 0 for an inner node.
    leaf_len: u32,
}

impl PanelTree {
    fn new(lights: &[Light], mut order: Vec<u32>) -> PanelTree {
        let boxes: Vec<Bounds> = lights.iter().map(padded_box).collect();
        let mut binary = Vec::with_capacity(2 * order.len());
        let len = order.len();
        build(&boxes, &mut order, 0, len, &mut binary);
        let mut nodes = Vec::with_capacity(binary.len() / 2 + 1);
        widen(&binary, 0, &mut nodes);
        PanelTree { nodes, order }
    }

    /// The index of the nearest light crossed, as [`scan_nearest`] finds it.
    fn nearest(&self, lights: &[Light], ray: &Ray) -> Option<(usize, f32, Side)> {
        let best: Cell<Option<(usize, f32, Side)>> = Cell::new(None);
        // Ties in the parameter go to the first light: a box is skipped
        // only when it starts strictly beyond the best so far.
        self.visit(
            ray,
            || best.get().map_or(ray.t_max, |b| b.1),
            |i| {
                if let Some((t, side)) = lights[i].crossing(ray) {
                    if best.get().is_none_or(|(j, bt, _)| t < bt || (t == bt && i < j)) {
                        best.set(Some((i, t, side)));
                    }
                }
                false
            },
        );
        best.get()
    }

    /// Whether `ray` crosses any light's panel.
    fn any(&self, lights: &[Light], ray: &Ray) -> bool {
        self.visit(ray, || ray.t_max, |i| lights[i].crossing(ray).is_some())
    }

    /// Hands `test` each light in a leaf whose box `ray` enters before the
    /// ray parameter `reach` gives (as it stands when the box's node is
    /// reached); stops, and says so, when `test` returns true.
    fn visit(&self, ray: &Ray, reach: impl Fn() -> f32, mut test: impl FnMut(usize) -> bool) -> bool {
        let inv = ray.dir.recip();
        // A node's children add at most `WIDTH - 1` to the stack each
        // level down, and the tree is no deeper than 32 levels.
        let mut stack = [0u32; 32 * WIDTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            let entered = enters_each(node, ray.origin, inv, reach());
            for (child, entered) in node.children.iter().zip(entered) {
                match *child {
                    _ if !entered => {}
                    Child::Empty => {}
                    Child::Node(next) => {
                        stack[top] = next;
                        top += 1;
                    }
                    Child::Leaf(first, len) => {
                        if self.order[first as usize..(first + len) as usize]
                            .iter()
                            .any(|&i| test(i as usize))
                        {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

/// The node of [`PanelTree`] over the binary tree's node `at` (an inner
/// one, or the root), made with those below it into `nodes`: its index.
/// Its children are the binary node's, each of the widest (by area) of
/// them that are inner nodes opened into its two until there are
/// [`WIDTH`].
fn widen(binary: &[Node], at: usize, nodes: &mut Vec<WideNode>) -> u32 {
    let inner = |i: usize| binary[i].leaf_len == 0;
    let mut picked: Vec<usize> = if inner(at) { vec![at + 1, binary[at].second as usize] } else { vec![at] };
    while picked.len() < WIDTH {
        let widest = (0..picked.len()).filter(|&k| inner(picked[k])).max_by(|&a, &b| {
            binary[picked[a]].bounds.half_area().total_cmp(&binary[picked[b]].bounds.half_area())
        });
        let Some(k) = widest else { break };
        let opened = picked[k];
        picked[k] = opened + 1;
        picked.push(binary[opened].second as usize);
    }
    let index = nodes.len();
    nodes.push(WideNode {
        min: [[f32::INFINITY; WIDTH]; 3],
        max: [[f32::NEG_INFINITY; WIDTH]; 3],
        children: [Child::Empty; WIDTH],
    });
    for (k, &i) in picked.iter().enumerate() {
        let b = binary[i].bounds;
        for axis in 0..3 {
            nodes[index].min[axis][k] = b.min[axis];
            nodes[index].max[axis][k] = b.max[axis];
        }
        nodes[index].children[k] = if inner(i) {
            Child::Node(widen(binary, i, nodes))
        } else {
            Child::Leaf(binary[i].first, binary[i].leaf_len)
        };
    }
    index as u32
}

/// Builds the subtree over `order[start..end]`, depth first, splitting at
/// the median of the panels' centres along their widest axis.
fn build(boxes: &[Bounds], order: &mut [u32], start: usize, end: usize, nodes: &mut Vec<Node>) {
    let bounds = order[start..end].iter().fold(Bounds::EMPTY, |b, &i| b.union(boxes[i as usize]));
    let at = nodes.len();
    nodes.push(Node { bounds, first: start as u32, second: 0, leaf_len: (end - start) as u32 });
    if end - start <= LEAF {
        return;
    }
    let centre = |i: u32| {
        let b = boxes[i as usize];
        0.5 * (b.min + b.max)
    };
    let axis = order[start..end].iter().fold(Bounds::EMPTY, |b, &i| b.grow(centre(i))).widest_axis();
    let mid = (start + end) / 2;
    order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
        centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b))
    });
    nodes[at].leaf_len = 0;
    build(boxes, order, start, mid, nodes);
    nodes[at].second = nodes.len() as u32;
    build(boxes, order, mid, end, nodes);
}

/// The box around an area light's panel, padded by far more than the
/// rounding of the point [`Light::crossing`] tests and the margin it
/// allows (a ten-thousandth of the panel's size, a hundred-thousandth of
/// its distance from the origin, twice its margin's reach):
/// a ray the test finds crossing the panel always enters the box.
fn padded_box(light: &Light) -> Bounds {
    let Light::Area { u, v, .. } = *light else { return Bounds::EMPTY };
    let b = light.bounds();
    // (And twice what the panel's own test reaches beyond it by.)
    let pad = 1e-4 * (u.abs() + v.abs()).max_element()
        + 1e-5 * b.min.abs().max(b.max.abs()).max_element()
        + 2.0 * light.margin_reach();
    Bounds { min: b.min - Vec3::splat(pad), max: b.max + Vec3::splat(pad) }
}

/// Whether the ray from `origin` with inverse direction `inv` enters each
/// of `node`'s children's boxes between 0 and `reach` (generously: a
/// little before and after; an empty place's answer means nothing). An
/// axis the ray runs parallel to gives a NaN or infinite slab, which
/// `f32::min` and `max` leave the other bounds to decide.
fn enters_each(node: &WideNode, origin: Vec3, inv: Vec3, reach: f32) -> [bool; WIDTH] {
    let mut near = [0.0f32; WIDTH];
    let mut far = [reach * (1.0 + 1e-5); WIDTH];
    for axis in 0..3 {
        let (o, inv) = (origin[axis], inv[axis]);
        for k in 0..WIDTH {
            let a = (node.min[axis][k] - o) * inv;
            let c = (node.max[axis][k] - o) * inv;
            near[k] = near[k].max(a.min(c));
            far[k] = far[k].min(a.max(c));
        }
    }
    std::array::from_fn(|k| near[k] <= far[k] * (1.0 + 1e-5))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Shape;
    use crate::sampling::Rng;

    #[test]
    fn a_light_is_found_at_its_index_and_a_copy_is_not() {
        let point = |x: f32| Light::Point { position: Vec3::new(x, 0.0, 0.0), power: Vec3::ONE };
        let lights = Lights::new((0..5).map(|i| point(i as f32)).collect());
        for (i, light) in lights.iter().enumerate() {
            assert_eq!(lights.index_of(light), Some(i));
        }
        let copy = lights[2].clone();
        assert_eq!(lights.index_of(&copy), None);
        // Nor a light that lies just past the list in memory.
        let others = [point(0.0), point(1.0)];
        assert_eq!(lights.index_of(&others[1]), None);
    }

    fn uniform_in(rng: &mut Rng, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * rng.uniform()
    }

    fn point_in(rng: &mut Rng, half: f32) -> Vec3 {
        Vec3::new(uniform_in(rng, -half, half), uniform_in(rng, -half, half), uniform_in(rng, -half, half))
    }

    /// Panels of every kind: turned every way (some triangles) and along the axes, from a
    /// thousandth to twice the room's size, far from the origin or near
    /// it, some twice over (ties), some on one plane, some with no area;
    /// and a point and a spot light among them.
    fn lights(rng: &mut Rng, offset: Vec3) -> Vec<Light> {
        let mut all = vec![Light::Point { position: offset, power: Vec3::ONE }];
        for i in 0..300 {
            let size = 10f32.powf(uniform_in(rng, -3.0, 0.3));
            let center = offset + point_in(rng, 1.0);
            let (u, v) = match i % 4 {
                0 => (Vec3::X * size, Vec3::Z * size),
                1 => (point_in(rng, size), point_in(rng, size)),
                2 => (Vec3::Y * size, Vec3::X * (size * 0.3)),
                _ => {
                    // On the plane y = 0.25, beside others there.
                    let c = Vec3::new(center.x, offset.y + 0.25, center.z);
                    all.push(Light::area(c, Vec3::X * size, Vec3::Z * size, Vec3::ONE));
                    continue;
                }
            };
            // Some of the panels turned every way are triangles.
            let shape = if i % 8 == 5 { Shape::Triangle } else { Shape::Parallelogram };
            all.push(Light::panel(shape, center, u, v, Vec3::ONE));
            if i % 37 == 0 {
                all.push(Light::area(center, u, v, Vec3::ONE)); // the same again
            }
            if i % 53 == 0 {
                all.push(Light::area(center, u, Vec3::ZERO, Vec3::ONE)); // no area
            }
        }
        all.push(Light::Spot {
            position: offset,
            direction: Vec3::Y,
            cone_angle: 0.5,
            falloff_start: 0.4,
            power: Vec3::ONE,
        });
        all
    }

    /// Rays from anywhere in the room every way, along the axes, to the
    /// panels' corners and edges, from points on the panels, with short,
    /// long and endless reaches.
    fn rays(rng: &mut Rng, lights: &[Light], offset: Vec3) -> Vec<Ray> {
        let mut rays = Vec::new();
        let areas: Vec<&Light> = lights.iter().filter(|l| !l.is_delta()).collect();
        for i in 0..20_000 {
            let origin = offset + point_in(rng, 1.5);
            let Light::Area { center, u, v, .. } = *areas[i % areas.len()] else { unreachable!() };
            let (a, b) = (rng.uniform() - 0.5, rng.uniform() - 0.5);
            let (dir, start) = match i % 6 {
                0 => (point_in(rng, 1.0), origin),
                1 => ([Vec3::X, Vec3::NEG_Y, Vec3::Z][i % 3], Vec3::new(origin.x, center.y, origin.z)),
                2 => (center + 0.5 * u + 0.5 * v - origin, origin), // a corner
                3 => (center + a * u + 0.5 * v - origin, origin),   // an edge
                4 => (point_in(rng, 1.0), center + a * u + b * v),  // from the panel
                _ => (center + a * u + b * v - origin, origin),
            };
            let t_max = match i % 5 {
                0 => f32::INFINITY,
                1 => 1.0, // ends on the panel it was aimed at
                _ => uniform_in(rng, 0.0, 3.0),
            };
            rays.push(Ray { t_max, ..Ray::new(start, dir) });
        }
        rays
    }

    #[test]
    fn the_tree_finds_what_testing_every_light_finds() {
        for (seed, offset) in [(1, Vec3::ZERO), (2, Vec3::new(1000.0, -20.0, 3.0))] {
            let mut rng = Rng::new(seed, 0);
            let all = lights(&mut rng, offset);
            let rays = rays(&mut rng, &all, offset);
            let lights = Lights::new(all.clone());
            assert!(lights.tree.is_some());
            let (mut crossed, mut ties) = (0, 0);
            for ray in &rays {
                let scan = scan_nearest(&all, ray);
                let tree = lights.nearest_crossing(ray);
                let tree = tree
                    .map(|(l, t, side)| (lights.iter().position(|x| std::ptr::eq(x, l)).unwrap(), t, side));
                assert_eq!(
                    scan.map(|(i, t, s)| (i, t.to_bits(), s)),
                    tree.map(|(i, t, s)| (i, t.to_bits(), s)),
                    "{ray:?}"
                );
                let any = all.iter().any(|l| l.crossing(ray).is_some());
                assert_eq!(lights.any_crossing(ray), any, "{ray:?}");
                crossed += scan.is_some() as u32;
                if let Some((i, t, _)) = scan {
                    ties += all.iter().skip(i + 1).any(|l| l.crossing(ray).is_some_and(|c| c.0 == t)) as u32;
                }
            }
            // The rays found many panels, and some at the same parameter twice.
            assert!(crossed > 8_000 && ties > 20, "{crossed} crossed, {ties} ties");
        }
    }

    #[test]
    fn a_few_lights_are_tested_one_by_one() {
        let panel = |x: f32| Light::area(Vec3::new(x, 1.0, 0.0), Vec3::X * 0.1, Vec3::Z * 0.1, Vec3::ONE);
        assert!(Lights::new((0..SCAN_UP_TO).map(|i| panel(i as f32)).collect()).tree.is_none());
        let many = Lights::new((0..=SCAN_UP_TO).map(|i| panel(i as f32)).collect());
        assert!(many.tree.is_some());
        // Straight up through the third: its front faces down (u x v = -y).
        let ray = Ray::new(Vec3::new(2.0, 0.0, 0.0), Vec3::Y);
        let (light, t, side) = many.nearest_crossing(&ray).unwrap();
        assert!(std::ptr::eq(light, &many[2]) && t == 1.0 && side == Side::Front);
        assert_eq!(many.len(), SCAN_UP_TO + 1);
    }
}
