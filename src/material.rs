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

    /// Checks energy conservation; the message names the worst channel.
    pub fn check_energy(&self) -> Result<(), String> {
        let total = self.total_reflectance();
        let (channel, worst) = ["red", "green", "blue"]
            .into_iter()
            .zip(total.to_array())
            .fold(
                ("red", f32::MIN),
                |best, c| if c.1 > best.1 { c } else { best },
            );
        if worst > 1.0 + 1e-6 {
            return Err(format!(
                "diffuse + specular + mirror + transmittance is {worst:.3} in the {channel} channel; \
                 it must be at most 1 or the surface would create light"
            ));
        }
        Ok(())
    }
}
