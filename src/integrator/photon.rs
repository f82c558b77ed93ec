//! Photon mapping (Jensen 1996, 2001): Whitted ray tracing for direct light
//! and specular chains, plus, at every diffuse or glossy surface it reaches,
//! caustics from the caustic map and indirect light from the global map,
//! read by final gathering (or shown directly when there are no gather rays).

mod gather_count;
mod record_texels;

use std::f32::consts::{FRAC_1_PI, PI};

use glam::{Vec2, Vec3};

use super::direct::{direct_light_against, Against, LightSamples};
use super::whitted::{Lit, Shading, SurfaceLight, WhittedTracer};
use super::{Context, Integrator, Progress, Rendered, Tuned};
use crate::accel::Hit;
use crate::accel::Ray;
use crate::bsdf::{Bsdf, RadianceScale};
use crate::config::{Estimate, PhotonConfig, RenderConfig};
use crate::light::Light;
use crate::photon::guide::GatherGuide;
use crate::photon::{build_maps, PhotonMap, PhotonMaps};
use crate::query::{Interaction, RayCount, SceneQuery, SurfacePoint};
use crate::sampling::{around, cosine_hemisphere, Frame, Rng, Strata};
use record_texels::{RecordTexels, SideHit};

/// The photon-mapping integrator.
pub struct PhotonMapping;

/// With a time budget of `t` seconds, the seconds to spend tracing and
/// building photon maps: none beyond the scene's own counts under 10 s,
/// then `0.43 t^(2/3)` (2 s of 10, 6.6 s of 60).
///
/// More photons shrink the estimates' radii, and with them the bias that
/// more camera samples cannot remove, so the error keeps falling as the
/// budget grows. The bias falls as 1 / photons (the radius squared at a
/// fixed k) and the noise as 1 / sqrt(samples); the least error for a time
/// `t` takes photons growing as `t^(2/3)` and samples as `t`. Bigger maps
/// also make each sample slower (deeper trees), and under 10 s the samples'
/// noise is most of the error: there more photons cost more than they gave
/// (BENCHMARKS.md, "Photon counts under a time budget").
fn photon_seconds(t: f64) -> f64 {
    if t < 10.0 {
        0.0
    } else {
        0.2 * 10f64.cbrt() * t.powf(2.0 / 3.0)
    }
}

/// The next photon count, as a multiple of the scene's, for maps that are
/// to take `target` seconds in all, when `spent` seconds are gone and the
/// last maps (at `factor` times the scene's count) took `last` seconds: what
/// the time left affords at the last maps' rate, at most 16 times them (the
/// rate is measured again at each step), or `None` when that is not at
/// least twice as many.
fn grow_photons(target: f64, spent: f64, last: f64, factor: f64) -> Option<f64> {
    let per_factor = last.max(1e-6) / factor;
    let next = ((target - spent) / per_factor).min(16.0 * factor);
    (next >= 2.0 * factor).then_some(next)
}

/// `photons` with `factor` times the photon counts (at most the limit).
fn scaled_photons(photons: &PhotonConfig, factor: f64) -> PhotonConfig {
    let grow = |n: u32| (n as f64 * factor).min(crate::config::limits::MAX_PHOTONS as f64) as u32;
    PhotonConfig {
        global_photons: grow(photons.global_photons),
        caustic_photons: grow(photons.caustic_photons),
        ..photons.clone()
    }
}

impl Integrator for PhotonMapping {
    fn refines_by_samples(&self) -> bool {
        true
    }

    fn pixels_sample_alone(&self) -> bool {
        true
    }

    /// The scene's maps; with a time budget, as many more photons as
    /// `photon_seconds` afford (never fewer than the scene's), grown in
    /// steps of at most 16 times, each judged by how long the last took.
    fn photon_maps(&self, ctx: &Context) -> Option<PhotonMaps> {
        let config = ctx.config;
        let mut maps = build_maps(
            &ctx.query,
            &config.photons,
            config.max_depth,
            config.seed,
            config.sampler,
            ctx.diagonal,
        );
        let Some(budget) = config.time else { return Some(maps) };
        // No map built (no light, say): nothing to grow.
        if maps.stats.global_emitted + maps.stats.caustic_emitted == 0 {
            return Some(maps);
        }
        let target = photon_seconds(budget as f64);
        let seconds = |maps: &PhotonMaps| maps.stats.trace_seconds + maps.stats.build_seconds;
        // Half the memory available at most, for the film and all else.
        let available = crate::memory::available().map(|bytes| bytes / 2);
        let fits = |photons: &PhotonConfig| {
            let scaled = RenderConfig { photons: photons.clone(), ..config.clone() };
            crate::memory::Estimate::of(ctx.scene(), &scaled).check(available).is_ok()
        };
        let (mut spent, mut factor) = (seconds(&maps), 1.0);
        // Every step's time and rays, reported with the last maps.
        let (mut traced, mut built) = (maps.stats.trace_seconds, maps.stats.build_seconds);
        let mut rays = maps.stats.rays;
        while let Some(next) = grow_photons(target, spent, seconds(&maps), factor) {
            // The most that fit in memory, halving down to twice the last.
            let fitting = std::iter::successors(Some(next), |f| Some(f / 2.0))
                .take_while(|&f| f >= 2.0 * factor)
                .map(|f| (f, scaled_photons(&config.photons, f)))
                .find(|(_, photons)| fits(photons));
            let Some((next, photons)) = fitting else { break };
            // At the photon-count limit: no more to grow.
            if photons == scaled_photons(&config.photons, factor) {
                break;
            }
            let more =
                build_maps(&ctx.query, &photons, config.max_depth, config.seed, config.sampler, ctx.diagonal);
            spent += seconds(&more);
            traced += more.stats.trace_seconds;
            built += more.stats.build_seconds;
            rays += more.stats.rays;
            (maps, factor) = (more, next);
        }
        (maps.stats.trace_seconds, maps.stats.build_seconds, maps.stats.rays) = (traced, built, rays);
        Some(maps)
    }

