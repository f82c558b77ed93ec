//! Direct light at a surface point by shadow rays towards the lights: the
//! one estimator of light arriving straight from the lights, shared by all
//! integrators. Up to [`EVERY_LIGHT_UP_TO`] lights, a point samples every
//! light; with more, it draws that many among them, each in proportion to
//! what it could send there ([`LightChoice`]); above
//! [`TABLE_UP_TO`](crate::light_choice_tree::TABLE_UP_TO) lights, down a
//! tree rather than weighing each ([`ChoiceTree`]). A shadow ray to each of
//! 256 lights made 36.8M rays for 65,536 camera samples (BENCHMARKS.md,
//! issue 17).

use glam::{Vec2, Vec3};

use crate::accel::Ray;

use crate::bsdf::Bsdf;
use crate::light::Light;
use crate::light_choice_tree::ChoiceTree;
use crate::light_tree::Lights;
use crate::query::{RayCount, SceneQuery, SurfacePoint};
use crate::sampling::{stratified, Rng};

/// Up to this many lights, every shading point samples each one; with
/// more, it draws this many among them (times the samples a light of
/// [`LightSampling::Stratified`]).
pub const EVERY_LIGHT_UP_TO: usize = 8;

/// How lights are sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightSampling {
    /// `samples` stratified shadow rays per area light (one per point or
    /// spot light), each weighted equally (Whitted, photon mapping, SPPM).
    Stratified {
        /// Shadow rays per area light.
        samples: u32,
    },
    /// One shadow ray per light, area-light samples weighted against the
    /// BSDF's own sampling by the balance heuristic (the path tracer, which
    /// adds the other half of the heuristic where its paths hit a light).
    MultipleImportance,
}

/// Shadow rays traced together, at most (they wait on the stack).
const BATCH: usize = 16;

/// Light arriving straight from the lights at `sp` and scattered towards
/// the viewer by `bsdf`'s smooth lobes. Skips the shadow ray wherever the
/// light cannot contribute.
///
/// Where the intersector says batches pay (Embree 3 from 8 rays on, as ray
/// streams: 1.2x faster at 16 light samples, BENCHMARKS.md), the shadow rays
/// go to it in batches of up to 16. Nothing random depends on whether
/// a ray is blocked, and the unblocked contributions are added in the order
/// they were drawn, so the result is the same to the bit either way.
pub fn direct_light(
    query: &SceneQuery,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    sampling: LightSampling,
    rng: &mut Rng,
    count: &mut RayCount,
) -> Vec3 {
    sampled_light(query, sp, bsdf, sampling, Against::Nothing, rng, count)
}

/// [`direct_light`] from `samples` stratified shadow rays per area light
/// where rays that follow the glossy lobe also find the area lights'
/// fronts: each sample's glossy part is weighted by the balance heuristic
/// against `other(wi)` (see [`Against`]), the number of such rays from
/// `sp` times their density towards `wi`, and those rays add the rest (see
/// [`LightSamples::expected_count`]). The diffuse part, and point and spot
/// lights, which no ray finds, keep all their light (with
/// [`Against::LobeOnly`], the glossy part is all there is).
pub fn direct_light_against(
    query: &SceneQuery,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    samples: u32,
    against: Against,
    rng: &mut Rng,
    count: &mut RayCount,
) -> Vec3 {
    sampled_light(query, sp, bsdf, LightSampling::Stratified { samples }, against, rng, count)
}

