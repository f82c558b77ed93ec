//! Final-gathering directions guided by the photon map (Jensen 1995,
//! "Importance driven path tracing using the photon map").
//!
//! The photons that landed near a gathering point after a diffuse bounce
//! show where its indirect light comes from: a bright patch of ceiling just
//! above a point light sends many. Their power, binned by incoming direction
//! over the hemisphere, makes a piecewise-constant density for the gather
//! rays. It is mixed with the cosine density, so that directions no photon
//! came from are still sampled: the estimate stays unbiased, and no gather
//! ray weighs more than `pi / UNIFORM_SHARE` (twice cosine sampling's `pi`),
//! so the guide cannot make fireflies of its own.
//!
//! The grid (8 x 8) and the cosine share (a half) were measured on the
//! Cornell box under a point light and under its area light, and on the
//! teapot (BENCHMARKS.md, "Guided final gathering"): coarser grids and a
//! smaller share helped the point light less, finer ones and a larger share
//! cost more on the area light, whose indirect light is smooth.
//!
//! The cells split the unit square that Malley's method lifts to the
//! cosine-weighted hemisphere (rows: the squared sine of the angle to the
//! normal; columns: the azimuth). Each cell holds the same share of `cos`
//! over solid angle, so a cell chosen with probability `p` has density
//! `cos / pi * CELLS * p` at its directions.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use crate::sampling::cosine_hemisphere;

/// Cells along the squared sine of the angle to the normal.
const ROWS: usize = 8;
/// Cells around the normal: the eight octants of the azimuth (see [`octant`]).
const COLUMNS: usize = 8;
/// Cells in all: the probabilities a saved map stores per guide.
pub const CELLS: usize = ROWS * COLUMNS;
/// The share of gather rays drawn from the cosine density whatever the photons say.
const UNIFORM_SHARE: f32 = 0.5;

/// A density over the hemisphere about +z (the shading normal) for gather rays.
#[derive(Debug, Clone, PartialEq)]
pub struct GatherGuide {
    /// Each cell's probability, row by row (all positive, summing to 1).
    cells: [f32; CELLS],
    /// Each row's probability (the sum of its cells).
    rows: [f32; ROWS],
}

impl GatherGuide {
    /// The guide from photons' incoming directions (unit, in the frame whose
    /// +z is the normal) and weights (their power); `None` when no photon
    /// with positive weight arrives from above: cosine sampling then.
    pub fn new(photons: impl IntoIterator<Item = (Vec3, f32)>) -> Option<GatherGuide> {
        let mut bins = GuideBins::default();
        for (dir, weight) in photons {
            bins.add(dir, weight);
        }
        bins.guide()
    }

    /// The guide with these cell probabilities (as [`GatherGuide::cells`]
    /// gives them), if they are one: each at least the cosine share, summing to 1.
    pub fn from_cells(cells: [f32; CELLS]) -> Option<GatherGuide> {
        let least = 0.999 * UNIFORM_SHARE / CELLS as f32;
        let valid =
            cells.iter().all(|&p| p >= least && p <= 1.0) && (cells.iter().sum::<f32>() - 1.0).abs() < 1e-3;
        valid.then(|| GatherGuide::with_cells(cells))
    }

    fn with_cells(cells: [f32; CELLS]) -> GatherGuide {
        let mut rows = [0.0; ROWS];
        for (row, sum) in rows.iter_mut().enumerate() {
            *sum = cells[row * COLUMNS..][..COLUMNS].iter().sum();
        }
        GatherGuide { cells, rows }
    }

    /// Each cell's probability, row by row.
    pub fn cells(&self) -> &[f32; CELLS] {
        &self.cells
    }

    /// A direction (about +z) from a uniform point `u` of the unit square,
    /// and `cos / pdf` there: the factor that turns `f * L` into the
    /// estimate of `f * L * cos` over the hemisphere (`pi` for cosine sampling).
    /// Stratified points stay stratified: `u` is mapped continuously within
    /// each cell.
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (row, ux) = pick(&self.rows, u.x);
        let (column, uy) = pick(&self.cells[row * COLUMNS..][..COLUMNS], u.y);
        let square = Vec2::new((row as f32 + ux) / ROWS as f32, (column as f32 + uy) / COLUMNS as f32);
        (cosine_hemisphere(square), self.cos_over_pdf_in(row * COLUMNS + column))
    }

    /// `cos / pdf` of [`GatherGuide::sample`] at the unit direction `dir` above the surface.
    pub fn cos_over_pdf(&self, dir: Vec3) -> f32 {
        self.cos_over_pdf_in(cell_of(dir))
    }

    fn cos_over_pdf_in(&self, cell: usize) -> f32 {
        PI / (CELLS as f32 * self.cells[cell])
    }
}