    /// With final gathering and a budget of at least 1 s (`PILOT_FROM_SECONDS`),
    /// the gather rays per camera sample that spend the budget best, from a
    /// pilot on the maps built (`gather_count`).
    fn tuned_for_time(&self, ctx: &Context) -> Option<Tuned> {
        let maps = ctx.photon_maps?;
        let budget = ctx.config.time? as f64;
        if !maps.for_gathering || maps.global.is_none() || budget < PILOT_FROM_SECONDS {
            return None;
        }
        let texels = RecordTexels::for_maps(ctx, maps);
        let (gather_rays, note, rays) =
            gather_count::choose(ctx, &MapLight::new(ctx, maps, texels.as_ref()), budget);
        let mut config = ctx.config.clone();
        config.photons.gather_rays = gather_rays;
        Some(Tuned { config, note, rays })
    }

    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered {
        let traced;
        let maps = match ctx.photon_maps {
            Some(loaded) => loaded,
            None => {
                traced = self.photon_maps(ctx).expect("photon mapping builds its maps");
                &traced
            }
        };
        let texels = RecordTexels::for_maps(ctx, maps);
        let light = MapLight::new(ctx, maps, texels.as_ref());
        let tracer = light.tracer(ctx);
        let s = &maps.stats;
        let mut notes = vec![if s.loaded {
            format!(
                "photons: {} global and {} caustic, from the saved maps",
                s.global_emitted, s.caustic_emitted
            )
        } else {
            format!(
                "photons: {} global and {} caustic emitted, traced in {:.2} s, maps built in {:.2} s",
                s.global_emitted, s.caustic_emitted, s.trace_seconds, s.build_seconds
            )
        }];
        notes.extend(s.skipped.iter().map(|line| format!("photons: {line}")));
        let mut rendered = tracer.render(progress, notes);
        // The photons' rays count where this render traced them (given
        // maps were traced before it, or by the caller, who counts them).
        if ctx.photon_maps.is_none() {
            rendered.stats.rays += s.rays;
        }
        rendered
    }
}

/// The maps of `ctx`'s settings for its scene, traced with seed 0 (for tests).
#[cfg(test)]
fn maps_for_tests(ctx: &Context) -> PhotonMaps {
    let config = ctx.config;
    build_maps(&ctx.query, &config.photons, config.max_depth, 0, config.sampler, ctx.diagonal)
}

/// The shortest budget for which photon mapping chooses its gather rays by
/// a pilot: at 1 s on the 256 x 256 Cornell boxes the pilot (0.06 s) takes
/// 18% off the error under the point light, and its bright gathering
/// specks (16 rays, where the scene says 4), and costs 4% more under the
/// area light, where it keeps the scene's 4 (BENCHMARKS.md). Below 1 s
/// its share of the budget grows.
const PILOT_FROM_SECONDS: f64 = 1.0;

/// Gather rays traced together, at most (they wait on the stack).
const GATHER_BATCH: usize = 16;

/// Caustics and indirect light from the photon maps.
#[derive(Clone, Copy)]
struct MapLight<'a> {
    query: SceneQuery<'a>,
    maps: &'a PhotonMaps,
    global_estimate: Estimate,
    caustic_estimate: Estimate,
    /// Final-gathering rays per camera sample, before scaling by the path's weight.
    gather_per_sample: u32,
    /// Whether gather rays follow the global map's guides (where it has them).
    guided: bool,
    /// Shadow rays per area light at each surface.
    light_samples: u32,
    /// Whether the scene has area lights, which gather rays can meet.
    area_lights: bool,
    /// Whether it has point or spot lights, which no ray meets.
    delta_lights: bool,
    /// The records the gather rays' hits read, by triangle and barycentrics.
    texels: Option<&'a RecordTexels>,
}

/// Shadow rays per area light at each camera sample's surfaces unless the
/// scene says. The gather rays beside them hold most of a sample's noise:
/// under a time budget one shadow ray (more samples in the same time) left
/// 2-8% less error than four on the area-lit Cornell box (BENCHMARKS.md,
/// "One shadow ray where passes or gather rays average it").
const LIGHT_SAMPLES: u32 = 1;

