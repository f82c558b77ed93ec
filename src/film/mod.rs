//! The film: what a render produces. It owns the pixels, each split into
//! components (AOVs) with one meaning whatever the integrator, and turns
//! them into images and files.

pub mod image;

use std::ops::{AddAssign, Mul};
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::error::Result;
pub use image::Image;

/// Radiance at a pixel split by how the light got there. The final image is
/// the sum; each part can be written as its own image (an AOV).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct Components {
    /// Lights seen directly, and direct light at the first surface hit.
    pub direct: Vec3,
    /// Everything reaching the camera through mirror reflection or refraction.
    pub specular: Vec3,
    /// Caustics at the first surface hit: light focused onto it by mirrors
    /// and glass (the caustic map).
    pub caustic: Vec3,
    /// Indirect light at the first surface hit: light that bounced off a
    /// diffuse surface before (the global map, or final gathering).
    pub global: Vec3,
}

impl Components {
    /// Names accepted by `--aov`, in output order.
    pub const NAMES: [&'static str; 5] = ["direct", "specular", "caustic", "global", "final"];

    /// The sum of all parts.
    pub fn total(&self) -> Vec3 {
        self.direct + self.specular + self.caustic + self.global
    }

    /// Radiance emitted by a light and seen after `depth` specular bounces.
    pub fn emitted(radiance: Vec3, depth: u32) -> Components {
        if depth == 0 {
            Components { direct: radiance, ..Default::default() }
        } else {
            Components { specular: radiance, ..Default::default() }
        }
    }

    /// The part called `name` (one of [`Components::NAMES`]).
    pub fn get(&self, name: &str) -> Option<Vec3> {
        match name {
            "direct" => Some(self.direct),
            "specular" => Some(self.specular),
            "caustic" => Some(self.caustic),
            "global" => Some(self.global),
            "final" => Some(self.total()),
            _ => None,
        }
    }
}

impl AddAssign for Components {
    fn add_assign(&mut self, o: Components) {
        self.direct += o.direct;
        self.specular += o.specular;
        self.caustic += o.caustic;
        self.global += o.global;
    }
}

impl Mul<f32> for Components {
    type Output = Components;
    fn mul(self, k: f32) -> Components {
        Components {
            direct: self.direct * k,
            specular: self.specular * k,
            caustic: self.caustic * k,
            global: self.global * k,
        }
    }
}

/// The pixels of a render, row-major from the top left.
#[derive(Debug, Clone)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One value per pixel.
    pub pixels: Vec<Components>,
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Film {
        Film { width, height, pixels: vec![Components::default(); width as usize * height as usize] }
    }

    /// Sets the pixel at column `x`, row `y`.
    pub fn set(&mut self, x: u32, y: u32, value: Components) {
        self.pixels[(y * self.width + x) as usize] = value;
    }

    /// The image of one component (`"final"` for the whole).
    pub fn image(&self, name: &str) -> Option<Image> {
        let pixels = self.pixels.iter().map(|c| c.get(name)).collect::<Option<Vec<Vec3>>>()?;
        Some(Image { width: self.width, height: self.height, pixels })
    }

    /// The whole image: every component summed.
    pub fn beauty(&self) -> Image {
        self.image("final").expect("final is a component")
    }

    /// Writes the whole image to `output`, and each component in `aovs` beside
    /// it as `NAME-COMPONENT.EXT`; returns the component files written.
    /// `exposure` applies to PNG output (see [`Image::save`]).
    pub fn write(&self, output: &Path, aovs: &[String], exposure: f32) -> Result<Vec<PathBuf>> {
        self.beauty().save(output, exposure)?;
        let mut written = Vec::new();
        for name in aovs {
            let path = aov_path(output, name);
            let image = self.image(name).ok_or_else(|| crate::Error::Setting {
                name: "aov",
                message: format!("`{name}` is not a component; choose from {}", Components::NAMES.join(", ")),
            })?;
            image.save(&path, exposure)?;
            written.push(path);
        }
        Ok(written)
    }
}

/// `out.png` with component `direct` -> `out-direct.png`.
pub fn aov_path(output: &Path, name: &str) -> PathBuf {
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let extension = output.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    output.with_file_name(format!("{stem}-{name}{extension}"))
}
