//! How much of a gathering disc lies on its own surface.
//!
//! A density estimate divides the photons' power found in a disc of radius
//! `r` around a point by the disc's area, `pi r^2`. Where the surface ends
//! within `r` (a wall meeting another in a room's corner, a floor meeting a
//! wall) only part of the disc can hold photons of this surface: the rest
//! lies beyond the corner, where photons land on the other surface and are
//! (rightly) not counted. Dividing by the whole disc then darkens every
//! point within `r` of a corner: on the Cornell box SPPM's indirect light
//! in the pixels astride a corner line was a tenth to a fifth short at any
//! budget, the pixels 7-8% too dark (BENCHMARKS.md, "Corners").
//!
//! The other surface shows itself by the photons it holds inside the
//! search: each such photon lies on that surface and carries its normal,
//! which gives the surface's tangent plane there. Taken as flat across the
//! disc, that plane cuts the disc along a line; the part beyond the line
//! (on the far side of the plane from the point) is off this surface. Up to
//! two such planes are kept (a room's corner where three walls meet cuts a
//! disc twice), and their cuts are taken as independent, which is exact for
//! perpendicular planes through the centre (a quarter of the disc left) and
//! close elsewhere.
//!
//! Where the other surface holds no photon near the corner (it is dark, or
//! mirror or glass) the disc is taken as whole, as before.

use glam::Vec3;

use super::map::Photon;

/// A plane's normal must lean at least this far from the point's own
/// normal (the sine of the angle between them) to cut the disc: a plane
/// nearly parallel to the point's surface would cut it, if at all, far
/// away and by rounding.
const LEAST_SINE: f32 = 0.1;

/// Normals at least this close (their dot product) face the same way: as
/// [`lands_near`](super::map::lands_near) counts photons.
pub(crate) const SAME_WAY: f32 = 0.9;

/// Planes kept at most: enough for the corner of three walls.
const PLANES: usize = 2;

/// The share of a gathering disc that lies on its surface, from the
/// planes of the other surfaces that photons found in the search lie on.
#[derive(Debug, Clone, Copy)]
pub struct DiscShare {
    centre: Vec3,
    normal: Vec3,
    radius: f32,
    /// Each cutting plane: a point on it, its unit normal, and the share
    /// of the disc its cut leaves.
    planes: [Plane; PLANES],
    len: usize,
    /// The cone filter's `k_c`, if the estimate weighs its photons by one.
    cone: Option<f32>,
}

#[derive(Debug, Clone, Copy)]
struct Plane {
    at: Vec3,
    normal: Vec3,
    left: f32,
}

impl DiscShare {
    /// The disc of `radius` around `centre` on a surface whose unit normal
    /// there is `normal`, whole until photons of other surfaces are offered.
    pub fn new(centre: Vec3, normal: Vec3, radius: f32) -> DiscShare {
        let whole = Plane { at: centre, normal, left: 1.0 };
        DiscShare { centre, normal, radius, planes: [whole; PLANES], len: 0, cone: None }
    }

    /// The same disc for an estimate that weighs each photon by Jensen's
    /// cone filter, `1 - distance / (k_c r)`: its shares are of the
    /// filter's weight rather than of the area (a cut near the rim takes
    /// off less).
    pub fn with_cone_filter(self, cone: Option<f32>) -> DiscShare {
        DiscShare { cone, ..self }
    }

