//! A tree for choosing among many lights at a shading point without
//! weighing every light there.
//!
//! Where more than a few lights reach a point, it draws among them, each in
//! proportion to [`Light::reach`] (`integrator/direct.rs`). Weighing every
//! light costs a point as much as the lights are many: with 1,024 small
//! ceiling lights `Light::reach` was 40% of an SPPM render, and at 16,384
//! lights the render took 10 times as long as at 1,024 (BENCHMARKS.md,
//! issue 17). Above [`TABLE_UP_TO`] lights a draw walks down this tree
//! instead (Conty Estevez and Kulla 2018; pbrt-v4's `BVHLightSampler`):
//! at each node it picks a child in proportion to a bound of what the
//! lights below could send the point, and at a single light its own reach.
//! The chance of a light is the product of the picks on its way down, which
//! [`ChoiceTree::chance`] works out again for the weights of multiple
//! importance sampling.
//!
//! A node's bound is 0 only where no light below can reach the point
//! (behind all their planes, outside all their cones, with a margin), so
//! every light that could light the point may be drawn: the estimate stays
//! unbiased whatever the bounds' quality, which decides only the noise.

use glam::{DVec3, Vec3};

use crate::bounds::Bounds;
use crate::light::Light;

/// Up to this many lights a point weighs each one (`integrator/direct.rs`);
/// with more the scene has a [`ChoiceTree`]. The tree's bounds choose
/// less well than each light's own reach: on the Cornell box with its
/// light split in 256, the path tracer's error at 4 s was 7% higher with
/// the tree, at no gain in speed; split in 529, the tree's was 13% lower
/// (BENCHMARKS.md, issue 17).
pub const TABLE_UP_TO: usize = 256;

/// The cosine below which a bound treats directions as turned away: a
/// little below what it should be (0 for a panel's plane), so that rounding
/// never turns away a light that reaches a point.
const MARGIN: f64 = 1e-4;

/// What the lights below a node could send anywhere: where they are, how
/// strong, and which way.
#[derive(Debug, Clone, Copy)]
struct Reach {
    /// Around every point of the lights.
    bounds: Bounds,
    /// The sum of their strengths, as [`Light::reach`] weighs them (power
    /// over pi for a panel, over 4 pi for a point light, a spot's peak
    /// intensity): each light's reach is at most its strength over the
    /// squared distance.
    strength: f64,
    /// The directions the lights face: every panel's normal and spot's
    /// axis lies within `spread` (radians, up to pi: all) of `axis`.
    axis: DVec3,
    spread: f64,
    /// How far from its own facing a light still sends light (pi/2 for a
    /// panel, a spot's cone angle, pi for a point light): the most of them.
    beyond: f64,
}

impl Reach {
    fn of(light: &Light) -> Reach {
        let (bounds, strength) = (light.bounds(), light.reach_strength());
        // A spot or panel without a direction faces nowhere in particular.
        let facing = |direction: Vec3| match direction.as_dvec3().try_normalize() {
            Some(axis) => (axis, 0.0),
            None => (DVec3::Z, std::f64::consts::PI),
        };
        let ((axis, spread), beyond) = match *light {
            Light::Point { .. } => ((DVec3::Z, std::f64::consts::PI), std::f64::consts::PI),
            Light::Spot { direction, cone_angle, .. } => {
                (facing(direction), (cone_angle as f64).min(std::f64::consts::PI))
            }
            Light::Area { .. } => (facing(light.facing()), std::f64::consts::FRAC_PI_2),
        };
        Reach { bounds, strength, axis, spread, beyond }
    }

    fn union(&self, other: &Reach) -> Reach {
        let (axis, spread) = union_cones((self.axis, self.spread), (other.axis, other.spread));
        Reach {
            bounds: self.bounds.union(other.bounds),
            strength: self.strength + other.strength,
            axis,
            spread,
            beyond: self.beyond.max(other.beyond),
        }
    }
}

/// A node's [`Reach`] as [`Bound::at`] reads it: the box as a centre and
/// radius, the angles as sines and cosines (so that their sums and
/// differences take no trigonometric functions: those were half of a
/// render's time at 1,024 lights).
#[derive(Debug, Clone, Copy)]
struct Bound {
    centre: DVec3,
    /// Half the box's diagonal, squared.
    radius2: f64,
    strength: f64,
    axis: DVec3,
    cos_spread: f64,
    sin_spread: f64,
    /// The cosine of how far beyond the lights send, less the margin.
    least_cos: f64,
    /// Whether any direction can be turned away at all.
    can_turn_away: bool,
}

