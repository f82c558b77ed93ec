//! Photon tracing (Jensen 1996, 2001): photons leave the lights carrying
//! power, bounce through the scene by Russian roulette, and are stored where
//! they land on diffuse or glossy surfaces, in two maps:
//!
//! - the **caustic map**: photons that reached a diffuse surface through
//!   mirrors and glass only (paths `L S+ D`), for sharp caustics;
//! - the **global map**: photons stored at diffuse surfaces after any path
//!   (`L {S|D}* D`). With final gathering it holds every stored photon (the
//!   gather rays ask it for all light leaving a surface); when it is shown
//!   directly it holds only photons that bounced diffusely at least once,
//!   since direct light comes from shadow rays and caustics from their map.
//!
//! Every photon carries its light's power divided by the number emitted
//! from that light: physical units, no tuning constants. Each photon has its
//! own random numbers (under the Sobol sampler, a light's photons leave it
//! stratified in position and direction: [`PhotonNumbers`]), so the maps do
//! not depend on the thread count.

mod cell_table;
mod cells;
pub mod disc;
pub mod file;
pub(crate) mod grid;
pub mod guide;
pub mod map;
pub mod nearest;
mod precompute;
pub(crate) mod ranges;
mod runs;

use std::time::Instant;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::accel::Ray;
use crate::bsdf::{russian_roulette, Bsdf};
use crate::config::PhotonConfig;
use crate::query::{Interaction, RayCount, SceneQuery, SurfacePoint};
use crate::sampling::{around, uniform_cone, Rng, SamplerKind, Sobol4};
use crate::scene::Scene;
pub use map::{Estimate, Photon, PhotonMap, RecordId};

/// What was built, skipped and how long it took.
#[derive(Debug, Clone, Default)]
pub struct PhotonStats {
    /// Photons emitted for the global map (0 if skipped).
    pub global_emitted: u64,
    /// Photons emitted for the caustic map (0 if skipped).
    pub caustic_emitted: u64,
    /// Seconds spent tracing photons.
    pub trace_seconds: f64,
    /// Seconds spent building the kd-trees.
    pub build_seconds: f64,
    /// Rays the photons traced (none for maps loaded from a file).
    pub rays: RayCount,
    /// One line per map that was not built, saying why.
    pub skipped: Vec<String>,
    /// Whether the maps were loaded from a file rather than traced now.
    pub loaded: bool,
}

/// The photon maps of a scene.
pub struct PhotonMaps {
    /// The global map, if built.
    pub global: Option<PhotonMap>,
    /// The caustic map, if built.
    pub caustic: Option<PhotonMap>,
    /// Whether the global map holds all photons (for final gathering) or
    /// only those that bounced diffusely (to be shown directly).
    pub for_gathering: bool,
    /// Counts and times.
    pub stats: PhotonStats,
}

/// Which map a tracing pass fills.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// Photons stored at every diffuse hit; `keep_direct` also keeps those
    /// arriving straight from a light (for final gathering).
    Global {
        /// Keep photons with no diffuse bounce yet.
        keep_direct: bool,
    },
    /// Photons stored at their first diffuse hit after one or more specular
    /// bounces; every other path is dropped at its first diffuse hit.
    Caustic,
}