    /// Takes in a photon found in the search but not counted, which landed
    /// at `at` on a surface with unit normal `surface_normal` there: if
    /// that surface faces another way than the disc's (as
    /// [`lands_near`](super::map::lands_near) tells them apart), its plane
    /// may cut the disc. The first photon of each plane (planes whose
    /// normals differ by more than about 25 degrees) decides where that
    /// plane is.
    pub fn offer(&mut self, at: Vec3, surface_normal: Vec3) {
        // (A NaN radius is not positive either.)
        let radius_positive = self.radius > 0.0;
        if self.len == PLANES || !radius_positive || surface_normal.dot(self.normal) >= SAME_WAY {
            return;
        }
        if self.planes[..self.len].iter().any(|plane| plane.normal.dot(surface_normal) >= SAME_WAY) {
            return;
        }
        // The plane's normal within the disc's plane: the direction across
        // the line where the planes meet.
        let across = surface_normal - surface_normal.dot(self.normal) * self.normal;
        let sine = across.length();
        // (False for a NaN normal.)
        let leans = sine >= LEAST_SINE;
        if !leans {
            return;
        }
        // The line lies `d` from the centre within the disc's plane.
        let d = (self.centre - at).dot(surface_normal).abs() / sine;
        let left = 1.0 - segment_share(d / self.radius, self.cone);
        if left < 1.0 {
            self.planes[self.len] = Plane { at, normal: surface_normal, left };
            self.len += 1;
        }
    }

    /// The share of the disc on its surface, in (0, 1], among the photons
    /// the search `found`: those counted on the surface are the ones that
    /// light it ([`Photon::lights_surface`] at the disc's centre, normal
    /// and radius), looked at only when a plane cuts the disc.
    pub fn share_among<'a>(self, found: impl IntoIterator<Item = &'a Photon>) -> f32 {
        let (centre, normal, radius) = (self.centre, self.normal, self.radius);
        let counted = found.into_iter().filter(move |photon| photon.lights_surface(centre, normal, radius));
        self.share(counted.map(|photon| photon.position))
    }

    /// The share of the disc on its surface, given where the photons
    /// counted on it lie: a plane that one of them lies beyond (by more
    /// than rounding) does not bound the surface, which goes on past the
    /// line (a curved surface, whose normal turns within the disc, or
    /// another object's face near it). 1 when no plane cuts the disc.
    fn share(mut self, counted: impl IntoIterator<Item = Vec3>) -> f32 {
        if self.planes[..self.len].iter().any(|plane| plane.left < 1.0) {
            for at in counted {
                self.counted(at);
            }
        }
        // A cut never takes more than half (the centre lies on the plane's
        // near side), so two leave at least a quarter.
        self.planes[..self.len].iter().map(|plane| plane.left).product()
    }

    fn counted(&mut self, at: Vec3) {
        let tolerance = 1e-3 * self.radius;
        // Where it lies across the disc: a curved surface falls away below
        // the disc's plane, behind every plane that touches it elsewhere.
        let across = at - (at - self.centre).dot(self.normal) * self.normal;
        for plane in &mut self.planes[..self.len] {
            let side = (self.centre - plane.at).dot(plane.normal).signum();
            if side * (across - plane.at).dot(plane.normal) < -tolerance {
                plane.left = 1.0;
            }
        }
    }
}

