//! Run time against error: each integrator renders a scene at a doubling
//! budget, every render is timed and compared with a reference image, and
//! the points go to a CSV file and a log-log plot (error against seconds),
//! one curve per integrator. A user picks settings by reading that plot.
//!
//! The budget at level `i` (doubling with `i`):
//! - `path`: `16 * 2^i` samples per pixel;
//! - `photon`: `2^i` samples per pixel with 16 gather rays each, and the
//!   scene file's photon counts times `2^i / 2^(levels - 1)` (the top level
//!   uses the scene file's counts);
//! - `sppm`: `4 * 2^i` passes of the scene file's photons per pass, read off
//!   one progressive run (each point is timed from that run's start).
//!
//! Optionally ([`Plan`]) each render is also denoised with Open Image
//! Denoise and measured again, and the error is also measured over the
//! caustic region alone (where a reference's caustic component is a large
//! part of its light), where denoisers are known to smear.

use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

use super::plot::{log_log, Series};
use crate::accel::Intersector;
use crate::config::{IntegratorKind as Integrator, RenderConfig};
use crate::film::image::{Difference, Image};
use crate::integrator::sppm::Progressive;
use crate::integrator::{render, Context, Rendered};
use crate::scene::Scene;

/// One timed render and its error against the reference.
#[derive(Debug, Clone)]
pub struct ErrorPoint {
    /// Which integrator.
    pub integrator: Integrator,
    /// The budget level (0 is the smallest).
    pub level: u32,
    /// The settings that level means, for people.
    pub setting: String,
    /// Wall-clock seconds of the render (photon tracing included).
    pub seconds: f64,
    /// Error against the reference.
    pub error: Difference,
    /// Error over the caustic region alone, when one was given.
    pub caustic_error: Option<Difference>,
    /// Pixels that are fireflies in the image but not in the reference
    /// ([`Image::fireflies_beyond`]).
    pub fireflies: usize,
    /// The same render denoised, when asked.
    pub denoised: Option<DenoisedPoint>,
}

/// A render of an [`ErrorPoint`] after denoising.
#[derive(Debug, Clone)]
pub struct DenoisedPoint {
    /// Wall-clock seconds of the denoising alone.
    pub seconds: f64,
    /// Error against the reference.
    pub error: Difference,
    /// Error over the caustic region alone, when one was given.
    pub caustic_error: Option<Difference>,
}

/// What to measure.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The integrators, each measured at every level.
    pub integrators: Vec<Integrator>,
    /// Budgets per integrator, each double the one before (see [`budget`]).
    pub levels: u32,
    /// Also denoise every render ([`crate::film::Film::denoised`]) and measure it.
    pub denoise: bool,
    /// Also measure the error over these pixels alone (see [`caustic_region`]).
    pub caustic_region: Option<Vec<bool>>,
}

/// The pixels where caustics make at least a quarter of the light: where
/// `caustic` (a reference's caustic component, `--aov caustic`) is at
/// least 0.25 of `reference` (the same render's final image), by channel
/// mean. `None` if the sizes differ.
pub fn caustic_region(reference: &Image, caustic: &Image) -> Option<Vec<bool>> {
    if (reference.width, reference.height) != (caustic.width, caustic.height) {
        return None;
    }
    let mean = |v: glam::Vec3| v.element_sum() / 3.0;
    Some(
        reference
            .pixels
            .iter()
            .zip(&caustic.pixels)
            .map(|(r, c)| mean(*c) > 0.0 && mean(*c) >= 0.25 * mean(*r))
            .collect(),
    )
}

/// The settings `integrator` uses at budget `level` of `levels`.
pub fn budget(base: &RenderConfig, integrator: Integrator, level: u32, levels: u32) -> RenderConfig {
    let m = 1u32 << level;
    let mut s = RenderConfig { integrator, ..base.clone() };
    match integrator {
        Integrator::Path => s.samples = 16 * m,
        Integrator::Vcm | Integrator::Bdpt | Integrator::Light => s.samples = 4 * m,
        Integrator::Photon => {
            s.samples = m;
            s.photons.gather_rays = 16;
            let scale = |n: u32| ((n as u64 * m as u64) >> (levels - 1)).max(1) as u32;
            s.photons.global_photons = scale(base.photons.global_photons);
            s.photons.caustic_photons = scale(base.photons.caustic_photons);
        }
        Integrator::Sppm => s.photons.sppm.passes = 4 * m,
        Integrator::Whitted | Integrator::Normals | Integrator::Depth => {}
    }
    s
}

/// What [`budget`] means, in words.
fn describe(s: &RenderConfig) -> String {
    let p = &s.photons;
    match s.integrator {
        Integrator::Path => format!("{} spp", s.samples),
        Integrator::Vcm | Integrator::Bdpt | Integrator::Light => format!("{} passes", s.samples),
        Integrator::Photon => format!(
            "{} spp, {} gather rays each, {} global + {} caustic photons",
            s.samples, p.gather_rays, p.global_photons, p.caustic_photons
        ),
        Integrator::Sppm => format!("{} passes of {} photons", p.sppm.passes, p.sppm.photons_per_pass),
        other => format!("{other:?}"),
    }
}

