//! Linear RGB images and their output files.

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};

/// A linear RGB image, row-major from the top-left pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` linear RGB values.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// The pixel at column `x`, row `y` (row 0 is the top).
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// 8-bit sRGB for display: each value times `2^exposure`, clamped to
    /// `[0, 1]` and gamma-encoded.
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        let scale = exposure.exp2();
        self.pixels
            .iter()
            .flat_map(|p| p.to_array().map(|c| (linear_to_srgb(c * scale) * 255.0).round() as u8))
            .collect()
    }

    /// Writes the image in the format its extension names: `.png` is
    /// display-ready 8-bit sRGB after `exposure` (in stops); `.exr` and `.hdr`
    /// keep the linear radiance values as they are (exposure is not applied).
    ///
    /// The file is encoded in memory and written whole or not at all (see
    /// [`crate::files::write_whole`]): a full disk is an error, and never
    /// leaves a truncated image behind.
    pub fn save(&self, path: &Path, exposure: f32) -> Result<()> {
        let mut encoded = std::io::Cursor::new(Vec::new());
        let result = match output_format(path)? {
            image::ImageFormat::Png => {
                image::RgbImage::from_raw(self.width, self.height, self.to_srgb8(exposure))
                    .expect("buffer size matches the image")
                    .write_to(&mut encoded, image::ImageFormat::Png)
            }
            linear => {
                let data = self.pixels.iter().flat_map(|p| p.to_array()).collect();
                image::Rgb32FImage::from_raw(self.width, self.height, data)
                    .expect("buffer size matches the image")
                    .write_to(&mut encoded, linear)
            }
        };
        result.map_err(|e| image_error(path, "cannot write image", e))?;
        crate::files::write_whole(path, encoded.get_ref())
    }

    /// Checks before any work that `path` names an image format [`Image::save`]
    /// writes and a place it can be written.
    pub fn check_output(path: &Path) -> Result<()> {
        output_format(path)?;
        crate::files::check_writable(path)
    }

    /// Whether a file of this name holds linear radiance (`.exr`, `.hdr`)
    /// rather than display values (PNG: exposed, clamped, sRGB-encoded).
    pub fn holds_radiance(path: &Path) -> bool {
        path.extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("exr") || e.eq_ignore_ascii_case("hdr"))
    }

    /// The first pixel (column, row) that is NaN or infinite, and how many are.
    pub fn non_finite(&self) -> Option<((u32, u32), usize)> {
        let first = self.pixels.iter().position(|p| !p.is_finite())?;
        let count = self.pixels.iter().filter(|p| !p.is_finite()).count();
        Some(((first as u32 % self.width, first as u32 / self.width), count))
    }

    /// Reads an image: `.exr` and `.hdr` as the linear values they hold, other
    /// formats (PNG) decoded from sRGB to linear.
    pub fn load(path: &Path) -> Result<Image> {
        crate::files::check_regular(path)?;
        let decoded = image::open(path).map_err(|e| image_error(path, "cannot read image", e))?;
        let is_linear = Image::holds_radiance(path);
        let rgb = decoded.to_rgb32f();
        let pixels = rgb
            .pixels()
            .map(
                |p| if is_linear { Vec3::from_array(p.0) } else { Vec3::from_array(p.0.map(srgb_to_linear)) },
            )
            .collect();
        Ok(Image { width: rgb.width(), height: rgb.height(), pixels })
    }
}

/// How far one image is from a reference, per channel value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Difference {
    /// Root mean squared error.
    pub rmse: f64,
    /// Mean of `(a - b)^2 / (b^2 + 0.01)` (relative MSE, as in the rendering
    /// literature; the 0.01 keeps black pixels from dominating).
    pub rel_mse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// Mean of the image and of the reference (all channels).
    pub means: (f64, f64),
}

impl Image {
    /// The difference of this image from `reference`; `None` if the sizes differ.
    pub fn difference(&self, reference: &Image) -> Option<Difference> {
        self.difference_where(reference, &vec![true; self.pixels.len()])
    }