impl Bound {
    fn new(reach: &Reach) -> Bound {
        let (lo, hi) = (reach.bounds.min.as_dvec3(), reach.bounds.max.as_dvec3());
        Bound {
            centre: 0.5 * (lo + hi),
            radius2: 0.25 * (hi - lo).length_squared(),
            strength: reach.strength,
            axis: reach.axis,
            cos_spread: reach.spread.cos(),
            sin_spread: reach.spread.sin(),
            least_cos: reach.beyond.cos() - MARGIN,
            can_turn_away: reach.spread + reach.beyond < std::f64::consts::PI,
        }
    }

    /// A bound of what the lights could send `p`, as [`Light::reach`]
    /// weighs it: their strength over the squared distance from the box's
    /// centre (no nearer than half its diagonal); 0 where every direction
    /// from the box to `p` lies further than `beyond` from every direction
    /// the lights face.
    fn at(&self, p: Vec3) -> f64 {
        let to_p = p.as_dvec3() - self.centre;
        let d2 = to_p.length_squared();
        if self.can_turn_away && d2 > self.radius2 {
            // The angle from the lights' axis to `p` as seen from the box's
            // centre (w), less the lights' spread (x), less what the box
            // subtends from `p` (the nearest): if that is still beyond what
            // they send, nothing reaches `p`. Each difference is clamped at 0.
            // Within the spread (x = 0) the nearest angle is 0, within
            // any `beyond` (`least_cos` is below 1): nothing more to work out.
            let cos_w = (self.axis.dot(to_p) / d2.sqrt()).clamp(-1.0, 1.0);
            if cos_w < self.cos_spread {
                let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
                let cos_x = cos_w * self.cos_spread + sin_w * self.sin_spread;
                let sin_x = sin_w * self.cos_spread - cos_w * self.sin_spread;
                let sin_b = (self.radius2 / d2).sqrt().min(1.0);
                let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
                let cos_nearest = if cos_x >= cos_b { 1.0 } else { cos_x * cos_b + sin_x * sin_b };
                if cos_nearest <= self.least_cos {
                    return 0.0;
                }
            }
        }
        // Finite at the lights themselves, as `Light::reach` is.
        (self.strength / d2.max(self.radius2).max(f64::MIN_POSITIVE)).min(1e30)
    }
}

/// The angle between two vectors, accurately at any size (`atan2` of the
/// cross and dot products).
fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The narrowest cone (axis, half-angle) found around two cones.
fn union_cones((a, ta): (DVec3, f64), (b, tb): (DVec3, f64)) -> (DVec3, f64) {
    use std::f64::consts::PI;
    if ta >= PI || tb >= PI {
        return (a, PI);
    }
    let between = angle_between(a, b);
    if between + tb <= ta {
        return (a, ta);
    }
    if between + ta <= tb {
        return (b, tb);
    }
    let spread = 0.5 * (ta + between + tb);
    if spread >= PI {
        return (a, PI);
    }
    // Turn `a` towards `b` by `spread - ta`, about their common normal.
    let Some(normal) = a.cross(b).try_normalize() else { return (a, PI) };
    let turn = spread - ta;
    let axis = a * turn.cos() + normal.cross(a) * turn.sin();
    (axis.normalize(), spread)
}

/// A binary tree over the lights: a node's bound covers its lights; a leaf
/// holds one light.
#[derive(Debug, Clone)]
pub struct ChoiceTree {
    nodes: Vec<Node>,
    /// Each node's parent (the root's is itself: node 0).
    parents: Vec<u32>,
    /// Each light's leaf.
    leaves: Vec<u32>,
}

#[derive(Debug, Clone, Copy)]
enum Node {
    /// One light, weighed by its own reach.
    Leaf { light: u32 },
    /// Two children, and the bound of all their lights.
    Inner { children: [u32; 2], bound: Bound },
}

impl ChoiceTree {
    /// The tree over `lights` (at least one).
    pub fn new(lights: &[Light]) -> ChoiceTree {
        assert!(!lights.is_empty(), "a tree needs a light");
        let reaches: Vec<Reach> = lights.iter().map(Reach::of).collect();
        let mut order: Vec<u32> = (0..lights.len() as u32).collect();
        let mut tree = ChoiceTree {
            nodes: Vec::with_capacity(2 * lights.len()),
            parents: Vec::with_capacity(2 * lights.len()),
            leaves: vec![0; lights.len()],
        };
        tree.build(&reaches, &mut order, 0);
        tree
    }

