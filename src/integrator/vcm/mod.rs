//! Vertex connection and merging (Georgiev, Křivánek, Davidovič and
//! Slusallek 2012), with its special cases: light tracing and bidirectional
//! path tracing.
//!
//! Each pass traces one light subpath per pixel of the whole image and one
//! camera subpath per pixel rendered, then joins them in every way it can:
//! camera vertices take light from a light sample (next-event estimation)
//! or by hitting a light, connect to every vertex of their pixel's light
//! subpath, and (VCM) merge with the light vertices of all subpaths within a
//! radius that shrinks pass by pass; light vertices connect to the camera
//! (light tracing, splatted to the pixel they land in). Every way of making
//! a path is weighted against all the others by the power heuristic,
//! computed incrementally along each subpath (the `d_vcm`, `d_vc`, `d_vm`
//! quantities of Georgiev's technical report, as SmallVCM names them).
//!
//! - `light`: light tracing alone, plus the lights the camera sees directly.
//!   It cannot see light sources through mirrors or glass (`E S+ L`).
//! - `bdpt`: every connection, no merging: unbiased.
//! - `vcm`: connections and merging: converges (consistent) and finds the
//!   paths no connection samples, such as a point light's caustic seen in a
//!   mirror.
//!
//! Components as every integrator has them (by the diffuse or glossy
//! vertices of the whole path and the mirrors and glass between, whichever
//! way the path was made). Camera subpaths draw their numbers as the path
//! tracer does (with Sobol, pass `i` is the pixel's `i`-th point); light
//! subpaths from independent streams, one per subpath and pass. Light
//! subpaths scatter with the same BSDF as camera subpaths, drawn as the
//! photon tracer's photons are ([`Bsdf::sample_adjoint`]; `Carries`),
//! and take Veach's correction for shading normals where they scatter, join
//! a camera vertex or the camera, and merge
//! ([`SurfacePoint::adjoint_shading`]).

mod grid;

use glam::Vec3;
use rayon::prelude::*;

use super::direct::{LightSamples, LightSampling};
use super::path::PathClass;
use super::pixels::render_pixels_into;
use super::to_camera::CameraView;
use super::unreached::Unreached;
use super::{Context, Integrator, Progress, Rendered, SampleRange};
use crate::accel::Ray;
use crate::bsdf::{Bsdf, BsdfSample, RadianceScale};
use crate::config::RenderConfig;
use crate::film::{Film, Sample};
use crate::light::Light;
use crate::light_tree::Lights;
use crate::photon::map::lands_near;
use crate::query::{Interaction, RayCount, SurfacePoint};
use crate::sampling::Rng;
use grid::Grid;

/// Which of the ways of joining subpaths a render uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Light subpaths connected to the camera.
    LightTracing,
    /// Bidirectional path tracing: every connection.
    Bidirectional,
    /// Connections and merging.
    VertexMerging,
}

/// The integrator, in one of its modes.
pub struct Vcm(pub Mode);

/// The merging radius before the first pass, in pixels' footprints at the
/// distance of the scene's centre (unless `[photons] sppm_radius` says
/// otherwise).
const RADIUS_PIXELS: f32 = 1.5;

/// [`RADIUS_PIXELS`] footprints: as many light vertices fall within the
/// radius at any image size, as there is one light subpath per pixel.
/// Measured at 128 x 128 within 5 s (BENCHMARKS.md): 0.75, 1.5 and 3
/// pixels give RMSE 0.085, 0.080 and 0.084 on the caustics scene, 0.106,
/// 0.105 and 0.106 on the Cornell box.
fn default_radius(ctx: &Context) -> f32 {
    let scene = ctx.scene();
    let b = scene.bounds();
    let distance = (0.5 * (b.min + b.max) - scene.camera.eye).length().max(1e-3 * ctx.diagonal);
    RADIUS_PIXELS * distance / scene.camera.image_distance(ctx.config.height)
}

/// Light subpaths traced per task.
const LIGHT_CHUNK: usize = 1024;

/// Light vertices kept per light subpath, on average, for the memory
/// estimate, with room: measured 1.7 in the Cornell box, 3.0 in the teapot
/// scene, 0.2-0.3 in the ring scenes (light mostly lost to the sky).
pub const VERTICES_PER_LIGHT_PATH: u64 = 4;

