//! The film: what a render produces. It owns the pixels, each split into
//! components (AOVs) with one meaning whatever the integrator, and turns
//! them into images and files.

pub mod denoise;
pub mod image;
pub mod tile;

use std::ops::{AddAssign, Mul};
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::error::Result;
pub use image::Image;

/// One camera sample (or one pixel, averaged): the light that reaches the
/// camera split by the path it took, plus the geometry a denoiser wants.
/// Every integrator fills these with the same meaning. In Heckbert's
/// notation, with `E` the eye, `L` a light, `S` a mirror or glass bounce
/// and `D` a diffuse or glossy one:
///
/// - `emission`: lights seen directly or through mirrors and glass (`L S* E`);
/// - `direct`: light straight from a light, scattered once by a diffuse or
///   glossy surface (`L D S* E`);
/// - `caustic`: light focused by mirrors and glass onto a diffuse or glossy
///   surface (`L S+ D S* E`);
/// - `indirect`: light scattered by two or more diffuse or glossy surfaces
///   (`L .* D .* D S* E`), and the constant ambient term;
/// - `albedo` and `normal`: the diffuse-plus-glossy reflectance and the
///   shading normal (towards the camera) of the first diffuse or glossy
///   surface, seen through mirrors and glass (weighted by them);
/// - `depth`: distance from the camera to the first surface (0 where the
///   camera ray leaves the scene).
///
/// The final image is `emission + direct + caustic + indirect`.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Lights seen directly or through mirrors and glass.
    pub emission: Vec3,
    /// Direct light at diffuse and glossy surfaces.
    pub direct: Vec3,
    /// Caustics at diffuse and glossy surfaces.
    pub caustic: Vec3,
    /// Light that bounced diffusely more than once.
    pub indirect: Vec3,
    /// Reflectance of the first diffuse or glossy surface.
    pub albedo: Vec3,
    /// Shading normal of the first diffuse or glossy surface.
    pub normal: Vec3,
    /// Distance to the first surface.
    pub depth: f32,
}

/// An image a film can make: the final image or one component of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Aov {
    /// The final image: the sum of the four light components.
    Final,
    /// [`Sample::emission`].
    Emission,
    /// [`Sample::direct`].
    Direct,
    /// [`Sample::caustic`].
    Caustic,
    /// [`Sample::indirect`].
    Indirect,
    /// [`Sample::albedo`].
    Albedo,
    /// [`Sample::normal`], as stored: components in `[-1, 1]`.
    Normal,
    /// [`Sample::depth`], in scene units, in all three channels.
    Depth,
}

impl Aov {
    /// Every image, with the name `--aov` and file names use.
    pub const ALL: [(&'static str, Aov); 8] = [
        ("final", Aov::Final),
        ("emission", Aov::Emission),
        ("direct", Aov::Direct),
        ("caustic", Aov::Caustic),
        ("indirect", Aov::Indirect),
        ("albedo", Aov::Albedo),
        ("normal", Aov::Normal),
        ("depth", Aov::Depth),
    ];

    /// Its name.
    pub fn name(self) -> &'static str {
        Aov::ALL.iter().find(|(_, a)| *a == self).map_or("final", |(n, _)| n)
    }
}

impl std::str::FromStr for Aov {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Aov::ALL.iter().find(|(n, _)| *n == s).map(|(_, a)| *a).ok_or_else(|| {
            let names: Vec<&str> = Aov::ALL.iter().map(|(n, _)| *n).collect();
            format!("unknown component `{s}`; choose from {}", names.join(", "))
        })
    }
}

impl Sample {
    /// The final image's value: all the light.
    pub fn total(&self) -> Vec3 {
        self.emission + self.direct + self.caustic + self.indirect
    }

    /// The value of one image.
    pub fn get(&self, aov: Aov) -> Vec3 {
        match aov {
            Aov::Final => self.total(),
            Aov::Emission => self.emission,
            Aov::Direct => self.direct,
            Aov::Caustic => self.caustic,
            Aov::Indirect => self.indirect,
            Aov::Albedo => self.albedo,
            Aov::Normal => self.normal,
            Aov::Depth => Vec3::splat(self.depth),
        }
    }

    /// What this sample, met at the end of a mirror or glass bounce of
    /// `weight`, adds to the path before it: its light and its first diffuse
    /// surface's albedo scaled by the bounce (the normal by its mean), its
    /// depth left out (the depth is the camera ray's own).
    pub fn through(&self, weight: Vec3) -> Sample {
        Sample {
            emission: self.emission * weight,
            direct: self.direct * weight,
            caustic: self.caustic * weight,
            indirect: self.indirect * weight,
            albedo: self.albedo * weight,
            normal: self.normal * (weight.element_sum() / 3.0),
            depth: 0.0,
        }
    }
}

impl AddAssign for Sample {
    fn add_assign(&mut self, o: Sample) {
        self.emission += o.emission;
        self.direct += o.direct;
        self.caustic += o.caustic;
        self.indirect += o.indirect;
        self.albedo += o.albedo;
        self.normal += o.normal;
        self.depth += o.depth;
    }
}

impl Mul<f32> for Sample {
    type Output = Sample;
    fn mul(self, k: f32) -> Sample {
        Sample {
            emission: self.emission * k,
            direct: self.direct * k,
            caustic: self.caustic * k,
            indirect: self.indirect * k,
            albedo: self.albedo * k,
            normal: self.normal * k,
            depth: self.depth * k,
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
    pub pixels: Vec<Sample>,
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Film {
        Film { width, height, pixels: vec![Sample::default(); width as usize * height as usize] }
    }

    /// One image of the film.
    pub fn image(&self, aov: Aov) -> Image {
        Image {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|p| p.get(aov)).collect(),
        }
    }

    /// The final image.
    pub fn beauty(&self) -> Image {
        self.image(Aov::Final)
    }

    /// The final image denoised by Open Image Denoise, guided by the albedo
    /// and normal components, the emission component kept out of the filter
    /// (see [`denoise::denoise`]; needs the cargo feature `denoise`).
    pub fn denoised(&self) -> Result<Image> {
        denoise::denoise(
            &self.beauty(),
            Some(&self.image(Aov::Emission)),
            Some(&self.image(Aov::Albedo)),
            Some(&self.image(Aov::Normal)),
        )
    }

    /// Writes the final image to `output`, and each of `aovs` beside it as
    /// `NAME-COMPONENT.EXT`; returns the component files written. `exposure`
    /// applies to PNG output (see [`Image::save`]).
    pub fn write(&self, output: &Path, aovs: &[Aov], exposure: f32) -> Result<Vec<PathBuf>> {
        self.beauty().save(output, exposure)?;
        self.write_aovs(output, aovs, exposure)
    }

    /// Writes each of `aovs` beside `output` as `NAME-COMPONENT.EXT` (the
    /// final image itself is the caller's: noisy or denoised); returns the
    /// files written.
    pub fn write_aovs(&self, output: &Path, aovs: &[Aov], exposure: f32) -> Result<Vec<PathBuf>> {
        let mut written = Vec::new();
        for &aov in aovs {
            let path = aov_path(output, aov.name());
            self.image(aov).save(&path, exposure)?;
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
