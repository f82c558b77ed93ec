//! Light sources, in physical units: power in watts per RGB channel.
//!
//! For shading, a light is sampled from a point: [`Light::sample_incident`]
//! picks a point on the light and says what irradiance it delivers (on a
//! surface facing it), which the integrator multiplies by the BRDF and the
//! cosine at the receiver after a shadow ray.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use crate::accel::Ray;
use crate::bounds::Bounds;
use crate::numeric;
use crate::sampling::{around, cosine_hemisphere, uniform_cone, uniform_sphere};

/// One sample of the light arriving at a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// The sampled point on the light (the shadow ray's target).
    pub position: Vec3,
    /// Irradiance at the receiver from this sample, on a surface facing the
    /// light (W/m^2 per channel), already divided by the sample's probability.
    pub irradiance: Vec3,
}

/// How likely the sampling routines are to make one light vertex, for
/// bidirectional methods ([`Light::emission_pdfs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmissionPdfs {
    /// Density per unit area with which [`Light::sample_incident`] picks the
    /// point (1 for point and spot lights, whose point is certain).
    pub direct_area: f32,
    /// Density of [`Light::emit`] leaving from the point along the
    /// direction: per unit area times per unit solid angle (per solid angle
    /// alone for point and spot lights). 0 where nothing is emitted.
    pub emit: f32,
    /// Cosine between the direction and the light's normal (1 for point
    /// and spot lights); 0 behind an area light.
    pub cos: f32,
}

/// What an area light's shading asks of its shape at every ray and sample,
/// worked out once when the light is made: its normal and area (in `f64`,
/// exact at any size: two square roots and a division a call otherwise),
/// its edges' dot products, and the radiance it leaves with. Made only
/// by [`Light::area`], from the edges and power it is given; a light whose
/// edges or power are changed in place keeps the old numbers, so make a
/// new one with [`Light::area`] instead.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaFace {
    /// Unit normal on the emitting side (`u x v`).
    normal: Vec3,
    /// Area, `|u x v|`.
    area: f64,
    /// `|u|^2` and `|v|^2`.
    length2: (f64, f64),
    /// `u . v`: zero for a rectangle, else the edges' skew.
    skew: f64,
    /// Radiance leaving the front: `power / (pi area)`.
    radiance: Vec3,
    /// A little over the squared distance from the centre to the farthest
    /// corner (and [`AreaFace::margin`] beyond), for [`Light::crossing`] to
    /// pass over most points of the light's plane outside it without the
    /// exact test.
    reach2: f64,
    /// Bound on each coordinate's rounding error of a point on the light
    /// (`center + a u + b v` in `f32`, with a margin).
    rounding: Vec3,
    /// The whole parallelogram, or the half of it towards `center - u/2 - v/2`.
    shape: Shape,
    /// How far beyond its edges, in units of `u` and of `v`, a ray still
    /// crosses the panel: [`AreaFace::rounding`]'s length, so that a ray
    /// through the edge two panels share (a lamp's triangles, whose corners
    /// each makes again from its centre and edges) crosses one of them. A
    /// sliver's (a corner sharper than [`SHARPEST`]) is less, or its sharp
    /// corners would reach out by the rounding over the sine of their angle.
    margin: (f64, f64),
}

impl AreaFace {
    /// The squared distance from the centre to the farthest corner (of
    /// the parallelogram: a triangle's corners are three of its four).
    fn half_diagonal2(&self) -> f64 {
        0.25 * (self.length2.0 + self.length2.1 + 2.0 * self.skew.abs())
    }

    /// Whether the point `center + a u + b v` lies on the panel, or within
    /// its margin of it.
    fn holds(&self, a: f64, b: f64) -> bool {
        let (ma, mb) = self.margin;
        a.abs() <= 0.5 + ma && b.abs() <= 0.5 + mb && (self.shape == Shape::Parallelogram || a + b <= ma + mb)
    }
}

/// The sine of the sharpest corner whose panel reaches over its edges by
/// its rounding ([`AreaFace::margin`]); sharper ones' corners then reach
/// out by at most its inverse times the rounding along each edge
/// ([`Light::margin_reach`]).
const SHARPEST: f64 = 1.0 / 16.0;

/// The shape of an area light's panel, over its centre and edges `u` and `v`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// Corners at `center +- u/2 +- v/2`.
    Parallelogram,
    /// Corners at `c = center - u/2 - v/2`, `c + u` and `c + v`: the half
    /// of the parallelogram on that side of its diagonal (so `center` is
    /// the midpoint of the edge opposite `c`). Mesh files' emitting faces
    /// that pair into no parallelogram (a curved lamp's) are these.
    Triangle,
}

impl Shape {
    /// How many triangles the panel is: 2 for a parallelogram, 1 for a
    /// triangle (its area is this half of `|u x v|`).
    pub fn triangles(self) -> usize {
        match self {
            Shape::Parallelogram => 2,
            Shape::Triangle => 1,
        }
    }

    /// The panel's area from `|u x v|`, its parallelogram's.
    pub fn area(self, whole: f64) -> f64 {
        0.5 * self.triangles() as f64 * whole
    }
}