/// Bytes per kept light vertex: the record, its copy while the chunks are
/// joined, and its place in the merging grid.
pub const LIGHT_VERTEX_BYTES: u64 = 2 * std::mem::size_of::<LightVertex>() as u64 + 16;

/// The power heuristic's weight of a density (ratio), in `f64`: products
/// of squared densities and distances leave `f32`'s range in scenes a
/// millionth or a million units across.
fn mis(x: f32) -> f64 {
    let x = x as f64;
    x * x
}

/// A subpath as it grows: its weight and the quantities from which the
/// multiple importance sampling weight of any path through its end is
/// computed without walking it again.
#[derive(Debug, Clone, Copy)]
struct Subpath {
    throughput: Vec3,
    /// Segments so far.
    length: u32,
    d_vcm: f64,
    d_vc: f64,
    d_vm: f64,
}

impl Subpath {
    /// Brings the quantities to a vertex reached over `distance` at the
    /// cosine `cos` with its normal; `false` where they cannot be (a
    /// grazing arrival), which ends the subpath.
    fn arrive(&mut self, distance: f32, cos: f32) -> bool {
        let cos = mis(cos.abs());
        if cos < 1e-12 || !distance.is_finite() {
            return false;
        }
        self.d_vcm *= mis(distance) * mis(distance) / cos;
        self.d_vc /= cos;
        self.d_vm /= cos;
        true
    }

    /// Samples the BSDF to continue, with Russian roulette by the surface's
    /// albedo; updates the weight and the quantities. The ray on, and the
    /// sample that sent it; `None`: the subpath ends.
    fn scatter(
        &mut self,
        bsdf: &Bsdf,
        sp: &SurfacePoint,
        pass: &Pass,
        carries: Carries,
        rng: &mut Rng,
    ) -> Option<(Ray, BsdfSample)> {
        let s = match carries {
            Carries::Importance => bsdf.sample(rng.uniform(), rng)?,
            Carries::Light => bsdf.sample_adjoint(rng.uniform(), rng)?,
        };
        let survive = continuation(bsdf);
        if rng.uniform() >= survive {
            return None;
        }
        let cos = s.wi.dot(sp.ns).abs();
        match s.pdf {
            // A delta lobe: its density is the same both ways and cancels.
            None => {
                self.d_vcm = 0.0;
                self.d_vc *= mis(cos);
                self.d_vm *= mis(cos);
            }
            Some(pdf) => {
                let forward = pdf * survive;
                let reverse = carries.other().pdf_reverse(bsdf, s.wi) * survive;
                let g = mis(cos / forward);
                self.d_vc = g * (self.d_vc * mis(reverse) + self.d_vcm + pass.vm_weight);
                self.d_vm = g * (self.d_vm * mis(reverse) + self.d_vcm * pass.vc_weight + 1.0);
                self.d_vcm = mis(1.0 / forward);
            }
        }
        self.throughput *= s.weight / survive;
        (self.throughput != Vec3::ZERO && self.throughput.is_finite()).then(|| (sp.spawn(s.wi), s))
    }
}

/// `value`, or nothing where a weight overflowed (a subpath's quantities
/// at extreme distances and grazing angles): one lost sample, not a pixel
/// of NaN.
fn finite(value: Vec3) -> Vec3 {
    if value.is_finite() {
        value
    } else {
        Vec3::ZERO
    }
}

/// The chance a subpath goes on at a surface: its albedo's largest channel.
fn continuation(bsdf: &Bsdf) -> f32 {
    bsdf.albedo().max_element().clamp(0.0, 1.0)
}

/// What a subpath carries, which decides how it draws its way on at a
/// diffuse or glossy vertex: camera subpaths about the shading normal, as
/// the path tracer; light subpaths over the surface's side by the adjoint
/// BSDF ([`Bsdf::sample_adjoint`], as photons), since camera paths see
/// light leave towards directions below the shading normal too. The
/// weights take each side's own density.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Carries {
    /// A camera subpath.
    Importance,
    /// A light subpath.
    Light,
}

impl Carries {
    /// The other kind of subpath.
    fn other(self) -> Carries {
        match self {
            Carries::Importance => Carries::Light,
            Carries::Light => Carries::Importance,
        }
    }

