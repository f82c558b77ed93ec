//! Stochastic progressive photon mapping (Hachisuka and Jensen 2009): the
//! consistent photon mapper. Each pass
//!
//! 1. traces one jittered camera path per pixel through mirrors and glass to
//!    its first diffuse or glossy surface (the pixel's *visible point*),
//!    adding the direct light there by shadow rays;
//! 2. traces a fresh batch of photons and lets every visible point within its
//!    pixel's radius of a photon's landing place gather it;
//! 3. shrinks each pixel's radius as photons arrive: with `N` photons so far
//!    and `M` new ones, `N' = N + alpha M`, `R' = R sqrt(N' / (N + M))`, and
//!    the gathered flux is scaled by `(R' / R)^2`.
//!
//! The radius goes to zero and the photon count to infinity, so the bias
//! and the noise both vanish as passes go on, while memory stays bounded by
//! one visible point per pixel and one batch of photons.
//!
//! Photons arriving straight from a light are not gathered (shadow rays
//! already count that light); those that came through mirrors and glass only
//! go to the `caustic` component, the rest to `global`. Direct light and
//! lights seen through mirrors go to `direct`.

use std::f32::consts::PI;
use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use super::surface::SurfacePoint;
use super::whitted::{RayCount, Whitted};
use super::{Components, RenderSettings, RenderStats, Rendered};
use crate::accel::{Intersector, Ray};
use crate::light::nearest_emitter;
use crate::photon::{emit, Arrival, PhotonStats};
use crate::sampling::Rng;
use crate::scene::Scene;

/// How progressive photon mapping runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SppmSettings {
    /// Passes (each one camera sample per pixel and one batch of photons).
    pub passes: u32,
    /// Photons emitted per pass.
    pub photons_per_pass: u32,
    /// Every pixel's gathering radius before the first pass.
    pub initial_radius: f32,
    /// The fraction of new photons kept per pass, in (0, 1): smaller shrinks
    /// the radius faster (less bias, more noise). Hachisuka and Jensen use 0.7.
    pub alpha: f32,
}

/// What a pixel carries from pass to pass.
#[derive(Debug, Clone)]
struct PixelState {
    rng: Rng,
    /// Sum over passes of the direct light and lights seen (by shadow rays).
    direct: Vec3,
    /// Gathered flux of caustic photons (`L S+ D`), scaled as the radius shrinks.
    tau_caustic: Vec3,
    /// Gathered flux of the other photons, scaled as the radius shrinks.
    tau_global: Vec3,
    /// Photons counted so far (`N`, fractional).
    photons: f32,
    /// Gathering radius.
    radius: f32,
}

/// Where a pixel's camera path met its first diffuse or glossy surface in
/// this pass, and with what weight.
#[derive(Debug, Clone, Copy)]
struct VisiblePoint {
    p: Vec3,
    /// Unit shading normal on the camera's side.
    n: Vec3,
    /// Unit direction back along the camera path.
    wo: Vec3,
    material: usize,
    weight: Vec3,
    /// The pixel's radius this pass.
    radius: f32,
}

/// Photon flux one visible point gathered in one pass.
#[derive(Debug, Clone, Copy, Default)]
struct Gathered {
    caustic: Vec3,
    global: Vec3,
    count: u32,
}

/// A progressive render in progress: run passes, read the image at any time.
pub struct Progressive<'a> {
    scene: &'a Scene,
    accel: &'a dyn Intersector,
    settings: &'a RenderSettings,
    pixels: Vec<PixelState>,
    passes: u32,
    /// Rays traced so far (camera paths and shadow rays; photons not counted).
    rays: RayCount,
    /// Seconds spent tracing photons and gathering them.
    photon_seconds: f64,
}

impl<'a> Progressive<'a> {
    /// A render with no passes yet.
    pub fn new(scene: &'a Scene, accel: &'a dyn Intersector, settings: &'a RenderSettings) -> Self {
        let count = settings.width as u64 * settings.height as u64;
        let radius = settings.photons.sppm.initial_radius;
        let pixels = (0..count)
            .map(|i| PixelState {
                rng: Rng::new(settings.seed, i),
                direct: Vec3::ZERO,
                tau_caustic: Vec3::ZERO,
                tau_global: Vec3::ZERO,
                photons: 0.0,
                radius,
            })
            .collect();
        Progressive {
            scene,
            accel,
            settings,
            pixels,
            passes: 0,
            rays: RayCount::default(),
            photon_seconds: 0.0,
        }
    }

