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
    /// An image from whole rows.
    pub fn from_rows(width: u32, height: u32, rows: Vec<Vec<Vec3>>) -> Image {
        let pixels: Vec<Vec3> = rows.into_iter().flatten().collect();
        assert_eq!(
            pixels.len(),
            width as usize * height as usize,
            "rows do not fill the image"
        );
        Image {
            width,
            height,
            pixels,
        }
    }

    /// The pixel at column `x`, row `y` (row 0 is the top).
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// 8-bit sRGB: linear values clamped to `[0, 1]` and gamma-encoded.
    pub fn to_srgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| {
                p.to_array()
                    .map(|c| (linear_to_srgb(c) * 255.0).round() as u8)
            })
            .collect()
    }

    /// Writes a PNG (sRGB, 8 bits per channel).
    pub fn save_png(&self, path: &Path) -> Result<()> {
        let buffer = image::RgbImage::from_raw(self.width, self.height, self.to_srgb8())
            .expect("buffer size matches the image");
        buffer
            .save_with_format(path, image::ImageFormat::Png)
            .map_err(|e| match e {
                image::ImageError::IoError(io) => Error::io(path, io),
                other => Error::Image {
                    path: path.to_path_buf(),
                    message: other.to_string(),
                },
            })
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
    }
}