/// What a light sample's contribution is weighed against.
#[derive(Clone, Copy)]
pub enum Against<'a> {
    /// Nothing: [`direct_light`].
    Nothing,
    /// Rays that follow the glossy lobe, with `other(wi)` their count
    /// times density: the glossy part is shared with them.
    Lobe(&'a dyn Fn(Vec3) -> f32),
    /// The same, and the glossy part alone is wanted: the light the lobe
    /// reflects, where the diffuse part is had otherwise (final gathering's
    /// records at a glossy surface a gather ray meets).
    LobeOnly(&'a dyn Fn(Vec3) -> f32),
}

/// [`direct_light`], or [`direct_light_against`] as `against` says.
fn sampled_light(
    query: &SceneQuery,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    sampling: LightSampling,
    against: Against,
    rng: &mut Rng,
    count: &mut RayCount,
) -> Vec3 {
    let plan = LightSamples::at(&query.scene.lights, sp.p, sampling);
    // Where a batch would not pay, each shadow ray is traced as it is drawn.
    let mut batch = query.accel.batches_pay((plan.most() as usize).min(BATCH)).then(ShadowBatch::new);
    let mut sum = Vec3::ZERO;
    for (_, light, u, divide_by, expected) in plan.take(rng) {
        let Some((ray, contribution)) =
            shadow_ray(sp, bsdf, sampling, against, light, u, divide_by, expected)
        else {
            continue;
        };
        match &mut batch {
            Some(batch) => {
                if batch.push(ray, contribution) {
                    sum = batch.flush(query, sum, count);
                }
            }
            None => {
                if !query.occluded(&ray, count) {
                    sum += contribution;
                }
            }
        }
    }
    match &mut batch {
        Some(batch) => batch.flush(query, sum, count),
        None => sum,
    }
}

/// The shadow ray of a sample of `light` at `sp` from the uniform pair `u`,
/// and the light it lets through if open, divided by `divide_by` (the
/// samples the light takes at this point, or is expected to); under
/// multiple importance sampling, `expected` is that expected count, which
/// multiplies the light's density against the BSDF's; `against`, another
/// strategy's count times density (see [`Against`]). `None` where the
/// sample cannot add anything.
#[inline]
#[allow(clippy::too_many_arguments)]
fn shadow_ray(
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    sampling: LightSampling,
    against: Against,
    light: &Light,
    u: Vec2,
    divide_by: f32,
    expected: f32,
) -> Option<(Ray, Vec3)> {
    let ls = light.sample_incident(sp.p, u)?;
    let wi = (ls.position - sp.p).normalize();
    let cos = wi.dot(sp.ns);
    if cos <= 0.0 || wi.dot(sp.ng) <= 0.0 || ls.irradiance == Vec3::ZERO {
        return None;
    }
    let f = match against {
        Against::LobeOnly(_) => bsdf.eval_glossy(wi),
        _ => bsdf.eval(wi),
    };
    if f == Vec3::ZERO {
        return None;
    }
    let contribution = match sampling {
        LightSampling::Stratified { .. } => match against {
            Against::LobeOnly(other) if !light.is_delta() => {
                let p_light = divide_by * light.pdf_solid_angle(ls.position, sp.p);
                let p_other = other(wi);
                // (Written so that an infinite density, a light seen edge
                // on, gives all or nothing rather than NaN.)
                let share = if p_other > 0.0 { 1.0 / (1.0 + p_other / p_light) } else { 1.0 };
                f * ls.irradiance * (cos / divide_by) * share
            }
            Against::Lobe(other) if !light.is_delta() => {
                // Each of this light's samples has its density; `divide_by`
                // is how many it takes here (or is expected to).
                let p_light = divide_by * light.pdf_solid_angle(ls.position, sp.p);
                let p_other = other(wi);
                let weighed = if p_other > 0.0 {
                    f - bsdf.eval_glossy(wi) * (p_other / (p_light + p_other))
                } else {
                    f
                };
                weighed * ls.irradiance * (cos / divide_by)
            }
            _ => f * ls.irradiance * (cos / divide_by),
        },
        LightSampling::MultipleImportance if light.is_delta() => f * ls.irradiance * (cos / divide_by),
        LightSampling::MultipleImportance => {
            let p_light = expected * light.pdf_solid_angle(ls.position, sp.p);
            let p_bsdf = bsdf.pdf(wi);
            f * ls.irradiance * (cos / divide_by) * (p_light / (p_light + p_bsdf))
        }
    };
    Some((sp.spawn_to(ls.position), contribution))
}

/// The light samples a shading point takes. Up to [`EVERY_LIGHT_UP_TO`]
/// lights, or where no more than that many reach the point, each light
/// (that reaches it) takes its samples, stratified over its area; where
/// more reach it, the point draws `EVERY_LIGHT_UP_TO` times a light's
/// samples among them ([`LightChoice`]). Above
/// [`TABLE_UP_TO`](crate::light_choice_tree::TABLE_UP_TO) lights, the
/// point always draws, down the scene's [`ChoiceTree`], without weighing
/// each light (none where no light may reach it).
pub struct LightSamples<'l> {
    lights: &'l [Light],
    sampling: LightSampling,
    /// With many lights: how the point chooses among them.
    choice: Option<Choice<'l>>,
    /// How many times the point draws among them, if it does.
    draws: Option<u32>,
}