    /// The density with which a subpath of this kind at the vertex of
    /// `bsdf` draws `wi`.
    fn pdf(self, bsdf: &Bsdf, wi: Vec3) -> f32 {
        match self {
            Carries::Importance => bsdf.pdf(wi),
            Carries::Light => bsdf.pdf_adjoint(wi),
        }
    }

    /// The density with which a subpath of this kind, arriving back along
    /// `wi`, would draw the direction towards `bsdf`'s viewer.
    fn pdf_reverse(self, bsdf: &Bsdf, wi: Vec3) -> f32 {
        match self {
            Carries::Importance => bsdf.pdf_reverse(wi),
            Carries::Light => bsdf.pdf_adjoint_reverse(wi),
        }
    }
}

/// The smooth lobes at a vertex towards a unit direction `wi`.
struct Lobes {
    f: Vec3,
    /// Cosine between `wi` and the shading normal.
    cos: f32,
    /// Density of continuing towards `wi` (Russian roulette included).
    forward: f32,
    /// Density of continuing the other way, from `wi` towards where the
    /// subpath came from.
    reverse: f32,
}

/// The smooth lobes at a vertex of a subpath that `carries` towards `wi`:
/// on a camera subpath, light arriving from `wi` must come from the shading
/// normal's side; on a light subpath, which sends its light on towards
/// `wi`, only the surface's side is asked of it (a camera path sees light
/// leave below the shading normal too; see [`connect`] for its shadow ray).
fn lobes(bsdf: &Bsdf, sp: &SurfacePoint, wi: Vec3, carries: Carries) -> Option<Lobes> {
    let cos = wi.dot(sp.ns);
    let side = match carries {
        Carries::Importance => cos > 0.0,
        Carries::Light => true,
    };
    if !side || wi.dot(sp.ng) <= 0.0 || !bsdf.has_smooth() {
        return None;
    }
    let f = bsdf.eval(wi);
    let survive = continuation(bsdf);
    (f != Vec3::ZERO).then(|| Lobes {
        f,
        cos: cos.abs(),
        forward: carries.pdf(bsdf, wi) * survive,
        reverse: carries.other().pdf_reverse(bsdf, wi) * survive,
    })
}

/// What one pass shares: its radius and the weights that depend on it.
struct Pass<'a> {
    mode: Mode,
    /// Most segments in a path: `max_depth` rays from the camera and the
    /// connection to a light, as the path tracer's paths end with a
    /// shadow ray after its last bounce.
    max_length: u32,
    radius: f32,
    /// Light subpaths traced (one per pixel of the whole image).
    light_paths: usize,
    /// Merging's weight relative to a connection (`eta_VCM` under the heuristic); 0 without merging.
    vm_weight: f64,
    /// A connection's weight relative to merging.
    vc_weight: f64,
    /// `1 / (pi r^2 N)`: a merged light vertex's share of the density.
    vm_normalization: f32,
    /// Each light's chance of being chosen to start a light subpath.
    pick: &'a [f32],
}

impl<'a> Pass<'a> {
    /// Pass `index` of a render whose merging radius starts at
    /// `base_radius`, with lights chosen by `pick` ([`light_choice`]).
    fn new(ctx: &Context, mode: Mode, index: u32, base_radius: f32, pick: &'a [f32]) -> Pass<'a> {
        let c = ctx.config;
        let radius = base_radius / ((index + 1) as f32).powf(0.5 * (1.0 - c.photons.sppm.vcm_alpha()));
        let light_paths = c.width as usize * c.height as usize;
        let eta = std::f64::consts::PI * mis(radius) * light_paths as f64;
        let merging = mode == Mode::VertexMerging;
        Pass {
            mode,
            max_length: c.max_depth + 1,
            radius,
            light_paths,
            vm_weight: if merging { eta * eta } else { 0.0 },
            vc_weight: if merging { 1.0 / (eta * eta) } else { 0.0 },
            vm_normalization: (1.0 / eta) as f32,
            pick,
        }
    }

    fn pick_of(&self, lights: &Lights, light: &Light) -> f32 {
        lights.index_of(light).map_or(0.0, |i| self.pick[i])
    }
}

/// Each light's chance of being chosen to start a light subpath: in
/// proportion to its power.
fn light_choice(lights: &[Light]) -> Vec<f32> {
    let powers: Vec<f32> = lights.iter().map(|l| l.power().element_sum().max(0.0)).collect();
    let total: f32 = powers.iter().sum();
    powers.iter().map(|p| if total > 0.0 { p / total } else { 0.0 }).collect()
}

/// A light subpath's vertex on a surface with a smooth lobe.
struct LightVertex {
    sp: SurfacePoint,
    /// Unit direction the light arrived along.
    dir: Vec3,
    path: Subpath,
    history: LightHistory,
}

/// What a light subpath passed on its way to a vertex.
#[derive(Debug, Clone, Copy, Default)]
struct LightHistory {
    /// A diffuse or glossy vertex.
    scattered: bool,
    /// A mirror or glass.
    specular: bool,
}

impl LightHistory {
    /// The component of a path whose only diffuse or glossy vertex is the
    /// one this subpath has reached.
    fn component(self) -> Component {
        match self {
            LightHistory { scattered: false, specular: false } => Component::Direct,
            LightHistory { scattered: false, specular: true } => Component::Caustic,
            _ => Component::Indirect,
        }
    }
}

/// The components a light subpath's light can go to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Component {
    Direct,
    Caustic,
    Indirect,
}