/// Traces and stores the maps the scene needs, skipping the ones it does
/// not (and saying so in the stats).
/// `seed` chooses the photons' random numbers, drawn as `sampler` says
/// ([`PhotonNumbers::for_sampler`]); default radii are fractions of the
/// scene's bounding-box `diagonal`.
pub fn build_maps(
    query: &SceneQuery,
    settings: &PhotonConfig,
    max_depth: u32,
    seed: u64,
    sampler: SamplerKind,
    diagonal: f32,
) -> PhotonMaps {
    let scene = query.scene;
    let mut stats = PhotonStats::default();
    let has_specular = scene.meshes.iter().any(|m| scene.materials[m.material].is_specular());
    let has_diffuse = scene.meshes.iter().any(|m| scene.materials[m.material].is_glossy_or_diffuse());
    let has_light = scene.lights.iter().any(|l| l.power().max_element() > 0.0);
    let for_gathering = settings.gather_rays > 0;
    let (global_bounces, caustic_bounces) = map_bounces(settings, max_depth);

    // Traces a map's photons.
    let traced = |pass: Pass, count: u32, stats: &mut PhotonStats| {
        let start = Instant::now();
        let max_bounces = if pass == Pass::Caustic { caustic_bounces } else { global_bounces };
        let (photons, rays) = trace(query, pass, count, max_bounces, seed, sampler);
        stats.trace_seconds += start.elapsed().as_secs_f64();
        stats.rays += rays;
        photons
    };

    let global = if !has_light {
        stats.skipped.push("global map skipped: no light emits power".into());
        None
    } else if !has_diffuse {
        stats.skipped.push("global map skipped: no diffuse or glossy surface to store photons on".into());
        None
    } else if settings.global_photons == 0 {
        stats.skipped.push("global map skipped: 0 global photons requested".into());
        None
    } else {
        stats.global_emitted = settings.global_photons as u64;
        Some(traced(Pass::Global { keep_direct: for_gathering }, settings.global_photons, &mut stats))
    };
    let caustic = if !has_light || !has_diffuse {
        stats.skipped.push("caustic map skipped: nothing for it to light".into());
        None
    } else if !has_specular {
        stats.skipped.push("caustic map skipped: no mirror or glass surface to focus light".into());
        None
    } else if settings.caustic_photons == 0 {
        stats.skipped.push("caustic map skipped: 0 caustic photons requested".into());
        None
    } else {
        stats.caustic_emitted = settings.caustic_photons as u64;
        Some(traced(Pass::Caustic, settings.caustic_photons, &mut stats))
    };

    // Both maps are built at once: neither build keeps both cores busy all
    // the time. Gather rays only need irradiance: estimate it ahead.
    let start = Instant::now();
    let (global, caustic) = rayon::join(
        || {
            global.map(|photons| match for_gathering {
                true => {
                    let stride = record_stride(settings.global_k);
                    PhotonMap::with_irradiance(photons, stride, &settings.global_estimate(diagonal))
                }
                false => PhotonMap::searched_by_runs(photons),
            })
        },
        || caustic.map(|photons| with_caustic_cells(PhotonMap::new(photons), settings, diagonal)),
    );
    stats.build_seconds = start.elapsed().as_secs_f64();
    PhotonMaps { global, caustic, for_gathering, stats }
}

/// Irradiance records per gathering disc of `global_k` photons, on average
/// (see [`record_stride`]).
pub(crate) const RECORDS_PER_DISC: u32 = 6;

/// Every how many photons of the global map (in Morton order) irradiance is
/// estimated ahead of final gathering, for estimates of `global_k` photons:
/// about [`RECORDS_PER_DISC`] records in each gathering disc (every 16th
/// photon at the default `global_k = 100`), at least every 4th.
///
/// Fewer records cost less to make; more make the irradiance between them
/// finer. Christensen's every 4th (25 to a disc) made building 2.5x slower
/// than every 12th (8 to a disc) for 0.4-0.9% less error. From 8 to 6 a
/// disc the teapot's maps at 1M photons built in 0.68-0.74 s instead of
/// 0.78-0.79 s, and the errors of the teapot and both Cornell boxes, at
/// equal samples and at equal time, stayed within their noise
/// (BENCHMARKS.md, issue 17).
pub(crate) fn record_stride(global_k: u32) -> usize {
    (global_k / RECORDS_PER_DISC).max(4) as usize
}

/// The most bounces the photons of the global and the caustic map make:
/// `max_bounces`, and none that would make paths longer than the path
/// tracer's, which follows at most `max_depth` camera rays and then a
/// shadow ray. A photon that bounced `b` times before landing lights a
/// surface seen straight from the camera along `b + 2` rays (its own
/// `b + 1` and the camera's), or `b + 3` when a gather ray reads it there:
/// at most `max_depth + 1` keeps `b` below `max_depth`, or `max_depth - 1`
/// with final gathering. (Surfaces seen through mirrors and glass make
/// longer paths of the same photons; they are few.) Left longer, the
/// photons added about 1% to the Cornell box's indirect light that the
/// path tracer and the references leave out (BENCHMARKS.md, "Corners").
pub fn map_bounces(settings: &PhotonConfig, max_depth: u32) -> (u32, u32) {
    let gather_ray = u32::from(settings.gather_rays > 0);
    let global = settings.max_bounces.min(max_depth.saturating_sub(gather_ray)).max(1);
    (global, settings.max_bounces.min(max_depth))
}