    /// The difference of this image from `reference` over the pixels where
    /// `mask` is true (one flag per pixel, row-major); `None` if the sizes
    /// differ or the mask selects no pixel.
    pub fn difference_where(&self, reference: &Image, mask: &[bool]) -> Option<Difference> {
        if (self.width, self.height) != (reference.width, reference.height)
            || mask.len() != self.pixels.len()
            || !mask.contains(&true)
        {
            return None;
        }
        let n = (mask.iter().filter(|&&m| m).count() * 3) as f64;
        let (mut se, mut rel, mut ae, mut ma, mut mb) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let selected = self.pixels.iter().zip(&reference.pixels).zip(mask).filter(|(_, &m)| m);
        for ((a, b), _) in selected {
            for (x, y) in a.to_array().into_iter().zip(b.to_array()) {
                let (x, y) = (x as f64, y as f64);
                se += (x - y) * (x - y);
                rel += (x - y) * (x - y) / (y * y + 0.01);
                ae += (x - y).abs();
                ma += x;
                mb += y;
            }
        }
        Some(Difference { rmse: (se / n).sqrt(), rel_mse: rel / n, mae: ae / n, means: (ma / n, mb / n) })
    }

    /// Which pixels are fireflies: brighter (mean of the channels) than 10
    /// times the median of their 3 x 3 neighbourhood (themselves included;
    /// at the border, the neighbours there are). One flag per pixel.
    pub fn fireflies(&self) -> Vec<bool> {
        let (w, h) = (self.width as i64, self.height as i64);
        let value = |x: i64, y: i64| self.pixels[(y * w + x) as usize].element_sum() / 3.0;
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let mut around: Vec<f32> = (-1..=1)
                    .flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy)))
                    .filter(|&(nx, ny)| (0..w).contains(&nx) && (0..h).contains(&ny))
                    .map(|(nx, ny)| value(nx, ny))
                    .collect();
                around.sort_by(f32::total_cmp);
                value(x, y) > 10.0 * around[around.len() / 2]
            })
            .collect()
    }

    /// How many pixels are fireflies ([`Image::fireflies`]) here but not in
    /// `reference`; `None` if the sizes differ.
    pub fn fireflies_beyond(&self, reference: &Image) -> Option<usize> {
        if (self.width, self.height) != (reference.width, reference.height) {
            return None;
        }
        Some(
            self.fireflies()
                .iter()
                .zip(reference.fireflies())
                .filter(|&(&here, there)| here && !there)
                .count(),
        )
    }

    /// A false-colour picture of where this image differs from `reference`:
    /// black where equal, through blue and green to red at `scale` or more
    /// (absolute difference, averaged over channels).
    pub fn error_image(&self, reference: &Image, scale: f32) -> Image {
        let pixels = self
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(a, b)| {
                let e = ((*a - *b).abs().element_sum() / 3.0 / scale).clamp(0.0, 1.0);
                // A simple ramp: blue -> green -> red.
                Vec3::new((2.0 * e - 1.0).max(0.0), 1.0 - (2.0 * e - 1.0).abs(), (1.0 - 2.0 * e).max(0.0))
                    * e.sqrt()
            })
            .collect();
        Image { width: self.width, height: self.height, pixels }
    }
}

fn image_error(path: &Path, doing: &str, e: image::ImageError) -> Error {
    match e {
        image::ImageError::IoError(io) => Error::io(path, io),
        other => Error::Image { path: path.to_path_buf(), message: format!("{doing}: {other}") },
    }
}

/// The format an output file's extension names.
fn output_format(path: &Path) -> Result<image::ImageFormat> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("png") => Ok(image::ImageFormat::Png),
        Some("exr") => Ok(image::ImageFormat::OpenExr),
        Some("hdr") => Ok(image::ImageFormat::Hdr),
        _ => Err(Error::Image {
            path: path.to_path_buf(),
            message: "unknown image format; name the file .png, .exr or .hdr".into(),
        }),
    }
}

