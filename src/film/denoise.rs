//! Denoising with Intel Open Image Denoise (OIDN), behind the cargo feature
//! `denoise`. Without it, [`denoise`] says how to get it.
//!
//! OIDN's `RT` filter takes the linear HDR image and, as guides, the albedo
//! and shading normal of the first diffuse or glossy surface (followed
//! through mirrors and glass: [`crate::film::Sample`]). The guides are
//! passed as noisy (OIDN's `cleanAux` off): the path tracer picks one branch
//! at glass, so its albedo seen through a glass sphere is noisy at low
//! sample counts, and OIDN then keeps some of the beauty's detail instead of
//! trusting the guides' edges.

use crate::error::{Error, Result};
use crate::film::Image;

/// Why a build without the feature cannot denoise, and what to do.
pub const NOT_BUILT: &str = "needs caustix built with `--features denoise` (Intel Open Image Denoise \
2.x; see the README's section on denoising)";

/// `beauty` (linear radiance, HDR) filtered by OIDN's `RT` filter, guided by
/// `albedo` (and `normal`, which OIDN takes only with an albedo).
///
/// `emission`, when given, is the part of `beauty` that lights seen
/// directly (or through mirrors and glass) make: it is kept out of the
/// filter and added back as it is. A light's radiance seen by a camera ray
/// is exact, not an estimate, and tens of times brighter than the surfaces
/// around it: filtered with them, a light's edges smear into the ceiling (at
/// 1 spp on the Cornell box that alone made the denoised image's RMSE worse
/// than the noisy one's).
///
/// The other images must be the beauty's size; the guides are clamped to
/// the ranges OIDN expects (albedo to `[0, 1]`, normal components to
/// `[-1, 1]`). Errors: OIDN's own message (no CPU device, unsupported
/// processor, out of memory), an image that is not finite or not the
/// beauty's size, or a build without the `denoise` feature.
pub fn denoise(
    beauty: &Image,
    emission: Option<&Image>,
    albedo: Option<&Image>,
    normal: Option<&Image>,
) -> Result<Image> {
    let failed = |message: String| Error::Denoise { message };
    if normal.is_some() && albedo.is_none() {
        return Err(failed(
            "a normal guide needs an albedo guide too (OIDN takes normals only with albedo)".into(),
        ));
    }
    let images = [("image", Some(beauty)), ("emission", emission), ("albedo", albedo), ("normal", normal)];
    for (name, image) in images {
        let Some(image) = image else { continue };
        if (image.width, image.height) != (beauty.width, beauty.height) {
            return Err(failed(format!(
                "the {name} is {}x{} but the image is {}x{}",
                image.width, image.height, beauty.width, beauty.height
            )));
        }
        if let Some(((x, y), count)) = image.non_finite() {
            return Err(failed(format!(
                "the {name} has {count} NaN or infinite values (the first at pixel ({x}, {y}))"
            )));
        }
    }
    let albedo = albedo.map(|a| flat(a, 0.0, 1.0));
    let normal = normal.map(|n| flat(n, -1.0, 1.0));
    let scattered: Vec<f32> = match emission {
        Some(e) => beauty.pixels.iter().zip(&e.pixels).flat_map(|(b, e)| (*b - *e).to_array()).collect(),
        None => flat(beauty, f32::MIN, f32::MAX),
    };
    let pixels =
        filter(beauty.width as usize, beauty.height as usize, &scattered, albedo, normal).map_err(failed)?;
    let mut denoised = Image {
        width: beauty.width,
        height: beauty.height,
        pixels: pixels.chunks_exact(3).map(|c| glam::Vec3::new(c[0], c[1], c[2])).collect(),
    };
    if let Some(e) = emission {
        for (out, e) in denoised.pixels.iter_mut().zip(&e.pixels) {
            *out += *e;
        }
    }
    if let Some(((x, y), count)) = denoised.non_finite() {
        return Err(failed(format!(
            "Open Image Denoise returned {count} NaN or infinite values (the first at pixel ({x}, {y}))"
        )));
    }
    Ok(denoised)
}

/// The image as OIDN's packed `float3` rows, each value clamped to `[min, max]`.
fn flat(image: &Image, min: f32, max: f32) -> Vec<f32> {
    image.pixels.iter().flat_map(|p| p.to_array().map(|c| c.clamp(min, max))).collect()
}