/// The caustic map with cells for its estimates' radius: most caustic
/// estimates find few photons, and the cells answer those (`grid.rs`).
/// Built maps and loaded ones both come through here.
pub(crate) fn with_caustic_cells(map: PhotonMap, settings: &PhotonConfig, diagonal: f32) -> PhotonMap {
    map.with_cells_for(settings.caustic_estimate(diagonal).max_radius)
}

/// Bounding spheres of the meshes with mirror or glass parts: where caustic
/// photons from point and spot lights are aimed.
fn specular_spheres(scene: &Scene) -> Vec<(Vec3, f32)> {
    scene
        .meshes
        .iter()
        .filter(|m| scene.materials[m.material].is_specular())
        .map(|m| {
            let b = m.bounds();
            let center = 0.5 * (b.min + b.max);
            (center, m.positions.iter().map(|p| (*p - center).length()).fold(0.0, f32::max))
        })
        .collect()
}

/// Cones from a point towards spheres, for aiming caustic photons: each
/// photon picks a cone in proportion to its solid angle and a direction
/// uniformly inside it. The density of the mixture at a direction sums over
/// every cone containing it, so overlapping cones are not counted twice.
struct Cones {
    /// (axis, 1 - cos of the half-angle, solid angle)
    cones: Vec<(Vec3, f32, f32)>,
    total: f32,
}

impl Cones {
    /// Cones from `origin` to `spheres`; `None` if the origin is inside one
    /// (then every direction may matter: emit as usual).
    fn new(origin: Vec3, spheres: &[(Vec3, f32)]) -> Option<Cones> {
        let mut cones = Vec::new();
        for &(center, radius) in spheres {
            let to = center - origin;
            let d = to.length();
            if d <= radius * 1.0001 {
                return None;
            }
            // A little wider than the sphere, for rounding at its rim.
            let sin = (radius / d * 1.01).min(1.0);
            let one_minus_cos = sin * sin / (1.0 + (1.0 - sin * sin).sqrt());
            cones.push((to / d, one_minus_cos, std::f32::consts::TAU * one_minus_cos));
        }
        let total = cones.iter().map(|c| c.2).sum();
        (total > 0.0).then_some(Cones { cones, total })
    }

    /// A direction from the uniforms `u` (cone choice in `u.x`, then reused).
    fn sample(&self, u: glam::Vec2, v: glam::Vec2) -> Vec3 {
        let mut pick = u.x * self.total;
        let cone = self.cones.iter().find(|c| {
            let hit = pick < c.2;
            pick -= c.2;
            hit
        });
        let &(axis, one_minus_cos, _) = cone.unwrap_or(self.cones.last().expect("at least one cone"));
        around(axis, uniform_cone(v, one_minus_cos))
    }

    /// The density (per steradian) of [`Cones::sample`] at `dir`.
    fn pdf(&self, dir: Vec3) -> f32 {
        let inside =
            self.cones.iter().filter(|c| crate::numeric::one_minus_cos_between(c.0, dir) <= c.1).count();
        // A direction sampled at a cone's rim may round to just outside it.
        inside.max(1) as f32 / self.total
    }
}

/// A photon arriving at a diffuse or glossy surface, with how it got there.
#[derive(Debug, Clone, Copy)]
pub struct Arrival<'a> {
    /// Where it landed and what it carries.
    pub photon: Photon,
    /// The surface point it landed on.
    pub surface: &'a SurfacePoint,
    /// Diffuse or glossy bounces before this surface.
    pub diffuse_bounces: u32,
    /// Mirror or glass bounces before this surface.
    pub specular_bounces: u32,
}

