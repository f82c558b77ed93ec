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

use crate::accel::Intersector;
use crate::render::image::{Difference, Image};
use crate::render::sppm::Progressive;
use crate::render::{render, Integrator, RenderSettings, Rendered};
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
pub fn budget(base: &RenderSettings, integrator: Integrator, level: u32, levels: u32) -> RenderSettings {
    let m = 1u32 << level;
    let mut s = RenderSettings { integrator, ..base.clone() };
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
fn describe(s: &RenderSettings) -> String {
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
    base: &RenderSettings,
    reference: &Image,
    integrators: &[Integrator],
    levels: u32,
    report: &mut dyn FnMut(&ErrorPoint),
) -> Vec<ErrorPoint> {
    let base = RenderSettings { width: reference.width, height: reference.height, ..base.clone() };
    let compare = |rendered: &Rendered| {
        let image = rendered.image("final").expect("final is a component");
        image.difference(reference).expect("rendered at the reference's size")
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
            let start = Instant::now();
            let mut run = Progressive::new(scene, accel, &last);
            for level in 0..levels {
                let settings = budget(&base, integrator, level, levels);
                while run.passes() < settings.photons.sppm.passes {
                    run.run_pass();
                }
                let seconds = start.elapsed().as_secs_f64();
                let rendered = Rendered {
                    width: base.width,
                    height: base.height,
                    pixels: run.components(),
                    stats: crate::render::RenderStats {
                        elapsed: start.elapsed(),
                        rays: 0,
                        shadow_rays: 0,
                        photons: None,
                    },
                };
                let error = compare(&rendered);
                push(ErrorPoint { integrator, level, setting: describe(&settings), seconds, error });
            }
            continue;
        }
        for level in 0..levels {
            let settings = budget(&base, integrator, level, levels);
            let rendered = render(scene, accel, &settings, &|_| {});
            let seconds = rendered.stats.elapsed.as_secs_f64();
            let error = compare(&rendered);
            push(ErrorPoint { integrator, level, setting: describe(&settings), seconds, error });
        }
    }
    points
}

/// Lower-case name of an integrator, as on the command line.
pub fn name(integrator: Integrator) -> String {
    format!("{integrator:?}").to_lowercase()
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
    use plotters::prelude::*;
    let failed = |e: &dyn std::fmt::Display| crate::Error::Image {
        path: path.to_path_buf(),
        message: format!("drawing the plot: {e}"),
    };
    let positive: Vec<&ErrorPoint> =
        points.iter().filter(|p| p.seconds > 0.0 && p.error.rmse > 0.0).collect();
    if positive.is_empty() {
        return Err(failed(&"no point with a positive time and error to plot"));
    }
    let range = |values: Vec<f64>| {
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(0.0, f64::max);
        (lo / 1.5)..(hi * 1.5)
    };
    let xs = range(positive.iter().map(|p| p.seconds).collect());
    let ys = range(positive.iter().map(|p| p.error.rmse).collect());

    let root = SVGBackend::new(path, (800, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| failed(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())
        .map_err(|e| failed(&e))?;
    chart
        .configure_mesh()
        .x_desc("seconds (wall clock)")
        .y_desc("RMSE against the reference")
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .draw()
        .map_err(|e| failed(&e))?;
    let colours =
        [RGBColor(200, 60, 40), RGBColor(40, 90, 200), RGBColor(30, 150, 70), RGBColor(150, 60, 170)];
    let mut integrators: Vec<Integrator> = Vec::new();
    for p in &positive {
        if !integrators.contains(&p.integrator) {
            integrators.push(p.integrator);
        }
    }
    for (i, &integrator) in integrators.iter().enumerate() {
        let colour = colours[i % colours.len()];
        let curve: Vec<(f64, f64)> = positive
            .iter()
            .filter(|p| p.integrator == integrator)
            .map(|p| (p.seconds, p.error.rmse))
            .collect();
        chart
            .draw_series(LineSeries::new(curve.clone(), colour.stroke_width(2)))
            .map_err(|e| failed(&e))?
            .label(name(integrator))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
        chart
            .draw_series(curve.into_iter().map(|xy| Circle::new(xy, 4, colour.filled())))
            .map_err(|e| failed(&e))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| failed(&e))?;
    root.present().map_err(|e| failed(&e))?;
    Ok(())
}

/// A tick label with at most three significant digits: `0.6`, `0.05`, `12.5`.
fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let text = format!("{v:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(short(0.6000000000000001), "0.6");
        assert_eq!(short(0.05), "0.05");
        assert_eq!(short(0.123456), "0.123");
        assert_eq!(short(12.5), "12.5");
        assert_eq!(short(1000.0), "1000");
        assert_eq!(short(2.0), "2");
    }
}
