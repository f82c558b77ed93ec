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
use super::{Components, RenderSettings};
use crate::accel::{Intersector, Ray};
use crate::optics::{fresnel_dielectric, reflect, refract};
use crate::sampling::{stratified, Rng};
use crate::scene::Scene;

/// The Whitted integrator over one scene and intersector.
pub struct Whitted<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Answers ray queries.
    pub accel: &'a dyn Intersector,
    /// Depth, light samples, cut-offs.
    pub settings: &'a RenderSettings,
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
        if let Some(emitted) = self.emitted(&nearest) {
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
            out.specular += follow(m.mirror, reflection(&sp, dir), rng, count);
        }
        if m.transmittance.max_element() > 0.0 {
            let (n1, n2) = if sp.front { (1.0, m.ior) } else { (m.ior, 1.0) };
            let kr = fresnel_dielectric((-dir.dot(sp.ns)).clamp(0.0, 1.0), n1, n2);
            out.specular += follow(m.transmittance * kr, reflection(&sp, dir), rng, count);
            if kr < 1.0 {
                if let Some(t) = refraction(&sp, dir, n1 / n2) {
                    out.specular += follow(m.transmittance * (1.0 - kr), t, rng, count);
                }
            }
        }
        out
    }

    /// Emitted radiance of the nearest area light hit before `ray.t_max`.
    fn emitted(&self, ray: &Ray) -> Option<Vec3> {
        let mut nearest: Option<(f32, Vec3)> = None;
        for light in &self.scene.lights {
            if let Some((t, radiance)) = light.intersect(ray) {
                if nearest.is_none_or(|(best, _)| t < best) {
                    nearest = Some((t, radiance));
                }
            }
        }
        nearest.map(|(_, radiance)| radiance)
    }

    /// Light arriving straight from the lights and reflected towards `wo` by
    /// the diffuse and glossy parts of the material.
    fn direct_light(&self, sp: &SurfacePoint, wo: Vec3, rng: &mut Rng, count: &mut RayCount) -> Vec3 {
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

    /// The radiance of one pixel: `settings.samples` stratified jittered
    /// camera rays (a single sample goes through the pixel's centre), averaged.
    pub fn pixel(&self, x: u32, y: u32, rng: &mut Rng, count: &mut RayCount) -> Components {
        let s = self.settings;
        let mut sum = Components::default();
        for i in 0..s.samples {
            let offset = if s.samples == 1 { glam::Vec2::splat(0.5) } else { stratified(i, s.samples, rng) };
            let ray = self.scene.camera.ray(x as f32 + offset.x, y as f32 + offset.y, s.width, s.height);
            sum += self.radiance(&ray, 0, Vec3::ONE, rng, count);
        }
        sum * (1.0 / s.samples as f32)
    }
}

/// Mirror direction about the shading normal; if the smooth normal would send
/// it below the actual surface, about the geometric normal instead.
fn reflection(sp: &SurfacePoint, dir: Vec3) -> Vec3 {
    let r = reflect(dir, sp.ns);
    if r.dot(sp.ng) > 0.0 {
        r
    } else {
        reflect(dir, sp.ng)
    }
}

/// Refracted direction through the shading normal, falling back to the
/// geometric normal when the smooth normal would keep it on the near side.
fn refraction(sp: &SurfacePoint, dir: Vec3, eta: f32) -> Option<Vec3> {
    match refract(dir, sp.ns, eta) {
        Some(t) if t.dot(sp.ng) < 0.0 => Some(t),
        _ => refract(dir, sp.ng, eta).filter(|t| t.dot(sp.ng) < 0.0),
    }
}