/// The point of a panel of `shape` that the uniform pair `s` picks, as
/// `(a, b)` in units of its edges from its centre: uniform over its area.
/// A triangle folds the square's far half onto its own (`1 - s`), which
/// keeps the density uniform and nearby pairs near each other.
fn panel_point(shape: Shape, s: Vec2) -> Vec2 {
    let s = if shape == Shape::Triangle && s.x + s.y > 1.0 { Vec2::ONE - s } else { s };
    s - Vec2::splat(0.5)
}

/// A light source.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// Emits `power` uniformly in all directions from one point.
    Point {
        /// Position.
        position: Vec3,
        /// Total emitted power (W per channel).
        power: Vec3,
    },
    /// A one-sided emitting panel (a parallelogram, or a triangle: its
    /// face's [`Shape`]), Lambertian (cosine) emission from the side `u x v`
    /// faces.
    Area {
        /// Centre of the parallelogram (of a triangle, its midpoint of the
        /// edge from `c + u` to `c + v`: [`Shape::Triangle`]).
        center: Vec3,
        /// First full edge vector.
        u: Vec3,
        /// Second full edge vector.
        v: Vec3,
        /// Total emitted power (W per channel).
        power: Vec3,
        /// What shading needs of the shape, worked out once ([`Light::area`]).
        face: AreaFace,
    },
    /// A point light restricted to a cone, with a smooth fall-off at its edge.
    Spot {
        /// Position.
        position: Vec3,
        /// Unit axis of the cone.
        direction: Vec3,
        /// Half-angle of the cone in radians: nothing is emitted outside.
        cone_angle: f32,
        /// Half-angle in radians where the fall-off towards the edge starts.
        falloff_start: f32,
        /// Total emitted power (W per channel).
        power: Vec3,
    },
}

impl Light {
    /// The one-sided parallelogram light centred at `center` with full
    /// edges `u` and `v`, emitting `power` from the side `u x v` faces.
    pub fn area(center: Vec3, u: Vec3, v: Vec3, power: Vec3) -> Light {
        Light::panel(Shape::Parallelogram, center, u, v, power)
    }

    /// The one-sided triangle light of corners `a`, `b`, `c`, emitting
    /// `power` from the side they turn counter-clockwise about.
    pub fn triangle(a: Vec3, b: Vec3, c: Vec3, power: Vec3) -> Light {
        Light::panel(Shape::Triangle, 0.5 * (b + c), b - a, c - a, power)
    }

    /// The one-sided panel light of `shape` over `center` and full edges
    /// `u` and `v` ([`Shape`]), emitting `power` from the side `u x v` faces.
    pub fn panel(shape: Shape, center: Vec3, u: Vec3, v: Vec3, power: Vec3) -> Light {
        let whole = numeric::cross_length(u, v);
        let area = shape.area(whole);
        let mut face = AreaFace {
            normal: numeric::unit_cross(u, v).unwrap_or(Vec3::ZERO),
            area,
            length2: (u.as_dvec3().length_squared(), v.as_dvec3().length_squared()),
            skew: u.as_dvec3().dot(v.as_dvec3()),
            radiance: (power.as_dvec3() / (std::f64::consts::PI * area)).as_vec3(),
            reach2: f64::INFINITY,
            rounding: 32.0 * f32::EPSILON * (center.abs() + (0.5 * u).abs() + (0.5 * v).abs()),
            shape,
            margin: (0.0, 0.0),
        };
        let slack = face.rounding.as_dvec3().length();
        let (lu, lv) = (face.length2.0.sqrt(), face.length2.1.sqrt());
        if whole > 0.0 && whole.is_finite() {
            // A point moves `1 / (|u| sin)` units of `u` (and `1 / (|v|
            // sin)` of `v`) per unit of distance across the edges.
            let sin = (whole / (lu * lv)).max(SHARPEST);
            face.margin = (slack / (lu * sin), slack / (lv * sin));
        }
        // A thousandth over, and the margin beyond.
        let reach = (1.001 * face.half_diagonal2()).sqrt() + 3.0 * slack / SHARPEST;
        if reach.is_finite() {
            face.reach2 = reach * reach;
        }
        Light::Area { center, u, v, power, face }
    }

    /// Total emitted power (W per channel).
    pub fn power(&self) -> Vec3 {
        match self {
            Light::Point { power, .. } | Light::Area { power, .. } | Light::Spot { power, .. } => *power,
        }
    }

    /// Whether the light is a single point (one sample says everything).
    pub fn is_delta(&self) -> bool {
        !matches!(self, Light::Area { .. })
    }

