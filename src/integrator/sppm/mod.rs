//! Stochastic progressive photon mapping (Hachisuka and Jensen 2009): the
//! consistent photon mapper. Each pass
//!
//! 1. traces jittered camera paths from each pixel (with the Sobol sampler,
//!    the pixel's successive samples over all passes, those that leave
//!    visible points in a sequence of their own) through mirrors and glass
//!    to their first diffuse or glossy surface, adding the direct light
//!    there by shadow rays (averaged over all the pixel's paths: 2 a pass;
//!    under a time budget 2 on average, more where the pixels around are
//!    noisier);
//!    the first path's surface point is the pixel's *visible point*. A
//!    sharp glossy lobe (Phong exponent above 10) is followed instead, by
//!    chance, as the path tracer follows it, and gathers only what no
//!    camera path meets: point and spot lights' caustics (a visible point
//!    there weighed the photons it found by the lobe's peak, a speckle),
//!    each such point within a radius of its own that shrinks pass by pass
//!    (`LobeRadius`);
//! 2. traces a fresh batch of photons (with the Sobol sampler, the next
//!    photons of each light's low-discrepancy sequence, so that all the
//!    passes' photons together leave the lights stratified) and lets every
//!    visible point gather the photons that land within its pixel's radius
//!    (a range search from each point, `photon::ranges`);
//! 3. shrinks each pixel's radius as photons arrive: with `N` photons so far
//!    and `M` new ones, `N' = N + alpha M`, `R' = R sqrt(N' / (N + M))`, and
//!    the gathered flux is scaled by `(R' / R)^2`.
//!
//! The radius goes to zero and the photon count to infinity, so the bias
//! and the noise both vanish as passes go on, while memory stays bounded by
//! one visible point per pixel and one batch of photons. Unless a starting
//! radius is given, each pixel starts with the radius that holds 32 photons
//! of a batch traced before the first pass, around its first visible point,
//! but grows no faster than a quarter of the distance from the photons
//! there (so that discs beside a caustic do not take it in: `Density`).
//! Under a time budget the last pass may be a part of one (fewer photons
//! and camera paths), weighed as that part.
//!
//! Photons arriving straight from a light are not gathered (shadow rays
//! already count that light); those that came through mirrors and glass only
//! go to the `caustic` component, the rest to `global`. A caustic photon on
//! a surface the camera sees directly also sends its light straight to the
//! pixel it is seen in (light tracing, one shadow ray to the eye), and the
//! two ways share each such path by weights that favour light tracing where
//! the pixel's disc is small beside its footprint (`to_camera_weight`): a
//! caustic's fold lines stay sharp. Direct light and
//! lights seen through mirrors go to `direct`. A visible point gathers only
//! photons whose paths, with the camera's, are no longer than the path
//! tracer's (`max_depth` camera rays, then a shadow ray), and near a corner
//! its flux stands for the share of its disc on its own surface
//! (`photon::disc`).

use std::f32::consts::{FRAC_1_PI, PI};
use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use super::direct::{direct_light, direct_light_against, Against, LightSamples, LightSampling};
use super::path::PathClass;
use super::rounds::{deviation, luminance, split_by_noise, LAST_ROUND_SHARE};
use super::to_camera::CameraView;
use super::{Context, Integrator, Progress, Rendered};
use crate::bsdf::{Bsdf, RadianceScale};
use crate::config::RenderConfig;
use crate::film::{Film, Sample};
use crate::material::Material;
use crate::photon::disc::DiscShare;
use crate::photon::nearest::{Nearest, PointTree};
use crate::photon::ranges::{close_together, GroupBuffers, RangeSearch};
use crate::photon::{emit, Arrival, Photon, PhotonNumbers};
use crate::query::{Interaction, RayCount};
use crate::sampling::{Rng, SamplerKind};

/// The progressive photon-mapping integrator.
pub struct Sppm;

impl Integrator for Sppm {
    fn work_units(&self, config: &RenderConfig) -> u64 {
        config.pixels() * config.photons.sppm.passes as u64
    }

    fn samples_per_pixel(&self, config: &RenderConfig) -> u32 {
        config.photons.sppm.passes
    }

    /// Every camera path adds the lights it sees, jittered over the pixel.
    fn averages_lights_seen(&self) -> bool {
        true
    }

    /// `CAMERA_PATHS_PER_PASS` camera paths a pass.
    fn emission_samples(&self, config: &RenderConfig) -> Option<u32> {
        Some(config.photons.sppm.passes * CAMERA_PATHS_PER_PASS)
    }

    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered {
        let start = Instant::now();
        let mut run = Progressive::new(ctx);
        match ctx.config.time {
            // Whole passes while one as long as the longest so far fits,
            // then a part of a pass in what is left.
            Some(budget) => {
                // What the lights' edges took before the first pass (the
                // budget counts from the render's start) and will take
                // after `passes` passes.
                let edges = |passes: u32| {
                    let paths = (passes * CAMERA_PATHS_PER_PASS) as f64;
                    ctx.light_edges.map_or(0.0, |e| e.look_seconds() + e.seconds_after(paths))
                };
                while run.passes() < crate::config::limits::MAX_PASSES {
                    let left = budget as f64 - start.elapsed().as_secs_f64() - edges(run.passes() + 1);
                    let fraction = if run.passes() == 0 { 1.0 } else { run.fraction_fitting(left) };
                    if fraction < MIN_PASS_FRACTION {
                        break;
                    }
                    run.run_part_of_pass(fraction);
                    progress(ctx.config.pixels());
                    if fraction < 1.0 {
                        break;
                    }
                    if let Some(snapshot) = ctx.snapshot.filter(|_| run.passes().is_power_of_two()) {
                        snapshot(&run.rendered(start.elapsed()).film, run.passes());
                    }
                }
            }
            None => {
                for _ in 0..ctx.config.photons.sppm.passes {
                    run.run_pass();
                    progress(ctx.config.pixels());
                }
            }
        }
        let mut rendered = run.rendered(start.elapsed());
        rendered.stats.samples_per_pixel = run.passes();
        if let Some(budget) = ctx.config.time {
            let last = match run.last_part() {
                Some(photons) => {
                    let share = photons as f64 / ctx.config.photons.sppm.photons_per_pass as f64;
                    format!(", the last {:.0}% of one", share * 100.0)
                }
                None => String::new(),
            };
            let passes = super::counted(run.passes().into(), "pass", "passes");
            rendered
                .stats
                .notes
                .push(format!("time budget {} s: {passes}{last}", super::budget_seconds(budget)));
            rendered.stats.pixel_samples = Some(run.pixels.iter().map(|s| s.paths).collect());
        }
        rendered
    }
}

/// What a pixel carries from pass to pass.
#[derive(Debug, Clone)]
struct PixelState {
    rng: Rng,
    /// Sum over camera paths of what they find themselves: lights seen,
    /// direct light by shadow rays, the ambient term, and the first
    /// surface's albedo, normal and depth.
    seen: Sample,
    /// Camera paths so far.
    paths: u32,
    /// Sum over camera paths of the square of the luminance of what each found.
    seen_sq: f64,
    /// Sum over passes of the caustic light the camera sees directly, from
    /// the caustic photons themselves (light tracing: `to_camera`).
    caustic_to_camera: Vec3,
    /// What the pixel's visible points gathered.
    visible: Disc,
    /// Sum over passes of the radiance gathered where the pixel's camera
    /// paths met glossy lobes they follow (point and spot lights' caustics
    /// on the lobe), caustic and global: each point within a radius of its
    /// own ([`LobeRadius`]).
    lobe: Radiance,
}

/// Radiance gathered: from caustic photons (`L S+ D`), and from the others.
#[derive(Debug, Clone, Copy, Default)]
struct Radiance {
    caustic: Vec3,
    global: Vec3,
}

/// A pixel's gathering disc as passes go (Hachisuka and Jensen 2009): its
/// radius, the photons counted, and the flux gathered, scaled as the
/// radius shrinks.
#[derive(Debug, Clone, Copy, Default)]
struct Disc {
    /// Gathered flux of caustic photons (`L S+ D`), scaled as the radius shrinks.
    tau_caustic: Vec3,
    /// Gathered flux of the other photons, scaled as the radius shrinks.
    tau_global: Vec3,
    /// Photons counted so far (`N`, fractional).
    photons: f32,
    /// Gathering radius (0 until the pixel's first point sets it).
    radius: f32,
}