    /// Builds the node over `order`'s lights, whose parent is `parent`,
    /// and returns its index: lights split at the median of their boxes'
    /// centres along the widest axis of those centres.
    fn build(&mut self, reaches: &[Reach], order: &mut [u32], parent: u32) -> u32 {
        let index = self.nodes.len() as u32;
        self.parents.push(parent);
        if let [light] = *order {
            self.nodes.push(Node::Leaf { light });
            self.leaves[light as usize] = index;
            return index;
        }
        let reach = order[1..].iter().fold(reaches[order[0] as usize], |r, &i| r.union(&reaches[i as usize]));
        let bound = Bound::new(&reach);
        self.nodes.push(Node::Inner { children: [0, 0], bound });
        let centre = |i: &u32| {
            let b = reaches[*i as usize].bounds;
            0.5 * (b.min + b.max)
        };
        let axis = Bounds::of(&order.iter().map(centre).collect::<Vec<_>>()).widest_axis();
        let half = order.len() / 2;
        order.select_nth_unstable_by(half, |a, b| centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(b)));
        let (left, right) = order.split_at_mut(half);
        let children = [self.build(reaches, left, index), self.build(reaches, right, index)];
        self.nodes[index as usize] = Node::Inner { children, bound };
        index
    }

    /// What node `node` could send `p`: a light's own reach at a leaf, the
    /// bound above it (finite, not negative).
    fn weight(&self, lights: &[Light], node: u32, p: Vec3) -> f64 {
        match &self.nodes[node as usize] {
            Node::Leaf { light } => lights[*light as usize].reach(p) as f64,
            Node::Inner { bound, .. } => bound.at(p),
        }
    }

    /// Whether any light may reach `p`.
    pub fn reaches(&self, lights: &[Light], p: Vec3) -> bool {
        self.weight(lights, 0, p) > 0.0
    }

    /// The light a uniform `u` in `[0, 1)` picks at `p`, walking down from
    /// the root, and its chance; `None` where the walk ends at nodes none
    /// of whose lights may reach `p`. Stratified `u` stay stratified: at
    /// each node `u` is rescaled within the child's part.
    pub fn pick(&self, lights: &[Light], p: Vec3, u: f32) -> Option<(usize, f32)> {
        // A stratified number that rounded up to 1 counts as just below it.
        let mut u = (u as f64).min(1.0 - f64::EPSILON);
        let mut chance = 1.0f64;
        let mut node = 0u32;
        loop {
            match self.nodes[node as usize] {
                Node::Leaf { light } => {
                    // (A chance too small for `f32` would divide by 0.)
                    let chance = chance as f32;
                    return (chance > 0.0).then_some((light as usize, chance));
                }
                Node::Inner { children: [left, right], .. } => {
                    let (l, r) = (self.weight(lights, left, p), self.weight(lights, right, p));
                    if l + r <= 0.0 {
                        return None;
                    }
                    // The same quotients as `chance` works out.
                    let (first, second) = (l / (l + r), r / (l + r));
                    if u < first {
                        (node, u, chance) = (left, u / first, chance * first);
                    } else {
                        (node, u, chance) =
                            (right, ((u - first) / second).min(1.0 - f64::EPSILON), chance * second);
                    }
                }
            }
        }
    }

    /// The chance that [`ChoiceTree::pick`] at `p` picks light `light`.
    pub fn chance(&self, lights: &[Light], p: Vec3, light: usize) -> f32 {
        let mut node = self.leaves[light];
        let mut chance = 1.0f64;
        while node != 0 {
            let parent = self.parents[node as usize];
            let Node::Inner { children: [left, right], .. } = self.nodes[parent as usize] else {
                unreachable!("a parent is an inner node")
            };
            let (l, r) = (self.weight(lights, left, p), self.weight(lights, right, p));
            let own = if node == left { l } else { r };
            if l + r <= 0.0 || own <= 0.0 {
                return 0.0;
            }
            chance *= own / (l + r);
            node = parent;
        }
        chance as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Lights of every kind in a 4-unit box, facing every way: panels of
    /// several sizes (skewed too), triangles, point lights, spots of narrow
    /// and wide cones.
    fn lights(rng: &mut Rng, count: usize) -> Vec<Light> {
        let mut point = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
        let mut lights = Vec::new();
        for i in 0..count {
            let (a, b, c) = (point(), point(), point());
            let power = Vec3::splat(1.0 + (i % 5) as f32);
            lights.push(match i % 6 {
                0 => Light::Point { position: a, power },
                1 => Light::Spot {
                    position: a,
                    direction: b.normalize(),
                    cone_angle: 0.1 + 0.5 * (i % 4) as f32,
                    falloff_start: 0.05,
                    power,
                },
                5 => Light::triangle(a, a + 0.2 * b, a + 0.1 * c, power),
                _ => Light::area(a, 0.2 * b, 0.1 * c, power),
            });
        }
        lights
    }

    #[test]
    fn every_light_that_reaches_a_point_may_be_drawn_and_the_chances_add_up() {
        let mut rng = Rng::new(1, 0);
        for count in [2, 3, 65, 300] {
            let lights = lights(&mut rng, count);
            let tree = ChoiceTree::new(&lights);
            for _ in 0..400 {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 6.0 - 3.0;
                let chances: Vec<f32> = (0..count).map(|i| tree.chance(&lights, p, i)).collect();
                for (i, light) in lights.iter().enumerate() {
                    // Were a light that reaches `p` never drawn, its light
                    // would be missing from the image.
                    assert_eq!(light.reach(p) > 0.0, chances[i] > 0.0, "light {i} of {count} at {p}");
                }
                let sum: f32 = chances.iter().sum();
                assert!(sum <= 1.0 + 1e-5, "chances add up to {sum}");
                assert_eq!(tree.reaches(&lights, p), sum > 0.0);
            }
        }
    }

    #[test]
    fn lights_in_one_place_seen_from_that_place_share_the_chances() {
        let light = Light::Point { position: Vec3::ONE, power: Vec3::ONE };
        let lights = vec![light; 70];
        let tree = ChoiceTree::new(&lights);
        for p in [Vec3::ONE, Vec3::ZERO] {
            let chances: Vec<f32> = (0..70).map(|i| tree.chance(&lights, p, i)).collect();
            assert!(chances.iter().all(|&c| c > 0.0 && c.is_finite()), "{chances:?}");
            assert!((chances.iter().sum::<f32>() - 1.0).abs() < 1e-5);
            assert!(tree.pick(&lights, p, 0.999_999_9).is_some());
        }
    }

    #[test]
    fn a_number_rounded_up_to_one_still_picks_a_light() {
        // The first panel faces the point, the second (the root's second
        // child, further along x) away from it: all the chance is the first's.
        let down = Light::area(Vec3::new(0.0, 1.0, 0.0), Vec3::X * 0.2, Vec3::Z * 0.2, Vec3::ONE);
        let up = Light::area(Vec3::new(1.0, 1.0, 0.0), Vec3::Z * 0.2, Vec3::X * 0.2, Vec3::ONE);
        let lights = [down, up];
        let p = Vec3::new(0.5, 0.0, 0.0);
        let tree = ChoiceTree::new(&lights);
        assert_eq!(tree.chance(&lights, p, 1), 0.0);
        assert_eq!(tree.pick(&lights, p, 1.0), Some((0, 1.0)));
    }

    #[test]
    fn picks_come_as_often_as_their_chance_says() {
        let mut rng = Rng::new(2, 0);
        let lights = lights(&mut rng, 100);
        let tree = ChoiceTree::new(&lights);
        let draws = 200_000;
        for _ in 0..5 {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 3.0 - 1.5;
            let mut picked = vec![0u32; lights.len()];
            for k in 0..draws {
                // Stratified, as a shading point draws.
                let u = (k as f32 + rng.uniform()) / draws as f32;
                if let Some((i, chance)) = tree.pick(&lights, p, u) {
                    let again = tree.chance(&lights, p, i);
                    assert!((chance / again - 1.0).abs() < 1e-5, "pick says {chance}, chance {again}");
                    picked[i] += 1;
                }
            }
            for (i, &n) in picked.iter().enumerate() {
                let expected = tree.chance(&lights, p, i) as f64 * draws as f64;
                // Stratified draws land within a few of what is expected.
                assert!(
                    (n as f64 - expected).abs() <= 2.0 + 1e-3 * expected,
                    "light {i}: {n} against {expected}"
                );
            }
        }
    }

    #[test]
    fn cones_around_two_cones_hold_both() {
        let mut rng = Rng::new(3, 0);
        for _ in 0..1000 {
            let mut dir = || {
                (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0).as_dvec3().normalize()
            };
            let (a, b) = (dir(), dir());
            let (ta, tb) = (0.5 * rng.uniform() as f64, 1.5 * rng.uniform() as f64);
            let (axis, spread) = union_cones((a, ta), (b, tb));
            assert!(angle_between(axis, a) + ta <= spread + 1e-9);
            assert!(angle_between(axis, b) + tb <= spread + 1e-9);
            // No wider than the wider cone, or the cone through both's far edges.
            let narrowest = ta.max(tb).max(0.5 * (ta + angle_between(a, b) + tb));
            assert!(spread <= narrowest + 1e-9 || spread == std::f64::consts::PI);
        }
    }
}
