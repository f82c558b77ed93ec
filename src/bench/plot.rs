//! Log-log line plots for the benchmarks, as SVG (no fonts needed).

use std::path::Path;

use plotters::prelude::*;

/// One named curve of `(x, y)` points.
pub struct Series {
    /// The legend's name for it.
    pub name: String,
    /// Its points; those with a coordinate at or below 0 are left out.
    pub points: Vec<(f64, f64)>,
}

/// Draws `series` on log-log axes into an SVG file at `path`.
pub fn log_log(path: &Path, title: &str, x_desc: &str, y_desc: &str, series: &[Series]) -> crate::Result<()> {
    let failed = |e: &dyn std::fmt::Display| crate::Error::Image {
        path: path.to_path_buf(),
        message: format!("drawing the plot: {e}"),
    };
    let usable = |s: &Series| -> Vec<(f64, f64)> {
        s.points
            .iter()
            .copied()
            .filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
            .collect()
    };
    let all: Vec<(f64, f64)> = series.iter().flat_map(usable).collect();
    if all.is_empty() {
        return Err(failed(&"no point with positive coordinates to plot"));
    }
    let range = |values: Vec<f64>| {
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(0.0, f64::max);
        (lo / 1.5)..(hi * 1.5)
    };
    let xs = range(all.iter().map(|p| p.0).collect());
    let ys = range(all.iter().map(|p| p.1).collect());

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
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .draw()
        .map_err(|e| failed(&e))?;
    let colours = [
        RGBColor(200, 60, 40),
        RGBColor(40, 90, 200),
        RGBColor(30, 150, 70),
        RGBColor(150, 60, 170),
        RGBColor(220, 140, 20),
    ];
    for (i, s) in series.iter().enumerate() {
        let colour = colours[i % colours.len()];
        let curve = usable(s);
        chart
            .draw_series(LineSeries::new(curve.clone(), colour.stroke_width(2)))
            .map_err(|e| failed(&e))?
            .label(s.name.clone())
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
