//! Geometric optics at a smooth surface: mirror reflection, refraction by
//! Snell's law, and the exact Fresnel equations for unpolarised light at a
//! dielectric interface.
//!
//! Conventions: `i` is the unit direction of travel *towards* the surface and
//! `n` the unit normal on the side `i` comes from (`n . i < 0`).

use glam::Vec3;

/// Mirror reflection of `i` about `n`: `i - 2 (n . i) n`.
pub fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    i - 2.0 * n.dot(i) * n
}

/// Refraction of `i` through a surface with normal `n` (facing `i`) and
/// relative index `eta = n1 / n2` (from the side of `n` into the other):
/// `T = eta i + (eta cos_i - cos_t) n` with `cos_i = -n . i`.
/// `None` on total internal reflection (`sin_t > 1`).
pub fn refract(i: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -n.dot(i);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(eta * i + (eta * cos_i - cos_t) * n)
}

/// The Fresnel amplitude coefficients `(r_par, r_perp)` for light arriving at
/// `cos_i` (in `[0, 1]`) from a medium of index `n1` onto one of index `n2`:
/// `r_par = (n2 cos_i - n1 cos_t) / (n2 cos_i + n1 cos_t)`,
/// `r_perp = (n1 cos_i - n2 cos_t) / (n1 cos_i + n2 cos_t)`.
/// `None` on total internal reflection.
pub fn fresnel_amplitudes(cos_i: f32, n1: f32, n2: f32) -> Option<(f32, f32)> {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).sqrt();
    if sin_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let r_par = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    let r_perp = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    Some((r_par, r_perp))
}

/// Reflected fraction of unpolarised light, `kr = (r_par^2 + r_perp^2) / 2`;
/// 1 on total internal reflection. The transmitted fraction is `1 - kr`.
pub fn fresnel_dielectric(cos_i: f32, n1: f32, n2: f32) -> f32 {
    match fresnel_amplitudes(cos_i, n1, n2) {
        Some((r_par, r_perp)) => 0.5 * (r_par * r_par + r_perp * r_perp),
        None => 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir_at(angle_deg: f32) -> Vec3 {
        // Arriving at `angle` from the normal (+y), travelling down.
        let a = angle_deg.to_radians();
        Vec3::new(a.sin(), -a.cos(), 0.0)
    }

    #[test]
    fn normal_incidence_on_glass_reflects_four_percent() {
        assert!((fresnel_dielectric(1.0, 1.0, 1.5) - 0.04).abs() < 1e-6);
        // The same from inside: ((n1 - n2) / (n1 + n2))^2 is symmetric.
        assert!((fresnel_dielectric(1.0, 1.5, 1.0) - 0.04).abs() < 1e-6);
    }

    #[test]
    fn r_par_vanishes_at_brewsters_angle() {
        for (n1, n2) in [(1.0f32, 1.5f32), (1.0, 1.33), (1.5, 1.0)] {
            let brewster = (n2 / n1).atan();
            let (r_par, r_perp) = fresnel_amplitudes(brewster.cos(), n1, n2).unwrap();
            assert!(r_par.abs() < 1e-6, "n {n1}->{n2}: r_par = {r_par}");
            assert!(r_perp.abs() > 0.05);
        }
    }

    #[test]
    fn total_internal_reflection_past_the_critical_angle() {
        let critical = (1.0f32 / 1.5).asin().to_degrees(); // 41.8 degrees
        assert_eq!(fresnel_dielectric(dir_at(critical + 0.5).y.abs(), 1.5, 1.0), 1.0);
        assert!(refract(dir_at(critical + 0.5), Vec3::Y, 1.5).is_none());
        assert!(fresnel_dielectric(dir_at(critical - 0.5).y.abs(), 1.5, 1.0) < 1.0);
        assert!(refract(dir_at(critical - 0.5), Vec3::Y, 1.5).is_some());
        // Below the critical angle kr rises to 1 like a square root (cos_t
        // goes as the square root of the distance): by hand, 0.89 at 0.01 deg.
        let kr = |below: f32| fresnel_dielectric(dir_at(critical - below).y.abs(), 1.5, 1.0);
        assert!((kr(0.01) - 0.89).abs() < 0.01, "{}", kr(0.01));
        assert!(kr(0.5) < kr(0.01) && kr(0.01) < kr(0.0001) && kr(0.0001) < 1.0);
    }

    #[test]
    fn kr_plus_kt_is_one_and_kr_grows_to_grazing() {
        let mut last = 0.0;
        for step in 0..=90 {
            let cos_i = (step as f32).to_radians().cos();
            let kr = fresnel_dielectric(cos_i, 1.0, 1.5);
            let kt = 1.0 - kr;
            assert!((0.0..=1.0).contains(&kr) && (0.0..=1.0).contains(&kt));
            assert!(kr >= last - 1e-6, "not monotonic at {step} degrees");
            last = kr;
        }
        assert!(last > 0.999, "grazing reflection is total: {last}");
    }

    #[test]
    fn reflect_and_refract_keep_unit_length_and_obey_snell() {
        for angle in [0.0f32, 10.0, 30.0, 45.0, 60.0, 80.0, 89.0] {
            let i = dir_at(angle);
            let r = reflect(i, Vec3::Y);
            assert!((r.length() - 1.0).abs() < 1e-6);
            assert!((r.y + i.y).abs() < 1e-6 && (r.x - i.x).abs() < 1e-6, "angle in = angle out");
            for (n1, n2) in [(1.0f32, 1.5f32), (1.0, 1.33), (1.5, 1.0), (2.4, 1.0)] {
                let Some(t) = refract(i, Vec3::Y, n1 / n2) else {
                    assert!(n1 / n2 * angle.to_radians().sin() > 1.0 - 1e-6, "TIR only past critical");
                    continue;
                };
                assert!((t.length() - 1.0).abs() < 1e-5, "|T| = {}", t.length());
                // Snell: n1 sin(theta_i) = n2 sin(theta_t), in the plane of incidence.
                assert!((n1 * i.x - n2 * t.x).abs() < 1e-5, "Snell at {angle} deg, {n1}->{n2}");
                assert!(t.y < 0.0 && t.z.abs() < 1e-6, "continues through the surface");
            }
        }
    }
}