/// How a point chooses among many lights.
enum Choice<'l> {
    /// Each light weighed at the point.
    Table(LightChoice<'l>),
    /// Drawn down the tree at the point.
    Tree(&'l ChoiceTree, Vec3),
}

impl<'l> LightSamples<'l> {
    /// The samples at `p` of `lights` under `sampling` (one a light under
    /// multiple importance sampling, and for point and spot lights).
    pub fn at(lights: &'l Lights, p: Vec3, sampling: LightSampling) -> Self {
        let choice = (lights.len() > EVERY_LIGHT_UP_TO).then(|| match lights.choice_tree() {
            Some(tree) => Choice::Tree(tree, p),
            None => Choice::Table(LightChoice::at(lights, p)),
        });
        let per_light = match sampling {
            LightSampling::Stratified { samples } => samples,
            LightSampling::MultipleImportance => 1,
        };
        let draws = EVERY_LIGHT_UP_TO as u32 * per_light;
        let draws = match &choice {
            None => None,
            Some(Choice::Table(table)) => (table.reaching > EVERY_LIGHT_UP_TO).then_some(draws),
            Some(Choice::Tree(tree, p)) => Some(if tree.reaches(lights, *p) { draws } else { 0 }),
        };
        LightSamples { lights, sampling, choice, draws }
    }

    /// Samples light `light` takes when each light takes its own.
    fn of(&self, light: &Light) -> u32 {
        match self.sampling {
            LightSampling::Stratified { samples } if !light.is_delta() => samples,
            _ => 1,
        }
    }

    /// Whether the point draws among the lights, and how many times.
    fn draws(&self) -> Option<(&Choice<'l>, u32)> {
        Some((self.choice.as_ref()?, self.draws?))
    }

    /// Whether light `i` may reach the point when each light takes its own
    /// samples (with few lights, each may; with the tree, the point draws).
    fn reaches(&self, i: usize) -> bool {
        match &self.choice {
            Some(Choice::Table(table)) => table.reach[i] > 0.0,
            _ => true,
        }
    }

    /// How many samples the point takes, at most.
    pub fn most(&self) -> u32 {
        match self.draws {
            Some(draws) => draws,
            None => {
                (0..self.lights.len()).filter(|&i| self.reaches(i)).map(|i| self.of(&self.lights[i])).sum()
            }
        }
    }

    /// The density of the light-sampling strategy at a point of `light`
    /// (one of `lights`), against its own [`Light::pdf_solid_angle`], under
    /// multiple importance sampling: the draws expected to pick it at `p`
    /// (one, where every light that reaches `p` takes a sample). For the
    /// weights where a path meets a light, or a light subpath leaves one.
    #[inline]
    pub fn mis_factor(lights: &Lights, light: &Light, p: Vec3) -> f32 {
        Self::expected_count(lights, light, p, LightSampling::MultipleImportance)
    }

    /// The density with which a point at `from`, taking `samples`
    /// stratified shadow rays per area light, sends one towards the point
    /// `on` of `light` (one of `lights`): the samples the light takes there
    /// ([`LightSamples::expected_count`]) times each one's density. The
    /// shadow rays' side of the balance heuristic that
    /// [`direct_light_against`] weighs a lobe's rays against.
    pub fn stratified_density(lights: &Lights, light: &Light, samples: u32, from: Vec3, on: Vec3) -> f32 {
        let sampling = LightSampling::Stratified { samples };
        Self::expected_count(lights, light, from, sampling) * light.pdf_solid_angle(on, from)
    }

    /// The share, by the balance heuristic, of a light's front at `on`
    /// that a lobe's ray from `from` keeps, drawn with density `pdf`; the
    /// rest is the `samples` shadow rays' ([`LightSamples::stratified_density`]).
    /// An infinite shadow-ray density (a light seen edge on) leaves the
    /// lobe no share.
    pub fn lobe_share(lights: &Lights, light: &Light, samples: u32, from: Vec3, on: Vec3, pdf: f32) -> f32 {
        1.0 / (1.0 + Self::stratified_density(lights, light, samples, from, on) / pdf)
    }

    /// How many samples `light` (one of `lights`) takes at `p` under
    /// `sampling`, or is expected to where the point draws among the
    /// lights: what its [`Light::pdf_solid_angle`] is multiplied by for
    /// the light-sampling strategy's part of a balance heuristic.
    pub fn expected_count(lights: &Lights, light: &Light, p: Vec3, sampling: LightSampling) -> f32 {
        let plan = LightSamples::at(lights, p, sampling);
        let Some((choice, draws)) = plan.draws() else { return plan.of(light) as f32 };
        let Some(index) = lights.index_of(light) else { return 1.0 };
        match choice {
            Choice::Table(table) => table.expected(draws, table.share(index)),
            Choice::Tree(tree, p) => draws as f32 * tree.chance(lights, *p, index),
        }
    }

    /// Each light sample in turn: the light's index and the light, the
    /// uniform pair for the point on it, what its light is divided by (the
    /// samples the light takes, or is expected to), and the count the
    /// light-sampling strategy expects of it there (its density's factor
    /// under multiple importance sampling: 1 where each light takes its
    /// own samples).
    pub fn take<'p, 'r>(&'p self, rng: &'r mut Rng) -> Taken<'p, 'l, 'r> {
        let state = match self.draws() {
            Some((Choice::Table(table), draws)) => State::Drawing { walk: table.walk(), draws, i: 0 },
            Some((&Choice::Tree(tree, p), draws)) => State::Descending { tree, p, draws, i: 0 },
            None => State::Each { light: 0, i: 0 },
        };
        Taken { plan: self, rng, state }
    }
}