impl<'a> MapLight<'a> {
    /// The recursion that adds this light at every diffuse or glossy surface.
    fn tracer(&'a self, ctx: &'a Context<'a>) -> WhittedTracer<'a> {
        WhittedTracer { ctx, surface_light: Some(self), light_samples: self.light_samples }
    }

    /// The light of `maps` with the settings of `ctx`, gather rays reading
    /// their records through `texels` (made for the same maps).
    fn new(ctx: &Context<'a>, maps: &'a PhotonMaps, texels: Option<&'a RecordTexels>) -> Self {
        let photons = &ctx.config.photons;
        MapLight {
            query: ctx.query,
            maps,
            global_estimate: photons.global_estimate(ctx.diagonal),
            caustic_estimate: photons.caustic_estimate(ctx.diagonal),
            gather_per_sample: photons.gather_rays,
            guided: photons.guided_gathering,
            light_samples: ctx.config.light_samples_or(LIGHT_SAMPLES),
            area_lights: ctx.query.scene.lights.iter().any(|light| !light.is_delta()),
            delta_lights: ctx.query.scene.lights.iter().any(|light| light.is_delta()),
            texels,
        }
    }
}

impl SurfaceLight for MapLight<'_> {
    /// On a glossy surface, the light its lobe reflects from area lights is
    /// shared between the shadow rays and the lobe's gather rays that meet
    /// a light's front (see [`GatherPlan::weighs_lights`]); elsewhere the
    /// shadow rays hold all of it.
    fn direct(&self, here: &Shading, rng: &mut Rng, count: &mut RayCount) -> Option<Vec3> {
        let Shading { sp, bsdf, throughput } = *here;
        // (Asked first: the plan looks up a guide.)
        if !self.area_lights || bsdf.glossy_share() <= 0.0 {
            return None;
        }
        let plan = self.gather_plan(sp, bsdf, throughput)?;
        if !plan.weighs_lights() {
            return None;
        }
        let other = |wi: Vec3| plan.lobe_density(bsdf, wi);
        let against = Against::Lobe(&other);
        Some(direct_light_against(&self.query, sp, bsdf, self.light_samples, against, rng, count))
    }

    fn at(&self, here: &Shading, rng: &mut Rng, count: &mut RayCount) -> Lit {
        let Shading { sp, bsdf, throughput } = *here;
        let (m, wo) = (bsdf.material(), bsdf.wo());
        let plan = self.gather_plan(sp, bsdf, throughput);
        let caustic = match &self.maps.caustic {
            // A sharp lobe's part of an area light's caustic is the gather
            // rays' (see `GatherPlan::lobe_caustics`).
            Some(caustic) if plan.is_some_and(|plan| plan.lobe_caustics) => {
                caustic.radiance_by(sp.p, sp.ns, &self.caustic_estimate, |photon| {
                    if photon.from_delta_light {
                        m.brdf(sp.ns, photon.incoming, wo)
                    } else {
                        m.diffuse * FRAC_1_PI
                    }
                })
            }
            Some(caustic) => caustic.radiance(sp.p, sp.ns, wo, m, &self.caustic_estimate),
            None => Vec3::ZERO,
        };
        let gathered = match (&self.maps.global, plan) {
            (Some(global), Some(plan)) => self.final_gather(sp, bsdf, global, &plan, rng, count),
            (Some(global), None) if !self.maps.for_gathering => {
                Lit { indirect: global.radiance(sp.p, sp.ns, wo, m, &self.global_estimate), ..Lit::default() }
            }
            _ => Lit::default(),
        };
        Lit { caustic: caustic + gathered.caustic, ..gathered }
    }
}

