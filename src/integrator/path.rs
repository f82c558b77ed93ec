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

use super::direct::{direct_light, LightSamples, LightSampling};
use super::pixels::{average_over_pixel, render_pixels};
use super::unreached::Unreached;
use super::{Context, Integrator, Progress, Rendered};
use crate::accel::Ray;
use crate::bsdf::{russian_roulette, Bsdf, RadianceScale};
use crate::film::Sample;
use crate::query::{Interaction, RayCount};
use crate::sampling::Rng;

/// The path tracer.
pub struct PathTracer;

impl Integrator for PathTracer {
    fn refines_by_samples(&self) -> bool {
        true
    }

    /// It reaches point and spot lights only by shadow rays.
    fn unreached(&self) -> Option<Unreached> {
        Some(Unreached::FromPointLightsThroughMirrors)
    }

    fn pixels_sample_alone(&self) -> bool {
        true
    }

    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered {
        let (film, rays) = render_pixels(ctx, progress, |x, y, rng, count| {
            average_over_pixel(ctx, (x, y), rng, |ray, rng| radiance(ctx, ray, rng, count))
        });
        Rendered::new(film, rays, Vec::new())
    }
}

/// Which component light found at a path vertex belongs to (see [`Sample`]),
/// from the diffuse or glossy vertices the path has passed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum PathClass {
    /// Only mirrors and glass since the camera.
    Specular,
    /// One diffuse or glossy vertex, and nothing after it yet.
    JustScattered,
    /// One diffuse or glossy vertex, then mirrors or glass.
    SpecularAfterScatter,
    /// Two or more diffuse or glossy vertices.
    Indirect,
}

impl PathClass {
    /// The component that light from a light source, reached by the path
    /// as it is now, adds to.
    pub(super) fn slot(self, out: &mut Sample) -> &mut Vec3 {
        match self {
            PathClass::Specular => &mut out.emission,
            PathClass::JustScattered => &mut out.direct,
            PathClass::SpecularAfterScatter => &mut out.caustic,
            PathClass::Indirect => &mut out.indirect,
        }
    }

    /// The class after a bounce of the given kind.
    pub(super) fn after(self, specular: bool) -> PathClass {
        match (self, specular) {
            (PathClass::Specular, true) => PathClass::Specular,
            (PathClass::Specular, false) => PathClass::JustScattered,
            (PathClass::JustScattered | PathClass::SpecularAfterScatter, true) => {
                PathClass::SpecularAfterScatter
            }
            _ => PathClass::Indirect,
        }
    }
}

/// Radiance along a camera ray, each part in its component.
fn radiance(ctx: &Context, mut ray: Ray, rng: &mut Rng, count: &mut RayCount) -> Sample {
    let query = &ctx.query;
    let mut out = Sample::default();
    let mut throughput = Vec3::ONE;
    // What light found here is worth at the camera across refractions, kept
    // apart from the throughput, which Russian roulette reads: the medium
    // changes what the light is worth, not the path's chance to go on.
    let mut scale = RadianceScale::ONE;
    let mut class = PathClass::Specular;
    let mut found_surface = false; // the first diffuse or glossy one, for albedo and normal
                                   // Solid-angle pdf of the last non-delta bounce, for MIS on lights it
                                   // finds; `None` after the camera or a delta bounce (no MIS then).
    let mut last_pdf: Option<f32> = None;
    // Where that bounce left from: with many lights, the chance that its
    // light sample picked a light depends on the point.
    let mut last_point = Vec3::ZERO;
    for depth in 0..ctx.config.max_depth {
        let sp = match query.first(&ray, count) {
            None => return out,
            Some(Interaction::Emitter { light, t, radiance }) => {
                let weight = match last_pdf {
                    None => 1.0,
                    Some(p_bsdf) => {
                        let lights = &query.scene.lights;
                        let p_light = light.pdf_solid_angle(ray.at(t), ray.origin)
                            * LightSamples::mis_factor(lights, light, last_point);
                        p_bsdf / (p_bsdf + p_light)
                    }
                };
                *class.slot(&mut out) += throughput * radiance * weight * scale.factor();
                return out;
            }
            Some(Interaction::Surface(sp)) => sp,
        };
        if depth == 0 {
            out.depth = sp.t * ray.dir.length();
        }
        let bsdf = Bsdf::new(query.material(&sp), &sp, ray.dir.normalize());
        if bsdf.has_smooth() {
            if !found_surface {
                found_surface = true;
                let m = bsdf.material();
                (out.albedo, out.normal) = (throughput * (m.diffuse + m.specular), sp.ns);
            }
            // A light sample makes the path one diffuse vertex longer.
            let light = direct_light(query, &sp, &bsdf, LightSampling::MultipleImportance, rng, count);
            *class.after(false).slot(&mut out) += throughput * light * scale.factor();
        }

        // Continue by sampling the BSDF.
        let Some(s) = bsdf.sample(rng.uniform(), rng) else { return out };
        throughput *= s.weight;
        scale = scale.after(&s);
        last_pdf = s.pdf;
        last_point = sp.p;
        class = class.after(s.kind.is_specular());
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
