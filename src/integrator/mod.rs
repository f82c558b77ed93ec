//! Integrators: what turns a scene into a film. Each lives in its own file
//! and implements [`Integrator`]; [`create`] is where they are registered.
//!
//! Every pixel owns a random stream derived from its index, and tiles are
//! written back by position, so an image is bit-identical whatever the
//! number of threads.

pub mod direct;
mod emission;
pub mod path;
pub mod photon;
pub mod pixels;
pub mod preview;
mod rounds;
pub mod sppm;
mod to_camera;
pub mod unreached;
pub mod vcm;
pub mod whitted;

use std::time::{Duration, Instant};

use crate::accel::Intersector;
use crate::config::{IntegratorKind, RenderConfig};
use crate::error::{Error, Result};
use crate::film::Film;
use crate::photon::PhotonMaps;
use crate::query::{RayCount, SceneQuery};
use crate::scene::Scene;
use emission::LightEdges;

/// Called as work gets done, with the units just finished (see
/// [`Integrator::work_units`]); the command line drives its progress bar with it.
pub type Progress<'p> = dyn Fn(u64) + Sync + 'p;

/// Called with the image so far and the camera samples (SPPM: passes) in
/// it, while a render to a time budget refines: after each round of
/// samples, and after SPPM passes 1, 2, 4, 8 and so on.
pub type Snapshot<'s> = dyn Fn(&Film, u32) + Sync + 's;

/// What every integrator reads: the scene, its intersector and the config.
#[derive(Clone, Copy)]
pub struct Context<'a> {
    /// First-interaction queries on the scene.
    pub query: SceneQuery<'a>,
    /// The settings (already validated).
    pub config: &'a RenderConfig,
    /// Length of the scene's bounding-box diagonal: default radii are fractions of it.
    pub diagonal: f32,
    /// Photon maps made beforehand (loaded from a file, or built once for
    /// all the rounds of a render to a time budget), for the integrators
    /// that use them; `None`: they trace their own.
    pub photon_maps: Option<&'a PhotonMaps>,
    /// The camera samples of each pixel this pass takes: all of them, or
    /// one round of a render to a time budget.
    pub samples: SampleRange,
    /// Instead of `samples`, each pixel's own (of the region, row by row):
    /// a round of a render to a time budget that follows the noise.
    pub pixel_samples: Option<&'a [SampleRange]>,
    /// Where the images so far of a render to a time budget go, if anywhere.
    pub snapshot: Option<&'a Snapshot<'a>>,
    /// Under a time budget, the pixels where a light's edge shows: after
    /// the render they take samples of the lights alone, and the render
    /// leaves them the time ([`LightEdges::seconds_after`]).
    pub(crate) light_edges: Option<&'a LightEdges>,
}

/// Camera samples `first .. first + count` of every pixel (by index: each
/// sample's random numbers depend on its index, so rounds continue where
/// the last one stopped).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleRange {
    /// The first sample's index.
    pub first: u32,
    /// How many.
    pub count: u32,
}

impl<'a> Context<'a> {
    /// The context for rendering `scene` through `accel` with `config`.
    pub fn new(scene: &'a Scene, accel: &'a dyn Intersector, config: &'a RenderConfig) -> Self {
        Context {
            query: SceneQuery::new(scene, accel),
            config,
            diagonal: Context::diagonal_of(scene),
            photon_maps: None,
            samples: SampleRange { first: 0, count: config.samples },
            pixel_samples: None,
            snapshot: None,
            light_edges: None,
        }
    }

    /// The length of `scene`'s bounding-box diagonal, as contexts hold it.
    pub fn diagonal_of(scene: &Scene) -> f32 {
        let b = scene.bounds();
        (b.max - b.min).length()
    }

    /// The scene.
    pub fn scene(&self) -> &'a Scene {
        self.query.scene
    }

    /// The camera samples this pass takes at pixel `(x, y)` of the region.
    pub fn samples_at(&self, x: u32, y: u32) -> SampleRange {
        match self.pixel_samples {
            None => self.samples,
            Some(each) => {
                let r = self.config.region();
                each[(y - r.y0) as usize * r.width() as usize + (x - r.x0) as usize]
            }
        }
    }
}