/// Emits `count` photons in total from all lights (shared in proportion to
/// their power), traces them, and returns the photons `pass` keeps and the
/// rays they traced.
///
/// For the caustic pass, point and spot lights aim their photons at the
/// bounding spheres of mirror and glass meshes (Jensen's projection maps,
/// with cones): photons that could only land on diffuse surfaces directly
/// would be thrown away anyway. Each carries `intensity / pdf / n`, so the
/// estimate is unchanged, with far more photons where caustics form.
pub fn trace(
    query: &SceneQuery,
    pass: Pass,
    count: u32,
    max_bounces: u32,
    seed: u64,
    sampler: SamplerKind,
) -> (Vec<Photon>, RayCount) {
    let stream_seed = seed ^ if pass == Pass::Caustic { 0xC0FFEE } else { 0x61_0BA1 };
    let (chunks, rays) = emit(
        query,
        count,
        max_bounces,
        PhotonNumbers::for_sampler(sampler, stream_seed, 0),
        pass == Pass::Caustic,
        Vec::new,
        |stored: &mut Vec<Photon>, arrival: &Arrival| {
            let keep = match pass {
                Pass::Caustic => arrival.specular_bounces > 0,
                Pass::Global { keep_direct } => keep_direct || arrival.diffuse_bounces > 0,
            };
            if keep {
                stored.push(arrival.photon);
            }
            // Caustic paths (`L S+ D`) take no diffuse or glossy bounce: at a
            // surface with a mirror or glass part too, they go on only by it.
            pass != Pass::Caustic
        },
    );
    (chunks.into_iter().flatten().collect(), rays)
}

/// Where each photon's random numbers come from.
#[derive(Debug, Clone, Copy)]
pub enum PhotonNumbers {
    /// Photon `i` draws from the PCG32 stream `(seed, i)`.
    Independent {
        /// Chooses the streams.
        seed: u64,
    },
    /// Photon `i` leaves its light at point `first + i` of the light's 4D
    /// Sobol sequence ([`Sobol4`]): where on the light it leaves and in
    /// which direction are stratified together over all the photons so
    /// far, those of earlier calls (SPPM's passes) too, so a patch of the
    /// scene gets its share of photons more evenly than at random (photon
    /// mapping's error in a glass sphere's caustic fell 29%, BENCHMARKS.md).
    /// Its bounces
    /// draw from a PCG32 stream of its own. With several lights, each
    /// light's photons of a call are a block of its sequence.
    Sobol {
        /// Chooses the scrambling and the bounces' streams.
        seed: u64,
        /// Photons emitted before this call.
        first: u64,
    },
}

impl PhotonNumbers {
    /// `Sobol` under the Sobol sampler, else `Independent` (then `first`
    /// plays no part: `seed` must differ from call to call).
    pub fn for_sampler(sampler: SamplerKind, seed: u64, first: u64) -> PhotonNumbers {
        match sampler {
            SamplerKind::Sobol => PhotonNumbers::Sobol { seed, first },
            SamplerKind::Independent => PhotonNumbers::Independent { seed },
        }
    }

    /// Each of `lights` lights' sequence (none for independent numbers).
    fn sequences(self, lights: usize) -> Vec<Sobol4> {
        match self {
            PhotonNumbers::Independent { .. } => Vec::new(),
            PhotonNumbers::Sobol { seed, .. } => (0..lights as u64).map(|l| Sobol4::new(seed, l)).collect(),
        }
    }

    /// Photon `index` of the call from light `light`: the uniforms of its
    /// light sample (position, direction) and the numbers for its bounces.
    /// `sequences` are [`PhotonNumbers::sequences`].
    fn light_sample(self, light: usize, index: u64, sequences: &[Sobol4]) -> (Vec2, Vec2, Rng) {
        match self {
            PhotonNumbers::Independent { seed } => {
                let mut rng = Rng::new(seed, index);
                let (u, v) = (rng.uniform2(), rng.uniform2());
                (u, v, rng)
            }
            PhotonNumbers::Sobol { seed, first } => {
                let i = first + index;
                // A sequence holds 2^32 points; past that, another.
                let (u, v) = match i >> 32 {
                    0 => sequences[light].point(i as u32),
                    wraps => Sobol4::new(seed, light as u64 ^ wraps << 32).point(i as u32),
                };
                (u, v, Rng::new(seed ^ (light as u64).wrapping_mul(0xA24B_AED4_963E_E407), i))
            }
        }
    }
}

/// Photons traced per work item: the unit of parallelism, and of order.
const CHUNK: u64 = 4096;