    /// Samples the light as seen from `p` with the uniform pair `u`. `None`
    /// when `p` receives nothing (behind a one-sided area light, outside a
    /// spot's cone).
    pub fn sample_incident(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match *self {
            Light::Point { position, .. } | Light::Spot { position, .. } => {
                // In f64: the squared distance of a tiny scene underflows in f32.
                let to_p = (p - position).as_dvec3();
                let d2 = to_p.length_squared();
                let (_, intensity) = self.intensity((to_p / d2.sqrt()).as_vec3())?;
                Some(LightSample { position, irradiance: (intensity.as_dvec3() / d2).as_vec3() })
            }
            Light::Area { center, u: eu, v: ev, power, face } => {
                // Uniform over the area (pdf 1/A) of a Lambertian emitter with
                // radiance L = power / (pi A): E = L cos_l A / d^2 = power cos_l / (pi d^2).
                let at = panel_point(face.shape, u);
                let position = center + at.x * eu + at.y * ev;
                let normal = face.normal;
                let to_p = (p - position).as_dvec3();
                let d2 = to_p.length_squared();
                let cos_l = normal.as_dvec3().dot(to_p) / d2.sqrt();
                let irradiance = power.as_dvec3() * (cos_l / (std::f64::consts::PI * d2));
                (cos_l > 0.0).then(|| LightSample { position, irradiance: irradiance.as_vec3() })
            }
        }
    }

    /// The radiance an area light's front sends every way (zero for lights
    /// with no surface).
    pub fn front_radiance(&self) -> Vec3 {
        match self {
            Light::Area { face, .. } => face.radiance,
            _ => Vec3::ZERO,
        }
    }

    /// How far along the unit vector `n` rounding may put a point of the
    /// light's surface from where it should be (zero for lights with none).
    pub fn rounding_along(&self, n: Vec3) -> f32 {
        match self {
            Light::Area { face, .. } => n.abs().dot(face.rounding),
            _ => 0.0,
        }
    }

    /// Where `ray` crosses the light's surface before `ray.t_max`, and on
    /// which side: the ray parameter. Only area lights have a surface.
    pub fn crossing(&self, ray: &Ray) -> Option<(f32, Side)> {
        let Light::Area { center, u, v, face, .. } = *self else { return None };
        // In f64, where the ray's point on the plane moves by far less than
        // the light's own rounding (`f32` moved it by as much again, more
        // the more the ray grazes), and tiny edges' squares do not underflow.
        let (origin, dir, normal) = (ray.origin.as_dvec3(), ray.dir.as_dvec3(), face.normal.as_dvec3());
        let facing = dir.dot(normal);
        if facing == 0.0 || facing.is_nan() {
            return None; // parallel
        }
        let c = center.as_dvec3();
        let t = (c - origin).dot(normal) / facing;
        let t32 = t as f32;
        if !(t32 > 0.0 && t32 <= ray.t_max) {
            return None;
        }
        // Most rays that cross the light's plane cross it far from the
        // light: beyond its farthest corner, it is missed.
        let local = origin + t * dir - c;
        if local.length_squared() > face.reach2 {
            return None;
        }
        // Where on the light, in units of its edges: `local = a u + b v`.
        // Edges at an angle other than a right one need the pair solved
        // together; projecting on each edge alone would find another shape
        // than the one sampled.
        let ((uu, vv), uv) = (face.length2, face.skew);
        let (lu, lv) = (local.dot(u.as_dvec3()), || local.dot(v.as_dvec3()));
        let crossed = if uv == 0.0 {
            // A rectangle (most lights): each edge alone, and most rays
            // that miss it miss on the first.
            let a = lu / uu;
            a.abs() <= 0.5 + face.margin.0 && face.holds(a, lv() / vv)
        } else {
            let (lv, det) = (lv(), uu * vv - uv * uv);
            face.holds((vv * lu - uv * lv) / det, (uu * lv - uv * lu) / det)
        };
        let side = if facing < 0.0 { Side::Front } else { Side::Back };
        crossed.then_some((t32, side))
    }

    /// Emits one photon from the uniforms `u` (position on the light) and `v`
    /// (direction): the ray it leaves along, and the power it carries times
    /// the number of photons emitted (so divide by that number).
    ///
    /// Point lights emit uniformly over the sphere, area lights from a uniform
    /// point with cosine-distributed directions (their emission profile), spot
    /// lights uniformly within the cone, weighted by the fall-off. In every
    /// case the expected power over many photons is exactly `power()`.
    pub fn emit(&self, u: Vec2, v: Vec2) -> (Ray, Vec3) {
        match *self {
            Light::Point { position, power } => (Ray::new(position, uniform_sphere(v)), power),
            Light::Area { center, u: eu, v: ev, power, face } => {
                let at = panel_point(face.shape, u);
                let on = center + at.x * eu + at.y * ev;
                let normal = face.normal;
                let dir = around(normal, cosine_hemisphere(v));
                // Leave from just in front of the light, by more than the
                // rounding error of the point on it: a surface flush with the
                // light (a ceiling) must not catch its photons at once.
                let origin = numeric::push_off(on, normal, face.rounding);
                (Ray::new(origin, dir), power)
            }
            Light::Spot { position, direction, cone_angle, .. } => {
                // Uniform in solid angle over the cone (pdf 1 / omega), so the
                // photon carries intensity / pdf = I(theta) * omega.
                let one_minus_cos = numeric::one_minus_cos(cone_angle);
                let dir = around(direction, uniform_cone(v, one_minus_cos));
                let omega = 2.0 * PI * one_minus_cos;
                let intensity = self.intensity(dir).map_or(Vec3::ZERO, |(_, i)| i);
                (Ray::new(position, dir), intensity * omega)
            }
        }
    }