#[cfg(feature = "denoise")]
fn filter(
    width: usize,
    height: usize,
    color: &[f32],
    albedo: Option<Vec<f32>>,
    normal: Option<Vec<f32>>,
) -> std::result::Result<Vec<f32>, String> {
    let oidn_error = |e: oidn::Error| format!("Open Image Denoise: {e}");
    let device = oidn::Device::new().map_err(oidn_error)?;
    let mut filter = oidn::RayTracing::try_new(&device).map_err(oidn_error)?;
    filter.image_dimensions(width, height).hdr(true).srgb(false).clean_aux(false);
    match (albedo, normal) {
        (Some(albedo), Some(normal)) => {
            let albedo = device.create_buffer(&albedo).map_err(oidn_error)?;
            let normal = device.create_buffer(&normal).map_err(oidn_error)?;
            filter.albedo_normal_buffer(albedo, normal).map_err(oidn_error)?;
        }
        (Some(albedo), None) => {
            let albedo = device.create_buffer(&albedo).map_err(oidn_error)?;
            filter.albedo_buffer(albedo).map_err(oidn_error)?;
        }
        _ => {}
    }
    let mut output = vec![0.0; color.len()];
    filter.filter(color, &mut output).map_err(oidn_error)?;
    Ok(output)
}

#[cfg(not(feature = "denoise"))]
fn filter(
    _width: usize,
    _height: usize,
    _color: &[f32],
    _albedo: Option<Vec<f32>>,
    _normal: Option<Vec<f32>>,
) -> std::result::Result<Vec<f32>, String> {
    Err(format!("denoising {NOT_BUILT}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn image(width: u32, height: u32, value: Vec3) -> Image {
        Image { width, height, pixels: vec![value; (width * height) as usize] }
    }

    #[test]
    fn guides_of_another_size_or_not_finite_are_refused_before_oidn() {
        let beauty = image(8, 4, Vec3::ONE);
        let small = image(4, 4, Vec3::ONE);
        let e = denoise(&beauty, None, Some(&small), None).unwrap_err().to_string();
        assert!(e.contains("albedo is 4x4 but the image is 8x4"), "{e}");
        let e = denoise(&beauty, None, None, Some(&beauty)).unwrap_err().to_string();
        assert!(e.contains("needs an albedo"), "{e}");
        let mut nan = beauty.clone();
        nan.pixels[5].y = f32::NAN;
        let e = denoise(&nan, None, None, None).unwrap_err().to_string();
        assert!(e.contains("the image has 1 NaN or infinite values (the first at pixel (5, 0))"), "{e}");
    }

    #[cfg(not(feature = "denoise"))]
    #[test]
    fn without_the_feature_it_says_how_to_get_it() {
        let beauty = image(2, 2, Vec3::ONE);
        let e = denoise(&beauty, None, None, None).unwrap_err().to_string();
        assert!(e.contains("--features denoise"), "{e}");
    }

    #[cfg(feature = "denoise")]
    #[test]
    fn a_flat_image_stays_flat_and_noise_is_removed() {
        // A constant image is a fixed point of any sensible denoiser; a
        // constant image with salt-and-pepper noise comes out closer to it.
        let (w, h) = (64, 64);
        let flat = image(w, h, Vec3::splat(0.5));
        let albedo = image(w, h, Vec3::splat(0.8));
        let normal = image(w, h, Vec3::Z);
        let out = denoise(&flat, None, Some(&albedo), Some(&normal)).unwrap();
        let d = out.difference(&flat).unwrap();
        assert!(d.rmse < 0.01, "a flat image changed by RMSE {}", d.rmse);

        let mut noisy = flat.clone();
        let mut state = 1u32;
        for p in noisy.pixels.iter_mut() {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            *p *= (state >> 8) as f32 / (1 << 24) as f32 * 2.0;
        }
        let before = noisy.difference(&flat).unwrap().rmse;
        let after =
            denoise(&noisy, None, Some(&albedo), Some(&normal)).unwrap().difference(&flat).unwrap().rmse;
        assert!(after < 0.25 * before, "RMSE {before} before denoising, {after} after");

        // Emission passes through untouched: a lone bright pixel that is all
        // emission comes out as it went in.
        let mut lit = flat.clone();
        let mut emission = image(w, h, Vec3::ZERO);
        emission.pixels[w as usize * 10 + 10] = Vec3::splat(50.0);
        lit.pixels[w as usize * 10 + 10] += Vec3::splat(50.0);
        let out = denoise(&lit, Some(&emission), Some(&albedo), Some(&normal)).unwrap();
        let lone = out.pixels[w as usize * 10 + 10];
        assert!((lone - Vec3::splat(50.5)).abs().max_element() < 0.01, "{lone}");
        assert!((out.pixels[w as usize * 10 + 11] - Vec3::splat(0.5)).abs().max_element() < 0.01);
    }
}