impl Component {
    fn slot(self, out: &mut Sample) -> &mut Vec3 {
        match self {
            Component::Direct => &mut out.direct,
            Component::Caustic => &mut out.caustic,
            Component::Indirect => &mut out.indirect,
        }
    }
}

/// One pass's light subpaths: their vertices path by path, and what they
/// add to pixels through the camera.
struct LightPaths {
    vertices: Vec<LightVertex>,
    /// `starts[i]..starts[i + 1]` index `vertices` for subpath `i`.
    starts: Vec<usize>,
    /// Light-tracing contributions: pixel of the film, component, value;
    /// in the chunks the paths were traced in, in order, each chunk's in a
    /// list of its own (joined into one, a pass's splats took fresh pages
    /// every pass: BENCHMARKS.md). [`light_path`] adds to the last list.
    splats: Vec<Vec<(usize, Component, Vec3)>>,
    rays: RayCount,
}

impl Integrator for Vcm {
    fn work_units(&self, config: &RenderConfig) -> u64 {
        config.pixels() * config.samples as u64
    }

    fn refines_by_samples(&self) -> bool {
        true
    }

    /// Merging carries every path; without it, a path whose every segment
    /// has a mirror or glass end (or a point light's) is never made.
    fn unreached(&self) -> Option<Unreached> {
        match self.0 {
            Mode::VertexMerging => None,
            Mode::Bidirectional => Some(Unreached::FromPointLightsSeenInMirrors),
            Mode::LightTracing => Some(Unreached::SeenInMirrors),
        }
    }

    /// Pass `i` of the render is camera sample `i` of every pixel, with its
    /// own light subpaths and radius: rounds of a time budget go on where
    /// the last stopped.
    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered {
        let region = ctx.config.region();
        let mut sum = vec![Sample::default(); region.pixels() as usize];
        let mut rays = RayCount::default();
        let mut radius = 0.0;
        let range = ctx.samples;
        // What every pass shares, worked out once (the default radius walks
        // the scene's vertices for its bounds).
        let base_radius = ctx.config.photons.sppm.initial_radius.unwrap_or_else(|| default_radius(ctx));
        let pick = light_choice(&ctx.scene().lights);
        // The passes' camera samples, tile by tile: the same memory each pass.
        let mut tiles = Vec::new();
        for index in range.first..range.first + range.count {
            let pass = Pass::new(ctx, self.0, index, base_radius, &pick);
            radius = pass.radius;
            let light = trace_light_paths(ctx, &pass, index);
            let grid = (self.0 == Mode::VertexMerging)
                .then(|| Grid::new(light.vertices.iter().map(|v| v.sp.p).collect(), pass.radius));
            let round = Context { samples: SampleRange { first: index, count: 1 }, ..*ctx };
            let add = |i: usize, sample: Sample| sum[i] += sample;
            let camera_rays = render_pixels_into(
                &round,
                progress,
                |x, y, rng, count| {
                    let c = ctx.config;
                    let path = y as usize * c.width as usize + x as usize;
                    // The camera subpath draws from the pixel's stream, or with
                    // Sobol from pass `index`'s low-discrepancy point.
                    let mut sobol = c.sampler.sample_stream(c.seed, path as u64, index);
                    let rng = sobol.as_mut().unwrap_or(rng);
                    let offset = rng.uniform2();
                    let ray =
                        ctx.scene().camera.ray(x as f32 + offset.x, y as f32 + offset.y, c.width, c.height);
                    let vertices = &light.vertices[light.starts[path]..light.starts[path + 1]];
                    camera_path(
                        ctx,
                        &pass,
                        ray,
                        vertices,
                        grid.as_ref().map(|g| (g, &light.vertices[..])),
                        rng,
                        count,
                    )
                },
                &mut tiles,
                add,
            );
            for &(pixel, component, value) in light.splats.iter().flatten() {
                *component.slot(&mut sum[pixel]) += value;
            }
            rays += camera_rays;
            rays += light.rays;
        }
        let mut film = Film::new(region.width(), region.height());
        film.pixels = sum.into_iter().map(|s| s * (1.0 / range.count as f32)).collect();
        let note = match self.0 {
            Mode::VertexMerging => vec![format!("vcm: merging radius {radius:.3e} at the last pass")],
            _ => Vec::new(),
        };
        Rendered::new(film, rays, note)
    }
}