/// A way of computing the image.
pub trait Integrator: Sync {
    /// Units of work [`Integrator::render`] reports through its progress
    /// callback in all (pixels, unless the integrator says otherwise).
    fn work_units(&self, config: &RenderConfig) -> u64 {
        config.pixels()
    }

    /// Whether each pixel's `emission` component is the mean of its own
    /// camera samples, spread over the pixel, in any render (the count of a
    /// render to a time budget in [`RenderStats::pixel_samples`]). Where a
    /// light's edge shows, those pixels then take more samples of the
    /// lights alone (`emission`). Not so where light paths add to any pixel
    /// (VCM and its special cases: their lights seen are weighted among
    /// strategies), nor for a single sample through the pixel's centre.
    fn averages_lights_seen(&self) -> bool {
        self.pixels_sample_alone()
    }

    /// Camera samples per pixel, as the summary line reports them.
    fn samples_per_pixel(&self, config: &RenderConfig) -> u32 {
        config.samples
    }

    /// How many camera samples each pixel's `emission` component averages
    /// over in a render of a fixed number of samples, where
    /// [`Integrator::averages_lights_seen`] (`None`: one, through the
    /// pixel's centre).
    fn emission_samples(&self, config: &RenderConfig) -> Option<u32> {
        (config.samples > 1).then_some(config.samples)
    }

    /// Whether more camera samples refine its image, so that a time budget
    /// renders in rounds of samples ([`RenderConfig::time`]).
    fn refines_by_samples(&self) -> bool {
        false
    }

    /// The light it cannot carry however many samples it takes, if any
    /// ([`unreached`]).
    fn unreached(&self) -> Option<unreached::Unreached> {
        None
    }

    /// Whether each pixel is computed from its own camera samples alone
    /// (through [`pixels::average_over_pixel`], which reads
    /// [`Context::samples_at`]), so that pixels may take different numbers
    /// of them. Not so where light paths add to any pixel (VCM and its
    /// special cases): their rounds take the same samples everywhere.
    fn pixels_sample_alone(&self) -> bool {
        false
    }

    /// Photon maps to build once for all the rounds of a render to a time
    /// budget (for the integrators that read them).
    fn photon_maps(&self, _ctx: &Context) -> Option<PhotonMaps> {
        None
    }

    /// Settings for all the rounds of a render to a time budget, measured
    /// on the scene with the maps built for them (`ctx.photon_maps`);
    /// `None`: the settings as given.
    fn tuned_for_time(&self, _ctx: &Context) -> Option<Tuned> {
        None
    }

    /// Renders the image: the samples of `ctx.samples`, or (SPPM) as many
    /// passes as the settings or the time budget ask.
    fn render(&self, ctx: &Context, progress: &Progress) -> Rendered;
}

/// Settings an integrator measured for a render to a time budget
/// ([`Integrator::tuned_for_time`]).
pub struct Tuned {
    /// The settings for all the rounds.
    pub config: RenderConfig,
    /// A line for the summary saying what was measured and chosen.
    pub note: String,
    /// Rays the measuring traced (counted with the render's).
    pub rays: RayCount,
}

/// The integrator of a kind: the one place integrators are registered.
pub fn create(kind: IntegratorKind) -> Box<dyn Integrator> {
    match kind {
        IntegratorKind::Photon => Box::new(photon::PhotonMapping),
        IntegratorKind::Sppm => Box::new(sppm::Sppm),
        IntegratorKind::Vcm => Box::new(vcm::Vcm(vcm::Mode::VertexMerging)),
        IntegratorKind::Bdpt => Box::new(vcm::Vcm(vcm::Mode::Bidirectional)),
        IntegratorKind::Light => Box::new(vcm::Vcm(vcm::Mode::LightTracing)),
        IntegratorKind::Whitted => Box::new(whitted::Whitted),
        IntegratorKind::Path => Box::new(path::PathTracer),
        IntegratorKind::Normals => Box::new(preview::Preview::Normals),
        IntegratorKind::Depth => Box::new(preview::Preview::Depth),
    }
}

