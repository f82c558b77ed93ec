//! Light sources, in physical units: power in watts per RGB channel.

use glam::Vec3;

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
    /// A one-sided emitting parallelogram, Lambertian (cosine) emission from
    /// the side `u x v` faces.
    Area {
        /// Centre of the rectangle.
        center: Vec3,
        /// First full edge vector.
        u: Vec3,
        /// Second full edge vector.
        v: Vec3,
        /// Total emitted power (W per channel).
        power: Vec3,
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
    /// Total emitted power (W per channel).
    pub fn power(&self) -> Vec3 {
        match self {
            Light::Point { power, .. } | Light::Area { power, .. } | Light::Spot { power, .. } => {
                *power
            }
        }
    }

    /// A short description for `caustix info`.
    pub fn describe(&self) -> String {
        let w = self.power();
        match self {
            Light::Point { position, .. } => format!("point at {position}, power {w} W"),
            Light::Area { center, u, v, .. } => format!(
                "area {:.3} x {:.3} at {center}, facing {}, power {w} W",
                u.length(),
                v.length(),
                u.cross(*v).normalize()
            ),
            Light::Spot {
                position,
                direction,
                cone_angle,
                ..
            } => format!(
                "spot at {position} towards {direction}, cone {:.1} deg, power {w} W",
                cone_angle.to_degrees()
            ),
        }
    }
}