/// Traces pass `index`'s light subpaths, in chunks on the threads, put
/// together in order so the result does not depend on the threads.
fn trace_light_paths(ctx: &Context, pass: &Pass, index: u32) -> LightPaths {
    let n = pass.light_paths;
    let keep = pass.mode != Mode::LightTracing;
    let seed = ctx.config.seed ^ 0xA076_1D64_78BD_642F;
    let chunks: Vec<LightPaths> = (0..n.div_ceil(LIGHT_CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut out = LightPaths {
                vertices: Vec::new(),
                starts: Vec::new(),
                splats: vec![Vec::new()],
                rays: RayCount::default(),
            };
            for i in chunk * LIGHT_CHUNK..((chunk + 1) * LIGHT_CHUNK).min(n) {
                out.starts.push(out.vertices.len());
                let mut rng = Rng::new(seed, index as u64 * n as u64 + i as u64);
                light_path(ctx, pass, &mut rng, keep, &mut out);
            }
            out
        })
        .collect();
    let mut all = LightPaths {
        vertices: Vec::with_capacity(chunks.iter().map(|c| c.vertices.len()).sum()),
        starts: Vec::with_capacity(n + 1),
        splats: Vec::with_capacity(chunks.len()),
        rays: RayCount::default(),
    };
    for chunk in chunks {
        let offset = all.vertices.len();
        all.starts.extend(chunk.starts.iter().map(|s| s + offset));
        all.vertices.extend(chunk.vertices);
        all.splats.extend(chunk.splats);
        all.rays += chunk.rays;
    }
    all.starts.push(all.vertices.len());
    all
}