impl MapLight<'_> {
    /// Indirect light at `sp` by final gathering (Jensen): rays sample the
    /// light arriving from the hemisphere, each asking the global map for the
    /// radiance leaving the diffuse surface it meets. Their directions follow
    /// the guide of the nearest irradiance record (where its photons came
    /// from, half of them; the cosine, the other half) or, unguided, the
    /// cosine; on a glossy surface some follow its lobe ([`glossy_or_gathered`]).
    ///
    /// Each camera sample sends its own gather rays (so more samples mean
    /// more gathering, and the estimate keeps converging), scaled by the
    /// weight of the path that got here (`throughput`), at least one: a
    /// surface seen through a 4% glass reflection needs few. Any count gives
    /// an unbiased estimate; fewer only add noise where it is weighted down.
    ///
    /// Returns the indirect light; the share of the area lights' light the
    /// rays that met a light's front keep (on glossy surfaces only:
    /// [`GatherPlan::weighs_lights`]), which is direct light; and, on sharp
    /// lobes, the lobe's part of area lights' caustics, which the rays find
    /// through mirrors and glass ([`GatherPlan::lobe_caustics`]).
    fn final_gather(
        &self,
        sp: &SurfacePoint,
        bsdf: &Bsdf,
        global: &PhotonMap,
        plan: &GatherPlan,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Lit {
        let GatherPlan { rays: n, guide, glossy, .. } = *plan;
        // The rays go out in batches: every direction of a batch is drawn
        // first, then the batch is traced at once (Embree 3's ray streams),
        // then each hit is shaded in order. Only the order of draws decides
        // the image, never how the intersector takes the batch.
        let (mut sum, mut lights, mut caustic) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); GATHER_BATCH];
        // Each ray's BSDF, `cos / pdf`, and whether it followed the glossy lobe.
        let mut weights = [(Vec3::ZERO, 0.0, false); GATHER_BATCH];
        let strata = Strata::of(n);
        for start in (0..n).step_by(GATHER_BATCH) {
            let mut len = 0;
            for i in start..(start + GATHER_BATCH as u32).min(n) {
                let u = strata.sample(i, rng);
                let (wi, cos_over_pdf, from_lobe) = if glossy > 0.0 {
                    glossy_or_gathered(sp, bsdf, plan, u)
                } else {
                    let (wi, cos_over_pdf) = gathered_direction(sp, guide, u);
                    (wi, cos_over_pdf, false)
                };
                if wi.dot(sp.ng) <= 0.0 || cos_over_pdf <= 0.0 {
                    continue;
                }
                (rays[len], weights[len]) = (sp.spawn(wi), (bsdf.eval(wi), cos_over_pdf, from_lobe));
                len += 1;
            }
            let mut add =
                |j: usize, first: Option<Interaction<Hit>>, read: Option<Vec3>, count: &mut RayCount| {
                    let (f, cos_over_pdf, from_lobe) = weights[j];
                    match first {
                        Some(Interaction::Emitter { light, t, radiance }) if plan.weighs_lights() => {
                            if from_lobe {
                                let glossy = bsdf.eval_glossy(rays[j].dir);
                                lights +=
                                    glossy * radiance * self.lobe_weight(sp, bsdf, plan, &rays[j], light, t);
                            }
                        }
                        first => {
                            let seen = if plan.lobe_caustics { LightsSeen::Caustic } else { LightsSeen::Not };
                            let found = self.gathered(&rays[j], first, read, global, seen, rng, count);
                            if found.incoming != Vec3::ZERO {
                                sum += f * found.incoming * cos_over_pdf;
                            }
                            if found.caustic != Vec3::ZERO {
                                caustic += bsdf.eval_glossy(rays[j].dir) * found.caustic * cos_over_pdf;
                            }
                        }
                    }
                };
            // The same answers either way.
            let mut first = [None; GATHER_BATCH];
            if self.query.accel.batches_pay(len) {
                self.query.first_meeting_batch(&rays[..len], &mut first[..len], count);
            } else {
                for (ray, first) in rays[..len].iter().zip(&mut first) {
                    *first = self.query.first_meeting(ray, count);
                }
            }
            // The irradiance the hits read, all of the batch's patches read
            // from memory together.
            let mut read = [None; GATHER_BATCH];
            if let Some(texels) = self.texels {
                let mut sides = [None; GATHER_BATCH];
                for ((ray, first), side) in rays.iter().zip(first).zip(&mut sides).take(len) {
                    *side = self.record_side(ray, first);
                }
                texels.irradiance_of_all(
                    self.query.scene,
                    global,
                    &self.global_estimate,
                    &sides[..len],
                    &mut read[..len],
                );
            }
            for j in 0..len {
                add(j, first[j], read[j], count);
            }
        }
        let n = n as f32;
        Lit { direct: lights / n, caustic: caustic / n, indirect: sum / n }
    }

    /// How final gathering draws its rays at `sp`, reached along a path of
    /// weight `throughput`; `None` where it does not gather (no global map
    /// read by gathering).
    fn gather_plan(&self, sp: &SurfacePoint, bsdf: &Bsdf, throughput: Vec3) -> Option<GatherPlan<'_>> {
        let global = self.maps.global.as_ref().filter(|_| self.maps.for_gathering)?;
        let rays = ((self.gather_per_sample as f32 * throughput.max_element().min(1.0)).ceil() as u32).max(1);
        let guide = self.guided.then(|| global.gather_guide(sp.p, sp.ns, &self.global_estimate)).flatten();
        let glossy = GLOSSY_SHARE_GATHERED * bsdf.glossy_share();
        let lobe_caustics = glossy > 0.0 && bsdf.material().phong_exponent > LOBE_CAUSTICS_ABOVE_EXPONENT;
        Some(GatherPlan { rays, guide, glossy, area_lights: self.area_lights, lobe_caustics })
    }

    /// What a gather ray `ray` from `sp` that followed the glossy lobe
    /// multiplies the lobe's `f L` by where it meets an area light's front
    /// at `t`, in place of its `cos / pdf`: the balance heuristic of the
    /// lobe's rays against the shadow rays, each strategy's count times
    /// density (the shadow rays' share is [`direct_light_against`]'s), over
    /// the lobe's chance and density: `n cos / (n_lobe p_lobe + n_light
    /// p_light)`, for `n` gather rays of which `n_lobe` follow the lobe on
    /// average.
    fn lobe_weight(
        &self,
        sp: &SurfacePoint,
        bsdf: &Bsdf,
        plan: &GatherPlan,
        ray: &Ray,
        light: &Light,
        t: f32,
    ) -> f32 {
        let both = plan.lobe_density(bsdf, ray.dir) + self.shadow_ray_density(light, sp.p, ray.at(t));
        if both > 0.0 {
            plan.rays as f32 * ray.dir.dot(sp.ns) / both
        } else {
            0.0
        }
    }

    /// Radiance along a gather ray that has bounced diffusely at least once
    /// before, given what it meets `first`: the global map's estimate where
    /// it meets a diffuse surface, through up to 8 mirrors and glass on the
    /// way. Light seen straight from a light (or through mirrors and glass
    /// only) is not counted here: shadow rays and the caustic map hold it
    /// (but for the share [`MapLight::final_gather`] keeps on glossy
    /// surfaces, and what `lights` says: [`LightsSeen::Caustic`]).
    ///
    /// A record holds irradiance, which gives a surface's diffuse part only.
    /// On a glossy surface the lobe's part is had by one more bounce, taken
    /// with the chance of the lobe's share of the reflectance (Russian
    /// roulette): shadow rays for the light the lobe reflects straight from
    /// the lights, and a ray along the lobe for the rest, the two weighed by
    /// the balance heuristic where that ray meets a light's front. Without
    /// it, light between glossy surfaces was lost: a Cornell box with glossy
    /// walls lost 29% of its indirect light (BENCHMARKS.md). A surface that
    /// is also a mirror or glass goes on through them, with the chance of
    /// their share (a box of walls a third mirror lost 17% without).
    ///
    /// `read`: the irradiance the first hit reads from its patch, where
    /// already read ([`RecordTexels`]). `lights`: how the ray counts a
    /// light's front, as it leaves the surface that gathers.
    #[allow(clippy::too_many_arguments)]
    fn gathered(
        &self,
        ray: &Ray,
        first: Option<Interaction<Hit>>,
        read: Option<Vec3>,
        global: &PhotonMap,
        lights: LightsSeen,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Gathered {
        let scene = self.query.scene;
        let (mut ray, mut first, mut read, mut weight, mut lights) = (*ray, first, read, Vec3::ONE, lights);
        let mut sum = Vec3::ZERO;
        // Across glass, what is found is worth (eta_i / eta_t)^2 here
        // ([`RadianceScale`]); apart from `weight`, so that in and out again
        // leaves it exactly as it was.
        let mut scale = RadianceScale::ONE;
        for bounces in 0.. {
            let hit = match first {
                Some(Interaction::Surface(hit)) => hit,
                Some(Interaction::Emitter { light, t, radiance }) => {
                    let met = weight * radiance * self.light_share(lights, &ray, light, t) * scale.factor();
                    return match lights {
                        LightsSeen::CausticThroughSpecular => Gathered { incoming: sum, caustic: met },
                        _ => Gathered::of(sum + met),
                    };
                }
                None => return Gathered::of(sum),
            };
            let m = self.query.hit_material(&hit);
            if m.is_glossy_or_diffuse() {
                // Most hits read their record from the triangle's patch,
                // without working out the point.
                let texel = read.or_else(|| {
                    self.texels?.irradiance(scene, global, &self.global_estimate, SideHit::of(&ray, hit))
                });
                let sp = match texel {
                    Some(e) => {
                        sum += weight * m.diffuse * FRAC_1_PI * e * scale.factor();
                        None
                    }
                    None => {
                        let sp = SurfacePoint::new(scene, &ray, &hit);
                        let radiance = global.precomputed_radiance(sp.p, sp.ns, m, &self.global_estimate);
                        sum += weight * radiance * scale.factor();
                        Some(sp)
                    }
                };
                if !(m.specular.max_element() > 0.0 || m.is_specular()) || bounces >= 8 {
                    return Gathered::of(sum);
                }
                let sp = sp.unwrap_or_else(|| SurfacePoint::new(scene, &ray, &hit));
                let bsdf = Bsdf::new(m, &sp, ray.dir.normalize());
                // Which part goes on, if any (Russian roulette): the glossy
                // lobe with the chance of its share of the reflectance, the
                // mirror or glass with that of theirs. (Without a mirror or
                // glass the lobe's chance is its share of the smooth parts.)
                let specular = bsdf.specular_probability();
                let q = bsdf.glossy_share() * (1.0 - specular);
                if q + specular <= 0.0 {
                    return Gathered::of(sum);
                }
                let u = rng.uniform();
                if u < q {
                    let lobe = |wi: Vec3| bsdf.glossy_pdf(wi);
                    let reflected = direct_light_against(
                        &self.query,
                        &sp,
                        &bsdf,
                        self.light_samples,
                        Against::LobeOnly(&lobe),
                        rng,
                        count,
                    );
                    let focused = self.lobe_of_delta_caustics(&sp, &bsdf);
                    sum += weight * (reflected + focused) / q * scale.factor();
                    let wi = bsdf.sample_glossy(rng.uniform2());
                    let (cos, pdf) = (wi.dot(sp.ns), bsdf.glossy_pdf(wi));
                    // (A density below the normal floats, as far off the lobe as
                    // a draw goes, would overflow `f / pdf`.)
                    if !(cos > 0.0 && wi.dot(sp.ng) > 0.0 && pdf >= f32::MIN_POSITIVE) {
                        return Gathered::of(sum);
                    }
                    weight *= bsdf.eval_glossy(wi) / pdf * (cos / q);
                    lights = LightsSeen::Shared { from: sp.p, pdf };
                    ray = sp.spawn(wi);
                } else if u < q + specular {
                    let Some(s) = bsdf.sample_specular(rng) else { return Gathered::of(sum) };
                    weight *= s.weight / specular;
                    scale = scale.after(&s);
                    lights = lights.through_specular();
                    ray = sp.spawn(s.wi);
                } else {
                    return Gathered::of(sum);
                }
            } else {
                if bounces >= 8 {
                    break;
                }
                let sp = SurfacePoint::new(scene, &ray, &hit);
                let bsdf = Bsdf::new(m, &sp, ray.dir.normalize());
                let Some(s) = bsdf.sample_specular(rng) else { return Gathered::of(sum) };
                weight *= s.weight;
                scale = scale.after(&s);
                lights = lights.through_specular();
                ray = sp.spawn(s.wi);
            }
            (first, read) = (self.query.first_meeting(&ray, count), None);
        }
        Gathered::of(sum)
    }

    /// The glossy lobe's part at `sp` of the caustics of point and spot
    /// lights, from the caustic map: light a gather ray's hit reflects
    /// along its lobe, which neither its shadow rays (stopped by the
    /// mirrors and glass that focus it) nor the ray going on along the lobe
    /// (which meets no such light) find. Without it a half-glass, half-glossy
    /// sphere in a grey box under a point light lost 3.7% of its indirect
    /// light; with glass of index 1.0001, a patch of the floor beside it
    /// 21% (BENCHMARKS.md, "Photon mapping on shiny surfaces").
    fn lobe_of_delta_caustics(&self, sp: &SurfacePoint, bsdf: &Bsdf) -> Vec3 {
        match &self.maps.caustic {
            Some(caustic) if self.delta_lights => {
                caustic.radiance_by(sp.p, sp.ns, &self.caustic_estimate, |photon| {
                    if photon.from_delta_light {
                        bsdf.eval_glossy(photon.incoming)
                    } else {
                        Vec3::ZERO
                    }
                })
            }
            _ => Vec3::ZERO,
        }
    }

    /// The share of a light's front, met at `t` along `ray`, that a gather
    /// ray keeps, as it came there (see [`LightsSeen`]).
    fn light_share(&self, lights: LightsSeen, ray: &Ray, light: &Light, t: f32) -> f32 {
        match lights {
            LightsSeen::Not | LightsSeen::Caustic => 0.0,
            LightsSeen::Whole | LightsSeen::CausticThroughSpecular => 1.0,
            LightsSeen::Shared { from, pdf } => LightSamples::lobe_share(
                &self.query.scene.lights,
                light,
                self.light_samples,
                from,
                ray.at(t),
                pdf,
            ),
        }
    }

    /// The number of shadow rays a surface at `from` sends to `light`
    /// ([`LightSamples::expected_count`]) times their density towards the
    /// point `on` of it: the shadow rays' side of the balance heuristic.
    fn shadow_ray_density(&self, light: &Light, from: Vec3, on: Vec3) -> f32 {
        LightSamples::stratified_density(&self.query.scene.lights, light, self.light_samples, from, on)
    }

    /// The hit of a gather ray `ray` that reads a record (on a diffuse or
    /// glossy surface), and its side: the front where the ray comes against
    /// the face's normal, as in `SurfacePoint`.
    fn record_side(&self, ray: &Ray, first: Option<Interaction<Hit>>) -> Option<SideHit> {
        let Some(Interaction::Surface(hit)) = first else { return None };
        self.query.hit_material(&hit).is_glossy_or_diffuse().then(|| SideHit::of(ray, hit))
    }
}