/// Photons' power binned by the cell of their incoming direction: a
/// [`GatherGuide`] in the making, for a caller that adds photons in its own
/// loop. (The irradiance records handed [`GatherGuide::new`] their photons
/// through a chain of iterator adaptors, which the compiler left as a call
/// per photon; in a plain loop they took a tenth less time, BENCHMARKS.md.)
#[derive(Debug, Clone)]
pub struct GuideBins {
    power: [f32; CELLS],
}

impl Default for GuideBins {
    fn default() -> GuideBins {
        GuideBins { power: [0.0; CELLS] }
    }
}

impl GuideBins {
    /// Adds a photon's weight (its power) at its incoming direction (unit,
    /// in the frame whose +z is the normal); one from below, or whose
    /// weight is not positive and finite, adds nothing.
    #[inline]
    pub fn add(&mut self, dir: Vec3, weight: f32) {
        if dir.z > 0.0 && weight > 0.0 && weight.is_finite() {
            self.power[cell_of(dir)] += weight;
        }
    }

    /// The guide of the photons added; `None` when none counted.
    pub fn guide(&self) -> Option<GatherGuide> {
        let total: f32 = self.power.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let cells = self.power.map(|p| (1.0 - UNIFORM_SHARE) * p / total + UNIFORM_SHARE / CELLS as f32);
        Some(GatherGuide::with_cells(cells))
    }
}

/// The cell of a unit direction above the surface.
fn cell_of(dir: Vec3) -> usize {
    let sin2 = (dir.x * dir.x + dir.y * dir.y).clamp(0.0, 1.0);
    // (Through `u32`, whose conversion is one instruction; the value, in
    // [0, ROWS] or NaN, converts the same.)
    let row = ((sin2 * ROWS as f32) as u32 as usize).min(ROWS - 1);
    row * COLUMNS + octant(dir.x, dir.y)
}

/// Which eighth of the turn about +z the azimuth of `(x, y)` lies in,
/// counting from +x towards +y: `floor(8 * azimuth / 2 pi)` with the azimuth
/// in [0, 2 pi), decided by turning the point into the first quadrant and
/// one comparison (an arctangent per photon was a tenth of the irradiance
/// precomputation; branching on the quadrant mispredicted on every other
/// photon). On a border either side may be chosen; the guide only bins
/// photons with it.
fn octant(x: f32, y: f32) -> usize {
    // Half a turn brings the lower half onto the upper one...
    let lower = y < 0.0;
    let (x, y) = if lower { (-x, -y) } else { (x, y) };
    // ... and a quarter turn back the upper left quadrant onto the upper right.
    let left = x <= 0.0;
    let (x, y) = if left { (y, -x) } else { (x, y) };
    4 * usize::from(lower) + 2 * usize::from(left) + usize::from(y >= x)
}

