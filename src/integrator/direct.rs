//! Direct light at a surface point by shadow rays towards every light: the
//! one estimator of light arriving straight from the lights, shared by all
//! integrators.

use glam::Vec3;

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

/// Light arriving straight from the lights at `sp` and scattered towards
/// the viewer by `bsdf`'s smooth lobes. Skips the shadow ray wherever the
/// light cannot contribute.
pub fn direct_light(
    query: &SceneQuery,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    sampling: LightSampling,
    rng: &mut Rng,
    count: &mut RayCount,
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for light in &query.scene.lights {
        let samples = match sampling {
            LightSampling::Stratified { samples } if !light.is_delta() => samples,
            _ => 1,
        };
        for i in 0..samples {
            let Some(ls) = light.sample_incident(sp.p, stratified(i, samples, rng)) else { continue };
            let wi = (ls.position - sp.p).normalize();
            let cos = wi.dot(sp.ns);
            if cos <= 0.0 || wi.dot(sp.ng) <= 0.0 || ls.irradiance == Vec3::ZERO {
                continue;
            }
            let f = bsdf.eval(wi);
            if f == Vec3::ZERO || query.occluded(&sp.spawn_to(ls.position), count) {
                continue;
            }
            sum += match sampling {
                LightSampling::Stratified { .. } => f * ls.irradiance * (cos / samples as f32),
                LightSampling::MultipleImportance if light.is_delta() => f * ls.irradiance * cos,
                LightSampling::MultipleImportance => {
                    let p_light = light.pdf_solid_angle(ls.position, sp.p);
                    let p_bsdf = bsdf.pdf(wi);
                    f * ls.irradiance * cos * (p_light / (p_light + p_bsdf))
                }
            };
        }
    }
    sum
}