/// One light subpath: from a light chosen by power, scattering until
/// Russian roulette or the depth limit ends it; each vertex with a smooth
/// lobe is kept (for connections and merging) and connected to the camera.
fn light_path(ctx: &Context, pass: &Pass, rng: &mut Rng, keep: bool, out: &mut LightPaths) {
    let query = &ctx.query;
    let lights = &ctx.scene().lights;
    let u = rng.uniform();
    let mut acc = 0.0;
    // (The sums may end a rounding short of 1: then the last light that emits.)
    let chosen = (0..lights.len())
        .find(|&i| {
            acc += pass.pick[i];
            u < acc && pass.pick[i] > 0.0
        })
        .or_else(|| (0..lights.len()).rev().find(|&i| pass.pick[i] > 0.0));
    let Some(chosen) = chosen else { return };
    let (light, pick) = (&lights[chosen], pass.pick[chosen]);
    let (mut ray, power) = light.emit(rng.uniform2(), rng.uniform2());
    let pdfs = light.emission_pdfs(ray.dir);
    if pdfs.emit <= 0.0 || power == Vec3::ZERO {
        return;
    }
    let emit = pick * pdfs.emit;
    let d_vc = if light.is_delta() { 0.0 } else { mis(pdfs.cos / emit) };
    let mut path = Subpath {
        throughput: power / pick,
        length: 1,
        d_vcm: mis(pdfs.direct_area / emit),
        d_vc,
        d_vm: d_vc * pass.vc_weight,
    };
    let mut history = LightHistory::default();
    loop {
        // Lights do not reflect: a subpath reaching one ends.
        let Some(Interaction::Surface(sp)) = query.first(&ray, &mut out.rays) else { return };
        let dir = ray.dir.normalize();
        if !path.arrive(sp.t * ray.dir.length(), dir.dot(sp.ns)) {
            return;
        }
        if path.length == 1 {
            // Next-event estimation from this vertex would sample the
            // light's point with this many samples ([`LightSamples`]).
            path.d_vcm *= mis(LightSamples::mis_factor(lights, light, sp.p));
        }
        let bsdf = Bsdf::new(query.material(&sp), &sp, dir);
        // Light from below the shading normal's side: the smooth lobes
        // reflect none of it (as the path tracer has it), only mirror and glass.
        let smooth = bsdf.has_smooth() && sp.smooth_lobes_take(-dir);
        if smooth {
            if let Some((pixel, value)) = connect_to_camera(ctx, pass, &sp, &bsdf, &path, &mut out.rays) {
                out.splats.last_mut().expect("a list for the chunk's splats").push((
                    pixel,
                    history.component(),
                    value,
                ));
            }
            if keep {
                out.vertices.push(LightVertex { sp, dir, path, history });
            }
        }
        if path.length + 2 > pass.max_length {
            return;
        }
        // Light from below the shading normal's side goes on by mirror and
        // glass alone: `sample_adjoint` draws no smooth lobe for it. The
        // smooth lobes' draw holds Veach's correction.
        let Some((next, s)) = path.scatter(&bsdf, &sp, pass, Carries::Light, rng) else { return };
        if s.kind.is_specular() {
            path.throughput *= sp.adjoint_shading(-dir, s.wi);
        }
        if path.throughput == Vec3::ZERO || !path.throughput.is_finite() {
            return;
        }
        let specular = s.kind.is_specular();
        history = LightHistory {
            scattered: history.scattered || !specular,
            specular: history.specular || specular,
        };
        ray = next;
        path.length += 1;
    }
}

/// Light tracing: the light vertex at `sp` seen by the camera, as the film
/// pixel it lands in and what it adds there.
fn connect_to_camera(
    ctx: &Context,
    pass: &Pass,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    path: &Subpath,
    rays: &mut RayCount,
) -> Option<(usize, Vec3)> {
    let view = CameraView::of(ctx, sp.p)?;
    // The camera must be on the surface's side, not above the shading
    // normal's hemisphere: at a smooth mesh's outline the eye may lie below
    // it, where the path tracer still sees the surface's light.
    if view.to_eye.dot(sp.ng) <= 0.0 {
        return None;
    }
    let f = bsdf.eval(view.to_eye);
    // The camera's density of this point, per unit area of the surface.
    let camera_area_pdf = view.area_pdf(view.to_eye.dot(sp.ns).abs());
    let weight = match pass.mode {
        Mode::LightTracing => 1.0,
        _ => {
            let reverse = bsdf.pdf_reverse(view.to_eye) * continuation(bsdf);
            let w_light = mis(camera_area_pdf / pass.light_paths as f32)
                * (pass.vm_weight + path.d_vcm + path.d_vc * mis(reverse));
            (1.0 / (w_light + 1.0)) as f32
        }
    };
    let value = path.throughput
        * f
        * (weight * camera_area_pdf / pass.light_paths as f32 * sp.adjoint_shading(bsdf.wo(), view.to_eye));
    if finite(value) == Vec3::ZERO || !view.unblocked(ctx, sp, rays) {
        return None;
    }
    Some((view.pixel, value))
}