impl Disc {
    /// A disc of `radius` (0: set at the first point) with nothing gathered.
    fn new(radius: f32) -> Disc {
        Disc { radius, ..Disc::default() }
    }

    /// Adds a pass's gathering `g` (`alpha`: the share of new photons
    /// kept): with `N` photons so far and `M` new ones, `N' = N + alpha M`,
    /// `R' = R sqrt(N' / (N + M))`, and the flux scaled by `(R' / R)^2`.
    fn add(&mut self, g: &Gathered, alpha: f32) {
        if g.count == 0 {
            return;
        }
        let m = g.count as f32;
        let kept = self.photons + alpha * m;
        let radius = self.radius * (kept / (self.photons + m)).sqrt();
        let shrink = (radius / self.radius).powi(2);
        self.tau_caustic = (self.tau_caustic + g.caustic) * shrink;
        self.tau_global = (self.tau_global + g.global) * shrink;
        self.photons = kept;
        self.radius = radius;
    }

    /// The radiance gathered, caustic and global, over `passes` passes'
    /// photons; `None` before a radius is set (nothing gathered).
    fn radiance(&self, passes: f32) -> Option<Radiance> {
        let area = passes * PI * self.radius * self.radius;
        (area != 0.0).then(|| Radiance { caustic: self.tau_caustic / area, global: self.tau_global / area })
    }
}

/// Where a pixel's camera path stopped at a diffuse or glossy surface in
/// this pass, and with what weight (or, gathering only a lobe's share of
/// point and spot lights' caustics, where it met a glossy lobe it
/// followed).
#[derive(Debug, Clone, Copy)]
pub(crate) struct VisiblePoint {
    p: Vec3,
    /// Unit shading normal on the camera's side.
    n: Vec3,
    /// Unit direction back along the camera path.
    wo: Vec3,
    material: usize,
    weight: Vec3,
    /// The radius it gathers within this pass: its pixel's, or, gathering
    /// a lobe's share ([`Gathers::LobeOfDeltaCaustics`]), its own.
    radius: f32,
    /// The camera path's rays up to this point (1 for a surface seen
    /// directly), for the length of the paths photons make through it.
    depth: u32,
    /// Whether the camera path followed a glossy lobe before: caustic
    /// photons gathered here are then light scattered twice (`indirect`).
    after_scatter: bool,
    /// What it gathers.
    gathers: Gathers,
}

/// Where a pass's camera paths gather photons, by pixel: each pixel's
/// visible point, if its first path left one, and the points where that
/// path met glossy lobes it followed ([`Gathers::LobeOfDeltaCaustics`]).
#[derive(Default)]
struct CameraPoints {
    visible: Vec<Option<VisiblePoint>>,
    lobes: Vec<Vec<VisiblePoint>>,
}

/// Photon flux a pixel's visible point gathered in one pass, and the
/// radiance its lobe points did.
#[derive(Debug, Clone, Copy, Default)]
struct Gathered {
    caustic: Vec3,
    global: Vec3,
    count: u32,
    /// The radiance its pixel's lobe points gathered, each within its own
    /// radius ([`LobeRadius`]).
    lobe: Radiance,
}

/// A progressive render in progress: run passes, read the image at any time.
pub struct Progressive<'a> {
    ctx: Context<'a>,
    pixels: Vec<PixelState>,
    passes: u32,
    /// Photons emitted so far (the starting radii's batch not counted):
    /// over a whole pass's count, the passes as the image weighs them (a
    /// part of a pass, always the last, counts as its part).
    emitted: u64,
    /// The longest whole pass so far: seconds on camera paths, and on photons.
    longest: (f64, f64),
    /// Rays traced so far: camera paths, photons, and their shadow rays.
    rays: RayCount,
    /// Seconds spent tracing photons and gathering them.
    photon_seconds: f64,
    /// Where a first batch of photons landed, for the starting radius of
    /// each pixel (traced before the first pass), when no radius is given.
    density: Option<Density>,
    /// The last pass's camera points, kept so that the next pass writes
    /// into the same memory (see [`Progressive::camera_paths`]).
    points: CameraPoints,
}

/// Photons of a batch of their own, traced before the first pass: each
/// pixel starts with the radius that holds [`START_NEIGHBOURS`] of them
/// around its first visible point. Where light is dense (a caustic, a wall
/// near the light) the start is sharp, where it is thin the start is wide
/// enough to gather some at once; a fixed start (a fraction of the scene,
/// or pixels' footprints) was measured worse, by scene, either way
/// (BENCHMARKS.md, "SPPM's starting radius").
struct Density {
    /// The batch's landing places (only their distances count).
    points: PointTree<()>,
    /// The own radius (as [`Density::radius_at`] finds it before the
    /// slope's bound) at every [`OWN_EVERY`]-th landing place by its slot
    /// in `points`: `own[slot / OWN_EVERY]`.
    own: Vec<f32>,
    /// The starting radius's bounds: 1e-4 and 1/25 of the scene's diagonal.
    min_radius: f32,
    max_radius: f32,
}

/// Camera paths per pixel and pass (under a time budget, on average: from
/// the second pass one each and the rest split by [`split_by_noise`], more
/// where the pixels around are noisier: a light's edges, the ceiling just
/// above a point light, highlights). Each adds the light it finds itself
/// (direct light by shadow rays, lights seen through mirrors and glass, the
/// first surface's albedo, normal and depth), averaged over the pass; the
/// first also leaves the visible point that gathers the pass's photons. One
/// path a pass left the camera's own noise (a light's edges, the steep
/// fall-off of light on the ceiling just above a point light, its
/// reflections) to shrink only as fast as photon passes come, the most of
/// SPPM's error on the Cornell boxes at 256 x 256 (at 4 s, 0.073 on the
/// area-lit box where two give 0.032). Four were 17-39% better than one
/// when the visible points were spread as independent jitter; since they
/// stratify their pixel (`CameraSample`), two are 3-9% better than four at
/// equal time, more passes making up for fewer paths (BENCHMARKS.md,
/// "SPPM: camera paths per pass" and "SPPM's visible points from a Sobol
/// sequence of their own").
const CAMERA_PATHS_PER_PASS: u32 = 2;

/// Shadow rays per area light at each camera path's surfaces unless the
/// scene says. A pixel's direct light is averaged over all its paths of
/// all passes, so one a path is plenty: at 32 passes the direct light's
/// noise was 0.0039 with one and 0.0030 with four, beside 0.048 for the
/// whole image, and a time budget ran 17-33% more passes (BENCHMARKS.md,
/// "One shadow ray where passes or gather rays average it").
const LIGHT_SAMPLES: u32 = 1;

/// The most camera paths beyond the first a pixel takes in one pass, so
/// that no pass waits long on a few pixels.
const MAX_EXTRA_PATHS: u32 = 64;

/// The smallest part of a pass worth running at a time budget's end.
const MIN_PASS_FRACTION: f64 = 0.05;

/// Photons of the density batch within a pixel's starting radius: measured
/// 8, 16, 32, 64 and 128 (32 and 64 best; 64 gathers more, so slower).
const START_NEIGHBOURS: usize = 32;

/// How fast the starting radius may grow with distance (see
/// [`Density::radius_at`]). Measured 0, 0.25 and 0.5 (BENCHMARKS.md).
const START_SLOPE: f32 = 0.25;

/// The landing places of the density batch whose own radius bounds the
/// starting radius: one in this many (in the tree's order, spread evenly
/// in space). A bright patch beside a pixel puts many of its photons among
/// the pixel's nearest, so a share of them finds it; a radius for each
/// cost a fifth of the first pass.
const OWN_EVERY: usize = 4;

impl Density {
    /// The density batch landed at `positions`, with the starting radius's
    /// bounds, and the own radius of every [`OWN_EVERY`]-th photon.
    fn new(positions: Vec<Vec3>, min_radius: f32, max_radius: f32) -> Density {
        let points = PointTree::new(&positions, &vec![(); positions.len()]);
        let mut density = Density { points, own: Vec::new(), min_radius, max_radius };
        // In the tree's order, where neighbours' searches read the same
        // memory; in parallel, each radius on its own (no thread count in it).
        density.own = (0..positions.len().div_ceil(OWN_EVERY))
            .into_par_iter()
            .map(|i| density.own_radius(&density.neighbours(density.points.point((i * OWN_EVERY) as u32))))
            .collect();
        density
    }

