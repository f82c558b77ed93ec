//! Photon mapping (Jensen 1996, 2001): Whitted ray tracing for direct light
//! and specular chains, plus, at every diffuse or glossy surface it reaches,
//! caustics from the caustic map and indirect light from the global map,
//! read by final gathering (or shown directly when there are no gather rays).

use std::f32::consts::PI;

use glam::Vec3;

use super::whitted::{SurfaceLight, WhittedTracer};
use super::{Context, Integrator, Progress, Rendered};
use crate::accel::Ray;
use crate::bsdf::Bsdf;
use crate::config::Estimate;
use crate::photon::{build_maps, PhotonMap, PhotonMaps};
use crate::query::{Interaction, RayCount, SceneQuery, SurfacePoint};
use crate::sampling::{around, cosine_hemisphere, stratified, Rng};

/// The photon-mapping integrator.
pub struct PhotonMapping;

impl Integrator for PhotonMapping {
    fn refines_by_samples(&self) -> bool {
        true
    }

    fn photon_maps(&self, ctx: &Context) -> Option<PhotonMaps> {
        let p = &ctx.config.photons;
        Some(build_maps(&ctx.query, p, ctx.config.seed, ctx.diagonal))
    }

    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered {
        let photons = &ctx.config.photons;
        let traced;
        let maps = match ctx.photon_maps {
            Some(loaded) => loaded,
            None => {
                traced = self.photon_maps(ctx).expect("photon mapping builds its maps");
                &traced
            }
        };
        let light = MapLight {
            query: ctx.query,
            maps,
            global_estimate: photons.global_estimate(ctx.diagonal),
            caustic_estimate: photons.caustic_estimate(ctx.diagonal),
            gather_per_sample: photons.gather_rays,
        };
        let tracer = WhittedTracer { ctx, surface_light: Some(&light) };
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
        tracer.render(progress, notes)
    }
}

/// Caustics and indirect light from the photon maps.
struct MapLight<'a> {
    query: SceneQuery<'a>,
    maps: &'a PhotonMaps,
    global_estimate: Estimate,
    caustic_estimate: Estimate,
    /// Final-gathering rays per camera sample, before scaling by the path's weight.
    gather_per_sample: u32,
}

impl SurfaceLight for MapLight<'_> {
    fn at(
        &self,
        sp: &SurfacePoint,
        bsdf: &Bsdf,
        throughput: Vec3,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> (Vec3, Vec3) {
        let (m, wo) = (bsdf.material(), bsdf.wo());
        let caustic = match &self.maps.caustic {
            Some(caustic) => caustic.radiance(sp.p, sp.ns, wo, m, &self.caustic_estimate),
            None => Vec3::ZERO,
        };
        let global = match &self.maps.global {
            Some(global) if self.maps.for_gathering => {
                self.final_gather(sp, bsdf, global, throughput, rng, count)
            }
            Some(global) => global.radiance(sp.p, sp.ns, wo, m, &self.global_estimate),
            None => Vec3::ZERO,
        };
        (caustic, global)
    }
}

impl MapLight<'_> {
    /// Indirect light at `sp` by final gathering (Jensen): cosine-distributed
    /// rays sample the light arriving from the hemisphere, each asking the
    /// global map for the radiance leaving the diffuse surface it meets.
    ///
    /// Each camera sample sends its own gather rays (so more samples mean
    /// more gathering, and the estimate keeps converging), scaled by the
    /// weight of the path that got here (`throughput`), at least one: a
    /// surface seen through a 4% glass reflection needs few. Any count gives
    /// an unbiased estimate; fewer only add noise where it is weighted down.
    fn final_gather(
        &self,
        sp: &SurfacePoint,
        bsdf: &Bsdf,
        global: &PhotonMap,
        throughput: Vec3,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Vec3 {
        let n = ((self.gather_per_sample as f32 * throughput.max_element().min(1.0)).ceil() as u32).max(1);
        let mut sum = Vec3::ZERO;
        for i in 0..n {
            let wi = around(sp.ns, cosine_hemisphere(stratified(i, n, rng)));
            if wi.dot(sp.ng) <= 0.0 {
                continue;
            }
            let incoming = self.gather_radiance(&sp.spawn(wi), global, 0, rng, count);
            if incoming != Vec3::ZERO {
                // f cos / pdf with pdf = cos / pi.
                sum += bsdf.eval(wi) * incoming * PI;
            }
        }
        sum / n as f32
    }

    /// Radiance along a gather ray that has bounced diffusely at least once
    /// before: the global map's estimate where it meets a diffuse surface,
    /// through mirrors and glass on the way. Light seen straight from a light
    /// (or through mirrors and glass only) is not counted: shadow rays and the
    /// caustic map already hold it.
    fn gather_radiance(
        &self,
        ray: &Ray,
        global: &PhotonMap,
        bounces: u32,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Vec3 {
        // The light's front is black here: its light is the shadow rays' part.
        let Some(Interaction::Surface(sp)) = self.query.first(ray, count) else { return Vec3::ZERO };
        let m = self.query.material(&sp);
        if m.is_glossy_or_diffuse() {
            return global.precomputed_radiance(sp.p, sp.ns, m, &self.global_estimate);
        }
        if bounces >= 8 {
            return Vec3::ZERO;
        }
        let bsdf = Bsdf::new(m, &sp, ray.dir.normalize());
        let Some(s) = bsdf.sample_specular(rng) else { return Vec3::ZERO };
        s.weight * self.gather_radiance(&sp.spawn(s.wi), global, bounces + 1, rng, count)
    }
}