/// What a gather ray found along its way ([`MapLight::gathered`]).
struct Gathered {
    /// The light arriving at the surface it left, for its whole BRDF.
    incoming: Vec3,
    /// Light of an area light's front seen through mirrors and glass, for
    /// the glossy part of its BRDF alone ([`LightsSeen::Caustic`]).
    caustic: Vec3,
}

impl Gathered {
    /// Light for the whole BRDF, and no caustic.
    fn of(incoming: Vec3) -> Gathered {
        Gathered { incoming, caustic: Vec3::ZERO }
    }
}

/// Whether a gather ray keeps the light of a light's front it meets.
#[derive(Debug, Clone, Copy)]
enum LightsSeen {
    /// No: it left a diffuse or glossy surface the camera saw (through
    /// mirrors and glass), whose shadow rays and caustic map hold that light.
    Not,
    /// As [`LightsSeen::Not`] for a light met straight, but the surface it
    /// left has a sharp lobe, whose part of an area light's caustic its
    /// caustic map leaves to the gather rays ([`GatherPlan::lobe_caustics`]):
    /// after a mirror or glass, [`LightsSeen::CausticThroughSpecular`].
    Caustic,
    /// All of it, for the glossy part of the BRDF of the surface the ray
    /// left (returned apart: [`Gathered::caustic`]): it left a sharp lobe's
    /// surface and passed mirrors or glass alone since.
    CausticThroughSpecular,
    /// A share: it left a glossy surface (at `from`) along its lobe, drawn
    /// with density `pdf`, where shadow rays also sought the lights.
    Shared { from: Vec3, pdf: f32 },
    /// All of it: it left a glossy surface along its lobe, then passed
    /// mirrors or glass, which shadow rays cannot.
    Whole,
}