/// Emits `count` photons from all lights in proportion to their power, each
/// carrying its light's power over the photons that light emits, and traces
/// them. `arrive` sees each photon at every diffuse or glossy surface it
/// reaches and says whether the photon may go on by a diffuse or glossy
/// bounce (if not, it goes on only by the surface's mirror or glass part,
/// if it has one, as a caustic path must). Photon `i` draws its
/// random numbers as `numbers` says; the photons are split into chunks of
/// consecutive indices, each with its own state from `start`, returned in
/// index order, so the result never depends on the thread count; with them,
/// the rays all the photons traced.
///
/// With `aim_at_specular`, point and spot lights emit only towards mirror
/// and glass meshes (see [`trace`]).
#[allow(clippy::too_many_arguments)]
pub fn emit<T: Send>(
    query: &SceneQuery,
    count: u32,
    max_bounces: u32,
    numbers: PhotonNumbers,
    aim_at_specular: bool,
    start: impl Fn() -> T + Sync,
    arrive: impl Fn(&mut T, &Arrival) -> bool + Sync,
) -> (Vec<T>, RayCount) {
    let scene = query.scene;
    // Photons per light, in proportion to power; each carries power / its count.
    let weights: Vec<f32> = scene.lights.iter().map(|l| l.power().element_sum()).collect();
    let total: f32 = weights.iter().sum();
    if total <= 0.0 || count == 0 {
        return (Vec::new(), RayCount::default());
    }
    let mut per_light: Vec<u64> =
        weights.iter().map(|w| (count as f64 * (*w / total) as f64).round() as u64).collect();
    for (n, w) in per_light.iter_mut().zip(&weights) {
        if *w > 0.0 && *n == 0 {
            *n = 1;
        }
    }
    let starts: Vec<u64> =
        per_light.iter().scan(0, |acc, n| Some(std::mem::replace(acc, *acc + n))).collect();
    let emitted: u64 = per_light.iter().sum();
    let spheres = if aim_at_specular { specular_spheres(scene) } else { Vec::new() };
    let aims: Vec<Option<Cones>> = scene
        .lights
        .iter()
        .map(|light| match light {
            crate::light::Light::Point { position, .. } | crate::light::Light::Spot { position, .. }
                if !spheres.is_empty() =>
            {
                Cones::new(*position, &spheres)
            }
            _ => None,
        })
        .collect();

    let sequences = numbers.sequences(scene.lights.len());
    let (chunks, counts): (Vec<T>, Vec<RayCount>) = (0..emitted.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut state = start();
            let mut rays = RayCount::default();
            for index in chunk * CHUNK..((chunk + 1) * CHUNK).min(emitted) {
                let light = starts.partition_point(|&s| s <= index) - 1;
                let (u, v, mut rng) = numbers.light_sample(light, index, &sequences);
                let (ray, power) = match &aims[light] {
                    Some(cones) => {
                        let dir = cones.sample(u, v);
                        match scene.lights[light].intensity(dir) {
                            Some((origin, intensity)) => (Ray::new(origin, dir), intensity / cones.pdf(dir)),
                            None => continue,
                        }
                    }
                    None => scene.lights[light].emit(u, v),
                };
                let power = power / per_light[light] as f32;
                let emitted = Emitted { ray, power, from_delta_light: scene.lights[light].is_delta() };
                trace_photon(query, emitted, max_bounces, &mut rng, &mut rays, &mut |a| {
                    arrive(&mut state, a)
                });
            }
            (state, rays)
        })
        .unzip();
    (chunks, counts.into_iter().sum())
}

/// A photon as it leaves its light.
struct Emitted {
    ray: Ray,
    power: Vec3,
    /// Whether the light is a point or spot light.
    from_delta_light: bool,
}