    /// The [`START_NEIGHBOURS`] photons nearest `p` within the largest radius.
    fn neighbours(&self, p: Vec3) -> Nearest<START_NEIGHBOURS> {
        self.points.nearest::<START_NEIGHBOURS>(p, self.max_radius * self.max_radius)
    }

    /// The distance from `p` to the [`START_NEIGHBOURS`]-th nearest photon
    /// (within the bounds: the largest where fewer are near), and no more
    /// than any of those photons' own such radius plus [`START_SLOPE`]
    /// times its distance from `p`.
    ///
    /// Why the bound: a pixel's disc counts the photons in it, so where
    /// discs of different sizes meet, light is counted more than once. A
    /// wide disc in the dark beside a caustic takes in the caustic's
    /// photons, which the caustic's own narrow discs count as well: the
    /// image had 3-5% too much caustic light after 32 passes (BENCHMARKS.md,
    /// issue 16). Where the radius changes slowly across the surface, a
    /// photon's light is shared among the discs it falls in, as in a
    /// kernel of one size; the bound keeps it slow.
    fn radius_at(&self, p: Vec3) -> f32 {
        let found = self.neighbours(p);
        let own = self.own_radius(&found);
        found
            .as_slice()
            .iter()
            .filter(|photon| (photon.slot as usize).is_multiple_of(OWN_EVERY))
            .map(|photon| self.own[photon.slot as usize / OWN_EVERY] + START_SLOPE * photon.distance2.sqrt())
            .fold(own, f32::min)
    }

    /// The starting radius the photons `found` around a point make there:
    /// the distance to the last, within the bounds; the largest where
    /// there are fewer than [`START_NEIGHBOURS`].
    fn own_radius(&self, found: &Nearest<START_NEIGHBOURS>) -> f32 {
        match found.as_slice() {
            all @ [.., farthest] if all.len() == START_NEIGHBOURS => {
                farthest.distance2.sqrt().clamp(self.min_radius, self.max_radius)
            }
            _ => self.max_radius,
        }
    }
}

impl<'a> Progressive<'a> {
    /// A render with no passes yet.
    pub fn new(ctx: &Context<'a>) -> Self {
        let config = ctx.config;
        // Zero: each pixel's radius is set at its first visible point.
        let radius = config.photons.sppm.initial_radius.unwrap_or(0.0);
        let region = config.region();
        let pixels = (0..region.pixels() as usize)
            .map(|i| region.pixel(i))
            .map(|(x, y)| PixelState {
                // The stream of the pixel's index in the whole image.
                rng: Rng::new(config.seed, y as u64 * config.width as u64 + x as u64),
                seen: Sample::default(),
                paths: 0,
                seen_sq: 0.0,
                caustic_to_camera: Vec3::ZERO,
                visible: Disc::new(radius),
                lobe: Radiance::default(),
            })
            .collect();
        let start = Instant::now();
        let (density, rays) = match config.photons.sppm.initial_radius {
            Some(_) => (None, RayCount::default()),
            None => {
                let (positions, rays) = density_positions(ctx);
                (Some(Density::new(positions, ctx.diagonal * 1e-4, ctx.diagonal / 25.0)), rays)
            }
        };
        let photon_seconds = start.elapsed().as_secs_f64();
        Progressive {
            ctx: *ctx,
            pixels,
            passes: 0,
            emitted: 0,
            longest: (0.0, 0.0),
            rays,
            photon_seconds,
            density,
            points: CameraPoints::default(),
        }
    }

    /// Passes run so far.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// The photons of the last pass, if it was a part of one.
    fn last_part(&self) -> Option<u64> {
        let part = self.emitted % self.ctx.config.photons.sppm.photons_per_pass as u64;
        (part > 0).then_some(part)
    }

    /// Runs one pass: visible points, photons, radius update.
    pub fn run_pass(&mut self) {
        self.run_part_of_pass(1.0);
    }

    /// The part of a pass (at most 1) that should fit in `left` seconds,
    /// with a margin, judged by the longest whole pass so far: a pixel's
    /// first camera path costs the same in any part of a pass (it leaves
    /// the visible point), its other paths and the photons cost in
    /// proportion to the part.
    fn fraction_fitting(&self, left: f64) -> f64 {
        let (camera, photons) = self.longest;
        if camera + photons <= left {
            return 1.0;
        }
        let first_path = camera / CAMERA_PATHS_PER_PASS as f64;
        let proportional = camera - first_path + photons;
        if proportional <= 0.0 {
            return 0.0;
        }
        ((left * LAST_ROUND_SHARE - first_path) / proportional).clamp(0.0, 1.0)
    }

    /// Runs a pass, or part of one (`fraction` of its photons and of its
    /// camera paths beyond each pixel's first), as [`Progressive::run_pass`]
    /// does. A part of a pass weighs as its part in the average over passes.
    pub fn run_part_of_pass(&mut self, fraction: f64) {
        let pass_start = Instant::now();
        self.camera_paths(fraction);
        let camera_seconds = pass_start.elapsed().as_secs_f64();
        let start = Instant::now();
        let ctx = self.ctx;
        let per_pass = ctx.config.photons.sppm.photons_per_pass;
        let photons = ((per_pass as f64 * fraction).round() as u32).clamp(1, per_pass);
        let (gathered, to_camera, photon_rays) = self.gather_photons(&self.points, photons);
        self.rays += photon_rays;
        // Serially, in the order the photons were emitted: the sums do not
        // depend on the thread count.
        for (pixel, light) in to_camera {
            self.pixels[pixel].caustic_to_camera += light;
        }
        let photon_seconds = start.elapsed().as_secs_f64();
        self.photon_seconds += photon_seconds;
        if photons == per_pass && camera_seconds + photon_seconds > self.longest.0 + self.longest.1 {
            self.longest = (camera_seconds, photon_seconds);
        }

        let alpha = ctx.config.photons.sppm.sppm_alpha();
        self.pixels.par_iter_mut().zip(gathered).for_each(|(state, g)| {
            state.visible.add(&g, alpha);
            state.lobe.caustic += g.lobe.caustic;
            state.lobe.global += g.lobe.global;
        });
        self.passes += 1;
        self.emitted += photons as u64;
    }

    /// The camera paths of a pass, or of `fraction` of one (every pixel's
    /// first path, that part of the others): what they find themselves
    /// goes to their pixels, and each pixel's visible point and lobe points
    /// to `self.points` (the pixel's starting radius set at its first).
    ///
    /// The points are written over the last pass's, in the same memory: a
    /// fresh array each pass (and growing ones) made the kernel hand out
    /// and clear new pages every pass, which took about a tenth of SPPM's
    /// time (BENCHMARKS.md).
    fn camera_paths(&mut self, fraction: f64) {
        let ctx = self.ctx;
        let region = ctx.config.region();
        let density = self.density.as_ref();
        let lobe_radius = LobeRadius::new(ctx.config, self.density.as_ref(), self.passes);
        // Split by the noise only under a time budget: a pixel's paths then
        // depend on the pixels around, which a tile of the image (rendered
        // on its own, to be merged) does not have at its edges. With a
        // fixed number of passes a tile renders its pixels as the whole
        // image does, bit for bit.
        let extra = match ctx.config.time {
            Some(_) => {
                let total = (CAMERA_PATHS_PER_PASS - 1) as f64 * self.pixels.len() as f64 * fraction;
                let width = region.width() as usize;
                extra_paths(&self.pixels, width, ctx.config.seed, self.passes, total.round() as u64)
            }
            None => vec![CAMERA_PATHS_PER_PASS - 1; self.pixels.len()],
        };
        let passes = self.passes;
        let points = &mut self.points;
        points.visible.resize(self.pixels.len(), None);
        points.lobes.resize_with(self.pixels.len(), Vec::new);
        let count: RayCount = self
            .pixels
            .par_iter_mut()
            .zip(extra)
            .zip(points.visible.par_iter_mut().zip(points.lobes.par_iter_mut()))
            .enumerate()
            .map(|(i, ((state, extra), (point, lobe_points)))| {
                let mut count = RayCount::default();
                // What the camera paths find themselves is averaged over
                // all of the pixel's; the first leaves the visible point.
                let mut seen = std::mem::take(&mut state.seen);
                *point = None;
                lobe_points.clear();
                for path in 0..=extra {
                    // Of the pixel's paths so far, `passes` left visible points.
                    let sample = match path {
                        0 => CameraSample::VisiblePoint(passes),
                        _ => CameraSample::Other(state.paths - passes + path - 1),
                    };
                    let lobes = (path == 0).then_some(&mut *lobe_points);
                    let found = visible_point(&ctx, region.pixel(i), sample, state, lobes, &mut count);
                    if path == 0 {
                        *point = found;
                    }
                    let this = std::mem::take(&mut state.seen);
                    state.seen_sq += luminance(&this).powi(2);
                    seen += this;
                }
                state.paths += 1 + extra;
                state.seen = seen;
                if let (Some(vp), Some(density)) = (point.as_mut(), density) {
                    if state.visible.radius == 0.0 {
                        state.visible.radius = density.radius_at(vp.p);
                        vp.radius = state.visible.radius;
                    }
                }
                for lp in lobe_points.iter_mut() {
                    lp.radius = lobe_radius.at(lp.p);
                }
                count
            })
            .sum();
        self.rays += count;
    }