    /// Passes run so far.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// Runs one pass: visible points, photons, radius update.
    pub fn run_pass(&mut self) {
        let (scene, settings) = (self.scene, self.settings);
        let whitted = Whitted { scene, accel: self.accel, settings, maps: None };
        let width = settings.width as usize;
        let (points, counts): (Vec<Option<VisiblePoint>>, Vec<RayCount>) = self
            .pixels
            .par_iter_mut()
            .enumerate()
            .map(|(i, state)| {
                let mut count = RayCount::default();
                let (x, y) = ((i % width) as u32, (i / width) as u32);
                (visible_point(&whitted, (x, y), state, &mut count), count)
            })
            .unzip();
        for c in counts {
            self.rays.closest += c.closest;
            self.rays.shadow += c.shadow;
        }

        let start = Instant::now();
        let gathered = self.gather_photons(&points);
        self.photon_seconds += start.elapsed().as_secs_f64();

        let alpha = settings.photons.sppm.alpha;
        self.pixels.par_iter_mut().zip(gathered).for_each(|(state, g)| {
            if g.count == 0 {
                return;
            }
            let m = g.count as f32;
            let kept = state.photons + alpha * m;
            let radius = state.radius * (kept / (state.photons + m)).sqrt();
            let shrink = (radius / state.radius).powi(2);
            state.tau_caustic = (state.tau_caustic + g.caustic) * shrink;
            state.tau_global = (state.tau_global + g.global) * shrink;
            state.photons = kept;
            state.radius = radius;
        });
        self.passes += 1;
    }

    /// The image so far, with its work counts; `elapsed` is the time to report.
    pub fn rendered(&self, elapsed: Duration) -> Rendered {
        let photons = PhotonStats {
            global_emitted: self.passes as u64 * self.settings.photons.sppm.photons_per_pass as u64,
            trace_seconds: self.photon_seconds,
            ..PhotonStats::default()
        };
        Rendered {
            width: self.settings.width,
            height: self.settings.height,
            pixels: self.components(),
            stats: RenderStats {
                elapsed,
                rays: self.rays.closest,
                shadow_rays: self.rays.shadow,
                photons: Some(photons),
            },
        }
    }

    /// The image so far, one [`Components`] per pixel, row-major.
    fn components(&self) -> Vec<Components> {
        let passes = self.passes.max(1) as f32;
        self.pixels
            .iter()
            .map(|s| {
                let area = passes * PI * s.radius * s.radius;
                Components {
                    direct: s.direct / passes,
                    specular: Vec3::ZERO,
                    caustic: s.tau_caustic / area,
                    global: s.tau_global / area,
                }
            })
            .collect()
    }