    /// For point and spot lights: where they are and their radiant intensity
    /// (W/sr per channel) towards the unit direction `dir` (`None` for area
    /// lights, and for spots outside their cone).
    pub fn intensity(&self, dir: Vec3) -> Option<(Vec3, Vec3)> {
        match *self {
            Light::Point { position, power } => Some((position, power / (4.0 * PI))),
            Light::Spot { position, direction, cone_angle, falloff_start, power } => {
                let falloff = spot_falloff(direction, dir, cone_angle, falloff_start);
                (falloff > 0.0)
                    .then(|| (position, spot_peak_intensity(power, cone_angle, falloff_start) * falloff))
            }
            Light::Area { .. } => None,
        }
    }

    /// What the light could send to `p`, unblocked, as a weight for
    /// choosing among many lights (`integrator/direct.rs`): its power over
    /// the squared distance (from an area light's centre, but no nearer
    /// than half its diagonal), a spot light's intensity that way; 0 only
    /// where it sends `p` nothing (behind an area light's plane, outside a
    /// spot's cone), so that every light that could light `p` may be
    /// chosen.
    pub fn reach(&self, p: Vec3) -> f32 {
        match *self {
            Light::Point { position, .. } => {
                reach_over(self.reach_strength(), (p - position).as_dvec3().length_squared())
            }
            Light::Spot { position, .. } => {
                let to_p = (p - position).as_dvec3();
                // The intensity that way (the falloff in it), not the peak.
                match self.intensity((to_p / to_p.length()).as_vec3()) {
                    Some((_, intensity)) => reach_over(intensity.element_sum() as f64, to_p.length_squared()),
                    None => 0.0,
                }
            }
            Light::Area { center, face, .. } => {
                let to_p = (p - center).as_dvec3();
                if face.normal.as_dvec3().dot(to_p) <= 0.0 {
                    return 0.0;
                }
                reach_over(self.reach_strength(), to_p.length_squared().max(face.half_diagonal2()))
            }
        }
    }

    /// The most [`Light::reach`] has over the squared distance: power over
    /// pi for a panel, over 4 pi for a point light, a spot's peak intensity
    /// (each summed over the channels).
    pub fn reach_strength(&self) -> f64 {
        match *self {
            Light::Point { power, .. } => power.element_sum() as f64 / (4.0 * std::f64::consts::PI),
            Light::Spot { power, cone_angle, falloff_start, .. } => {
                spot_peak_intensity(power, cone_angle, falloff_start).element_sum() as f64
            }
            Light::Area { power, .. } => power.element_sum() as f64 / std::f64::consts::PI,
        }
    }

    /// The box around the light: its point, or its panel's corners.
    pub fn bounds(&self) -> Bounds {
        match *self {
            Light::Point { position, .. } | Light::Spot { position, .. } => Bounds::of(&[position]),
            Light::Area { center, u, v, face, .. } => {
                let (hu, hv) = (0.5 * u, 0.5 * v);
                let corners = [center - hu - hv, center + hu - hv, center - hu + hv, center + hu + hv];
                match face.shape {
                    Shape::Parallelogram => Bounds::of(&corners),
                    Shape::Triangle => Bounds::of(&corners[..3]),
                }
            }
        }
    }

    /// How far beyond its panel a ray may still cross an area light (its
    /// margin for rounding, at a corner), at most
    /// (zero for lights with no surface).
    pub fn margin_reach(&self) -> f32 {
        match self {
            Light::Area { face, .. } => (2.0 * face.rounding.as_dvec3().length() / SHARPEST) as f32,
            _ => 0.0,
        }
    }

    /// An area light's shape ([`Shape`]); `None` for lights with no surface.
    pub fn shape(&self) -> Option<Shape> {
        match self {
            Light::Area { face, .. } => Some(face.shape),
            _ => None,
        }
    }

    /// The unit normal of a panel's emitting side (zero for point and spot lights).
    pub fn facing(&self) -> Vec3 {
        match self {
            Light::Area { face, .. } => face.normal,
            _ => Vec3::ZERO,
        }
    }

    /// Solid-angle density, seen from `from`, with which
    /// [`Light::sample_incident`] picks the point `on` of an area light
    /// (uniformly by area): `d^2 / (A cos_l)`. 0 for point and spot lights,
    /// and behind the light.
    pub fn pdf_solid_angle(&self, on: Vec3, from: Vec3) -> f32 {
        let Light::Area { face: AreaFace { normal, area, .. }, .. } = *self else { return 0.0 };
        let to = (from - on).as_dvec3();
        let d2 = to.length_squared();
        let cos_l = normal.as_dvec3().dot(to) / d2.sqrt();
        if cos_l <= 0.0 {
            return 0.0;
        }
        (d2 / (area * cos_l)) as f32
    }