    /// The image so far, with its work counts; `elapsed` is the time to report.
    pub fn rendered(&self, elapsed: Duration) -> Rendered {
        let sppm = &self.ctx.config.photons.sppm;
        let emitted = self.emitted;
        let density = match self.density {
            Some(_) => format!(" (and {} for the starting radii)", sppm.photons_per_pass),
            None => String::new(),
        };
        let last = match self.last_part() {
            Some(photons) => format!(", the last of {photons}"),
            None => String::new(),
        };
        let note = format!(
            "photons: {emitted} emitted in {} passes of {}{last}{density}, traced and gathered in {:.2} s",
            self.passes, sppm.photons_per_pass, self.photon_seconds
        );
        let config = self.ctx.config;
        let region = config.region();
        let film = Film { width: region.width(), height: region.height(), pixels: self.components() };
        let mut rendered = Rendered::new(film, self.rays, vec![note]);
        rendered.stats.elapsed = elapsed;
        rendered
    }

    /// The image so far, one [`Sample`] per pixel, row-major.
    fn components(&self) -> Vec<Sample> {
        let passes = (self.emitted as f64 / self.ctx.config.photons.sppm.photons_per_pass as f64) as f32;
        self.pixels
            .iter()
            .map(|s| {
                let mut seen = s.seen * (1.0 / s.paths.max(1) as f32);
                if passes > 0.0 {
                    seen.caustic += s.caustic_to_camera / passes;
                    seen.caustic += s.lobe.caustic / passes;
                    seen.indirect += s.lobe.global / passes;
                }
                // (Before a visible point sets the radius, it gathered nothing.)
                if let Some(gathered) = s.visible.radiance(passes) {
                    seen.caustic += gathered.caustic;
                    seen.indirect += gathered.global;
                }
                seen
            })
            .collect()
    }

    /// Traces `photons` photons (a pass's count, or a part of it: each
    /// carries a whole pass's share of the lights' power) and sums, per
    /// pixel, the flux its visible point gathers. Each point finds the
    /// photons within its radius (`RangeSearch`) and adds them in the order
    /// they were emitted, so the sums do not depend on the thread count.
    /// Also returns the light caustic photons send the camera directly (by
    /// pixel, in the order emitted; see [`caustic_to_camera`]) and the
    /// photons' rays.
    fn gather_photons(
        &self,
        CameraPoints { visible: points, lobes: lobe_points }: &CameraPoints,
        photons: u32,
    ) -> (Vec<Gathered>, Vec<(usize, Vec3)>, RayCount) {
        let ctx = &self.ctx;
        let radii: Vec<f32> = self.pixels.iter().map(|s| s.visible.radius).collect();
        let lobe_radius = LobeRadius::new(ctx.config, self.density.as_ref(), self.passes);
        let scene = ctx.scene();
        let config = ctx.config;
        // `emit` gives each photon its light's power over the photons
        // emitted; this makes that over a whole pass's count.
        let share = photons as f32 / config.photons.sppm.photons_per_pass as f32;
        // Under the Sobol sampler each pass's photons go on from the last
        // pass's in one low-discrepancy sequence, so all of them so far are
        // stratified; independent photons take new streams every pass.
        let pass_seed = match config.sampler {
            SamplerKind::Sobol => config.seed ^ 0x5_99A1,
            SamplerKind::Independent => (config.seed ^ 0x5_99A1)
                .wrapping_add((self.passes as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)),
        };
        let numbers = PhotonNumbers::for_sampler(config.sampler, pass_seed, self.emitted);
        // A photon that bounced `b` times before landing at a visible point
        // `d` camera rays deep makes a path of `b + 1 + d` rays, which the
        // path tracer (camera rays up to `max_depth`, then a shadow ray)
        // makes only while `b + d <= max_depth`: photons gather only there,
        // and none is traced beyond `max_depth` bounces. Left longer, the
        // photons' paths added about 1% to the Cornell box's indirect light
        // that the path tracer and the references leave out (BENCHMARKS.md).
        let max_depth = config.max_depth;
        // Each photon where it lands, with its bounces, in the order emitted
        // (a photon that bounced off no diffuse or glossy surface before,
        // `!indirect`, is caustic light); a caustic photon also goes to the
        // camera, when seen directly.
        let (chunks, mut rays) = emit(
            &ctx.query,
            photons,
            config.photons.max_bounces.min(max_depth),
            numbers,
            false,
            Landed::default,
            |landed: &mut Landed, arrival: &Arrival| {
                if is_gathered(arrival) {
                    let bounces = arrival.diffuse_bounces + arrival.specular_bounces;
                    landed.photons.push(Landing { photon: arrival.photon, bounces });
                    if !arrival.photon.indirect && bounces < max_depth {
                        landed.to_camera.extend(caustic_to_camera(
                            ctx,
                            arrival,
                            share,
                            &radii,
                            &lobe_radius,
                            &mut landed.rays,
                        ));
                    }
                }
                true
            },
        );
        // Joined into one array its exact size: each chunk is freed as it
        // is copied, so a pass holds its photons about once. (Kept from
        // pass to pass instead, it made twice the page faults: the next
        // pass's chunks could no longer use its memory.)
        let mut arrived = Vec::with_capacity(chunks.iter().map(|c| c.photons.len()).sum());
        let mut to_camera = Vec::new();
        for chunk in chunks {
            arrived.extend(chunk.photons);
            to_camera.extend(chunk.to_camera);
            rays += chunk.rays;
        }
        // With no visible point to gather (the region's first camera paths
        // all missed diffuse and glossy surfaces this pass), the photons
        // still went to the camera: a tile must get the same light there
        // as the whole image does.
        let gathering = points.iter().flatten().chain(lobe_points.iter().flatten());
        if !gathering.into_iter().any(|vp| vp.radius > 0.0) {
            return (vec![Default::default(); points.len()], to_camera, rays);
        }
        let search = RangeSearch::new(&arrived, |landing| landing.photon.position);
        // The flux a visible point gathers from the photons `found` within
        // its radius, in the order they were emitted.
        let gathered = |vp: &VisiblePoint, found: &[u32]| {
            let mut g = Gathered::default();
            // Worked out at the first caustic photon: most points find none.
            let mut caustic_weight = None;
            let mut disc = DiscShare::new(vp.p, vp.n, vp.radius);
            for &i in found {
                let Landing { photon, bounces } = &arrived[i as usize];
                if !photon.lights_surface(vp.p, vp.n, vp.radius) {
                    disc.offer(photon.position, photon.normal);
                    continue;
                }
                if bounces + vp.depth > max_depth {
                    continue;
                }
                let m = &scene.materials[vp.material];
                let f = match vp.gathers {
                    Gathers::Whole => m.brdf(vp.n, photon.incoming, vp.wo),
                    Gathers::Diffuse => m.diffuse * FRAC_1_PI,
                    Gathers::LobeOfDeltaCaustics if !photon.indirect && photon.from_delta_light => {
                        m.glossy_brdf(vp.n, photon.incoming, vp.wo)
                    }
                    Gathers::LobeOfDeltaCaustics => continue,
                };
                let flux = vp.weight * f * photon.power * share;
                if !photon.indirect && !vp.after_scatter {
                    g.caustic +=
                        flux * *caustic_weight.get_or_insert_with(|| caustic_gathering_weight(ctx, vp));
                } else {
                    g.global += flux;
                }
                g.count += u32::from(vp.gathers != Gathers::LobeOfDeltaCaustics);
            }
            // Near a corner only part of the disc lies on the point's
            // surface: the flux found there stands for the whole disc's.
            let share = disc.share_among(found.iter().map(|&i| &arrived[i as usize].photon));
            if share < 1.0 {
                g.caustic /= share;
                g.global /= share;
            }
            g
        };
        // Searched a square of pixels at a time: neighbouring visible points
        // mostly find the same photons, so one search around a square's
        // points serves them all where they lie close together, and each
        // finds exactly the photons its own search would (`SquareSearch`).
        let width = self.ctx.config.region().width() as usize;
        let height = points.len() / width.max(1);
        let squares: Vec<(usize, usize)> = (0..height)
            .step_by(GATHER_TILE)
            .flat_map(|y| (0..width).step_by(GATHER_TILE).map(move |x| (x, y)))
            .collect();
        let by_square: Vec<Vec<(usize, Gathered)>> = squares
            .par_iter()
            .map_init(SquareSearch::default, |square_search, &corner| {
                let mut here = Vec::new();
                square_search.search(&search, points, width, corner, |i, vp, found| {
                    here.push((i, gathered(vp, found)))
                });
                here
            })
            .collect();
        let mut all = vec![Gathered::default(); points.len()];
        for (i, g) in by_square.into_iter().flatten() {
            all[i] = g;
        }
        // The points where camera paths followed a glossy lobe gather the
        // lobe's caustic photons of point and spot lights, each on its own
        // (few pixels have them) and within its own radius: the radiance
        // each finds.
        let lobes: Vec<(usize, Radiance)> = lobe_points
            .par_iter()
            .enumerate()
            .filter(|(_, here)| !here.is_empty())
            .map_init(
                || (Vec::new(), Vec::new()),
                |(keys, found), (i, here)| {
                    let mut sum = Radiance::default();
                    for lp in here.iter().filter(|lp| lp.radius > 0.0) {
                        search.within(lp.p, lp.radius * lp.radius, keys, found);
                        let g = gathered(lp, found);
                        let area = PI * lp.radius * lp.radius;
                        sum.caustic += g.caustic / area;
                        sum.global += g.global / area;
                    }
                    (i, sum)
                },
            )
            .collect();
        for (i, radiance) in lobes {
            all[i].lobe = radiance;
        }
        (all, to_camera, rays)
    }
}

