//! Whitted-style ray tracing (Whitted 1980) with physical units: direct light
//! through shadow rays, perfect mirror reflection, and refraction through
//! smooth dielectrics split by the exact Fresnel equations, recursively.
//!
//! It sees light that reaches the eye through specular chains from diffuse or
//! glossy surfaces that a light shines on directly. Light that bounces
//! diffusely first (indirect light) and light focused by specular surfaces
//! onto diffuse ones (caustics) are the photon maps' job: the photon-mapping
//! integrator runs this same recursion with [`SurfaceLight`] from its maps.

use glam::Vec3;

use super::direct::{direct_light, LightSampling};
use super::pixels::{average_over_pixel, render_pixels};
use super::unreached::Unreached;
use super::{Context, Integrator, Progress, Rendered};
use crate::accel::Ray;
use crate::bsdf::{Bsdf, RadianceScale};
use crate::film::Sample;
use crate::query::{Interaction, RayCount, SurfacePoint};
use crate::sampling::Rng;

/// Shadow rays per area light at each shading point unless the scene says:
/// a camera sample's direct light is all its estimate of the light there
/// (photon mapping, whose samples also gather, takes one).
const LIGHT_SAMPLES: u32 = 4;

/// The Whitted integrator.
pub struct Whitted;

impl Integrator for Whitted {
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
        let tracer = WhittedTracer {
            ctx,
            surface_light: None,
            light_samples: ctx.config.light_samples_or(LIGHT_SAMPLES),
        };
        tracer.render(progress, Vec::new())
    }
}

/// Light the recursion cannot find by itself, added at every diffuse or
/// glossy surface it reaches (the photon maps' caustics and indirect light).
pub trait SurfaceLight: Sync {
    /// Direct light at a surface where this light's own rays also find the
    /// lights (then it weighs the shadow rays against them); `None`: the
    /// tracer's shadow rays alone hold it.
    fn direct(&self, here: &Shading, rng: &mut Rng, count: &mut RayCount) -> Option<Vec3> {
        let _ = (here, rng, count);
        None
    }

    /// The radiance leaving a surface towards the viewer that this light adds.
    fn at(&self, here: &Shading, rng: &mut Rng, count: &mut RayCount) -> Lit;
}

/// A surface the recursion shades: the point, its BSDF towards the
/// viewer, and the weight of the path from the camera (what the caller
/// multiplies the light there by).
#[derive(Clone, Copy)]
pub struct Shading<'s> {
    /// The surface point.
    pub sp: &'s SurfacePoint,
    /// Its material, seen along the arriving ray.
    pub bsdf: &'s Bsdf<'s>,
    /// The path's weight.
    pub throughput: Vec3,
}

/// Radiance a [`SurfaceLight`] adds at a surface, by component (as
/// [`Sample`] has them).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Lit {
    /// Light from a light that its own rays found (the rest of the direct
    /// light when it weighs the shadow rays: [`SurfaceLight::direct`]).
    pub direct: Vec3,
    /// Light focused by mirrors and glass.
    pub caustic: Vec3,
    /// Light that bounced diffusely before.
    pub indirect: Vec3,
}

/// The recursion over one scene, with the surface light an integrator adds.
pub struct WhittedTracer<'a> {
    /// Scene, intersector and settings.
    pub ctx: &'a Context<'a>,
    /// Caustics and indirect light, if the integrator has them.
    pub surface_light: Option<&'a dyn SurfaceLight>,
    /// Shadow rays per area light at each diffuse or glossy surface.
    pub light_samples: u32,
}

impl WhittedTracer<'_> {
    /// Renders every pixel; `notes` go to the stats.
    pub fn render(&self, progress: &Progress, notes: Vec<String>) -> Rendered {
        let (film, rays) = render_pixels(self.ctx, progress, |x, y, rng, count| {
            average_over_pixel(self.ctx, (x, y), rng, |ray, rng| {
                self.radiance(&ray, 0, (Vec3::ONE, RadianceScale::ONE), rng, count)
            })
        });
        Rendered::new(film, rays, notes)
    }

    /// Radiance arriving along `ray`, split into components (see
    /// [`Sample`]). `depth` counts the specular bounces so far;
    /// `throughput` is what the caller will multiply the result by (for the
    /// cut-off), and `scale` that of the refractions on the way, which the
    /// light found here is multiplied by ([`RadianceScale`]).
    pub fn radiance(
        &self,
        ray: &Ray,
        depth: u32,
        (throughput, scale): (Vec3, RadianceScale),
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Sample {
        let query = &self.ctx.query;
        let sp = match query.first(ray, count) {
            None => return Sample::default(),
            Some(Interaction::Emitter { radiance, .. }) => {
                return Sample { emission: radiance * scale.factor(), ..Sample::default() }
            }
            Some(Interaction::Surface(sp)) => sp,
        };
        let config = self.ctx.config;
        let m = query.material(&sp);
        let bsdf = Bsdf::new(m, &sp, ray.dir.normalize());

        let mut out = Sample { depth: sp.t * ray.dir.length(), ..Sample::default() };
        if bsdf.has_smooth() {
            let sampling = LightSampling::Stratified { samples: self.light_samples };
            let here = Shading { sp: &sp, bsdf: &bsdf, throughput };
            let weighed = self.surface_light.and_then(|extra| extra.direct(&here, rng, count));
            out.direct = match weighed {
                Some(direct) => direct,
                None => direct_light(query, &sp, &bsdf, sampling, rng, count),
            };
            out.indirect = m.diffuse * config.ambient;
            if let Some(extra) = self.surface_light {
                let lit = extra.at(&here, rng, count);
                out.direct += lit.direct;
                out.caustic = lit.caustic;
                out.indirect += lit.indirect;
            }
            let f = scale.factor();
            (out.direct, out.caustic, out.indirect) = (out.direct * f, out.caustic * f, out.indirect * f);
            (out.albedo, out.normal) = (m.diffuse + m.specular, sp.ns);
        }
        if depth + 1 >= config.max_depth {
            return out;
        }
        for branch in bsdf.specular_branches() {
            let carried = throughput * branch.weight;
            if carried.max_element() < config.min_throughput {
                continue;
            }
            let on = (carried, scale.after(&branch));
            let mut seen =
                self.radiance(&sp.spawn(branch.wi), depth + 1, on, rng, count).through(branch.weight);
            if bsdf.has_smooth() {
                // The albedo and normal are this surface's own.
                (seen.albedo, seen.normal) = (Vec3::ZERO, Vec3::ZERO);
            }
            out += seen;
        }
        out
    }
}