/// Numbers for the summary line of a render.
#[derive(Debug, Clone)]
pub struct RenderStats {
    /// Wall-clock time of the render.
    pub elapsed: Duration,
    /// Rays traced to their closest hit, and shadow rays.
    pub rays: RayCount,
    /// Lines worth telling the user (what photon maps were built or skipped).
    pub notes: Vec<String>,
    /// Camera samples per pixel taken (passes for SPPM, one for the
    /// previews; on average, for a render to a time budget).
    pub samples_per_pixel: u32,
    /// For a render to a time budget, the camera samples (SPPM: camera
    /// paths) each pixel of the region took, row by row (noisier pixels
    /// take more).
    pub pixel_samples: Option<Vec<u32>>,
}

/// A finished render.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// The pixels.
    pub film: Film,
    /// Time and work.
    pub stats: RenderStats,
}

impl Rendered {
    /// A render's film with the rays it traced and its notes; [`render`]
    /// times it.
    pub fn new(film: Film, rays: RayCount, notes: Vec<String>) -> Rendered {
        Rendered {
            film,
            stats: RenderStats {
                elapsed: Duration::ZERO,
                rays,
                notes,
                samples_per_pixel: 0,
                pixel_samples: None,
            },
        }
    }
}

/// Renders `scene` through `accel` as `config` says, after checking
/// `config` ([`RenderConfig::validate`]). `progress` is called as work gets
/// done; [`work_units`] says how much there is in all.
pub fn render(
    scene: &Scene,
    accel: &dyn Intersector,
    config: &RenderConfig,
    progress: &Progress,
) -> Result<Rendered> {
    render_with_maps(scene, accel, config, None, progress, None)
}

/// [`render`] with photon maps made beforehand (see
/// [`crate::photon::file::load`], which checks they fit the scene and
/// settings) instead of tracing them, for the integrators that use them;
/// with a time budget, `snapshot` (if given) sees the image as it refines.
pub fn render_with_maps(
    scene: &Scene,
    accel: &dyn Intersector,
    config: &RenderConfig,
    maps: Option<&PhotonMaps>,
    progress: &Progress,
    snapshot: Option<&Snapshot>,
) -> Result<Rendered> {
    check(scene, config)?;
    let start = Instant::now();
    let integrator = create(config.integrator);
    let ctx = Context { photon_maps: maps, snapshot, ..Context::new(scene, accel, config) };
    let refines_lights = integrator.averages_lights_seen();
    // Under a time budget the first look comes first, so that the render
    // leaves the refinement its time.
    let edges = match config.time {
        Some(_) if refines_lights => LightEdges::find(&ctx),
        _ => None,
    };
    let ctx = Context { light_edges: edges.as_ref(), ..ctx };
    let mut rendered = match config.time {
        Some(seconds) if integrator.refines_by_samples() => rounds::render_to_time(
            integrator.as_ref(),
            &ctx,
            Duration::from_secs_f32(seconds),
            start,
            progress,
        ),
        _ => integrator.render(&ctx, progress),
    };
    if rendered.stats.samples_per_pixel == 0 {
        rendered.stats.samples_per_pixel = integrator.samples_per_pixel(config);
    }
    let mut rays = RayCount::default();
    let note = match (config.time, &rendered.stats.pixel_samples) {
        (None, _) => integrator
            .emission_samples(config)
            .filter(|_| refines_lights)
            .and_then(|samples| emission::refine(&ctx, &mut rendered.film, samples, &mut rays)),
        (Some(budget), Some(counts)) => edges.as_ref().and_then(|edges| {
            let mean = counts.iter().map(|&n| n as f64).sum::<f64>() / counts.len().max(1) as f64;
            let left = budget as f64 - start.elapsed().as_secs_f64();
            let extra = edges.extra_after(mean, left);
            edges.refine(&ctx, &mut rendered.film, &|i| counts[i], extra, &mut rays)
        }),
        (Some(_), None) => None,
    };
    rendered.stats.notes.extend(note);
    rendered.stats.rays += rays;
    rendered.stats.elapsed = start.elapsed();
    check_finite(&rendered.film, config)?;
    Ok(rendered)
}

