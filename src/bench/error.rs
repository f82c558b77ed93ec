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
}

/// The settings `integrator` uses at budget `level` of `levels`.
pub fn budget(base: &RenderConfig, integrator: Integrator, level: u32, levels: u32) -> RenderConfig {
    let m = 1u32 << level;
    let mut s = RenderConfig { integrator, ..base.clone() };
    match integrator {
        Integrator::Path => s.samples = 16 * m,
        Integrator::Photon => {
            s.samples = m;
            s.photons.gather_rays = 16 * m;
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
        Integrator::Photon => format!(
            "{} spp, {} gather rays, {} global + {} caustic photons",
            s.samples, p.gather_rays, p.global_photons, p.caustic_photons
        ),
        Integrator::Sppm => format!("{} passes of {} photons", p.sppm.passes, p.sppm.photons_per_pass),
        other => format!("{other:?}"),
    }
}

/// Renders `scene` with each of `integrators` at `levels` doubling budgets
/// (at the reference's size), comparing each image with `reference`.
/// `report` sees every point as soon as it is measured.
pub fn measure(
    scene: &Scene,
    accel: &dyn Intersector,
    base: &RenderConfig,
    reference: &Image,
    integrators: &[Integrator],
    levels: u32,
    report: &mut dyn FnMut(&ErrorPoint),
) -> crate::Result<Vec<ErrorPoint>> {
    let base = RenderConfig { width: reference.width, height: reference.height, ..base.clone() };
    let compare = |rendered: &Rendered| {
        rendered.film.beauty().difference(reference).expect("rendered at the reference's size")
    };
    let mut points = Vec::new();
    let mut push = |point: ErrorPoint| {
        report(&point);
        points.push(point);
    };
    for &integrator in integrators {
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
                let rendered = run.rendered(start.elapsed());
                let seconds = rendered.stats.elapsed.as_secs_f64();
                let error = compare(&rendered);
                push(ErrorPoint { integrator, level, setting: describe(&settings), seconds, error });
            }
            continue;
        }
        for level in 0..levels {
            let settings = budget(&base, integrator, level, levels);
            let rendered = render(scene, accel, &settings, &|_| {})?;
            let seconds = rendered.stats.elapsed.as_secs_f64();
            let error = compare(&rendered);
            push(ErrorPoint { integrator, level, setting: describe(&settings), seconds, error });
        }
    }
    Ok(points)
}

/// Lower-case name of an integrator, as on the command line.
pub fn name(integrator: Integrator) -> String {
    integrator.name().to_string()
}

/// The points as CSV, one row each, with a header.
pub fn csv(points: &[ErrorPoint]) -> String {
    let mut out = String::from("integrator,level,setting,seconds,rmse,rel_mse,mae,mean_ratio\n");
    for p in points {
        let e = &p.error;
        let _ = writeln!(
            out,
            "{},{},\"{}\",{:.4},{:.6e},{:.6e},{:.6e},{:.5}",
            name(p.integrator),
            p.level,
            p.setting,
            p.seconds,
            e.rmse,
            e.rel_mse,
            e.mae,
            e.means.0 / e.means.1
        );
    }
    out
}

/// Draws RMSE against seconds on log-log axes, one curve per integrator, as
/// an SVG file at `path`.
pub fn plot(points: &[ErrorPoint], title: &str, path: &Path) -> crate::Result<()> {
    let mut series: Vec<Series> = Vec::new();
    for p in points {
        let name = name(p.integrator);
        let point = (p.seconds, p.error.rmse);
        match series.iter_mut().find(|s| s.name == name) {
            Some(s) => s.points.push(point),
            None => series.push(Series { name, points: vec![point] }),
        }
    }
    log_log(path, title, "seconds (wall clock)", "RMSE against the reference", &series)
}