/// The radius a point where a camera path met a glossy lobe it follows
/// gathers within, in one pass: the starting radius a visible point there
/// would take (`Density`; or the one given), shrunk pass by pass as in
/// probabilistic progressive photon mapping (Knaus and Zwicker 2011), by
/// `pass^((alpha - 1) / 2)`, as VCM's. Not a disc carried from pass to
/// pass as a visible point's: a path's lobe points lie on other surfaces
/// than its visible point, each pass elsewhere (a sphere's outside, then,
/// through its glass, its inside), in light of other densities. Under the
/// visible point's radius (the wall's, behind a glass sphere with a sharp
/// glossy coat) the lobe gathered photons from far off, each weighed by
/// the lobe at its own direction: a spot's edge across the sphere's inside
/// left a bright blot where no light is, 3x the reference's light at
/// 2,048 passes.
struct LobeRadius<'a> {
    density: Option<&'a Density>,
    given: f32,
    shrink: f32,
}

impl<'a> LobeRadius<'a> {
    /// The radius in pass `passes` (from 0) of a render of `config`, by
    /// the starting radii's `density` if it was traced.
    fn new(config: &RenderConfig, density: Option<&'a Density>, passes: u32) -> Self {
        let alpha = config.photons.sppm.sppm_alpha();
        LobeRadius {
            density,
            given: config.photons.sppm.initial_radius.unwrap_or(0.0),
            shrink: ((passes + 1) as f32).powf(0.5 * (alpha - 1.0)),
        }
    }

    /// The radius at `p`.
    fn at(&self, p: Vec3) -> f32 {
        self.density.map_or(self.given, |d| d.radius_at(p)) * self.shrink
    }
}

/// A photon where it landed, as a visible point may gather it.
struct Landing {
    photon: Photon,
    /// Its bounces before it landed.
    bounces: u32,
}

/// What a chunk of a pass's photons leaves.
#[derive(Default)]
struct Landed {
    /// Each photon a visible point may gather.
    photons: Vec<Landing>,
    /// The light of caustic photons seen directly, by pixel.
    to_camera: Vec<(usize, Vec3)>,
    /// The shadow rays towards the eye.
    rays: RayCount,
}

/// The light a caustic photon (`L S+ D`) that arrived on a surface the
/// camera sees directly sends to its pixel, and that pixel: light tracing,
/// weighed against gathering the photon at the pixel's visible points by
/// [`to_camera_weight`] (`radii`: each pixel's gathering radius this pass;
/// the lobe's part of the light by the radius a lobe point there gathers
/// within, `lobe_radius`; `share` scales the photon's power to a whole
/// pass's). One shadow ray, counted in `rays`.
fn caustic_to_camera(
    ctx: &Context,
    arrival: &Arrival,
    share: f32,
    radii: &[f32],
    lobe_radius: &LobeRadius,
    rays: &mut RayCount,
) -> Option<(usize, Vec3)> {
    let (photon, sp) = (&arrival.photon, arrival.surface);
    let view = CameraView::of(ctx, sp.p)?;
    // The eye on the side the photon came from, as a visible point's
    // gathering asks of the photons it counts.
    let cos = view.to_eye.dot(sp.ns);
    if cos <= 0.0 || view.to_eye.dot(sp.ng) <= 0.0 || photon.incoming.dot(sp.ns) <= 0.0 {
        return None;
    }
    // Where camera paths follow the glossy lobe, they meet an area light's
    // front through mirrors and glass themselves: its caustic photons give
    // the diffuse part alone, as visible points gather them. Point and spot
    // lights' give the lobe's part too, which the lobe points gather, each
    // within a radius of its own.
    let m = ctx.query.material(sp);
    // The camera's density of the point per unit area of the surface, with
    // the correction light tracing takes where the shading normal is not
    // the geometric one (`SurfacePoint::adjoint_shading`, as VCM's light
    // tracer; the photon's power holds its first factor, the light's way in):
    // without it, a smooth sphere of 20 triangles showed its facets in the
    // caustic (pixels 0.6-1.5 of bidirectional path tracing's), and a floor
    // whose normals lean 45 degrees 2.7 times the path tracer's. The weight
    // against gathering takes the density without it, as the visible
    // point's side does (`caustic_gathering_weight`).
    let pdf = view.area_pdf(cos);
    let density = pdf / sp.shading_over_geometric(view.to_eye);
    let visible = radii[view.pixel];
    let light = if lobe_followed(m) && photon.from_delta_light {
        let diffuse = m.diffuse * FRAC_1_PI * to_camera_weight(visible, pdf);
        let lobe = to_camera_weight(lobe_radius.at(sp.p), pdf);
        let glossy = m.glossy_brdf(sp.ns, photon.incoming, view.to_eye) * lobe;
        photon.power * share * (diffuse + glossy) * density
    } else {
        let f = if lobe_followed(m) {
            m.diffuse * FRAC_1_PI
        } else {
            m.brdf(sp.ns, photon.incoming, view.to_eye)
        };
        photon.power * share * f * density * to_camera_weight(visible, pdf)
    };
    if light == Vec3::ZERO || !light.is_finite() || !view.unblocked(ctx, sp, rays) {
        return None;
    }
    Some((view.pixel, light))
}

/// The weight a visible point gives the caustic photons it gathers: caustic
/// light seen directly (at camera depth 1) also comes to the camera from
/// the photons themselves (`caustic_to_camera`), and gathering keeps the
/// rest; where light tracing cannot take the path (the point out of the
/// region, or its shading normal turned from the eye), all of it.
fn caustic_gathering_weight(ctx: &Context, vp: &VisiblePoint) -> f32 {
    if vp.depth != 1 {
        return 1.0;
    }
    let Some(view) = CameraView::of(ctx, vp.p) else { return 1.0 };
    let cos = view.to_eye.dot(vp.n);
    if cos > 0.0 {
        1.0 - to_camera_weight(vp.radius, view.area_pdf(cos))
    } else {
        1.0
    }
}

