//! Direct light at a surface point by shadow rays towards every light: the
//! one estimator of light arriving straight from the lights, shared by all
//! integrators.

use glam::Vec3;

use crate::accel::Ray;

use crate::bsdf::Bsdf;
use crate::query::{RayCount, SceneQuery, SurfacePoint};
use crate::sampling::{stratified, Rng};

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
    let samples = |light: &crate::light::Light| match sampling {
        LightSampling::Stratified { samples } if !light.is_delta() => samples,
        _ => 1,
    };
    let rays: u32 = query.scene.lights.iter().map(samples).sum();
    // Where a batch would not pay, each shadow ray is traced as it is drawn.
    let mut batch = query.accel.batches_pay(rays.min(BATCH as u32) as usize).then(ShadowBatch::new);
    let mut sum = Vec3::ZERO;
    for light in &query.scene.lights {
        let samples = samples(light);
        for i in 0..samples {
            let Some(ls) = light.sample_incident(sp.p, stratified(i, samples, rng)) else { continue };
            let wi = (ls.position - sp.p).normalize();
            let cos = wi.dot(sp.ns);
            if cos <= 0.0 || wi.dot(sp.ng) <= 0.0 || ls.irradiance == Vec3::ZERO {
                continue;
            }
            let f = bsdf.eval(wi);
            if f == Vec3::ZERO {
                continue;
            }
            let contribution = match sampling {
                LightSampling::Stratified { .. } => f * ls.irradiance * (cos / samples as f32),
                LightSampling::MultipleImportance if light.is_delta() => f * ls.irradiance * cos,
                LightSampling::MultipleImportance => {
                    let p_light = light.pdf_solid_angle(ls.position, sp.p);
                    let p_bsdf = bsdf.pdf(wi);
                    f * ls.irradiance * cos * (p_light / (p_light + p_bsdf))
                }
            };
            let ray = sp.spawn_to(ls.position);
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
    }
    match &mut batch {
        Some(batch) => batch.flush(query, sum, count),
        None => sum,
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
