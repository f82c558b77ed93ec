//! Vector arithmetic that holds over the whole range of `f32`: lengths,
//! normals and areas computed in `f64`, where the squares of any `f32`
//! (from about 1e-45 to 3e38) neither underflow to zero nor overflow to
//! infinity. A sphere of radius 1e-12 or a scene 1e15 across gets the same
//! unit normals as one of size 1.

use glam::{DVec3, Vec3};

/// `v` scaled to unit length; `None` for the zero vector or a non-finite one.
pub fn unit(v: Vec3) -> Option<Vec3> {
    let unit = v.as_dvec3().try_normalize()?.as_vec3();
    unit.is_finite().then_some(unit)
}

/// The unit vector along `a x b`; `None` when they are parallel (or zero).
pub fn unit_cross(a: Vec3, b: Vec3) -> Option<Vec3> {
    let c = a.as_dvec3().cross(b.as_dvec3()).try_normalize()?.as_vec3();
    c.is_finite().then_some(c)
}

/// `|a x b|` (twice a triangle's area, or a parallelogram's area).
pub fn cross_length(a: Vec3, b: Vec3) -> f64 {
    a.as_dvec3().cross(b.as_dvec3()).length()
}

/// `p` pushed along the unit normal `n` by just more than `error`, the
/// bound on each coordinate's floating-point error: the origin of a ray
/// leaving a surface (or a light) at `p` towards the side `n` faces, sure
/// not to start behind it. Scale-aware: no fixed epsilon.
pub fn push_off(p: Vec3, n: Vec3, error: Vec3) -> Vec3 {
    p + (n.abs().dot(error) + f32::MIN_POSITIVE) * n
}

/// The angle between `a` and `b` in radians (0 when either is zero).
pub fn angle_between(a: Vec3, b: Vec3) -> f32 {
    let (a, b): (DVec3, DVec3) = (a.as_dvec3(), b.as_dvec3());
    let (la, lb) = (a.length(), b.length());
    if la == 0.0 || lb == 0.0 {
        return 0.0;
    }
    (a.dot(b) / (la * lb)).clamp(-1.0, 1.0).acos() as f32
}

/// `1 - cos(angle)` without the cancellation that makes it 0 in `f32` for
/// angles below about 0.02 degrees: `2 sin^2(angle / 2)`.
pub fn one_minus_cos(angle: f32) -> f32 {
    let s = (0.5 * angle as f64).sin();
    (2.0 * s * s) as f32
}

/// `1 - cos` of the angle between the unit vectors `a` and `b`, from the
/// sine, so that small angles keep their size (2 for opposite vectors).
pub fn one_minus_cos_between(a: Vec3, b: Vec3) -> f32 {
    let cos = a.dot(b);
    if cos <= 0.0 {
        return 1.0 - cos;
    }
    a.cross(b).length_squared() / (1.0 + cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_hold_at_every_scale() {
        for scale in [1e-30f32, 1e-20, 1e-12, 1.0, 1e12, 1e18] {
            let (a, b) = (Vec3::new(scale, 0.0, 0.0), Vec3::new(0.0, scale, 0.0));
            assert_eq!(unit_cross(a, b), Some(Vec3::Z), "scale {scale}");
            assert_eq!(unit(a + b).map(|u| (u.length() - 1.0).abs() < 1e-6), Some(true), "scale {scale}");
            assert!((cross_length(a, b) / (scale as f64 * scale as f64) - 1.0).abs() < 1e-12);
            assert!((angle_between(a, b) - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        }
        // f32 alone fails here: the squares underflow or overflow.
        assert!(Vec3::new(1e-30, 0.0, 0.0).cross(Vec3::new(0.0, 1e-30, 0.0)).try_normalize().is_none());
        assert_eq!(unit_cross(Vec3::X, Vec3::X * 2.0), None);
        assert_eq!(unit(Vec3::ZERO), None);
    }

    #[test]
    fn one_minus_cos_keeps_tiny_angles() {
        let angle = 0.01f32.to_radians();
        assert_eq!(1.0 - angle.cos(), 0.0, "the naive form cancels");
        let exact = angle as f64 * angle as f64 / 2.0;
        assert!((one_minus_cos(angle) as f64 / exact - 1.0).abs() < 1e-6);
        assert!((one_minus_cos(1.0) - (1.0 - 1.0f32.cos())).abs() < 1e-7);
        let tilted = Vec3::new(angle.sin(), 0.0, angle.cos());
        assert!((one_minus_cos_between(Vec3::Z, tilted) as f64 / exact - 1.0).abs() < 1e-5);
        assert_eq!(one_minus_cos_between(Vec3::Z, -Vec3::Z), 2.0);
    }
}