    /// The densities with which a light vertex leaving along the unit
    /// direction `dir` is made, for bidirectional methods' multiple
    /// importance sampling (where on an area light does not matter: its
    /// points are uniform).
    pub fn emission_pdfs(&self, dir: Vec3) -> EmissionPdfs {
        match *self {
            Light::Point { .. } => EmissionPdfs { direct_area: 1.0, emit: 1.0 / (4.0 * PI), cos: 1.0 },
            Light::Spot { direction, cone_angle, .. } => {
                let one_minus_cos = numeric::one_minus_cos(cone_angle);
                let inside = numeric::one_minus_cos_between(direction, dir) <= one_minus_cos;
                let emit = if inside { 1.0 / (2.0 * PI * one_minus_cos) } else { 0.0 };
                EmissionPdfs { direct_area: 1.0, emit, cos: 1.0 }
            }
            Light::Area { face: AreaFace { normal, area, .. }, .. } => {
                let cos = normal.dot(dir);
                let direct_area = (1.0 / area) as f32;
                let emit = if cos > 0.0 { direct_area * cos * std::f32::consts::FRAC_1_PI } else { 0.0 };
                EmissionPdfs { direct_area, emit, cos: cos.max(0.0) }
            }
        }
    }

    /// A short description for `caustix info`, with positions in the
    /// coordinates of a scene whose origin is `origin` (the scene file's).
    pub fn describe(&self, origin: glam::DVec3) -> String {
        let w = self.power();
        let at = |p: Vec3| (p.as_dvec3() + origin).as_vec3();
        match self {
            Light::Point { position, .. } => format!("point at {}, power {w} W", at(*position)),
            Light::Area { center, u, v, face, .. } if face.shape == Shape::Triangle => {
                let corner = *center - 0.5 * (*u + *v);
                format!(
                    "triangle at {}, {}, {}, facing {}, power {w} W",
                    at(corner),
                    at(corner + *u),
                    at(corner + *v),
                    face.normal
                )
            }
            Light::Area { center, u, v, face, .. } => format!(
                "area {:.3} x {:.3} at {}, facing {}, power {w} W",
                u.length(),
                v.length(),
                at(*center),
                face.normal
            ),
            Light::Spot { position, direction, cone_angle, .. } => format!(
                "spot at {} towards {direction}, cone {:.1} deg, power {w} W",
                at(*position),
                cone_angle.to_degrees()
            ),
        }
    }
}

/// Which side of an area light a ray meets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The emitting side.
    Front,
    /// The back, which does not emit.
    Back,
}

/// [`Light::reach`] from its numerator and squared distance: within the
/// range of `f32`, and finite at the light itself.
fn reach_over(strength: f64, d2: f64) -> f32 {
    (strength / d2.max(f64::MIN_POSITIVE)).clamp(0.0, 1e30) as f32
}