/// Renders `scene` with each of the plan's integrators at its doubling
/// budgets (at the reference's size), comparing each image with
/// `reference`, and measures what else the plan asks. `report` sees every
/// point as soon as it is measured.
pub fn measure(
    scene: &Scene,
    accel: &dyn Intersector,
    base: &RenderConfig,
    reference: &Image,
    plan: &Plan,
    report: &mut dyn FnMut(&ErrorPoint),
) -> crate::Result<Vec<ErrorPoint>> {
    let levels = plan.levels;
    let base = RenderConfig { width: reference.width, height: reference.height, ..base.clone() };
    let errors = |image: &Image| {
        let whole = image.difference(reference).expect("rendered at the reference's size");
        let caustic = plan.caustic_region.as_ref().and_then(|mask| image.difference_where(reference, mask));
        (whole, caustic)
    };
    let mut points = Vec::new();
    let mut push = |integrator, level, settings: &RenderConfig, rendered: &Rendered| -> crate::Result<()> {
        let beauty = rendered.film.beauty();
        let (error, caustic_error) = errors(&beauty);
        let fireflies = beauty.fireflies_beyond(reference).expect("rendered at the reference's size");
        let denoised = if plan.denoise {
            let start = Instant::now();
            let image = rendered.film.denoised()?;
            let seconds = start.elapsed().as_secs_f64();
            let (error, caustic_error) = errors(&image);
            Some(DenoisedPoint { seconds, error, caustic_error })
        } else {
            None
        };
        let point = ErrorPoint {
            integrator,
            level,
            setting: describe(settings),
            seconds: rendered.stats.elapsed.as_secs_f64(),
            error,
            caustic_error,
            fireflies,
            denoised,
        };
        report(&point);
        points.push(point);
        Ok(())
    };
    for &integrator in &plan.integrators {
        if integrator == Integrator::Sppm {
            // One progressive run, read at each level's pass count.
            let last = budget(&base, integrator, levels - 1, levels);
            last.validate()?;
            let start = Instant::now();
            let mut run = Progressive::new(&Context::new(scene, accel, &last));
            for level in 0..levels {
                let settings = budget(&base, integrator, level, levels);
                while run.passes() < settings.photons.sppm.passes {
                    run.run_pass();
                }
                push(integrator, level, &settings, &run.rendered(start.elapsed()))?;
            }
            continue;
        }
        for level in 0..levels {
            let settings = budget(&base, integrator, level, levels);
            push(integrator, level, &settings, &render(scene, accel, &settings, &|_| {})?)?;
        }
    }
    Ok(points)
}

/// Lower-case name of an integrator, as on the command line.
pub fn name(integrator: Integrator) -> String {
    integrator.name().to_string()
}

/// The points as CSV, one row each, with a header. Columns of what was not
/// measured (caustic region, denoising) are empty.
pub fn csv(points: &[ErrorPoint]) -> String {
    let mut out = String::from(
        "integrator,level,setting,seconds,rmse,rel_mse,mae,mean_ratio,caustic_rmse,\
         denoise_seconds,denoised_rmse,denoised_caustic_rmse,fireflies\n",
    );
    let rmse = |d: Option<&Difference>| d.map_or(String::new(), |d| format!("{:.6e}", d.rmse));
    for p in points {
        let e = &p.error;
        let d = p.denoised.as_ref();
        let _ = writeln!(
            out,
            "{},{},\"{}\",{:.4},{:.6e},{:.6e},{:.6e},{:.5},{},{},{},{},{}",
            name(p.integrator),
            p.level,
            p.setting,
            p.seconds,
            e.rmse,
            e.rel_mse,
            e.mae,
            e.means.0 / e.means.1,
            rmse(p.caustic_error.as_ref()),
            d.map_or(String::new(), |d| format!("{:.4}", d.seconds)),
            rmse(d.map(|d| &d.error)),
            rmse(d.and_then(|d| d.caustic_error.as_ref())),
            p.fireflies,
        );
    }
    out
}

/// Where denoising stops paying: for each integrator measured with
/// denoising, the first level whose denoised image is no closer to the
/// reference than the noisy one, or `None` if denoising helped at every
/// level; by the RMSE that `error` picks from a point and its denoised
/// version (whole image, or caustic region: skipped where it is `None`).
pub fn denoising_stops_helping(
    points: &[ErrorPoint],
    error: impl Fn(&ErrorPoint, &DenoisedPoint) -> Option<(f64, f64)>,
) -> Vec<(Integrator, Option<u32>)> {
    let mut out: Vec<(Integrator, Option<u32>)> = Vec::new();
    for p in points {
        let Some((noisy, denoised)) = p.denoised.as_ref().and_then(|d| error(p, d)) else { continue };
        let hurts = denoised >= noisy;
        match out.iter_mut().find(|(i, _)| *i == p.integrator) {
            Some((_, first)) => {
                if hurts && first.is_none() {
                    *first = Some(p.level);
                }
            }
            None => out.push((p.integrator, hurts.then_some(p.level))),
        }
    }
    out
}

/// Draws RMSE against seconds on log-log axes, one curve per integrator, as
/// an SVG file at `path`.
pub fn plot(points: &[ErrorPoint], title: &str, path: &Path) -> crate::Result<()> {
    let mut series: Vec<Series> = Vec::new();
    let mut add = |name: String, point: (f64, f64)| match series.iter_mut().find(|s| s.name == name) {
        Some(s) => s.points.push(point),
        None => series.push(Series { name, points: vec![point] }),
    };
    for p in points {
        add(name(p.integrator), (p.seconds, p.error.rmse));
        if let Some(d) = &p.denoised {
            add(format!("{} + denoise", name(p.integrator)), (p.seconds + d.seconds, d.error.rmse));
        }
    }
    log_log(path, title, "seconds (wall clock)", "RMSE against the reference", &series)
}