/// The entry a uniform `u` picks from positive `weights` in proportion to
/// them, and where `u` fell within it, rescaled to [0, 1).
fn pick(weights: &[f32], u: f32) -> (usize, f32) {
    let total: f32 = weights.iter().sum();
    let mut left = u * total;
    for (i, &w) in weights.iter().enumerate() {
        if left < w || i == weights.len() - 1 {
            return (i, (left / w).clamp(0.0, 1.0 - f32::EPSILON / 2.0));
        }
        left -= w;
    }
    unreachable!("weights is never empty")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{stratified, Rng};

    /// Photons from one direction (and a few from elsewhere).
    fn peaked() -> GatherGuide {
        let mut rng = Rng::new(5, 5);
        let main = Vec3::new(0.6, -0.3, 0.5).normalize();
        let photons =
            (0..200).map(
                |i| {
                    if i % 10 == 0 {
                        (cosine_hemisphere(rng.uniform2()), 1.0)
                    } else {
                        (main, 1.0)
                    }
                },
            );
        GatherGuide::new(photons).expect("photons from above")
    }

    #[test]
    fn estimates_integrals_over_the_hemisphere_without_bias() {
        // The integral of g(w) cos over the hemisphere is estimated by
        // g(w) * cos_over_pdf at sampled w: for g = 1 it is pi; for g = z,
        // 2 pi / 3; for g = 1 within 60 degrees of a tilted axis, whatever
        // cosine sampling gives with many samples.
        let guide = peaked();
        let axis = Vec3::new(-0.5, 0.2, 0.8).normalize();
        let (n, mut rng) = (1 << 16, Rng::new(9, 1));
        let (mut one, mut z, mut lobe, mut lobe_cos) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for i in 0..n {
            let u = stratified(i, n, &mut rng);
            let (dir, w) = guide.sample(u);
            one += w as f64;
            z += (dir.z * w) as f64;
            lobe += if dir.dot(axis) > 0.5 { w as f64 } else { 0.0 };
            let c = cosine_hemisphere(u);
            lobe_cos += if c.dot(axis) > 0.5 { PI as f64 } else { 0.0 };
        }
        let n = n as f64;
        assert!((one / n - PI as f64).abs() < 0.01, "{}", one / n);
        assert!((z / n - 2.0 * PI as f64 / 3.0).abs() < 0.01, "{}", z / n);
        assert!((lobe / n - lobe_cos / n).abs() < 0.01 * lobe_cos / n, "{} vs {}", lobe / n, lobe_cos / n);
    }

    #[test]
    fn sends_most_rays_where_the_photons_came_from() {
        let guide = peaked();
        let main = Vec3::new(0.6, -0.3, 0.5).normalize();
        let mut rng = Rng::new(3, 4);
        let n = 4096;
        let towards =
            (0..n).filter(|&i| cell_of(guide.sample(stratified(i, n, &mut rng)).0) == cell_of(main)).count();
        // 90% of the photons' power, less the cosine share.
        let expected = (1.0 - UNIFORM_SHARE) * 0.9 + UNIFORM_SHARE / CELLS as f32;
        assert!(towards as f32 > 0.95 * expected * n as f32, "{towards} of {n}, expected {expected}");
        assert!((guide.cos_over_pdf(main) - PI / (CELLS as f32 * guide.cells[cell_of(main)])).abs() < 1e-6);
        // No direction weighs more than pi over the uniform share.
        assert!(guide.cells.iter().all(|&p| PI / (CELLS as f32 * p) <= PI / UNIFORM_SHARE * 1.0001));
    }

    #[test]
    fn the_weight_returned_is_the_density_at_the_direction() {
        let guide = peaked();
        let mut rng = Rng::new(7, 7);
        let mut agree = 0;
        for _ in 0..1000 {
            let (dir, w) = guide.sample(rng.uniform2());
            assert!((dir.length() - 1.0).abs() < 1e-5 && dir.z >= 0.0, "{dir}");
            // A direction may round across a cell's border; almost none do.
            agree += usize::from(w == guide.cos_over_pdf(dir));
        }
        assert!(agree >= 990, "{agree} of 1000");
    }

    #[test]
    fn octants_follow_the_azimuth() {
        for i in 0..3600 {
            let azimuth = (i as f32 + 0.5) / 3600.0 * std::f32::consts::TAU;
            let (x, y) = (azimuth.cos(), azimuth.sin());
            assert_eq!(octant(x, y), (azimuth / std::f32::consts::FRAC_PI_4) as usize, "at {azimuth}");
            // Any length.
            assert_eq!(octant(3.0 * x, 3.0 * y), octant(x, y));
        }
        assert_eq!(octant(1.0, 0.0), 0);
    }

    #[test]
    fn no_photons_from_above_means_no_guide() {
        assert!(GatherGuide::new([]).is_none());
        assert!(GatherGuide::new([(Vec3::NEG_Z, 1.0), (Vec3::Z, 0.0), (Vec3::Z, f32::NAN)]).is_none());
        let even = GatherGuide::new([(Vec3::Z, 1.0)]).unwrap();
        assert!(even.cells.iter().all(|&p| p > 0.0));
        assert!((even.cells.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn cells_make_the_same_guide_and_only_valid_ones_do() {
        let guide = peaked();
        assert_eq!(GatherGuide::from_cells(*guide.cells()), Some(guide.clone()));
        let mut zero = *guide.cells();
        zero[3] = 0.0;
        assert!(GatherGuide::from_cells(zero).is_none());
        let mut nan = *guide.cells();
        nan[0] = f32::NAN;
        assert!(GatherGuide::from_cells(nan).is_none());
        assert!(GatherGuide::from_cells(guide.cells().map(|p| 2.0 * p)).is_none());
    }
}