/// The smooth edge of a spot light with unit `axis`, towards the unit
/// direction `dir`: 1 inside `falloff_start`, 0 outside `cone_angle`, and a
/// smoothstep in the cosine between (as pbrt-v4 does). Cosines are handled
/// as `1 - cos`, from the sine, so a cone of 0.01 degrees keeps its shape
/// where `f32` cosines all round to 1.
fn spot_falloff(axis: Vec3, dir: Vec3, cone_angle: f32, falloff_start: f32) -> f32 {
    let one_minus_cos = numeric::one_minus_cos_between(axis, dir);
    let (total, start) = (numeric::one_minus_cos(cone_angle), numeric::one_minus_cos(falloff_start));
    if one_minus_cos > total {
        return 0.0;
    }
    if total - start <= 0.0 {
        return 1.0;
    }
    let x = ((total - one_minus_cos) / (total - start)).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The intensity on the axis for a spot light emitting `power` in total:
/// the falloff integrates (over solid angle, d omega = d cos dphi) to
/// `2 pi ((1 - cos_start) + (cos_start - cos_total) / 2)`, exactly, because a
/// smoothstep averages to one half.
fn spot_peak_intensity(power: Vec3, cone_angle: f32, falloff_start: f32) -> Vec3 {
    let (total, start) = (numeric::one_minus_cos(cone_angle), numeric::one_minus_cos(falloff_start));
    power / (2.0 * PI * (start + 0.5 * (total - start)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{stratified, Rng};

    /// Form factor from a point to a parallel rectangle `a x b` at distance
    /// `d` with one corner straight above it.
    fn corner_form_factor(a: f32, b: f32, d: f32) -> f32 {
        let (x, y) = (a / d, b / d);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
    }

    #[test]
    fn area_light_irradiance_matches_the_form_factor() {
        let (w, h, d) = (1.0f32, 0.5f32, 0.8f32);
        let light = Light::area(Vec3::Y * d, Vec3::X * w, Vec3::Z * h, Vec3::splat(10.0));
        // u x v = X x Z = -Y: facing down at the origin.
        let radiance = 10.0 / (PI * w * h);
        let analytic = PI * radiance * 4.0 * corner_form_factor(w / 2.0, h / 2.0, d);
        let mut rng = Rng::new(0, 0);
        let n = 64 * 64;
        let mut estimate = 0.0;
        for i in 0..n {
            let s = light.sample_incident(Vec3::ZERO, stratified(i, n, &mut rng)).unwrap();
            let cos_receiver = (s.position - Vec3::ZERO).normalize().y;
            estimate += s.irradiance.x * cos_receiver / n as f32;
        }
        assert!((estimate / analytic - 1.0).abs() < 1e-3, "{estimate} vs {analytic}");
        // Behind the light: nothing.
        assert!(light.sample_incident(Vec3::Y * 2.0, Vec2::splat(0.5)).is_none());
    }

    /// The emission density over all directions integrates to the density
    /// of the point (1/area, or 1 for point and spot lights); each emitted
    /// photon's weight is the emitted radiance (or intensity) over it.
    #[test]
    fn emission_densities_match_the_sampling() {
        let lights = [
            Light::Point { position: Vec3::ZERO, power: Vec3::splat(7.0) },
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::new(0.0, -1.0, 0.2).normalize(),
                cone_angle: 0.6,
                falloff_start: 0.3,
                power: Vec3::splat(3.0),
            },
            Light::area(Vec3::ONE, Vec3::X * 0.5, Vec3::Z * 2.0, Vec3::splat(5.0)),
            // Half of a parallelogram of area 2.
            Light::triangle(Vec3::ONE, Vec3::ONE + Vec3::X, Vec3::ONE + Vec3::Z * 2.0, Vec3::splat(5.0)),
        ];
        let mut rng = Rng::new(4, 0);
        for light in &lights {
            let n = 400_000;
            let integral = (0..n)
                .map(|_| light.emission_pdfs(uniform_sphere(rng.uniform2())).emit * 4.0 * PI)
                .sum::<f32>()
                / n as f32;
            let direct = light.emission_pdfs(Vec3::Y).direct_area;
            assert!((integral / direct - 1.0).abs() < 0.01, "{light:?}: {integral} vs {direct}");
            for _ in 0..100 {
                let (ray, weight) = light.emit(rng.uniform2(), rng.uniform2());
                let pdfs = light.emission_pdfs(ray.dir);
                let emitted = match light.intensity(ray.dir) {
                    Some((_, intensity)) => intensity,
                    // Radiance power / (pi area), the area 0.5 x 2 = 1, times the cosine.
                    None => light.power() / PI * pdfs.cos,
                };
                assert!(pdfs.emit > 0.0, "{light:?}: emitted where the density is 0");
                let expected = emitted / pdfs.emit;
                assert!((weight - expected).abs().max_element() < 1e-3 * expected.max_element(), "{light:?}");
            }
        }
    }

    #[test]
    fn spot_light_emits_its_power() {
        let (cone, start) = (30f32.to_radians(), 20f32.to_radians());
        let light = Light::Spot {
            position: Vec3::ZERO,
            direction: -Vec3::Y,
            cone_angle: cone,
            falloff_start: start,
            power: Vec3::splat(5.0),
        };
        // Flux through a unit sphere = integral of intensity = irradiance * r^2 over the sphere.
        let (nt, np) = (4000, 64);
        let mut flux = 0.0;
        for i in 0..nt {
            let cos_t = -1.0 + 2.0 * (i as f32 + 0.5) / nt as f32;
            let sin_t = (1.0 - cos_t * cos_t).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f32 + 0.5) / np as f32;
                let p = Vec3::new(sin_t * phi.cos(), cos_t, sin_t * phi.sin());
                if let Some(s) = light.sample_incident(p, Vec2::ZERO) {
                    flux += s.irradiance.x * 4.0 * PI / (nt * np) as f32;
                }
            }
        }
        assert!((flux - 5.0).abs() < 0.01, "flux {flux}");
        assert!(light.sample_incident(Vec3::new(1.0, -1.0, 0.0), Vec2::ZERO).is_none(), "45 deg is outside");
    }

    #[test]
    fn emitted_photons_carry_the_lights_power() {
        let lights = [
            Light::Point { position: Vec3::ZERO, power: Vec3::new(1.0, 2.0, 3.0) },
            Light::area(Vec3::Y, Vec3::X, Vec3::Z, Vec3::splat(7.0)),
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::Y,
                cone_angle: 40f32.to_radians(),
                falloff_start: 25f32.to_radians(),
                power: Vec3::splat(5.0),
            },
            // So narrow that every f32 cosine in it rounds to 1 (it used to give NaN).
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::Y,
                cone_angle: 0.01f32.to_radians(),
                falloff_start: 0.008f32.to_radians(),
                power: Vec3::splat(5.0),
            },
            // An area light whose u x v underflows in f32 (it used to give NaN).
            Light::area(Vec3::Y, Vec3::X, Vec3::Z * 1e-25, Vec3::splat(7.0)),
            Light::triangle(Vec3::Y, Vec3::Y + Vec3::X, Vec3::Y + Vec3::Z, Vec3::splat(7.0)),
        ];
        for light in lights {
            let mut rng = Rng::new(9, 9);
            let n = 200_000;
            let mut total = Vec3::ZERO;
            for _ in 0..n {
                let (ray, power) = light.emit(rng.uniform2(), rng.uniform2());
                assert!((ray.dir.length() - 1.0).abs() < 1e-5);
                if let Light::Area { .. } = light {
                    assert!(ray.dir.y < 0.0, "area light emits from the u x v side (down)");
                }
                total += power / n as f32;
            }
            assert!(
                (total / light.power() - Vec3::ONE).abs().max_element() < 0.01,
                "{} vs {}",
                total,
                light.power()
            );
        }
    }

    #[test]
    fn point_light_follows_the_inverse_square_law() {
        let light = Light::Point { position: Vec3::Y * 2.0, power: Vec3::splat(4.0 * PI) };
        let s = light.sample_incident(Vec3::ZERO, Vec2::ZERO).unwrap();
        assert!((s.irradiance.x - 0.25).abs() < 1e-6);
    }

    #[test]
    fn rays_see_the_front_of_an_area_light_only() {
        let light = Light::area(Vec3::Y, Vec3::X, Vec3::Z, Vec3::splat(PI));
        let up = Ray::new(Vec3::new(0.2, 0.0, -0.3), Vec3::Y);
        let (t, side) = light.crossing(&up).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && side == Side::Front);
        assert!((light.front_radiance().x - 1.0).abs() < 1e-6);
        // The back is crossed too, but does not emit (it blocks rays: `SceneQuery::first`).
        let down = Ray::new(Vec3::new(0.2, 2.0, 0.0), -Vec3::Y);
        assert_eq!(light.crossing(&down), Some((1.0, Side::Back)), "back side");
        assert!(light.crossing(&Ray::new(Vec3::new(0.6, 0.0, 0.0), Vec3::Y)).is_none(), "beside it");
        assert!(light.crossing(&Ray { t_max: 0.5, ..up }).is_none(), "beyond t_max");
        assert!(light.crossing(&Ray::new(Vec3::new(0.2, 2.0, 0.0), Vec3::X)).is_none(), "parallel");
    }

    /// A light with edges at 60 degrees is seen where it emits from: rays
    /// to the points it samples cross it, and rays to points just outside
    /// its edges do not, near the sharp corners too (projecting on each
    /// edge alone once saw another, narrower shape there).
    #[test]
    fn rays_see_a_skewed_light_where_its_samples_lie() {
        let (u, v) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.8));
        let light = Light::area(Vec3::Y, u, v, Vec3::ONE);
        let eye = Vec3::new(0.1, -1.0, 0.2);
        let towards = |a: f32, b: f32| {
            let p = Vec3::Y + a * u + b * v;
            Ray { t_max: 2.0, ..Ray::new(eye, p - eye) }
        };
        let mut rng = Rng::new(5, 0);
        for i in 0..1024 {
            let s = light.sample_incident(eye, stratified(i, 1024, &mut rng)).unwrap();
            let ray = Ray { t_max: 2.0, ..Ray::new(eye, s.position - eye) };
            assert!(light.crossing(&ray).is_some(), "{:?}", s.position);
        }
        // (The farthest corners, (0.5, 0.5) and (-0.5, -0.5), within a
        // ten-thousandth: the quick test of the distance to the centre
        // passes them on to the exact one.)
        let corners = [(0.49995, 0.49995), (-0.49995, -0.49995)];
        for (a, b) in [(0.48, 0.48), (-0.48, -0.48), (0.48, -0.3), (-0.1, 0.49)].into_iter().chain(corners) {
            assert!(light.crossing(&towards(a, b)).is_some(), "inside at ({a}, {b})");
        }
        for (a, b) in [(0.52, 0.48), (0.48, 0.52), (-0.52, -0.48), (-0.48, -0.52), (0.0, 0.51)] {
            assert!(light.crossing(&towards(a, b)).is_none(), "outside at ({a}, {b})");
        }
    }

    /// A square light cut along its diagonal into two triangle lights of
    /// half its power each lights a point as the square does (the form
    /// factor), and each triangle half as much as its half of the square
    /// would by symmetry; each triangle's samples lie on it.
    #[test]
    fn two_triangles_light_as_the_square_they_make() {
        let (w, d) = (1.0f32, 0.8f32);
        let corners = [
            Vec3::new(-0.5, d, -0.5),
            Vec3::new(0.5, d, -0.5),
            Vec3::new(0.5, d, 0.5),
            Vec3::new(-0.5, d, 0.5),
        ];
        // Wound counter-clockwise seen from below: both face down.
        let halves = [
            Light::triangle(corners[0], corners[1], corners[2], Vec3::splat(5.0)),
            Light::triangle(corners[2], corners[3], corners[0], Vec3::splat(5.0)),
        ];
        let radiance = 10.0 / (PI * w * w);
        let analytic = PI * radiance * 4.0 * corner_form_factor(w / 2.0, w / 2.0, d);
        let n = 64 * 64;
        let mut total = 0.0;
        for (k, light) in halves.iter().enumerate() {
            assert_eq!(light.shape(), Some(Shape::Triangle));
            assert!(light.facing().abs_diff_eq(-Vec3::Y, 1e-6), "{}", light.facing());
            assert!((light.front_radiance().x - radiance).abs() < 1e-4 * radiance);
            let mut rng = Rng::new(k as u64, 0);
            let mut estimate = 0.0;
            for i in 0..n {
                let s = light.sample_incident(Vec3::ZERO, stratified(i, n, &mut rng)).unwrap();
                // On its own half: x + z <= 0 for the first, >= 0 for the second.
                let side = if k == 0 { 1.0 } else { -1.0 };
                assert!(side * (s.position.x - s.position.z) >= -1e-6, "{k}: {}", s.position);
                assert!(s.position.x.abs() <= 0.5 && s.position.z.abs() <= 0.5, "{k}: {}", s.position);
                estimate += s.irradiance.x * s.position.normalize().y / n as f32;
            }
            assert!((2.0 * estimate / analytic - 1.0).abs() < 2e-3, "{k}: {estimate} vs half of {analytic}");
            total += estimate;
        }
        assert!((total / analytic - 1.0).abs() < 1e-3, "{total} vs {analytic}");
    }

    /// Rays see a triangle light where it samples and emits from, and not
    /// across its long edge, where the parallelogram of its edges goes on.
    #[test]
    fn rays_see_a_triangle_light_where_its_samples_lie() {
        let (a, b, c) = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.2), Vec3::new(0.3, 1.0, 0.9));
        let light = Light::triangle(a, b, c, Vec3::ONE);
        let bounds = light.bounds();
        // (Its corner is made again from the centre and edges: within rounding.)
        assert!(bounds.min.abs_diff_eq(Vec3::new(0.0, 1.0, 0.0), 1e-6), "{bounds:?}");
        assert!(bounds.max.abs_diff_eq(Vec3::new(1.0, 1.0, 0.9), 1e-6), "{bounds:?}");
        // b - a = (1, 0, 0.2), c - a = (0.3, 0, 0.9): u x v faces -y.
        assert!(light.facing().y < -0.99);
        let eye = Vec3::new(0.4, 0.0, 0.3);
        let through = |p: Vec3| Ray { t_max: 2.0, ..Ray::new(eye, p - eye) };
        let mut rng = Rng::new(6, 0);
        for i in 0..1024 {
            let s = light.sample_incident(eye, stratified(i, 1024, &mut rng)).unwrap();
            assert!(light.crossing(&through(s.position)).is_some(), "{:?}", s.position);
            let (ray, _) = light.emit(rng.uniform2(), rng.uniform2());
            let back = Ray { t_max: 2.0, ..Ray::new(ray.origin + Vec3::Y * 0.5, -Vec3::Y) };
            assert!(light.crossing(&back).is_some(), "emitted from {}", ray.origin);
        }
        let at = |x: f32, y: f32| a + x * (b - a) + y * (c - a);
        for (x, y) in [(0.02, 0.02), (0.97, 0.02), (0.02, 0.97), (0.49, 0.49), (0.3, 0.3)] {
            assert!(light.crossing(&through(at(x, y))).is_some(), "inside at ({x}, {y})");
        }
        for (x, y) in [(0.51, 0.51), (0.9, 0.9), (0.2, 0.82), (-0.02, 0.5), (0.5, -0.02)] {
            assert!(light.crossing(&through(at(x, y))).is_none(), "outside at ({x}, {y})");
        }
        assert!(light
            .describe(glam::DVec3::ZERO)
            .starts_with("triangle at [0, 1, 0], [1, 1, 0.2], [0.3, 1, 0.9]"));
    }

    /// Rays aimed at the edge two triangle lights share (a lamp's faces,
    /// their corners made again from centres and edges) cross one or both,
    /// never neither: none passes between them into the lamp. In `f32`
    /// without a margin for rounding, about one ray in four did here.
    #[test]
    fn no_ray_passes_between_two_triangles_on_their_shared_edge() {
        let mut rng = Rng::new(8, 0);
        let point = |rng: &mut Rng, scale: f32| {
            (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5) * scale
        };
        let mut missed = 0;
        for _ in 0..200 {
            let base = Vec3::new(3.0, 1.0, -2.0);
            let (a, c) = (base + point(&mut rng, 2.0), base + point(&mut rng, 2.0));
            let (b, d) = (a + point(&mut rng, 1.0), a + point(&mut rng, 1.0));
            // b and d on either side of the edge a c, both facing one way.
            let first = Light::triangle(a, b, c, Vec3::ONE);
            let second = if first.facing().dot((d - a).cross(c - a)) > 0.0 {
                Light::triangle(a, d, c, Vec3::ONE)
            } else {
                Light::triangle(c, d, a, Vec3::ONE)
            };
            for _ in 0..100 {
                let on_edge = a + rng.uniform() * (c - a);
                let eye = on_edge + point(&mut rng, 40.0);
                let ray = Ray::new(eye, on_edge - eye);
                missed += u32::from(first.crossing(&ray).is_none() && second.crossing(&ray).is_none());
            }
        }
        assert_eq!(missed, 0, "rays between the triangles");
    }

    /// A sliver of a triangle (a corner of a ten-thousandth of a degree)
    /// is crossed where it lies and not beyond its sharp corners, which a
    /// margin of the light's rounding across each edge would stretch by
    /// that over the sine of the angle; nor far beyond its own rounding.
    #[test]
    fn a_sliver_is_crossed_where_it_lies_only() {
        let (a, b, c) = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 2e-6));
        let light = Light::triangle(a, b, c, Vec3::ONE);
        let eye = Vec3::new(0.3, 0.0, 0.2);
        let through = |p: Vec3| Ray { t_max: 2.0, ..Ray::new(eye, p - eye) };
        assert!(light.crossing(&through(Vec3::new(0.5, 1.0, 5e-7))).is_some());
        for beyond in [a - 1e-3 * (b - a), b + 1e-3 * (b - a), Vec3::new(0.5, 1.0, -1e-3)] {
            assert!(light.crossing(&through(beyond)).is_none(), "{beyond}");
        }
    }
}