/// Inverse of [`linear_to_srgb`] on `[0, 1]`.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB transfer function, with clamping to `[0, 1]`.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        // 18% grey encodes to about 46%.
        assert!((linear_to_srgb(0.18) - 0.4614).abs() < 1e-3);
        assert_eq!(linear_to_srgb(f32::NAN), 0.0);
        assert_eq!(linear_to_srgb(7.0), linear_to_srgb(1.0));
        for c in [0.0, 0.002, 0.1, 0.5, 1.0] {
            assert!((srgb_to_linear(linear_to_srgb(c)) - c).abs() < 1e-5);
        }
    }

    #[test]
    fn linear_formats_round_trip_and_unknown_ones_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let pixels = (0..6).map(|i| Vec3::new(i as f32 * 2.5, 0.125, 1e-3)).collect();
        let image = Image { width: 3, height: 2, pixels };
        let exr = dir.path().join("a.exr");
        image.save(&exr, 3.0).unwrap();
        assert_eq!(Image::load(&exr).unwrap(), image, "EXR keeps linear f32 values, no exposure");
        let hdr = dir.path().join("a.hdr");
        image.save(&hdr, 0.0).unwrap();
        let back = Image::load(&hdr).unwrap();
        for (a, b) in back.pixels.iter().zip(&image.pixels) {
            assert!((*a - *b).abs().max_element() <= 0.01 * b.max_element(), "{a} vs {b}");
        }
        let err = image.save(&dir.path().join("a.jpg"), 0.0).unwrap_err().to_string();
        assert!(err.contains(".png, .exr or .hdr"), "{err}");
    }

    #[test]
    fn differences_are_measured() {
        let a = Image { width: 2, height: 1, pixels: vec![Vec3::ONE, Vec3::ZERO] };
        let b = Image { width: 2, height: 1, pixels: vec![Vec3::ONE, Vec3::splat(0.5)] };
        let d = a.difference(&b).unwrap();
        assert!((d.rmse - (0.125f64).sqrt()).abs() < 1e-9 && (d.mae - 0.25).abs() < 1e-9);
        assert_eq!(a.difference(&a).unwrap().rmse, 0.0);
        assert!(a.difference(&Image { width: 1, height: 1, pixels: vec![Vec3::ONE] }).is_none());
        assert_eq!(a.error_image(&a, 1.0).pixels, vec![Vec3::ZERO; 2]);
        // Over the second pixel alone: every channel off by 0.5.
        let d = a.difference_where(&b, &[false, true]).unwrap();
        assert!((d.rmse - 0.5).abs() < 1e-9 && (d.means.1 - 0.5).abs() < 1e-9);
        assert_eq!(a.difference_where(&b, &[true, false]).unwrap().rmse, 0.0);
        assert!(a.difference_where(&b, &[false, false]).is_none());
        assert!(a.difference_where(&b, &[true]).is_none());
    }

    #[test]
    fn fireflies_are_pixels_far_above_their_neighbourhood() {
        // A grey 5 x 4 image with one pixel 11x its surroundings (a firefly),
        // one 9x (not), and a bright pair side by side on the bottom row
        // (each sees the other among its six neighbours there: the median
        // stays grey, so both count).
        let mut pixels = vec![Vec3::splat(0.1); 20];
        pixels[6] = Vec3::splat(1.1);
        pixels[8] = Vec3::splat(0.9);
        pixels[16] = Vec3::splat(2.0);
        pixels[17] = Vec3::splat(2.0);
        let image = Image { width: 5, height: 4, pixels };
        let flagged: Vec<usize> =
            image.fireflies().iter().enumerate().filter(|(_, &f)| f).map(|(i, _)| i).collect();
        assert_eq!(flagged, vec![6, 16, 17]);
        // Against a reference that has the pair too, only the lone pixel counts.
        let mut pixels = vec![Vec3::splat(0.1); 20];
        pixels[16] = Vec3::splat(2.0);
        pixels[17] = Vec3::splat(2.0);
        let reference = Image { width: 5, height: 4, pixels };
        assert_eq!(image.fireflies_beyond(&reference), Some(1));
        assert_eq!(
            image.fireflies_beyond(&Image { width: 4, height: 5, pixels: vec![Vec3::ZERO; 20] }),
            None
        );
    }

    #[test]
    fn exposure_scales_by_powers_of_two() {
        let quarter = Image { width: 1, height: 1, pixels: vec![Vec3::splat(0.25)] };
        let half = Image { width: 1, height: 1, pixels: vec![Vec3::splat(0.5)] };
        assert_eq!(quarter.to_srgb8(2.0), vec![255, 255, 255]);
        assert_eq!(quarter.to_srgb8(1.0), half.to_srgb8(0.0));
    }
}