/// The light samples of [`LightSamples::take`], drawn as they are asked for.
pub struct Taken<'p, 'l, 'r> {
    plan: &'p LightSamples<'l>,
    rng: &'r mut Rng,
    state: State<'p, 'l>,
}

enum State<'p, 'l> {
    /// Draw `i` of `draws` among many lights.
    Drawing { walk: Walk<'p, 'l>, draws: u32, i: u32 },
    /// Draw `i` of `draws` down the tree at `p`.
    Descending { tree: &'l ChoiceTree, p: Vec3, draws: u32, i: u32 },
    /// Sample `i` of light `light`, each light taking its own.
    Each { light: usize, i: u32 },
}

impl<'l> Iterator for Taken<'_, 'l, '_> {
    type Item = (usize, &'l Light, Vec2, f32, f32);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        let plan = self.plan;
        match &mut self.state {
            State::Drawing { walk, draws, i } => {
                if *i == *draws {
                    return None;
                }
                // Stratified over the lights' reach.
                let (index, share) = walk.at((*i as f32 + self.rng.uniform()) / *draws as f32)?;
                let expected = walk.choice.expected(*draws, share);
                *i += 1;
                Some((index, &plan.lights[index], self.rng.uniform2(), expected, expected))
            }
            State::Descending { tree, p, draws, i } => loop {
                if *i == *draws {
                    return None;
                }
                // Stratified over the tree's choices; a draw that finds no
                // light reaching the point adds nothing.
                let u = (*i as f32 + self.rng.uniform()) / *draws as f32;
                *i += 1;
                if let Some((index, chance)) = tree.pick(plan.lights, *p, u) {
                    let expected = *draws as f32 * chance;
                    return Some((index, &plan.lights[index], self.rng.uniform2(), expected, expected));
                }
            },
            State::Each { light, i } => loop {
                let l = plan.lights.get(*light)?;
                let n = plan.of(l);
                if *i < n && plan.reaches(*light) {
                    let u = stratified(*i, n, self.rng);
                    *i += 1;
                    return Some((*light, l, u, n as f32, 1.0));
                }
                (*light, *i) = (*light + 1, 0);
            },
        }
    }
}

/// How a shading point chooses among many lights: each in proportion to
/// [`Light::reach`] there, what it could send the point unblocked.
pub struct LightChoice<'l> {
    lights: &'l [Light],
    /// Each light's reach at the point.
    reach: Vec<f32>,
    /// Their sum, in the lights' order.
    total: f32,
    /// How many reach it at all.
    reaching: usize,
}

