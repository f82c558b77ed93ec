//! Surface materials: what fraction of light a surface scatters, and how.
//!
//! A material splits incoming light per RGB channel into diffuse (Lambertian),
//! glossy (normalised Phong lobe), mirror and dielectric (Fresnel
//! reflection/refraction) parts. The parts must sum to at most 1 per channel,
//! so no surface creates energy; the rest is absorbed.

use glam::Vec3;

/// A surface material. Colours are reflectances in `[0, 1]` per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// The name it has in the scene file (or `file.obj:name` for MTL materials).
    pub name: String,
    /// Lambertian reflectance.
    pub diffuse: Vec3,
    /// Glossy (Phong lobe) reflectance.
    pub specular: Vec3,
    /// Phong exponent of the glossy lobe; larger is sharper.
    pub phong_exponent: f32,
    /// Perfect mirror reflectance.
    pub mirror: Vec3,
    /// Weight of the smooth dielectric interface (Fresnel reflection plus refraction).
    pub transmittance: Vec3,
    /// Index of refraction of the inside, for the dielectric part.
    pub ior: f32,
}

impl Default for Material {
    /// Black, absorbing everything; fields are meant to be overridden.
    fn default() -> Self {
        Material {
            name: String::new(),
            diffuse: Vec3::ZERO,
            specular: Vec3::ZERO,
            phong_exponent: 1.0,
            mirror: Vec3::ZERO,
            transmittance: Vec3::ZERO,
            ior: 1.5,
        }
    }
}

impl Material {
    /// The fraction of light scattered in each channel (at most 1 when valid).
    pub fn total_reflectance(&self) -> Vec3 {
        self.diffuse + self.specular + self.mirror + self.transmittance
    }

    /// Whether any part is a delta (mirror or dielectric) interaction: the
    /// kind of surface that makes caustics.
    pub fn is_specular(&self) -> bool {
        self.mirror.max_element() > 0.0 || self.transmittance.max_element() > 0.0
    }

    /// Whether part of it is a dielectric: the only part for which the side
    /// a ray meets it from (its inside or outside) matters.
    pub fn refracts(&self) -> bool {
        self.transmittance.max_element() > 0.0
    }

    /// Whether the material has a non-delta part that direct light and photon
    /// estimates act on (diffuse or glossy).
    pub fn is_glossy_or_diffuse(&self) -> bool {
        self.diffuse.max_element() > 0.0 || self.specular.max_element() > 0.0
    }

    /// The BRDF of the diffuse and glossy parts: `diffuse / pi` plus the
    /// energy-normalised Phong lobe `specular (e + 2) / (2 pi) cos^e(alpha)`,
    /// where `alpha` is the angle between `wo` and the mirror direction of
    /// `wi` (Lafortune and Willems 1994). `wi` points to the light, `wo` to
    /// the viewer, `n` is the unit shading normal on their side; all unit.
    /// With this normalisation the lobe reflects at most `specular`, so the
    /// material never reflects more than `diffuse + specular`.
    pub fn brdf(&self, n: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
        let mut f = self.diffuse * std::f32::consts::FRAC_1_PI;
        if self.specular.max_element() > 0.0 {
            f += self.glossy_brdf(n, wi, wo);
        }
        f
    }

    /// The glossy part of [`Material::brdf`] alone.
    pub fn glossy_brdf(&self, n: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
        let cos_alpha = crate::optics::reflect(-wi, n).dot(wo).max(0.0);
        let e = self.phong_exponent;
        self.specular * ((e + 2.0) / std::f32::consts::TAU * cos_alpha.powf(e))
    }

    /// The sharpest glossy lobe: beyond it, `cos^e` is a mirror in all but
    /// name and its normalisation loses precision.
    pub const MAX_PHONG_EXPONENT: f32 = 1e6;

    /// Checks energy conservation and the Phong exponent's range; the
    /// message names the worst channel.
    pub fn check_energy(&self) -> Result<(), String> {
        if !(self.phong_exponent > 0.0 && self.phong_exponent <= Self::MAX_PHONG_EXPONENT) {
            return Err(format!(
                "phong_exponent is {}; it must be above 0 and at most 1e6 (sharper is a mirror: use `mirror`)",
                self.phong_exponent
            ));
        }
        let total = self.total_reflectance();
        let (channel, worst) = ["red", "green", "blue"]
            .into_iter()
            .zip(total.to_array())
            .fold(("red", f32::MIN), |best, c| if c.1 > best.1 { c } else { best });
        if worst > 1.0 + 1e-6 {
            return Err(format!(
                "diffuse + specular + mirror + transmittance is {worst:.3} in the {channel} channel; \
                 it must be at most 1 or the surface would create light"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// `int f(wi, wo) cos(theta_i) d wi` over the hemisphere, by the midpoint
    /// rule in (cos theta, phi): the fraction of light from `wo` reflected.
    fn albedo(m: &Material, wo: Vec3) -> Vec3 {
        let (nt, np) = (2000, 400);
        let mut sum = Vec3::ZERO;
        for i in 0..nt {
            let cos_t = (i as f32 + 0.5) / nt as f32;
            let sin_t = (1.0 - cos_t * cos_t).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f32 + 0.5) / np as f32;
                let wi = Vec3::new(sin_t * phi.cos(), cos_t, sin_t * phi.sin());
                sum += m.brdf(Vec3::Y, wi, wo) * cos_t;
            }
        }
        sum * (2.0 * PI / (nt * np) as f32)
    }

    #[test]
    fn brdf_reflects_at_most_the_albedo() {
        let m = Material {
            diffuse: Vec3::new(0.5, 0.2, 0.0),
            specular: Vec3::new(0.3, 0.3, 0.6),
            ..Material::default()
        };
        for exponent in [1.0, 10.0, 100.0] {
            let m = Material { phong_exponent: exponent, ..m.clone() };
            for view_deg in [0.0f32, 30.0, 60.0, 85.0] {
                let t = view_deg.to_radians();
                let a = albedo(&m, Vec3::new(t.sin(), t.cos(), 0.0));
                let limit = m.diffuse + m.specular;
                assert!(a.cmple(limit + 2e-3).all(), "exp {exponent}, view {view_deg}: {a} > {limit}");
                if view_deg == 0.0 {
                    // At normal view the whole lobe lies in the hemisphere: equality.
                    assert!((a - limit).abs().max_element() < 5e-3, "exp {exponent}: {a} vs {limit}");
                }
            }
        }
    }

    #[test]
    fn lambertian_albedo_is_the_diffuse_colour() {
        let m = Material { diffuse: Vec3::splat(0.8), ..Material::default() };
        let a = albedo(&m, Vec3::new(0.6, 0.8, 0.0));
        assert!((a - Vec3::splat(0.8)).abs().max_element() < 1e-3, "{a}");
    }

    #[test]
    fn energy_check_names_the_channel() {
        let m =
            Material { diffuse: Vec3::new(0.5, 0.9, 0.5), mirror: Vec3::splat(0.2), ..Material::default() };
        let err = m.check_energy().unwrap_err();
        assert!(err.contains("1.100 in the green channel"), "{err}");
    }
}