/// The share of a unit disc beyond a line at distance `u` (at least 0)
/// from its centre: the circular segment's area over `pi`, or with a cone
/// filter `k_c`, the filter's weight `1 - rho / k_c` over the segment
/// against its weight over the disc, `pi (1 - 2 / (3 k_c))`.
fn segment_share(u: f32, cone: Option<f32>) -> f32 {
    if u >= 1.0 {
        return 0.0;
    }
    let u = u.max(0.0);
    let (angle, half_chord) = (u.acos(), (1.0 - u * u).sqrt());
    let area = angle - u * half_chord;
    let share = match cone {
        None => area / std::f32::consts::PI,
        Some(kc) => {
            // The integral of rho over the segment, in polar coordinates
            // (rho from u / cos(phi) to 1): (2 angle - u half_chord
            // - u^3 ln((1 + half_chord) / u)) / 3; the last term tends to
            // 0 with u.
            let log_term = if u > 0.0 { u * u * u * ((1.0 + half_chord) / u).ln() } else { 0.0 };
            let rho = (2.0 * angle - u * half_chord - log_term) / 3.0;
            (area - rho / kc) / (std::f32::consts::PI * (1.0 - 2.0 / (3.0 * kc)))
        }
    };
    share.clamp(0.0, 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// The share of points of the disc on the near side of every plane, by
    /// Monte Carlo: planes as (point, unit normal).
    fn sampled_share(centre: Vec3, normal: Vec3, radius: f32, planes: &[(Vec3, Vec3)]) -> f32 {
        let (t, b) = normal.any_orthonormal_pair();
        let mut rng = Rng::new(9, 1);
        let n = 200_000;
        let inside = (0..n)
            .filter(|_| {
                let (x, y) = (2.0 * rng.uniform() - 1.0, 2.0 * rng.uniform() - 1.0);
                if x * x + y * y > 1.0 {
                    return false;
                }
                let p = centre + radius * (x * t + y * b);
                planes.iter().all(|&(q, m)| (p - q).dot(m).signum() == (centre - q).dot(m).signum())
            })
            .count();
        let in_disc = std::f32::consts::PI / 4.0;
        inside as f32 / n as f32 / in_disc
    }

    #[test]
    fn a_cut_takes_off_the_cone_filters_weight_beyond_it() {
        // Monte Carlo over the unit disc, each point weighed by the filter.
        let kc = 1.1;
        let mut rng = Rng::new(4, 2);
        let points: Vec<(f32, f32)> = (0..400_000)
            .map(|_| (2.0 * rng.uniform() - 1.0, 2.0 * rng.uniform() - 1.0))
            .filter(|(x, y)| x * x + y * y <= 1.0)
            .collect();
        let weight = |(x, y): (f32, f32)| 1.0 - (x * x + y * y).sqrt() / kc;
        let total: f32 = points.iter().map(|&p| weight(p)).sum();
        for u in [0.0, 0.1, 0.3, 0.5, 0.8, 0.95] {
            let beyond: f32 = points.iter().filter(|p| p.0 > u).map(|&p| weight(p)).sum();
            let share = segment_share(u, Some(kc));
            assert!((share - beyond / total).abs() < 0.004, "u {u}: {share} against {}", beyond / total);
            // Less than the area beyond, but for the half through the centre.
            assert!(share <= segment_share(u, None) + 1e-6);
        }
        assert!((segment_share(0.0, Some(kc)) - 0.5).abs() < 1e-5);
        assert_eq!(segment_share(1.0, Some(kc)), 0.0);
    }

    #[test]
    fn a_disc_no_photon_of_another_surface_reaches_is_whole() {
        let share = DiscShare::new(Vec3::ZERO, Vec3::Y, 0.1);
        assert_eq!(share.share([]), 1.0);
    }

    #[test]
    fn a_wall_cuts_a_floor_disc_as_the_segment_beyond_it() {
        // A floor (normal +y) meets a wall at x = 1 (normal -x, facing the room).
        for d in [0.0, 0.02, 0.05, 0.08, 0.099, 0.15] {
            let centre = Vec3::new(1.0 - d, 0.0, 0.3);
            let mut share = DiscShare::new(centre, Vec3::Y, 0.1);
            share.offer(Vec3::new(1.0, 0.07, 0.33), Vec3::NEG_X);
            let expected = sampled_share(centre, Vec3::Y, 0.1, &[(Vec3::X, Vec3::NEG_X)]);
            assert!(
                (share.share([]) - expected).abs() < 0.01,
                "d {d}: {} against {expected}",
                share.share([])
            );
        }
        // Right at the wall, half the disc is left.
        let mut share = DiscShare::new(Vec3::new(1.0, 0.0, 0.0), Vec3::Y, 0.1);
        share.offer(Vec3::new(1.0, 0.05, 0.0), Vec3::NEG_X);
        assert!((share.share([]) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn a_slanted_plane_and_a_convex_edge_cut_as_sampled() {
        let centre = Vec3::new(0.2, 0.0, -0.1);
        let radius = 0.3;
        // A plane through (0.4, 0, 0) leaning 30 degrees from the vertical,
        // facing the centre; then the same plane facing away (the centre
        // behind it, as on a box's top beside its front face).
        for flip in [1.0, -1.0] {
            let m = flip * Vec3::new(-(60f32.to_radians().sin()), 60f32.to_radians().cos(), 0.0);
            let q = Vec3::new(0.4, 0.0, 0.0);
            let mut share = DiscShare::new(centre, Vec3::Y, radius);
            share.offer(q + Vec3::new(0.0, 0.0, 0.2), m);
            let expected = sampled_share(centre, Vec3::Y, radius, &[(q, m)]);
            assert!((share.share([]) - expected).abs() < 0.01, "{} against {expected}", share.share([]));
        }
    }

    #[test]
    fn a_corner_of_three_walls_leaves_a_quarter_and_more_photons_change_nothing() {
        // Floor disc at the corner where walls x = 0 and z = 0 meet it.
        let mut share = DiscShare::new(Vec3::ZERO, Vec3::Y, 0.1);
        share.offer(Vec3::new(0.0, 0.02, 0.05), Vec3::X);
        share.offer(Vec3::new(0.0, 0.01, 0.07), Vec3::X);
        share.offer(Vec3::new(0.03, 0.04, 0.0), Vec3::Z);
        share.offer(Vec3::new(0.0, 0.02, 0.01), Vec3::new(1.0, 0.0, 1.0).normalize());
        assert!((share.share([]) - 0.25).abs() < 1e-6, "{}", share.share([]));
        // Off the corner, against sampling (perpendicular cuts are independent).
        let centre = Vec3::new(0.03, 0.0, 0.06);
        let mut share = DiscShare::new(centre, Vec3::Y, 0.1);
        share.offer(Vec3::new(0.0, 0.02, 0.05), Vec3::X);
        share.offer(Vec3::new(0.03, 0.04, 0.0), Vec3::Z);
        let expected = sampled_share(centre, Vec3::Y, 0.1, &[(Vec3::ZERO, Vec3::X), (Vec3::ZERO, Vec3::Z)]);
        assert!((share.share([]) - expected).abs() < 0.01, "{} against {expected}", share.share([]));
    }

    #[test]
    fn a_curved_surface_whose_photons_go_on_past_the_line_is_not_cut() {
        // The top of a unit sphere, a disc of radius 0.5: a photon 30 degrees
        // round faces another way and would cut it at tan(15 deg) = 0.27, but
        // one 20 degrees round (0.34 across) is on the disc's own surface.
        let around = |degrees: f32| {
            let (sin, cos) = degrees.to_radians().sin_cos();
            Vec3::new(sin, cos, 0.0)
        };
        let mut share = DiscShare::new(Vec3::Y, Vec3::Y, 0.5);
        share.offer(around(30.0), around(30.0));
        let near_side = [around(-20.0), Vec3::new(0.0, 0.99, 0.1)];
        assert!(share.share(near_side) < 0.9, "photons on the near side leave the cut");
        assert_eq!(share.share([around(-20.0), around(20.0)]), 1.0);
    }

    #[test]
    fn parallel_surfaces_and_far_planes_do_not_cut() {
        let mut share = DiscShare::new(Vec3::ZERO, Vec3::Y, 0.1);
        // The floor's underside, and a ceiling's photon facing down.
        share.offer(Vec3::new(0.01, -0.001, 0.0), Vec3::NEG_Y);
        // A wall beyond the radius.
        share.offer(Vec3::new(0.2, 0.05, 0.0), Vec3::NEG_X);
        assert_eq!(share.share([]), 1.0);
        // A disc of no radius is whole.
        let mut share = DiscShare::new(Vec3::ZERO, Vec3::Y, 0.0);
        share.offer(Vec3::new(0.0, 0.0, 0.0), Vec3::NEG_X);
        assert_eq!(share.share([]), 1.0);
    }
}
