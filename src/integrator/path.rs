//! The reference: an unbiased path tracer over the same scenes, materials,
//! lights and intersectors as the photon mapper.
//!
//! At every diffuse or glossy vertex it samples each light (next-event
//! estimation) and continues by sampling the BSDF; light reached by that
//! continuation is weighted against the light sample by multiple importance
//! sampling (Veach's balance heuristic) for area lights. Mirrors and glass
//! are followed as delta bounces. Russian roulette ends long paths without
//! bias.
//!
//! Limit: a point or spot light seen through glass or a mirror (`L S+ D E`
//! with a delta light) has zero probability of being found by a path traced
//! from the camera: such caustics need area lights in reference scenes.

use glam::Vec3;

use super::direct::{direct_light, LightSampling};
use super::pixels::{average_over_pixel, render_pixels};
use super::{Context, Integrator, Progress, RenderStats, Rendered};
use crate::accel::Ray;
use crate::bsdf::{russian_roulette, Bsdf};
use crate::film::Components;
use crate::query::{Interaction, RayCount};
use crate::sampling::Rng;

/// The path tracer.
pub struct PathTracer;

impl Integrator for PathTracer {
    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered {
        let (film, rays) = render_pixels(ctx, progress, |x, y, rng, count| {
            average_over_pixel(ctx, (x, y), rng, |ray, rng| radiance(ctx, ray, rng, count))
        });
        let stats = RenderStats {
            elapsed: Default::default(),
            rays,
            samples_per_pixel: ctx.config.samples,
            photons_emitted: 0,
            notes: Vec::new(),
        };
        Rendered { film, stats }
    }
}

/// Radiance along a camera ray. What the camera's first vertex receives
/// straight from lights goes to `direct`, everything else to `global`.
fn radiance(ctx: &Context, mut ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Components {
    let query = &ctx.query;
    let mut out = Components::default();
    let mut throughput = Vec3::ONE;
    // Solid-angle pdf of the last non-delta bounce, for MIS on lights it
    // finds; `None` after the camera or a delta bounce (no MIS then).
    let mut last_pdf: Option<f32> = None;
    // Direct light: emission seen by the camera, or reached from the first
    // vertex (by its light sample, or by its continuation ray).
    let add = |out: &mut Components, l: Vec3, direct: bool| {
        if direct {
            out.direct += l
        } else {
            out.global += l
        }
    };
    for depth in 0..ctx.config.max_depth {
        let sp = match query.first(&ray, count) {
            None => return out,
            Some(Interaction::Emitter { light, t, radiance }) => {
                let weight = match last_pdf {
                    None => 1.0,
                    Some(p_bsdf) => {
                        let p_light = light.pdf_solid_angle(ray.at(t), ray.origin);
                        p_bsdf / (p_bsdf + p_light)
                    }
                };
                add(&mut out, throughput * radiance * weight, depth <= 1);
                return out;
            }
            Some(Interaction::Surface(sp)) => sp,
        };
        let bsdf = Bsdf::new(query.material(&sp), &sp, ray.dir.normalize());
        if bsdf.has_smooth() {
            let light = direct_light(query, &sp, &bsdf, LightSampling::MultipleImportance, rng, count);
            add(&mut out, throughput * light, depth == 0);
        }

        // Continue by sampling the BSDF.
        let Some(s) = bsdf.sample(rng.uniform(), rng) else { return out };
        throughput *= s.weight;
        last_pdf = s.pdf;
        if depth >= 3 {
            match russian_roulette(throughput.max_element().clamp(0.05, 1.0), rng.uniform()) {
                Some(q) => throughput /= q,
                None => return out,
            }
        }
        if throughput == Vec3::ZERO {
            return out;
        }
        ray = sp.spawn(s.wi);
    }
    out
}
