//! The reference: an unbiased path tracer over the same scenes, materials,
//! lights and intersectors as the photon mapper.
//!
//! At every diffuse or glossy vertex it samples each light (next-event
//! estimation) and continues by sampling the material; light reached by that
//! continuation is weighted against the light sample by multiple importance
//! sampling (Veach's balance heuristic) for area lights. Mirrors and glass
//! are followed as delta bounces. Russian roulette ends long paths without
//! bias.
//!
//! Limit: a point or spot light seen through glass or a mirror (`L S+ D E`
//! with a delta light) has zero probability of being found by a path traced
//! from the camera: such caustics need area lights in reference scenes.

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use super::surface::SurfacePoint;
use super::whitted::RayCount;
use super::{average_over_pixel, Components, RenderSettings};
use crate::accel::{Intersector, Ray};
use crate::light::{nearest_emitter, Light};
use crate::material::Material;
use crate::sampling::{around, cosine_hemisphere, phong_lobe, phong_lobe_pdf, Rng};
use crate::scene::Scene;

/// The path tracer over one scene and intersector.
pub struct PathTracer<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Answers ray queries.
    pub accel: &'a dyn Intersector,
    /// Depth and samples.
    pub settings: &'a RenderSettings,
}

/// Probabilities of choosing each material part when continuing a path:
/// in proportion to its reflectance summed over channels.
struct Choice {
    diffuse: f32,
    glossy: f32,
    mirror: f32,
    glass: f32,
}

impl Choice {
    fn of(m: &Material) -> Choice {
        let sums = [m.diffuse, m.specular, m.mirror, m.transmittance].map(|c| c.element_sum());
        let total: f32 = sums.iter().sum();
        let p = |i: usize| if total > 0.0 { sums[i] / total } else { 0.0 };
        Choice { diffuse: p(0), glossy: p(1), mirror: p(2), glass: p(3) }
    }

    /// Density (solid angle) of sampling `wi` from the diffuse and glossy parts.
    fn pdf(&self, m: &Material, n: Vec3, wi: Vec3, wo: Vec3) -> f32 {
        let cos = wi.dot(n);
        if cos <= 0.0 {
            return 0.0;
        }
        let mut pdf = self.diffuse * cos * FRAC_1_PI;
        if self.glossy > 0.0 {
            let e = m.phong_exponent;
            pdf += self.glossy * phong_lobe_pdf(crate::optics::reflect(-wo, n).dot(wi), e);
        }
        pdf
    }
}

