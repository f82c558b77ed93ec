//! Whitted-style ray tracing (Whitted 1980) with physical units: direct light
//! through shadow rays, perfect mirror reflection, and refraction through
//! smooth dielectrics split by the exact Fresnel equations, recursively.
//!
//! It sees light that reaches the eye through specular chains from diffuse or
//! glossy surfaces that a light shines on directly. Light that bounces
//! diffusely first (indirect light) and light focused by specular surfaces
//! onto diffuse ones (caustics) are the photon maps' job.

use glam::Vec3;

use super::surface::SurfacePoint;
use super::{average_over_pixel, Components, RenderSettings};
use crate::accel::{Intersector, Ray};
use crate::light::nearest_emitter;
use crate::photon::{PhotonMap, PhotonMaps};
use crate::sampling::{around, cosine_hemisphere, stratified, Rng};
use crate::scene::Scene;

/// The Whitted integrator over one scene and intersector.
pub struct Whitted<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Answers ray queries.
    pub accel: &'a dyn Intersector,
    /// Depth, light samples, cut-offs, photon estimates.
    pub settings: &'a RenderSettings,
    /// Photon maps, for the photon-mapping integrator.
    pub maps: Option<&'a PhotonMaps>,
}

/// Per-pixel work counters.
#[derive(Debug, Default, Clone, Copy)]
pub struct RayCount {
    /// Rays traced through `intersect` (camera, reflection, refraction).
    pub closest: u64,
    /// Shadow rays traced through `occluded`.
    pub shadow: u64,
}