/// A camera subpath through one pixel, joined to the light subpaths.
/// `vertices` is the pixel's own light subpath; `merge` (VCM) the grid over
/// every light vertex of the pass, and those vertices.
fn camera_path(
    ctx: &Context,
    pass: &Pass,
    mut ray: Ray,
    vertices: &[LightVertex],
    merge: Option<(&Grid, &[LightVertex])>,
    rng: &mut Rng,
    count: &mut RayCount,
) -> Sample {
    let (query, c) = (&ctx.query, ctx.config);
    let lights = &ctx.scene().lights;
    let camera = &ctx.scene().camera;
    let to_image_plane = camera.image_distance(c.height) / ray.dir.dot(-camera.w);
    let camera_pdf = to_image_plane * to_image_plane * to_image_plane / camera.image_distance(c.height);
    let mut path = Subpath {
        throughput: Vec3::ONE,
        length: 1,
        d_vcm: mis(pass.light_paths as f32 / camera_pdf),
        d_vc: 0.0,
        d_vm: 0.0,
    };
    let mut out = Sample::default();
    let mut class = PathClass::Specular;
    // What light found here is worth at the camera across refractions
    // ([`RadianceScale`]): the camera path carries radiance, the light
    // subpaths power. Kept apart from the throughput, so that a path into
    // glass and out again is back at exactly 1.
    let mut scale = RadianceScale::ONE;
    let mut found_surface = false;
    // Where the path last scattered (with many lights, the light sample
    // there chose among them by its place).
    let mut last_point = Vec3::ZERO;
    loop {
        let sp = match query.first(&ray, count) {
            None => return out,
            Some(Interaction::Emitter { light, t, radiance }) => {
                if path.length == 1 {
                    out.emission += radiance;
                } else if pass.mode != Mode::LightTracing {
                    let dir = ray.dir.normalize();
                    let pdfs = light.emission_pdfs(-dir);
                    if path.arrive(t * ray.dir.length(), pdfs.cos) {
                        // Next-event estimation at the vertex before would
                        // have sampled this light with this many samples.
                        let nee = LightSamples::mis_factor(lights, light, last_point);
                        let w_camera = mis(pdfs.direct_area * nee) * path.d_vcm
                            + mis(pass.pick_of(lights, light) * pdfs.emit) * path.d_vc;
                        *class.slot(&mut out) +=
                            finite(path.throughput * radiance / (1.0 + w_camera) as f32 * scale.factor());
                    }
                }
                return out;
            }
            Some(Interaction::Surface(sp)) => sp,
        };
        let dir = ray.dir.normalize();
        let distance = sp.t * ray.dir.length();
        if path.length == 1 {
            out.depth = distance;
        }
        if !path.arrive(distance, dir.dot(sp.ns)) {
            return out;
        }
        let bsdf = Bsdf::new(query.material(&sp), &sp, dir);
        if bsdf.has_smooth() && !found_surface {
            found_surface = true;
            let m = bsdf.material();
            (out.albedo, out.normal) = (path.throughput * (m.diffuse + m.specular), sp.ns);
        }
        if pass.mode == Mode::LightTracing || path.length >= pass.max_length {
            return out;
        }
        if bsdf.has_smooth() {
            // A light sample makes the path one diffuse vertex longer.
            let direct = next_event(ctx, pass, &sp, &bsdf, &path, rng, count);
            let throughput = path.throughput * scale.factor();
            *class.after(false).slot(&mut out) += throughput * direct;
            for v in vertices {
                if v.path.length + 1 + path.length > pass.max_length {
                    break;
                }
                out.indirect += throughput * connect(ctx, pass, &sp, &bsdf, &path, v, count);
            }
            if let Some((grid, all)) = merge {
                let merged = throughput * pass.vm_normalization;
                grid.visit(sp.p, |i| {
                    let v = &all[i];
                    // As photon estimates: not the other wall of a corner,
                    // nor the far side of a thin shell.
                    if v.path.length + path.length > pass.max_length
                        || !lands_near(v.sp.p, v.sp.ns, v.sp.ng, sp.p, sp.ns, pass.radius)
                    {
                        return;
                    }
                    let Some(lobes) = lobes(&bsdf, &sp, -v.dir, Carries::Importance) else { return };
                    let w_light = v.path.d_vcm * pass.vc_weight + v.path.d_vm * mis(lobes.forward);
                    let w_camera = path.d_vcm * pass.vc_weight + path.d_vm * mis(lobes.reverse);
                    // The merged vertex is this one: diffuse once if neither
                    // subpath scattered before it.
                    let component = match class {
                        PathClass::Specular => v.history.component(),
                        _ => Component::Indirect,
                    };
                    // The light's density weighed by the shading normal's
                    // cosine, as a photon's stored power is (`Photon::power`).
                    let landed = v.path.throughput * v.sp.shading_over_geometric(-v.dir);
                    *component.slot(&mut out) +=
                        finite(merged * lobes.f * landed / (w_light + 1.0 + w_camera) as f32);
                });
            }
        }
        let Some((next, s)) = path.scatter(&bsdf, &sp, pass, Carries::Importance, rng) else { return out };
        scale = scale.after(&s);
        last_point = sp.p;
        class = class.after(s.kind.is_specular());
        ray = next;
        path.length += 1;
    }
}