/// The share of a caustic path seen directly (`L S+ D E`) that light
/// tracing takes, where the pixel gathers within `radius` and the camera's
/// pixels sample the surface with density `camera_pdf` per unit area;
/// gathering at the pixel's visible point takes the rest, so the two add
/// up to the path once.
///
/// Gathering makes such a path `k = pi radius^2 camera_pdf` times as often
/// as light tracing (the disc's area in pixels' footprints), so where the
/// disc spans pixels its estimate is the less noisy one, and the power
/// heuristic would give light tracing `1 / (1 + k^2)`. But a caustic's
/// fold lines and edges are sharper than a disc, which blurs them, and
/// the heuristic sees only noise: here `k / 2` stands in for `k`.
///
/// Measured at 57 passes (alpha 0.7), four seeds a box, RMSE against the
/// VCM references (BENCHMARKS.md, issue 16): gathering all such paths
/// 0.0214 on the area-lit Cornell box and 0.0260 on the point-lit one;
/// light tracing all of them 0.0223 and 0.0219 (sharp caustics, but the mirror sphere's dim
/// caustic over the walls is noisier by light tracing); the balance and
/// power heuristics with `k` 0.0194 / 0.0222 and 0.0194 / 0.0221; with
/// `k / 2` 0.0194 / 0.0216 and 0.0195 / 0.0214 (this); with `k / 4` 0.0195
/// / 0.0214 and 0.0196 / 0.0214. On the point-lit box the floor under the
/// glass sphere held 34% of the squared error by gathering alone, 9% now.
fn to_camera_weight(radius: f32, camera_pdf: f32) -> f32 {
    let k = 0.5 * PI * radius * radius * camera_pdf;
    1.0 / (1.0 + k * k)
}

/// What a thread's searches of squares of pixels reuse.
#[derive(Default)]
struct SquareSearch {
    buffers: GroupBuffers,
    /// The photons each visible point of a square finds.
    found: Vec<Vec<u32>>,
    keys: Vec<u64>,
    /// The square's pixels with a visible point.
    members: Vec<usize>,
    /// Their visible points' centres and squared radii.
    queries: Vec<(Vec3, f32)>,
}

impl SquareSearch {
    /// The photons within each visible point's radius, in the square of
    /// [`GATHER_TILE`] pixels whose top left is `corner` (of a region
    /// `width` wide): `visit(pixel, point, found)` for each. Points that
    /// lie [`close_together`] are searched at once; a square whose points
    /// do not is split in four, down to single pixels.
    fn search(
        &mut self,
        search: &RangeSearch,
        points: &[Option<VisiblePoint>],
        width: usize,
        corner: (usize, usize),
        mut visit: impl FnMut(usize, &VisiblePoint, &[u32]),
    ) {
        let height = points.len() / width.max(1);
        self.found.resize_with(GATHER_TILE * GATHER_TILE, Vec::new);
        let mut squares = vec![(corner, GATHER_TILE)];
        while let Some(((x0, y0), side)) = squares.pop() {
            self.members.clear();
            self.members.extend(
                (y0..(y0 + side).min(height))
                    .flat_map(|y| (x0..(x0 + side).min(width)).map(move |x| y * width + x))
                    .filter(|&i| points[i].is_some()),
            );
            self.queries.clear();
            self.queries.extend(
                self.members.iter().flat_map(|&i| &points[i]).map(|vp| (vp.p, vp.radius * vp.radius)),
            );
            if close_together(&self.queries) {
                search.within_each(&self.queries, &mut self.buffers, &mut self.found);
            } else if side > 1 {
                let half = side / 2;
                let quarters = [(x0, y0), (x0 + half, y0), (x0, y0 + half), (x0 + half, y0 + half)];
                squares.extend(quarters.map(|corner| (corner, half)));
                continue;
            } else {
                for (&(q, r2), found) in self.queries.iter().zip(self.found.iter_mut()) {
                    search.within(q, r2, &mut self.keys, found);
                }
            }
            for (&i, found) in self.members.iter().zip(&self.found) {
                if let Some(vp) = &points[i] {
                    visit(i, vp, found);
                }
            }
        }
    }
}

/// The side of the largest square of pixels whose visible points SPPM
/// searches together (a power of two).
const GATHER_TILE: usize = 4;

/// How many camera paths beyond the first each pixel (of a region `width`
/// wide) takes in pass `pass`: `total` in all ([`CAMERA_PATHS_PER_PASS`] - 1
/// a pixel on average in a whole pass), split by the deviation of what the
/// paths of the pixels around found (evenly before two paths of each are
/// known), at most [`MAX_EXTRA_PATHS`]. Decided before the pass, serially: the same for any
/// thread count.
fn extra_paths(pixels: &[PixelState], width: usize, seed: u64, pass: u32, total: u64) -> Vec<u32> {
    // Each path is a group of one.
    let own: Vec<f64> = pixels.iter().map(|s| deviation(&s.seen, s.seen_sq, s.paths, s.paths)).collect();
    // Where the rounding draws from: a stream per pass.
    let mut rng = Rng::new(seed ^ 0x5_99A1, 0x7061_7468 + pass as u64);
    split_by_noise(&own, width, total, &mut rng).into_iter().map(|n| n.min(MAX_EXTRA_PATHS)).collect()
}

/// Whether a pass gathers a photon: not one straight from a light (shadow
/// rays already count that light).
fn is_gathered(arrival: &Arrival) -> bool {
    arrival.diffuse_bounces + arrival.specular_bounces > 0
}

/// Where a batch of photons of its own (a pass's count) lands, of those a
/// pass would gather, and the rays the batch traced.
fn density_positions(ctx: &Context) -> (Vec<Vec3>, RayCount) {
    let config = ctx.config;
    let (chunks, rays) = emit(
        &ctx.query,
        config.photons.sppm.photons_per_pass,
        config.photons.max_bounces,
        // Its own numbers: under the Sobol sampler, not the passes' first.
        match config.sampler {
            SamplerKind::Sobol => PhotonNumbers::Sobol { seed: config.seed ^ 0xDE45_17E5, first: 0 },
            SamplerKind::Independent => PhotonNumbers::Independent { seed: config.seed ^ 0x5_99A1 },
        },
        false,
        Vec::new,
        |kept: &mut Vec<Vec3>, arrival: &Arrival| {
            if is_gathered(arrival) {
                kept.push(arrival.photon.position);
            }
            true
        },
    );
    (chunks.into_iter().flatten().collect(), rays)
}

/// Which of a pixel's camera paths a path is, for its Sobol samples. The
/// paths that leave the visible points, one a pass, are the samples 0, 1,
/// 2, ... of the pixel's stream; the others count on in a stream of their
/// own. So the visible points alone are a prefix of one low-discrepancy
/// sequence and stratify the pixel as finely as their number allows, and
/// the photons a pixel gathers (a caustic's most) are averaged over its
/// area evenly. Counted in one stream with the other paths, the visible
/// points were every fourth sample of it, no better spread than
/// independent jitter (BENCHMARKS.md, issue 16).
#[derive(Debug, Clone, Copy)]
enum CameraSample {
    /// The path of pass `n` that leaves the visible point.
    VisiblePoint(u32),
    /// The pixel's `n`-th other path.
    Other(u32),
}

/// Where the streams of the paths that leave no visible point start: past
/// any pixel's index.
const OTHER_PATHS_STREAM: u64 = 1 << 48;