/// `n` things for a note: "1 pass", "2 passes".
pub(crate) fn counted(n: u64, one: &str, many: &str) -> String {
    match n {
        1 => format!("1 {one}"),
        n => format!("{n} {many}"),
    }
}

/// A time budget for a note: tenths of a second, or every digit of one
/// too short for them ("4.0", "0.05").
pub(crate) fn budget_seconds(s: f32) -> String {
    if s >= 0.1 {
        format!("{s:.1}")
    } else {
        format!("{s}")
    }
}

/// Checks, before any work, that `config` is valid ([`RenderConfig::validate`])
/// and that a render of `scene` with it fits in the memory available.
pub fn check(scene: &Scene, config: &RenderConfig) -> Result<()> {
    config.validate()?;
    // A search radius the scene's floats cannot resolve gathers nothing, or
    // divides by a disc whose area rounds to zero.
    let b = scene.bounds();
    let smallest = (b.max - b.min).length() * 1e-6;
    let p = &config.photons;
    for (name, radius) in [
        ("global_radius", p.global_radius),
        ("caustic_radius", p.caustic_radius),
        ("sppm_radius", p.sppm.initial_radius),
    ] {
        if let Some(r) = radius.filter(|&r| r < smallest) {
            return Err(Error::Setting {
                name,
                message: format!(
                    "is {r:e}, below a millionth of the scene's size ({smallest:e}): too small for 32-bit \
                     floats to resolve here"
                ),
            });
        }
    }
    crate::memory::Estimate::of(scene, config).check(crate::memory::available())
}

/// The first pixel of `film` holding NaN or infinity, as an error naming it,
/// its component and how it was rendered. None should ever get there: each
/// is a bug to report.
fn check_finite(film: &Film, config: &RenderConfig) -> Result<()> {
    use crate::film::Aov;
    for (i, sample) in film.pixels.iter().enumerate() {
        // The components before their sum, so the error names where it began.
        let mut order = Aov::ALL.iter().skip(1).chain(&Aov::ALL[..1]);
        let Some(&(name, _)) = order.find(|(_, aov)| !sample.get(*aov).is_finite()) else { continue };
        let r = config.region();
        let (x, y) = (r.x0 + i as u32 % film.width, r.y0 + i as u32 / film.width);
        return Err(Error::NonFinite {
            x,
            y,
            component: name,
            integrator: config.integrator.name(),
            seed: config.seed,
        });
    }
    Ok(())
}

/// How many units of work [`render`] reports through `progress` in all.
pub fn work_units(config: &RenderConfig) -> u64 {
    create(config.integrator).work_units(config)
}

/// Camera samples per pixel that a render with `config` takes (passes for
/// progressive photon mapping, one for the previews), for summaries.
pub fn samples_per_pixel(config: &RenderConfig) -> u32 {
    create(config.integrator).samples_per_pixel(config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notes_count_and_time_in_words_that_agree() {
        assert_eq!(counted(1, "pass", "passes"), "1 pass");
        assert_eq!(counted(0, "pass", "passes"), "0 passes");
        assert_eq!(counted(36, "round", "rounds"), "36 rounds");
        assert_eq!(budget_seconds(4.0), "4.0");
        assert_eq!(budget_seconds(0.3), "0.3");
        assert_eq!(budget_seconds(0.05), "0.05");
        assert_eq!(budget_seconds(Duration::from_secs_f32(1e-6).as_secs_f32()), "0.000001");
    }
}