impl Whitted<'_> {
    /// Radiance arriving along `ray`, split into components. `depth` counts
    /// the specular bounces so far; `throughput` is what the caller will
    /// multiply the result by (for the cut-off).
    pub fn radiance(
        &self,
        ray: &Ray,
        depth: u32,
        throughput: Vec3,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Components {
        count.closest += 1;
        let hit = self.accel.intersect(ray);
        // Area lights are not geometry: check whether one is nearer.
        let nearest = Ray { t_max: hit.map_or(ray.t_max, |h| h.t), ..*ray };
        if let Some((_, _, emitted)) = nearest_emitter(&self.scene.lights, &nearest) {
            return Components::emitted(emitted, depth);
        }
        let Some(hit) = hit else { return Components::default() };
        let sp = SurfacePoint::new(self.scene, ray, &hit);
        let m = &self.scene.materials[sp.material];
        let dir = ray.dir.normalize();
        let wo = -dir;

        let mut out = Components::default();
        if m.is_glossy_or_diffuse() {
            out.direct = self.direct_light(&sp, wo, rng, count) + m.diffuse * self.settings.ambient;
            if let Some(maps) = self.maps {
                let p = &self.settings.photons;
                if let Some(caustic) = &maps.caustic {
                    out.caustic = caustic.radiance(sp.p, sp.ns, wo, m, &p.caustic_estimate);
                }
                if let Some(global) = &maps.global {
                    out.global = if maps.for_gathering {
                        self.final_gather(&sp, wo, global, throughput, rng, count)
                    } else {
                        global.radiance(sp.p, sp.ns, wo, m, &p.global_estimate)
                    };
                }
            }
        }
        if depth + 1 >= self.settings.max_depth {
            return out;
        }
        let follow = |weight: Vec3, new_dir: Vec3, rng: &mut Rng, count: &mut RayCount| {
            let carried = throughput * weight;
            if carried.max_element() < self.settings.min_throughput {
                return Vec3::ZERO;
            }
            weight * self.radiance(&sp.spawn(new_dir), depth + 1, carried, rng, count).total()
        };
        if m.mirror.max_element() > 0.0 {
            out.specular += follow(m.mirror, sp.reflect(dir), rng, count);
        }
        if m.transmittance.max_element() > 0.0 {
            let (kr, refracted) = sp.refract(dir, m.ior);
            out.specular += follow(m.transmittance * kr, sp.reflect(dir), rng, count);
            if let Some(t) = refracted {
                out.specular += follow(m.transmittance * (1.0 - kr), t, rng, count);
            }
        }
        out
    }

    /// Indirect light at `sp` by final gathering (Jensen): cosine-distributed
    /// rays sample the light arriving from the hemisphere, each asking the
    /// global map for the radiance leaving the diffuse surface it meets.
    ///
    /// The gather rays are shared out over the pixel's samples and scaled by
    /// the weight of the path that got here (`throughput`), at least one: a
    /// surface seen through a 4% glass reflection needs few. Any count gives
    /// an unbiased estimate; fewer only add noise where it is weighted down.
    fn final_gather(
        &self,
        sp: &SurfacePoint,
        wo: Vec3,
        global: &PhotonMap,
        throughput: Vec3,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Vec3 {
        let m = &self.scene.materials[sp.material];
        let per_sample = self.settings.photons.gather_rays.div_ceil(self.settings.samples);
        let n = ((per_sample as f32 * throughput.max_element().min(1.0)).ceil() as u32).max(1);
        let mut sum = Vec3::ZERO;
        for i in 0..n {
            let wi = around(sp.ns, cosine_hemisphere(stratified(i, n, rng)));
            if wi.dot(sp.ng) <= 0.0 {
                continue;
            }
            let incoming = self.gather_radiance(&sp.spawn(wi), global, 0, rng, count);
            if incoming != Vec3::ZERO {
                // f cos / pdf with pdf = cos / pi.
                sum += m.brdf(sp.ns, wi, wo) * incoming * std::f32::consts::PI;
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
        count.closest += 1;
        let Some(hit) = self.accel.intersect(ray) else { return Vec3::ZERO };
        if nearest_emitter(&self.scene.lights, &Ray { t_max: hit.t, ..*ray }).is_some() {
            return Vec3::ZERO; // the light's front is black, its light the shadow rays' part
        }
        let sp = SurfacePoint::new(self.scene, ray, &hit);
        let m = &self.scene.materials[sp.material];
        let dir = ray.dir.normalize();
        if m.is_glossy_or_diffuse() {
            return global.precomputed_radiance(sp.p, sp.ns, m, &self.settings.photons.global_estimate);
        }
        if bounces >= 8 {
            return Vec3::ZERO;
        }
        let Some((weight, next)) = sp.specular_bounce(m, dir, rng) else { return Vec3::ZERO };
        weight * self.gather_radiance(&sp.spawn(next), global, bounces + 1, rng, count)
    }

    /// Light arriving straight from the lights and reflected towards `wo` by
    /// the diffuse and glossy parts of the material.
    pub(crate) fn direct_light(
        &self,
        sp: &SurfacePoint,
        wo: Vec3,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Vec3 {
        let m = &self.scene.materials[sp.material];
        let mut sum = Vec3::ZERO;
        for light in &self.scene.lights {
            let samples = if light.is_delta() { 1 } else { self.settings.light_samples };
            for i in 0..samples {
                let Some(ls) = light.sample_incident(sp.p, stratified(i, samples, rng)) else { continue };
                let wi = (ls.position - sp.p).normalize();
                let cos = wi.dot(sp.ns);
                // Skip the shadow ray where the light cannot contribute.
                if cos <= 0.0 || wi.dot(sp.ng) <= 0.0 || ls.irradiance == Vec3::ZERO {
                    continue;
                }
                let f = m.brdf(sp.ns, wi, wo);
                if f == Vec3::ZERO {
                    continue;
                }
                count.shadow += 1;
                if !self.accel.occluded(&sp.spawn_to(ls.position)) {
                    sum += f * ls.irradiance * (cos / samples as f32);
                }
            }
        }
        sum
    }

    /// The radiance of one pixel, averaged over its camera samples.
    pub fn pixel(&self, x: u32, y: u32, rng: &mut Rng, count: &mut RayCount) -> Components {
        average_over_pixel(self.scene, self.settings, (x, y), rng, |ray, rng| {
            self.radiance(&ray, 0, Vec3::ONE, rng, count)
        })
    }
}