/// Follows one jittered camera path from pixel `(x, y)` to its visible
/// point, adding what it finds itself (lights, direct light by shadow rays,
/// the first surface's albedo, normal and depth) to `state.seen`, each in
/// its component. At a surface with both diffuse/glossy and mirror/glass
/// parts the path stops or goes on at random, in proportion to their
/// weights (the weight divided by that chance keeps it unbiased); a glossy
/// lobe it follows ([`lobe_followed`]) is one more way on, and where the
/// path meets one, a point for the lobe's share of point and spot lights'
/// caustics goes to `lobe_points` (given for the path that leaves the
/// visible point). Light the lobe finds on an area light is shared with
/// the shadow rays by the balance heuristic, as the path tracer's.
///
/// With the Sobol sampler the path draws from its `sample`'s
/// low-discrepancy stream, as the path tracer's samples do, so the pixel's
/// paths over all passes stratify its area: a light's edge, where a pixel
/// is partly light and partly wall, was the largest part of SPPM's error at
/// long budgets with independent jitter (BENCHMARKS.md, issue 16).
/// Otherwise from the pixel's own stream.
fn visible_point(
    ctx: &Context,
    (x, y): (u32, u32),
    sample: CameraSample,
    state: &mut PixelState,
    mut lobe_points: Option<&mut Vec<VisiblePoint>>,
    count: &mut RayCount,
) -> Option<VisiblePoint> {
    let (query, config) = (&ctx.query, ctx.config);
    let pixel = y as u64 * config.width as u64 + x as u64;
    let (stream, index) = match sample {
        CameraSample::VisiblePoint(pass) => (pixel, pass),
        CameraSample::Other(index) => (pixel + OTHER_PATHS_STREAM, index),
    };
    let mut sobol = config.sampler.sample_stream(config.seed, stream, index);
    let rng = sobol.as_mut().unwrap_or(&mut state.rng);
    let jitter = rng.uniform2();
    let mut ray =
        ctx.scene().camera.ray(x as f32 + jitter.x, y as f32 + jitter.y, config.width, config.height);
    let mut weight = Vec3::ONE;
    // What light found here is worth at the camera across refractions, kept
    // apart from the weight: a path that enters glass and leaves it again
    // is back at exactly 1.
    let mut scale = RadianceScale::ONE;
    let seen = &mut state.seen;
    let mut found_surface = false; // the first diffuse or glossy one, for albedo and normal

    // How the path counts a light's front it meets, and which component
    // light found along it goes to.
    let mut lights = LightsMet::Whole;
    let mut class = PathClass::Specular;
    let samples = config.light_samples_or(LIGHT_SAMPLES);
    for bounce in 0..config.max_depth {
        let sp = match query.first(&ray, count)? {
            Interaction::Emitter { light, t, radiance } => {
                let met = weight * radiance * scale.factor();
                *class.slot(seen) += match lights {
                    LightsMet::Whole => met,
                    LightsMet::Shared { from, pdf } => {
                        met * LightSamples::lobe_share(
                            &ctx.scene().lights,
                            light,
                            samples,
                            from,
                            ray.at(t),
                            pdf,
                        )
                    }
                };
                return None;
            }
            Interaction::Surface(sp) => sp,
        };
        if bounce == 0 {
            seen.depth += sp.t * ray.dir.length();
        }
        let m = query.material(&sp);
        let bsdf = Bsdf::new(m, &sp, ray.dir.normalize());
        if bsdf.has_smooth() {
            let choice = Choice::at(&bsdf);
            let f = scale.factor();
            *class.after(false).slot(seen) += weight
                * if choice.lobe > 0.0 {
                    let other = |wi: Vec3| choice.lobe * bsdf.glossy_pdf(wi);
                    direct_light_against(query, &sp, &bsdf, samples, Against::Lobe(&other), rng, count)
                } else {
                    let sampling = LightSampling::Stratified { samples };
                    direct_light(query, &sp, &bsdf, sampling, rng, count)
                }
                * f;
            seen.indirect += weight * m.diffuse * config.ambient * f;
            if !found_surface {
                found_surface = true;
                seen.albedo += weight * (m.diffuse + m.specular);
                seen.normal += sp.ns * (weight.element_sum() / 3.0);
            }
            let point = |weight: Vec3, gathers: Gathers| VisiblePoint {
                p: sp.p,
                n: sp.ns,
                wo: bsdf.wo(),
                material: sp.material,
                weight: weight * f,
                radius: state.visible.radius,
                depth: bounce + 1,
                after_scatter: class != PathClass::Specular,
                gathers,
            };
            if choice.lobe > 0.0 {
                if let Some(lobe_points) = lobe_points.as_deref_mut() {
                    lobe_points.push(point(weight, Gathers::LobeOfDeltaCaustics));
                }
            }
            // (One number drawn only where there is a choice.)
            let u = if choice.stop >= 1.0 { 0.0 } else { rng.uniform() };
            if u < choice.stop {
                let gathers = if choice.lobe > 0.0 { Gathers::Diffuse } else { Gathers::Whole };
                return Some(point(weight / choice.stop, gathers));
            }
            if u < choice.stop + choice.lobe {
                let wi = bsdf.sample_glossy(rng.uniform2());
                let (cos, pdf) = (wi.dot(sp.ns), bsdf.glossy_pdf(wi));
                // (A density below the normal floats, as far off the lobe as
                // a draw goes, would overflow `f / pdf`.)
                if !(cos > 0.0 && wi.dot(sp.ng) > 0.0 && pdf >= f32::MIN_POSITIVE) {
                    return None;
                }
                weight *= bsdf.eval_glossy(wi) * (cos / (pdf * choice.lobe));
                lights = LightsMet::Shared { from: sp.p, pdf: pdf * choice.lobe };
                class = class.after(false);
                ray = sp.spawn(wi);
                continue;
            }
            weight /= 1.0 - (choice.stop + choice.lobe);
        }
        let s = bsdf.sample_specular(rng)?;
        weight *= s.weight;
        scale = scale.after(&s);
        lights = LightsMet::Whole;
        class = class.after(true);
        if weight == Vec3::ZERO {
            return None;
        }
        ray = sp.spawn(s.wi);
    }
    None
}

/// Where a camera path goes from a diffuse or glossy surface, by chance:
/// it stops there (its visible point) with the chance `stop`, follows the
/// glossy lobe with the chance `lobe`, or goes on through the surface's
/// mirror or glass part with the rest.
#[derive(Debug, Clone, Copy)]
struct Choice {
    stop: f32,
    lobe: f32,
}

impl Choice {
    fn at(bsdf: &Bsdf) -> Choice {
        let smooth = if bsdf.has_specular() { bsdf.smooth_probability() } else { 1.0 };
        let lobe = if lobe_followed(bsdf.material()) { smooth * bsdf.glossy_share() } else { 0.0 };
        Choice { stop: smooth - lobe, lobe }
    }
}

/// Camera paths follow glossy lobes sharper than this Phong exponent
/// (whose peak is more than 6 times a diffuse surface's radiance for the
/// same reflectance); broader lobes gather photons at the visible point,
/// as diffuse surfaces do. A visible point's photons come from all
/// directions, and a sharp lobe weighs a few of them by its peak: a shiny
/// sphere (exponent 3000) under an area light was a speckle of photons
/// (RMSE 0.23-0.25 over it at 6 s, 0.012-0.015 following the lobe).
/// Measured on such a sphere, RMSE at 6 s over four seeds, gathering
/// against following (with a tenth of the lobe's chance still stopping,
/// a first version): at exponent 2 0.0086 and 0.0127; at 5, 0.0105 and
/// 0.0136; at 10, 0.0123 and 0.0130; at 20, 0.0162 and 0.0149; at 60,
/// 0.025 and 0.017 (BENCHMARKS.md, "SPPM follows sharp glossy lobes").
const FOLLOWED_ABOVE_EXPONENT: f32 = 10.0;

/// Whether camera paths follow a material's glossy lobe
/// ([`FOLLOWED_ABOVE_EXPONENT`]).
fn lobe_followed(m: &Material) -> bool {
    m.specular.max_element() > 0.0 && m.phong_exponent > FOLLOWED_ABOVE_EXPONENT
}

/// How a camera path counts a light's front it meets.
#[derive(Debug, Clone, Copy)]
enum LightsMet {
    /// All of it: seen directly, or through mirrors and glass only (shadow
    /// rays cannot pass them).
    Whole,
    /// A share: the path left a glossy surface (at `from`) along its lobe,
    /// drawn with density `pdf` (the lobe's chance included), where shadow
    /// rays also sought the lights (the balance heuristic).
    Shared { from: Vec3, pdf: f32 },
}