impl<'l> LightChoice<'l> {
    /// The choice at `p` among `lights`.
    pub fn at(lights: &'l [Light], p: Vec3) -> Self {
        let reach: Vec<f32> = lights.iter().map(|l| l.reach(p)).collect();
        let total = reach.iter().sum();
        let reaching = reach.iter().filter(|&&r| r > 0.0).count();
        LightChoice { lights, reach, total, reaching }
    }

    /// How many of `draws` draws are expected to pick a light of `share`.
    fn expected(&self, draws: u32, share: f32) -> f32 {
        draws as f32 * share
    }

    /// Light `i`'s share of the total reach.
    fn share(&self, i: usize) -> f32 {
        self.reach[i] / self.total
    }

    /// A walk along the lights for draws in increasing order.
    fn walk(&self) -> Walk<'_, 'l> {
        Walk { choice: self, next: 0, end: 0.0, current: None }
    }
}

/// Lights picked in turn by increasing uniforms: each light holds the part
/// of `[0, total)` as wide as its reach, in the lights' order.
struct Walk<'c, 'l> {
    choice: &'c LightChoice<'l>,
    /// The next light to look at.
    next: usize,
    /// Where the current light's part ends.
    end: f32,
    /// The last light with any reach.
    current: Option<usize>,
}

impl Walk<'_, '_> {
    /// The index of the light whose part holds `u * total` (`u` no smaller
    /// than the last call's), and its share of the total. A `u` that rounds
    /// past the end picks the last light with any reach.
    fn at(&mut self, u: f32) -> Option<(usize, f32)> {
        let c = self.choice;
        let target = u * c.total;
        loop {
            if let Some(i) = self.current {
                if target < self.end || self.next == c.lights.len() {
                    return Some((i, c.share(i)));
                }
            } else if self.next == c.lights.len() {
                return None;
            }
            if c.reach[self.next] > 0.0 {
                self.end += c.reach[self.next];
                self.current = Some(self.next);
            }
            self.next += 1;
        }
    }
}

/// Shadow rays waiting to be traced, each with the light it lets through.
struct ShadowBatch {
    rays: [Ray; BATCH],
    contributions: [Vec3; BATCH],
    len: usize,
}

impl ShadowBatch {
    fn new() -> Self {
        let nothing = Ray::new(Vec3::ZERO, Vec3::Z);
        ShadowBatch { rays: [nothing; BATCH], contributions: [Vec3::ZERO; BATCH], len: 0 }
    }

    /// Adds a shadow ray; says whether the batch is now full.
    fn push(&mut self, ray: Ray, contribution: Vec3) -> bool {
        self.rays[self.len] = ray;
        self.contributions[self.len] = contribution;
        self.len += 1;
        self.len == BATCH
    }