/// Follows one photon, showing it to `arrive` at every diffuse or glossy
/// surface, until it is absorbed, makes a diffuse or glossy bounce where
/// `arrive` said it may not, or has made `max_bounces` bounces. Its rays are
/// added to `count`.
fn trace_photon(
    query: &SceneQuery,
    emitted: Emitted,
    max_bounces: u32,
    rng: &mut Rng,
    count: &mut RayCount,
    arrive: &mut dyn FnMut(&Arrival) -> bool,
) {
    let Emitted { mut ray, mut power, from_delta_light } = emitted;
    let (mut diffuse_bounces, mut specular_bounces) = (0u32, 0u32);
    for _ in 0..max_bounces {
        // The front of an area light absorbs photons, as camera paths see it.
        let Some(Interaction::Surface(sp)) = query.first(&ray, count) else { return };
        let m = query.material(&sp);
        let dir = ray.dir.normalize();

        let mut may_scatter_diffusely = true;
        if m.is_glossy_or_diffuse() {
            // Light from below the shading normal's side lights nothing there.
            let taken = if sp.smooth_lobes_take(-dir) { sp.shading_over_geometric(-dir) } else { 0.0 };
            let photon = Photon {
                position: sp.p,
                incoming: -dir,
                power: power * taken,
                normal: sp.ns,
                face_normal: sp.ng,
                indirect: diffuse_bounces > 0,
                from_delta_light,
            };
            may_scatter_diffusely =
                arrive(&Arrival { photon, surface: &sp, diffuse_bounces, specular_bounces });
            // A caustic photon on a surface of mirror or glass and diffuse
            // parts (an MTL `illum 3` paint, frosted glass) goes on through
            // the first; ending it here lost that part's whole caustic.
            if !may_scatter_diffusely && !m.is_specular() {
                return;
            }
        }

        // Russian roulette on the surface's albedo (the seed report's table,
        // with the four lobes of our materials): the photon goes on with
        // probability max(albedo), in a lobe chosen in proportion to its
        // reflectance by the same uniform; dividing by that probability keeps
        // the power unbiased per channel.
        let bsdf = Bsdf::new(m, &sp, dir);
        let xi = rng.uniform();
        let Some(q) = russian_roulette(bsdf.albedo().max_element().min(1.0), xi) else { return };
        // Light carried from the lights takes Veach's correction where the
        // shading normal leans (as VCM's light subpaths): with the stored
        // power's, the density estimates and the path tracer agree on
        // smooth meshes of few triangles. The smooth lobes' sample holds it.
        let Some(s) = bsdf.sample_adjoint(xi / q, rng) else { return };
        let turn = if s.kind.is_specular() {
            specular_bounces += 1;
            sp.adjoint_shading(-dir, s.wi)
        } else if may_scatter_diffusely {
            diffuse_bounces += 1;
            1.0
        } else {
            return;
        };
        power *= s.weight / q * turn;
        ray = sp.spawn(s.wi);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Photons aimed through overlapping cones carry `intensity / pdf`: the
    /// pdf must count every cone that holds a direction, or the overlap gets
    /// twice the light. Then `E[1/pdf]` over the directions inside any one
    /// cone is that cone's solid angle, overlap or not.
    #[test]
    fn overlapping_cones_weigh_each_direction_once() {
        let origin = Vec3::ZERO;
        // Two spheres whose cones overlap, and a third apart.
        let spheres = [
            (Vec3::new(0.0, -4.0, 0.0), 1.0),
            (Vec3::new(0.8, -4.0, 0.0), 1.0),
            (Vec3::new(0.0, 4.0, 0.0), 0.5),
        ];
        let cones = Cones::new(origin, &spheres).unwrap();
        let mut rng = Rng::new(3, 0);
        let n = 400_000;
        let mut sums = [0.0f64; 3];
        for _ in 0..n {
            let dir = cones.sample(rng.uniform2(), rng.uniform2());
            let weight = 1.0 / cones.pdf(dir) as f64;
            for (sum, cone) in sums.iter_mut().zip(&cones.cones) {
                if crate::numeric::one_minus_cos_between(cone.0, dir) <= cone.1 {
                    *sum += weight;
                }
            }
        }
        for (sum, cone) in sums.iter().zip(&cones.cones) {
            let estimate = sum / n as f64;
            let ratio = estimate / cone.2 as f64;
            assert!((ratio - 1.0).abs() < 0.01, "solid angle {} estimated as {estimate}", cone.2);
        }
        // The overlap is real: some directions lie in both of the first two cones.
        let both = (0..10_000)
            .map(|_| cones.sample(rng.uniform2(), rng.uniform2()))
            .filter(|&d| {
                cones.cones[..2].iter().all(|c| crate::numeric::one_minus_cos_between(c.0, d) <= c.1)
            })
            .count();
        assert!(both > 1000, "{both}");
    }
}