/// What a point of a camera path gathers from the photons.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Gathers {
    /// Every photon, by the whole BRDF: a visible point.
    Whole,
    /// Every photon, by the diffuse part alone: a visible point where
    /// camera paths follow the glossy lobe for the rest.
    Diffuse,
    /// The caustic photons of point and spot lights alone, by the glossy
    /// lobe: where a camera path met a lobe it follows (whichever way it
    /// then went), the light of those photons, which no camera path meets.
    /// Area lights' caustic photons there come to the camera along the lobe,
    /// through the mirrors and glass they came by.
    LobeOfDeltaCaustics,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn density(positions: Vec<Vec3>) -> Density {
        Density::new(positions, 1e-4, 0.4)
    }

    #[test]
    fn the_starting_radius_holds_its_photons_where_they_are_dense_or_thin() {
        // Uniform on the unit square, n photons: k of them lie within
        // sqrt(k / (pi n)) of a point inside.
        let mut rng = Rng::new(4, 4);
        for n in [10_000, 160_000] {
            let photons = (0..n).map(|_| Vec3::new(rng.uniform(), 0.0, rng.uniform())).collect();
            let expected = (START_NEIGHBOURS as f32 / (PI * n as f32)).sqrt();
            let r = density(photons).radius_at(Vec3::new(0.5, 0.0, 0.5));
            assert!((r / expected - 1.0).abs() < 0.2, "{n} photons: {r} against {expected}");
        }
    }

    #[test]
    fn the_starting_radius_grows_slowly_beside_a_bright_patch() {
        // A dense patch (a caustic) at the corner of a thinly lit square.
        let mut rng = Rng::new(4, 5);
        let mut photons: Vec<Vec3> =
            (0..2000).map(|_| Vec3::new(rng.uniform(), 0.0, rng.uniform()) * 0.1).collect();
        photons.extend((0..200).map(|_| Vec3::new(rng.uniform(), 0.0, rng.uniform())));
        let density = density(photons);
        // Just beside the patch the 32 nearest reach into it from far off;
        // the patch's own radii (about 0.007) bound the start to about a
        // quarter of the way there.
        let beside = Vec3::new(0.3, 0.0, 0.05);
        let unbounded = density.own_radius(&density.neighbours(beside));
        let bounded = density.radius_at(beside);
        assert!(unbounded > 0.15, "{unbounded}");
        assert!(bounded < 0.06 && bounded > 0.04, "{bounded}");
        // Far from it, in the thin light, the start is the photons' own.
        let far = Vec3::new(0.7, 0.0, 0.7);
        let own = density.own_radius(&density.neighbours(far));
        assert!(density.radius_at(far) > 0.7 * own, "{} against {own}", density.radius_at(far));
    }

    #[test]
    fn camera_paths_go_where_the_pixels_around_are_noisy() {
        // A row of five: the middle pixel's paths found 0 and 2 by turns,
        // the others 1 always.
        let state = |paths: u32, seen: f32, seen_sq: f64| PixelState {
            rng: Rng::new(0, 0),
            seen: Sample { direct: Vec3::splat(seen), ..Sample::default() },
            paths,
            seen_sq,
            caustic_to_camera: Vec3::ZERO,
            visible: Disc::default(),
            lobe: Radiance::default(),
        };
        let calm = state(8, 8.0, 8.0);
        let pixels = vec![calm.clone(), calm.clone(), state(8, 8.0, 16.0), calm.clone(), calm];
        let mut sum = [0u64; 5];
        for pass in 0..1000 {
            for (s, n) in sum.iter_mut().zip(extra_paths(&pixels, 5, 1, pass, 15)) {
                *s += n as u64;
            }
        }
        // 3 extra a pixel on average, 15 in all: 7.5 evenly, 7.5 to the
        // middle one's two neighbours, none by its own spread.
        let mean = sum.map(|s| s as f64 / 1000.0);
        for (i, expected) in [1.5, 5.25, 1.5, 5.25, 1.5].into_iter().enumerate() {
            assert!((mean[i] - expected).abs() < 0.1, "{mean:?}");
        }
        // Nothing known yet (a first pass): three each.
        let fresh = vec![state(0, 0.0, 0.0); 5];
        assert!(extra_paths(&fresh, 5, 1, 0, 15).iter().all(|&n| n == 3));
    }

    #[test]
    fn the_visible_points_of_a_pixel_stratify_it() {
        // A wall that fills the view, square to it: where in its pixel a
        // visible point fell is where it lies on the wall.
        let scene = crate::scene::test_scenes::wall_facing_the_camera();
        let accel = crate::accel::build(crate::accel::Backend::Native, &scene.triangle_views()).unwrap();
        let mut config = RenderConfig { width: 3, height: 2, ..scene.config.clone() };
        config.photons.sppm.initial_radius = Some(0.1);
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        let mut run = Progressive::new(&ctx);
        // Where the camera's ray through `(x, y)` of the image meets the
        // wall (at depth `z`: the scene is placed about the camera).
        let wall = |x: f32, y: f32, z: f32| {
            let ray = scene.camera.ray(x, y, config.width, config.height);
            ray.origin + ray.dir * ((z - ray.origin.z) / ray.dir.z)
        };
        let mut cells = vec![[[0; 4]; 4]; 6];
        for _ in 0..16 {
            run.camera_paths(1.0);
            run.passes += 1;
            for (i, vp) in run.points.visible.iter().enumerate() {
                let (x, y) = ((i % 3) as f32, (i / 3) as f32);
                let p = vp.expect("every path meets the wall").p;
                // The edges between its 4 x 4 cells, on the wall.
                let column = (1..4).filter(|&c| p.x > wall(x + c as f32 / 4.0, y, p.z).x).count();
                let row = (1..4).filter(|&r| p.y < wall(x, y + r as f32 / 4.0, p.z).y).count();
                cells[i][row][column] += 1;
            }
        }
        // 16 passes' visible points, one in each cell of every pixel (drawn
        // as every fourth sample of the pixel's stream, as before, pixel 0's
        // filled 9 of the 16 cells).
        for (pixel, cells) in cells.iter().enumerate() {
            assert_eq!(cells, &[[1; 4]; 4], "pixel {pixel}");
        }
    }

    #[test]
    fn gathering_keeps_what_light_tracing_cannot_take_of_a_caustic() {
        let scene = crate::scene::test_scenes::wall_facing_the_camera();
        let accel = crate::accel::build(crate::accel::Backend::Native, &scene.triangle_views()).unwrap();
        let config = RenderConfig { width: 64, height: 48, ..scene.config.clone() };
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        // The wall's point at the image's centre, seen directly.
        let ray = scene.camera.ray(32.5, 24.5, 64, 48);
        let p = ray.origin + ray.dir * (3.0 / -ray.dir.z);
        let footprint = {
            let view = CameraView::of(&ctx, p).unwrap();
            1.0 / view.area_pdf(view.to_eye.dot(Vec3::Z))
        };
        let vp = |n: Vec3, radius: f32, depth: u32| VisiblePoint {
            p,
            n,
            wo: Vec3::Z,
            material: 0,
            weight: Vec3::ONE,
            radius,
            depth,
            after_scatter: false,
            gathers: Gathers::Whole,
        };
        // A disc of one footprint: light tracing takes 1 / (1 + (1/2)^2).
        let one = (footprint / PI).sqrt();
        let w = caustic_gathering_weight(&ctx, &vp(Vec3::Z, one, 1));
        assert!((w - 0.2).abs() < 1e-4, "{w}");
        // Discs far larger than a pixel gather nearly all; far smaller, nearly none.
        assert!(caustic_gathering_weight(&ctx, &vp(Vec3::Z, 30.0 * one, 1)) > 0.999);
        assert!(caustic_gathering_weight(&ctx, &vp(Vec3::Z, 0.01 * one, 1)) < 1e-3);
        // Seen through a mirror, or with the shading normal turned from
        // the eye (light tracing takes no such path): all of it.
        assert_eq!(caustic_gathering_weight(&ctx, &vp(Vec3::Z, one, 2)), 1.0);
        assert_eq!(caustic_gathering_weight(&ctx, &vp(-Vec3::Z, one, 1)), 1.0);
    }

    #[test]
    fn the_starting_radius_stays_within_its_bounds() {
        // None near: the largest; all at one point: the smallest, never zero.
        assert_eq!(density(Vec::new()).radius_at(Vec3::ZERO), 0.4);
        assert_eq!(density(vec![Vec3::X; 10]).radius_at(Vec3::ZERO), 0.4);
        assert_eq!(density(vec![Vec3::ZERO; 100]).radius_at(Vec3::ZERO), 1e-4);
    }
}