impl PathTracer<'_> {
    /// One pixel: `settings.samples` stratified jittered paths, averaged.
    pub fn pixel(&self, x: u32, y: u32, rng: &mut Rng, count: &mut RayCount) -> Components {
        average_over_pixel(self.scene, self.settings, (x, y), rng, |ray, rng| self.radiance(ray, rng, count))
    }

    /// Radiance along a camera ray. What the camera's first vertex receives
    /// straight from lights goes to `direct`, everything else to `global`.
    fn radiance(&self, mut ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Components {
        let mut out = Components::default();
        let mut throughput = Vec3::ONE;
        // Solid-angle pdf of the last non-delta bounce, for MIS on lights it
        // finds; `None` after the camera or a delta bounce (no MIS then).
        let mut last_pdf: Option<f32> = None;
        for depth in 0..self.settings.max_depth {
            // Direct light: emission seen by the camera, or reached from the
            // first vertex (by its light sample, or by its continuation ray).
            let add = |out: &mut Components, l: Vec3, direct: bool| {
                if direct {
                    out.direct += l
                } else {
                    out.global += l
                }
            };
            count.closest += 1;
            let hit = self.accel.intersect(&ray);
            let nearest = Ray { t_max: hit.map_or(ray.t_max, |h| h.t), ..ray };
            if let Some((light, t, emitted)) = nearest_emitter(&self.scene.lights, &nearest) {
                let weight = match last_pdf {
                    None => 1.0,
                    Some(p_bsdf) => {
                        let p_light = area_pdf(light, ray.at(t), ray.origin);
                        p_bsdf / (p_bsdf + p_light)
                    }
                };
                add(&mut out, throughput * emitted * weight, depth <= 1);
                return out;
            }
            let Some(hit) = hit else { return out };
            let sp = SurfacePoint::new(self.scene, &ray, &hit);
            let m = &self.scene.materials[sp.material];
            let dir = ray.dir.normalize();
            let wo = -dir;
            let choice = Choice::of(m);

            if m.is_glossy_or_diffuse() {
                add(&mut out, throughput * self.next_event(&sp, m, &choice, wo, rng, count), depth == 0);
            }

            // Continue by sampling the material.
            let (new_dir, pdf) = match self.sample(&sp, m, &choice, dir, rng) {
                Some(step) => step,
                None => return out,
            };
            throughput *= pdf.1;
            last_pdf = pdf.0;
            // Russian roulette after a few bounces.
            if depth >= 3 {
                let q = throughput.max_element().clamp(0.05, 1.0);
                if rng.uniform() >= q {
                    return out;
                }
                throughput /= q;
            }
            if throughput == Vec3::ZERO {
                return out;
            }
            ray = sp.spawn(new_dir);
        }
        out
    }

    /// Picks a material part and a direction. Returns the direction, and
    /// (the solid-angle pdf for MIS if non-delta, the throughput factor).
    #[allow(clippy::type_complexity)]
    fn sample(
        &self,
        sp: &SurfacePoint,
        m: &Material,
        choice: &Choice,
        dir: Vec3,
        rng: &mut Rng,
    ) -> Option<(Vec3, (Option<f32>, Vec3))> {
        let wo = -dir;
        let xi = rng.uniform();
        let non_delta = choice.diffuse + choice.glossy;
        if xi < non_delta {
            // One sample from the mixture of the diffuse and glossy lobes.
            let wi = if xi < choice.diffuse {
                around(sp.ns, cosine_hemisphere(rng.uniform2()))
            } else {
                around(sp.reflect(dir), phong_lobe(rng.uniform2(), m.phong_exponent))
            };
            let cos = wi.dot(sp.ns);
            let pdf = choice.pdf(m, sp.ns, wi, wo);
            if cos <= 0.0 || wi.dot(sp.ng) <= 0.0 || pdf <= 0.0 {
                return None;
            }
            return Some((wi, (Some(pdf), m.brdf(sp.ns, wi, wo) * cos / pdf)));
        }
        if xi < non_delta + choice.mirror {
            return Some((sp.reflect(dir), (None, m.mirror / choice.mirror)));
        }
        if choice.glass <= 0.0 {
            return None;
        }
        let next = sp.dielectric_direction(dir, m.ior, rng);
        Some((next, (None, m.transmittance / choice.glass)))
    }

    /// Light arriving straight from the lights at `sp`, reflected to `wo`;
    /// area-light samples weighted by the balance heuristic against the
    /// material's own sampling.
    fn next_event(
        &self,
        sp: &SurfacePoint,
        m: &Material,
        choice: &Choice,
        wo: Vec3,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for light in &self.scene.lights {
            let Some(ls) = light.sample_incident(sp.p, rng.uniform2()) else { continue };
            let wi = (ls.position - sp.p).normalize();
            let cos = wi.dot(sp.ns);
            if cos <= 0.0 || wi.dot(sp.ng) <= 0.0 {
                continue;
            }
            let f = m.brdf(sp.ns, wi, wo);
            if f == Vec3::ZERO {
                continue;
            }
            count.shadow += 1;
            if self.accel.occluded(&sp.spawn_to(ls.position)) {
                continue;
            }
            let weight = if light.is_delta() {
                1.0
            } else {
                let p_light = area_pdf(light, ls.position, sp.p);
                let p_bsdf = choice.pdf(m, sp.ns, wi, wo);
                p_light / (p_light + p_bsdf)
            };
            sum += f * ls.irradiance * cos * weight;
        }
        sum
    }
}

/// Solid-angle density, seen from `from`, of sampling the point `on` of an
/// area light uniformly by area: `d^2 / (A cos_l)`.
fn area_pdf(light: &Light, on: Vec3, from: Vec3) -> f32 {
    let Light::Area { u, v, .. } = *light else { return 0.0 };
    let normal = u.cross(v);
    let area = normal.length();
    let to = from - on;
    let d2 = to.length_squared();
    let cos_l = normal.dot(to) / (area * d2.sqrt());
    if cos_l <= 0.0 {
        return 0.0;
    }
    d2 / (area * cos_l)
}