    /// Traces the waiting rays and adds, in order, what the unblocked ones
    /// let through to `sum`; leaves the batch empty.
    fn flush(&mut self, query: &SceneQuery, mut sum: Vec3, count: &mut RayCount) -> Vec3 {
        let n = std::mem::take(&mut self.len);
        let mut occluded = [false; BATCH];
        match n {
            0 => return sum,
            // One ray: no batch to gain from.
            1 => occluded[0] = query.occluded(&self.rays[0], count),
            _ => query.occluded_batch(&self.rays[..n], &mut occluded[..n], count),
        }
        for (&c, &blocked) in self.contributions[..n].iter().zip(&occluded[..n]) {
            if !blocked {
                sum += c;
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{self, Backend, Hit, Intersector};
    use crate::query::Interaction;
    use crate::scene::Scene;

    /// Answers as the intersector it wraps, but traces batches ray by ray
    /// (the trait's own `occluded_batch`).
    struct OneByOne<'a>(&'a dyn Intersector);

    impl Intersector for OneByOne<'_> {
        fn intersect(&self, ray: &Ray) -> Option<Hit> {
            self.0.intersect(ray)
        }
        fn occluded(&self, ray: &Ray) -> bool {
            self.0.occluded(ray)
        }
        fn name(&self) -> String {
            format!("{} one by one", self.0.name())
        }
    }

    #[test]
    fn batched_shadow_rays_give_the_same_light_to_the_bit() {
        // A floor, a blocker half over it, two area lights and a point light.
        let scene = Scene::from_toml(
            r#"
            [camera]
            eye = [0, 3, 0]
            look_at = [0, 0, 0]
            up = [0, 0, 1]
            [materials.m]
            diffuse = 0.5
            specular = 0.3
            phong_exponent = 10
            [[quad]]
            center = [0, 0, 0]
            u = [0, 0, 2]
            v = [2, 0, 0]
            material = "m"
            [[quad]]
            center = [0.5, 1, 0]
            u = [0, 0, 0.5]
            v = [0.5, 0, 0]
            material = "m"
            [[area_light]]
            center = [0, 2, 0]
            u = [0.6, 0, 0]
            v = [0, 0, 0.6]
            power = 20
            [[area_light]]
            center = [1, 1.8, 0.5]
            u = [0.3, 0, 0]
            v = [0, 0, 0.3]
            power = 5
            [[point_light]]
            position = [-0.5, 1.5, 0.3]
            power = 3
        "#,
            std::path::Path::new("blocker.toml"),
        )
        .unwrap();
        let embree = accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
        let batched = SceneQuery::new(&scene, embree.as_ref());
        let single = OneByOne(embree.as_ref());
        let one_by_one = SceneQuery::new(&scene, &single);
        let (mut shadowed, mut lit) = (0, 0);
        for i in 0..400 {
            let (x, z) = ((i % 20) as f32 / 10.0 - 0.95, (i / 20) as f32 / 10.0 - 0.95);
            // From just above the floor (the scene is placed about the
            // camera), below the lights, whose backs block rays.
            let above_floor = (glam::DVec3::new(x as f64, 0.5, z as f64) - scene.origin).as_vec3();
            let down = Ray::new(above_floor, -Vec3::Y);
            let mut count = RayCount::default();
            let Some(Interaction::Surface(sp)) = batched.first(&down, &mut count) else {
                panic!("floor missed")
            };
            let bsdf = Bsdf::new(batched.material(&sp), &sp, down.dir);
            // 37 rays per area light: two full batches and a part of one.
            for sampling in [LightSampling::Stratified { samples: 37 }, LightSampling::MultipleImportance] {
                let (mut c1, mut c2) = (RayCount::default(), RayCount::default());
                let a = direct_light(&batched, &sp, &bsdf, sampling, &mut Rng::new(3, i), &mut c1);
                let b = direct_light(&one_by_one, &sp, &bsdf, sampling, &mut Rng::new(3, i), &mut c2);
                assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits), "at ({x}, {z})");
                assert_eq!(c1, c2);
                assert!(a.is_finite() && a.min_element() >= 0.0);
            }
            // Blocked rays are told apart from open ones: some points see
            // all of the light, some only part of it.
            let all = direct_light(
                &batched,
                &sp,
                &bsdf,
                LightSampling::Stratified { samples: 37 },
                &mut Rng::new(3, i),
                &mut count,
            );
            let unblocked = direct_light(
                &SceneQuery::new(&scene, &NothingBlocks(embree.as_ref())),
                &sp,
                &bsdf,
                LightSampling::Stratified { samples: 37 },
                &mut Rng::new(3, i),
                &mut count,
            );
            if all.x < 0.999 * unblocked.x {
                shadowed += 1;
            } else {
                lit += 1;
            }
        }
        assert!(shadowed > 20 && lit > 20, "{shadowed} shadowed, {lit} lit");
    }

    /// Answers as the intersector it wraps, except that no shadow ray is blocked.
    struct NothingBlocks<'a>(&'a dyn Intersector);

    impl Intersector for NothingBlocks<'_> {
        fn intersect(&self, ray: &Ray) -> Option<Hit> {
            self.0.intersect(ray)
        }
        fn occluded(&self, _: &Ray) -> bool {
            false
        }
        fn name(&self) -> String {
            "nothing blocks".into()
        }
    }
}