impl LightsSeen {
    /// As it is after a mirror or glass.
    fn through_specular(self) -> LightsSeen {
        match self {
            LightsSeen::Not => LightsSeen::Not,
            LightsSeen::Caustic | LightsSeen::CausticThroughSpecular => LightsSeen::CausticThroughSpecular,
            LightsSeen::Shared { .. } | LightsSeen::Whole => LightsSeen::Whole,
        }
    }
}

/// How final gathering draws its rays at one surface point.
#[derive(Clone, Copy)]
struct GatherPlan<'g> {
    /// How many.
    rays: u32,
    /// The guide they follow, if any (else the cosine).
    guide: Option<&'g GatherGuide>,
    /// The chance that a ray follows the glossy lobe instead (0 without one).
    glossy: f32,
    /// Whether the scene has area lights.
    area_lights: bool,
    /// Whether the surface's lobe is sharp (its Phong exponent above
    /// [`LOBE_CAUSTICS_ABOVE_EXPONENT`]), so that its part of area lights'
    /// caustics is the gather rays' that find a light's front through
    /// mirrors and glass, not the caustic map's, which weighs the few
    /// photons near the lobe's axis by its peak: in a half-glass sphere
    /// with a lobe of exponent 1000 in a box of lights, pixels of 6 where
    /// the lights are 1. Point and spot lights' caustics, which no ray
    /// meets, stay the caustic map's by the whole BRDF.
    lobe_caustics: bool,
}