    /// Traces this pass's photons and sums, per pixel, the flux its visible
    /// point gathers. Splats are collected per chunk of photons and added in
    /// photon order, so the sums do not depend on the thread count.
    fn gather_photons(&self, points: &[Option<VisiblePoint>]) -> Vec<Gathered> {
        let mut gathered = vec![Gathered::default(); points.len()];
        let grid = Grid::new(points);
        if grid.is_empty() {
            return gathered;
        }
        let scene = self.scene;
        let sppm = &self.settings.photons.sppm;
        // A different photon stream every pass.
        let stream_seed = (self.settings.seed ^ 0x5_99A1)
            .wrapping_add((self.passes as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let chunks = emit(
            scene,
            self.accel,
            sppm.photons_per_pass,
            self.settings.photons.max_bounces,
            stream_seed,
            false,
            Vec::new,
            |splats: &mut Vec<(u32, Vec3, bool)>, arrival: &Arrival| {
                if arrival.diffuse_bounces + arrival.specular_bounces == 0 {
                    return true; // direct light: the shadow rays' part
                }
                let photon = &arrival.photon;
                for &i in grid.near(photon.position) {
                    let Some(vp) = &points[i as usize] else { continue };
                    if (vp.p - photon.position).length_squared() > vp.radius * vp.radius
                        || !photon.lights_surface(vp.n)
                    {
                        continue;
                    }
                    let f = scene.materials[vp.material].brdf(vp.n, photon.incoming, vp.wo);
                    splats.push((i, vp.weight * f * photon.power, arrival.diffuse_bounces == 0));
                }
                true
            },
        );
        for (i, flux, caustic) in chunks.into_iter().flatten() {
            let g = &mut gathered[i as usize];
            if caustic {
                g.caustic += flux;
            } else {
                g.global += flux;
            }
            g.count += 1;
        }
        gathered
    }
}

/// Follows one jittered camera path from pixel `(x, y)` to its visible
/// point, adding the light that shadow rays and emitters give to
/// `state.direct`. At a surface with both diffuse/glossy and
/// mirror/glass parts the path stops or goes on at random, in proportion
/// to their weights (the weight divided by that chance keeps it unbiased).
fn visible_point(
    whitted: &Whitted,
    (x, y): (u32, u32),
    state: &mut PixelState,
    count: &mut RayCount,
) -> Option<VisiblePoint> {
    let (scene, settings) = (whitted.scene, whitted.settings);
    let rng = &mut state.rng;
    let jitter = rng.uniform2();
    let mut ray = scene.camera.ray(x as f32 + jitter.x, y as f32 + jitter.y, settings.width, settings.height);
    let mut weight = Vec3::ONE;
    for _ in 0..settings.max_depth {
        count.closest += 1;
        let hit = whitted.accel.intersect(&ray);
        let nearest = Ray { t_max: hit.map_or(ray.t_max, |h| h.t), ..ray };
        if let Some((_, _, emitted)) = nearest_emitter(&scene.lights, &nearest) {
            state.direct += weight * emitted;
            return None;
        }
        let hit = hit?;
        let sp = SurfacePoint::new(scene, &ray, &hit);
        let m = &scene.materials[sp.material];
        let dir = ray.dir.normalize();
        let non_delta = (m.diffuse + m.specular).element_sum();
        let delta = (m.mirror + m.transmittance).element_sum();
        if non_delta > 0.0 {
            let direct = whitted.direct_light(&sp, -dir, rng, count) + m.diffuse * settings.ambient;
            state.direct += weight * direct;
            let stop = non_delta / (non_delta + delta);
            if delta <= 0.0 || rng.uniform() < stop {
                return Some(VisiblePoint {
                    p: sp.p,
                    n: sp.ns,
                    wo: -dir,
                    material: sp.material,
                    weight: weight / stop,
                    radius: state.radius,
                });
            }
            weight /= 1.0 - stop;
        }
        let (part, next) = sp.specular_bounce(m, dir, rng)?;
        weight *= part;
        if weight == Vec3::ZERO {
            return None;
        }
        ray = sp.spawn(next);
    }
    None
}

/// Visible points hashed into a uniform grid whose cells are as wide as the
/// largest radius: each point is listed in every cell its sphere touches, so
/// a photon needs to look in its own cell only.
struct Grid {
    cell: f32,
    /// `starts[b]..starts[b + 1]` index `points` for bucket `b`.
    starts: Vec<u32>,
    points: Vec<u32>,
}

impl Grid {
    fn new(visible: &[Option<VisiblePoint>]) -> Grid {
        let cell = visible.iter().flatten().map(|vp| vp.radius).fold(0.0, f32::max);
        let buckets = (visible.len() * 2).max(1);
        if cell <= 0.0 {
            return Grid { cell, starts: vec![0; buckets + 1], points: Vec::new() };
        }
        let mut entries: Vec<(u32, u32)> = visible
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, vp)| {
                let mut cells = Vec::new();
                if let Some(vp) = vp {
                    let lo = Self::cell_of(vp.p - Vec3::splat(vp.radius), cell);
                    let hi = Self::cell_of(vp.p + Vec3::splat(vp.radius), cell);
                    for z in lo[2]..=hi[2] {
                        for y in lo[1]..=hi[1] {
                            for x in lo[0]..=hi[0] {
                                cells.push((Self::bucket([x, y, z], buckets), i as u32));
                            }
                        }
                    }
                }
                cells
            })
            .collect();
        // Two cells of one point may share a bucket: list it once.
        entries.par_sort_unstable();
        entries.dedup();
        let mut starts = vec![0u32; buckets + 1];
        for &(b, _) in &entries {
            starts[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            starts[b + 1] += starts[b];
        }
        Grid { cell, starts, points: entries.into_iter().map(|e| e.1).collect() }
    }

    fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    fn cell_of(p: Vec3, cell: f32) -> [i32; 3] {
        (p / cell).floor().to_array().map(|c| c as i32)
    }

    fn bucket(c: [i32; 3], buckets: usize) -> u32 {
        let h = (c[0] as u32).wrapping_mul(73_856_093)
            ^ (c[1] as u32).wrapping_mul(19_349_663)
            ^ (c[2] as u32).wrapping_mul(83_492_791);
        (h as usize % buckets) as u32
    }

    /// The visible points that may be within their radius of `p`.
    fn near(&self, p: Vec3) -> &[u32] {
        let b = Self::bucket(Self::cell_of(p, self.cell), self.starts.len() - 1) as usize;
        &self.points[self.starts[b] as usize..self.starts[b + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_finds_exactly_the_points_in_reach() {
        let mut rng = Rng::new(3, 4);
        let points: Vec<Option<VisiblePoint>> = (0..2000)
            .map(|i| {
                (i % 7 != 0).then(|| VisiblePoint {
                    p: Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0,
                    n: Vec3::Y,
                    wo: Vec3::Y,
                    material: 0,
                    weight: Vec3::ONE,
                    radius: 0.02 + 0.1 * rng.uniform(),
                })
            })
            .collect();
        let grid = Grid::new(&points);
        let mut total = 0;
        for k in 0..2000 {
            // Half anywhere, half within 0.05 per axis of a point (mostly in its reach).
            let jitter = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5;
            let q = match points[k] {
                Some(vp) if k % 2 == 0 => vp.p + 0.1 * jitter,
                _ => jitter * 4.4,
            };
            let in_reach = |i: usize| points[i].is_some_and(|vp| (vp.p - q).length() <= vp.radius);
            let mut found: Vec<usize> =
                grid.near(q).iter().map(|&i| i as usize).filter(|&i| in_reach(i)).collect();
            found.sort_unstable();
            let listed = found.len();
            found.dedup();
            assert_eq!(found.len(), listed, "a point listed twice would gather a photon twice");
            let brute: Vec<usize> = (0..points.len()).filter(|&i| in_reach(i)).collect();
            assert_eq!(found, brute, "at {q}");
            total += found.len();
        }
        assert!(total > 500, "the queries must reach points: {total}");
    }
}