/// Next-event estimation at a camera vertex: one sample of every light
/// (or, where many reach it, of as many drawn among them:
/// [`LightSamples`]), weighted against reaching it by BSDF sampling and
/// from light subpaths.
fn next_event(
    ctx: &Context,
    pass: &Pass,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    path: &Subpath,
    rng: &mut Rng,
    count: &mut RayCount,
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let plan = LightSamples::at(&ctx.scene().lights, sp.p, LightSampling::MultipleImportance);
    for (index, light, u, divide_by, expected) in plan.take(rng) {
        let Some(sample) = light.sample_incident(sp.p, u) else { continue };
        let to = sample.position - sp.p;
        let distance2 = to.length_squared();
        let wi = to / distance2.sqrt();
        let Some(lobes) = lobes(bsdf, sp, wi, Carries::Importance) else { continue };
        let pdfs = light.emission_pdfs(-wi);
        if pdfs.cos <= 0.0 {
            continue;
        }
        // Solid-angle density of this light sample, times the samples
        // the light is expected to take here; a point light's is its
        // squared distance (its point is certain).
        let direct = expected * pdfs.direct_area * distance2 / pdfs.cos;
        let by_bsdf = if light.is_delta() { 0.0 } else { lobes.forward };
        let w_light = mis(by_bsdf / direct);
        let w_camera = mis(pass.pick[index] * pdfs.emit * lobes.cos / (direct * pdfs.cos))
            * (pass.vm_weight + path.d_vcm + path.d_vc * mis(lobes.reverse));
        let value = lobes.f * sample.irradiance * (lobes.cos / divide_by / (w_light + 1.0 + w_camera) as f32);
        if value != Vec3::ZERO
            && value.is_finite()
            && !ctx.query.occluded(&sp.spawn_to(sample.position), count)
        {
            sum += value;
        }
    }
    sum
}

/// The connection of the camera vertex at `sp` to the light vertex `v`:
/// what the path through both adds, before the camera subpath's weight.
fn connect(
    ctx: &Context,
    pass: &Pass,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    path: &Subpath,
    v: &LightVertex,
    count: &mut RayCount,
) -> Vec3 {
    let to = v.sp.p - sp.p;
    let distance2 = to.length_squared();
    let dir = to / distance2.sqrt();
    let Some(camera_side) = lobes(bsdf, sp, dir, Carries::Importance) else { return Vec3::ZERO };
    let light_bsdf = Bsdf::new(ctx.query.material(&v.sp), &v.sp, v.dir);
    let Some(light_side) = lobes(&light_bsdf, &v.sp, -dir, Carries::Light) else { return Vec3::ZERO };
    let geometry = camera_side.cos * light_side.cos / distance2;
    // Each side's density of making the other's vertex, per unit area there.
    let camera_makes_light = camera_side.forward * light_side.cos / distance2;
    let light_makes_camera = light_side.forward * camera_side.cos / distance2;
    let w_light =
        mis(camera_makes_light) * (pass.vm_weight + v.path.d_vcm + v.path.d_vc * mis(light_side.reverse));
    let w_camera =
        mis(light_makes_camera) * (pass.vm_weight + path.d_vcm + path.d_vc * mis(camera_side.reverse));
    let light_turns = v.sp.adjoint_shading(-v.dir, -dir);
    let value = camera_side.f
        * light_side.f
        * v.path.throughput
        * (geometry / (w_light + 1.0 + w_camera) as f32 * light_turns);
    if finite(value) == Vec3::ZERO || ctx.query.occluded(&sp.spawn_to(v.sp.p), count) {
        return Vec3::ZERO;
    }
    // A shadow ray stops just short of its end, where a way that leaves the
    // light vertex below its shading normal may graze past the triangle's
    // edge into the next one: on a closed shell around a point light, such
    // joins lit its outside. From the light vertex's side that is seen.
    if light_side_below(v, dir) && ctx.query.occluded(&v.sp.spawn_to(sp.p), count) {
        return Vec3::ZERO;
    }
    value
}

/// Whether the way from the light vertex `v` to a camera vertex in the
/// direction `-dir` lies below its shading normal.
fn light_side_below(v: &LightVertex, dir: Vec3) -> bool {
    (-dir).dot(v.sp.ns) <= 0.0
}