impl GatherPlan<'_> {
    /// Whether the gather rays that followed the glossy lobe and meet an
    /// area light's front keep a share of the light the lobe reflects
    /// (weighed against the shadow rays by [`MapLight::lobe_weight`]): on
    /// glossy surfaces. A narrow lobe reflects a light that shadow rays
    /// alone find only where a sample of the light falls in it: the light's
    /// reflection in a shiny sphere was blotched. Only the lobe's rays, and
    /// only the lobe's part of the BRDF: where every gather ray shared all
    /// of the light, a glossy floor under a large panel (exponent 50) went
    /// from one shadow ray's smooth estimate to the gather rays' rare hits,
    /// with 2.8 times the noise; the lobe's rays sharing all of it, 1.6
    /// times; as now, 1.17 times (BENCHMARKS.md). The diffuse part, other
    /// surfaces, and point and spot lights (which no ray meets) keep the
    /// shadow rays' whole estimate, as before.
    fn weighs_lights(&self) -> bool {
        self.area_lights && self.glossy > 0.0
    }

    /// The number of gather rays that follow the glossy lobe (on average)
    /// times the lobe's solid-angle density at the unit direction `wi`.
    fn lobe_density(&self, bsdf: &Bsdf, wi: Vec3) -> f32 {
        self.rays as f32 * self.glossy * bsdf.glossy_pdf(wi)
    }

    /// The solid-angle density of one gather ray at the unit direction `wi`
    /// (0 below the shading normal's hemisphere).
    fn pdf(&self, sp: &SurfacePoint, bsdf: &Bsdf, wi: Vec3) -> f32 {
        let cos = wi.dot(sp.ns);
        if cos.is_nan() || cos <= 0.0 {
            return 0.0;
        }
        let gathered = match self.guide {
            Some(guide) => cos / guide.cos_over_pdf(Frame::new(sp.ns).to_local(wi)),
            None => cos / PI,
        };
        if self.glossy > 0.0 {
            self.glossy * bsdf.glossy_pdf(wi) + (1.0 - self.glossy) * gathered
        } else {
            gathered
        }
    }
}

/// A gather direction as a diffuse surface draws it, from a uniform point
/// `u` of the unit square: from the guide, or else the cosine; and `cos /
/// pdf` there.
fn gathered_direction(sp: &SurfacePoint, guide: Option<&GatherGuide>, u: Vec2) -> (Vec3, f32) {
    // With pdf = cos / pi, cos / pdf = pi.
    let (local, cos_over_pdf) = match guide {
        Some(guide) => guide.sample(u),
        None => (cosine_hemisphere(u), PI),
    };
    (around(sp.ns, local), cos_over_pdf)
}

/// The share of gather rays drawn from a glossy lobe, in the lobe's share of
/// the smooth reflectance. The whole share (what the BSDF's own sampler
/// gives it) left too few rays for the diffuse part where the light comes
/// from off the lobe: under a bright patch the noise was twice that of
/// cosine sampling alone, and at half it is less (the test below); on the
/// teapot's red sphere halving it changed nothing measurable (BENCHMARKS.md).
const GLOSSY_SHARE_GATHERED: f32 = 0.5;

/// The Phong exponent above which a glossy lobe's part of area lights'
/// caustics comes from gather rays ([`GatherPlan::lobe_caustics`]).
const LOBE_CAUSTICS_ABOVE_EXPONENT: f32 = 10.0;

/// A gather direction where the surface has a glossy lobe, and `cos / pdf`
/// there (0 below the surface): drawn from the lobe with chance `glossy`
/// (see [`GLOSSY_SHARE_GATHERED`]), else as a diffuse surface draws
/// it (from the guide, or the cosine), with the density of the two mixed
/// (one-sample multiple importance sampling, balance heuristic; Veach
/// 1997). Guide and cosine alone seldom send a ray into a narrow lobe, and
/// then it weighs `f / pdf` many times the rest: on the teapot's red
/// sphere (Phong exponent 60) such rays were most of the noise.
/// `u` picks the technique by its first coordinate, rescaled within it,
/// so stratified points stay stratified in each. Also says whether the
/// direction came from the lobe.
fn glossy_or_gathered(sp: &SurfacePoint, bsdf: &Bsdf, plan: &GatherPlan, u: Vec2) -> (Vec3, f32, bool) {
    const BELOW_ONE: f32 = 1.0 - f32::EPSILON / 2.0;
    let glossy = plan.glossy;
    let from_lobe = u.x < glossy;
    let wi = if from_lobe {
        bsdf.sample_glossy(Vec2::new((u.x / glossy).min(BELOW_ONE), u.y))
    } else {
        let u = Vec2::new(((u.x - glossy) / (1.0 - glossy)).min(BELOW_ONE), u.y);
        gathered_direction(sp, plan.guide, u).0
    };
    let pdf = plan.pdf(sp, bsdf, wi);
    (wi, if pdf > 0.0 { wi.dot(sp.ns) / pdf } else { 0.0 }, from_lobe)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::sampling::stratified;

    /// The direction the light `arriving` is brightest from, at the plane
    /// of `bsdf::tests::point` (normal +y): off the glossy lobe of
    /// [`glossy_gather_rays_are_unbiased_and_find_the_lobe`].
    fn bright() -> Vec3 {
        Vec3::new(-0.6, 0.7, 0.3).normalize()
    }

    /// Light arriving from `wi`: 1 from everywhere, `more` more from within
    /// 25 degrees of [`bright`].
    fn arriving(wi: Vec3, more: f32) -> f32 {
        1.0 + if wi.dot(bright()) > 25f32.to_radians().cos() { more } else { 0.0 }
    }

    /// Mean and variance of `f L cos / pdf` (green) over `n` stratified
    /// gather directions drawn by `draw`, under [`arriving`] light.
    fn gathered_moments(
        bsdf: &Bsdf,
        more: f32,
        n: u32,
        mut draw: impl FnMut(Vec2) -> (Vec3, f32),
    ) -> (f64, f64) {
        let mut rng = Rng::new(11, 3);
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let (wi, cos_over_pdf) = draw(stratified(i, n, &mut rng));
            let x = if cos_over_pdf > 0.0 {
                (bsdf.eval(wi).y * arriving(wi, more) * cos_over_pdf) as f64
            } else {
                0.0
            };
            (sum, sum2) = (sum + x, sum2 + x * x);
        }
        let mean = sum / n as f64;
        (mean, sum2 / n as f64 - mean * mean)
    }

    #[test]
    fn glossy_gather_rays_are_unbiased_and_find_the_lobe() {
        let sp = crate::bsdf::tests::point();
        let m = Material {
            diffuse: Vec3::splat(0.3),
            specular: Vec3::splat(0.5),
            phong_exponent: 60.0,
            ..Material::default()
        };
        let bsdf = Bsdf::new(&m, &sp, Vec3::new(0.5, -0.6, 0.2).normalize());
        let share = GLOSSY_SHARE_GATHERED * bsdf.glossy_share();
        assert!((share - 0.3125).abs() < 1e-6, "{share}");
        // The guide of photons that came from the bright patch.
        let frame = Frame::new(sp.ns);
        let guide = GatherGuide::new((0..64).map(|_| (frame.to_local(bright()), 1.0))).unwrap();
        let n = 1 << 20;
        for more in [0.0, 20.0] {
            // What the BSDF's own sampler (held unbiased in bsdf.rs) gives.
            let mut rng = Rng::new(5, 8);
            let mut expected = 0.0f64;
            for _ in 0..n {
                if let Some(s) = bsdf.sample(rng.uniform(), &mut rng) {
                    expected += (s.weight.y * arriving(s.wi, more)) as f64;
                }
            }
            let expected = expected / n as f64;
            for guide in [None, Some(&guide)] {
                let case = format!("guided {}, {more} more", guide.is_some());
                // The gather rays before glossy lobes were sampled: the
                // guide's, or the cosine's.
                let before = |u| gathered_direction(&sp, guide, u);
                let (before_mean, before_variance) = gathered_moments(&bsdf, more, n, before);
                assert!(
                    (before_mean - expected).abs() < 0.01 * expected,
                    "{case}: {before_mean} against {expected}"
                );
                let plan =
                    GatherPlan { rays: 1, guide, glossy: share, area_lights: false, lobe_caustics: false };
                let now = |u| {
                    let (wi, cos_over_pdf, _) = glossy_or_gathered(&sp, &bsdf, &plan, u);
                    (wi, cos_over_pdf)
                };
                let (mean, variance) = gathered_moments(&bsdf, more, n, now);
                assert!((mean - expected).abs() < 0.01 * expected, "{case}: {mean} against {expected}");
                // Under even light the lobe was most of the noise (measured:
                // 24-28 times less now); with a bright patch off the lobe,
                // the rays left to the guide or the cosine still do better
                // than all of them did (6-15% less).
                let better = if more == 0.0 { 10.0 } else { 1.0 };
                assert!(variance * better < before_variance, "{case}: {variance} against {before_variance}");
            }
        }
    }

    #[test]
    fn photon_time_grows_slower_than_the_budget_and_not_below_ten_seconds() {
        assert_eq!(photon_seconds(9.9), 0.0);
        let at = |t: f64| photon_seconds(t) / t;
        assert!((photon_seconds(10.0) - 2.0).abs() < 0.01);
        assert!(at(10.0) > at(60.0) && at(60.0) > at(600.0) && at(600.0) > 0.0);
    }

    #[test]
    fn photons_grow_in_steps_the_time_left_affords() {
        // Scene counts took 0.1 s of a 2-s target: at most 16x in one step.
        assert_eq!(grow_photons(2.0, 0.1, 0.1, 1.0), Some(16.0));
        // 16x took 1.6 s (1.7 s spent): 0.3 s left at 0.1 s per unit affords
        // 3 units, less than twice 16: stop.
        assert_eq!(grow_photons(2.0, 1.7, 1.6, 16.0), None);
        // Scene counts took 0.5 s of a 2-s target: 3x more.
        assert_eq!(grow_photons(2.0, 0.5, 0.5, 1.0), Some(3.0));
        // Nothing left, or no target: stay.
        assert_eq!(grow_photons(0.0, 0.2, 0.2, 1.0), None);
        // A build too quick to time does not divide by zero.
        assert_eq!(grow_photons(2.0, 0.0, 0.0, 1.0), Some(16.0));
    }
}
