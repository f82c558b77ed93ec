//! Vertex connection and merging and its special cases, light tracing and
//! bidirectional path tracing: against an exact answer, against the path
//! tracer with glass and a mirror, on a caustic the path tracer cannot see,
//! and the same image whatever the thread count.

mod common;

use std::f32::consts::PI;

use caustix::accel::Backend;
use caustix::config::IntegratorKind as Integrator;
use caustix::film::{Aov, Image};
use caustix::scene::Scene;
use caustix::{render, RenderConfig, Rendered};

const BIDIRECTIONAL: [Integrator; 3] = [Integrator::Light, Integrator::Bdpt, Integrator::Vcm];

fn render_with(scene: &Scene, integrator: Integrator, samples: u32, size: u32) -> Rendered {
    let settings = RenderConfig { integrator, samples, width: size, height: size, ..scene.config.clone() };
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    render(scene, accel.as_ref(), &settings, &|_| {}).unwrap()
}

fn mean(image: &Image) -> f32 {
    image.pixels.iter().map(|p| p.element_sum() / 3.0).sum::<f32>() / image.pixels.len() as f32
}

/// Means of `block x block` squares of pixels.
fn blocks(image: &Image, block: u32) -> Vec<f32> {
    let (w, h) = (image.width / block, image.height / block);
    (0..w * h)
        .map(|b| {
            let (bx, by) = (b % w * block, b / w * block);
            let mut sum = 0.0;
            for y in by..by + block {
                for x in bx..bx + block {
                    sum += image.pixels[(y * image.width + x) as usize].element_sum() / 3.0;
                }
            }
            sum / (block * block) as f32
        })
        .collect()
}

/// Inside a closed grey sphere around a point light every surface sends
/// `a / pi * power / ((1 - a) area)`: direct light and all bounces.
#[test]
fn the_furnace_comes_out_exact() {
    let albedo = 0.5;
    let scene = common::furnace(albedo, "");
    let exact = albedo / PI * 100.0 / ((1.0 - albedo) * common::mesh_area(&scene));
    for integrator in BIDIRECTIONAL {
        let image = render_with(&scene, integrator, 16, 16).film.beauty();
        let m = mean(&image);
        eprintln!("{integrator:?}: mean {m:.5} vs exact {exact:.5} ({:+.2}%)", 100.0 * (m / exact - 1.0));
        assert!((m / exact - 1.0).abs() < 0.02, "{integrator:?}: {m} vs {exact}");
    }
}

/// The Cornell box with a glass and a mirror sphere under an area light:
/// every path the path tracer finds, the others find with the same weight.
#[test]
fn agrees_with_the_path_tracer_on_glass_and_a_mirror() {
    let scene =
        Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.toml")))
            .unwrap();
    let reference_film = render_with(&scene, Integrator::Path, 4096, 32).film;
    let reference = reference_film.beauty();
    let reference_blocks = blocks(&reference, 8);
    for integrator in [Integrator::Bdpt, Integrator::Vcm] {
        let film = render_with(&scene, integrator, 256, 32).film;
        // Each component: the paths are sorted the same way, whichever
        // technique made them. The caustic is the slowest to converge
        // without merging (its rare camera paths through the glass to the
        // light are large): bidirectional path tracing's mean at this size
        // came out -8.0% and -3.1% off the path tracer's at 256 passes (seeds
        // 0 and 1), -3.3% and -2.8% at 1024, -0.9% and +0.3% at 4096; VCM's
        // -1.7% at 256.
        let caustic = if integrator == Integrator::Bdpt { 0.12 } else { 0.05 };
        for (aov, tolerance) in
            [(Aov::Emission, 0.02), (Aov::Direct, 0.02), (Aov::Caustic, caustic), (Aov::Indirect, 0.03)]
        {
            let (m, r) = (mean(&film.image(aov)), mean(&reference_film.image(aov)));
            eprintln!("{integrator:?} {aov:?}: {m:.5} vs {r:.5} ({:+.2}%)", 100.0 * (m / r - 1.0));
            assert!((m / r - 1.0).abs() < tolerance, "{integrator:?} {aov:?}: {m} vs the path tracer's {r}");
        }
        let image = film.beauty();
        let ratio = mean(&image) / mean(&reference);
        let worst = blocks(&image, 8)
            .iter()
            .zip(&reference_blocks)
            .map(|(b, r)| (b / r - 1.0).abs())
            .fold(0.0, f32::max);
        eprintln!("{integrator:?}: mean ratio {ratio:.4}, worst 8x8 block {:.2}%", 100.0 * worst);
        assert!((ratio - 1.0).abs() < 0.01, "{integrator:?}: mean ratio {ratio}");
        assert!(worst < 0.05, "{integrator:?}: a block is {worst} off");
    }
}

/// A diffuse sphere of 80 triangles with smooth normals, in the box of
/// lights. Light subpaths run the other way to the camera's, and a BSDF on
/// shading normals is not symmetric, so they take Veach's correction
/// (`adjoint_shading`); and the light tracer's join to the camera asks only
/// that the eye be on the surface's side, not in the shading normal's
/// hemisphere (at the outline it may not be, and the path tracer still
/// shows the light there). Before, bidirectional path tracing and VCM
/// showed the outline dark: the image's mean 0.9931 of the path tracer's
/// (0.9960 with the correction alone, 0.9941 with the join alone); now
/// 0.9992-1.0007 over seeds 0-2.
/// The light tracer showed the facets' pattern: the middle 6 x 6 pixels
/// 1.037 (seed 0) and 1.049 (seed 2) at 16,384 samples, now 1.003 and
/// 1.017 (seed 1: 0.990); it is the noisiest here, hence its tolerance.
#[test]
fn a_smooth_sphere_of_few_triangles_agrees_with_the_path_tracer() {
    let text = format!(
        "[camera]\neye = [0, 0, 1.8]\nlook_at = [0, 0, 0]\nfov = 70\n[materials.grey]\ndiffuse = 0.8\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nsubdivisions = 1\nmaterial = \"grey\"\n{}",
        common::box_of_lights()
    );
    let scene = Scene::from_toml(&text, std::path::Path::new("few.toml")).unwrap();
    let middle = |image: &Image| common::middle_of_12x12().map(|i| image.pixels[i].x).sum::<f32>() / 36.0;
    let reference = render_with(&scene, Integrator::Path, 1024, 12).film.beauty();
    let (reference_middle, reference_mean) = (middle(&reference), mean(&reference));
    // The light tracer is the noisiest: more samples, and room for its noise.
    for (integrator, samples, tolerance) in
        [(Integrator::Light, 16384, 0.03), (Integrator::Bdpt, 4096, 0.004), (Integrator::Vcm, 4096, 0.004)]
    {
        let image = render_with(&scene, integrator, samples, 12).film.beauty();
        let (m, all) = (middle(&image) / reference_middle, mean(&image) / reference_mean);
        eprintln!("{integrator:?}: the middle {m:.4}, the image {all:.4} of the path tracer's");
        for (part, ratio) in [("middle", m), ("image", all)] {
            assert!(
                (ratio - 1.0).abs() < tolerance,
                "{integrator:?}: the {part} at {ratio} of the path tracer's"
            );
        }
    }
}

/// A point light's caustic off a mirror ring, seen directly and reflected
/// in the ring (`L S D S E`): no connection of subpaths makes the second,
/// so bidirectional path tracing comes out darker, while merging finds it
/// and agrees with progressive photon mapping.
#[test]
fn merging_finds_the_caustic_seen_in_a_mirror() {
    let scene =
        Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/ring.toml"))).unwrap();
    let mut sppm =
        RenderConfig { integrator: Integrator::Sppm, width: 32, height: 32, ..scene.config.clone() };
    sppm.photons.sppm.passes = 256;
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let reference = mean(&render(&scene, accel.as_ref(), &sppm, &|_| {}).unwrap().film.beauty());
    let vcm = mean(&render_with(&scene, Integrator::Vcm, 256, 32).film.beauty());
    let bdpt = mean(&render_with(&scene, Integrator::Bdpt, 256, 32).film.beauty());
    eprintln!(
        "sppm {reference:.5}, vcm {vcm:.5} ({:+.2}%), bdpt {bdpt:.5} ({:+.2}%)",
        100.0 * (vcm / reference - 1.0),
        100.0 * (bdpt / reference - 1.0)
    );
    assert!((vcm / reference - 1.0).abs() < 0.015, "vcm {vcm} vs sppm {reference}");
    assert!(bdpt / reference < 0.98, "bdpt {bdpt}: the scene should need merging");
}

#[test]
fn the_image_does_not_depend_on_the_threads() {
    let scene =
        Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.toml")))
            .unwrap();
    let images: Vec<Vec<glam::Vec3>> = [1, 2]
        .iter()
        .map(|&threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| render_with(&scene, Integrator::Vcm, 2, 48).film.beauty().pixels)
        })
        .collect();
    assert!(images[0]
        .iter()
        .zip(&images[1])
        .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)));
}

/// The furnace from 1e-12 to 1e9 times the size (scenes go to 1e12), with
/// the power scaled to keep the radiance: the weights (products of squared
/// densities and distances) must not overflow or vanish. (With them in
/// `f32`, the image at 1e-12 came out black.)
#[test]
fn the_furnace_comes_out_exact_at_any_scale() {
    let albedo = 0.5;
    let exact = albedo / PI * 100.0 / ((1.0 - albedo) * common::mesh_area(&common::furnace(albedo, "")));
    for scale in [1e-12f64, 1e-6, 1e6, 1e9] {
        let scene = common::furnace_scaled(albedo, scale, "");
        for integrator in [Integrator::Bdpt, Integrator::Vcm] {
            let m = mean(&render_with(&scene, integrator, 16, 16).film.beauty());
            eprintln!(
                "x{scale:e} {integrator:?}: mean {m:.5} vs exact {exact:.5} ({:+.2}%)",
                100.0 * (m / exact - 1.0)
            );
            assert!((m / exact - 1.0).abs() < 0.02, "x{scale:e} {integrator:?}: {m} vs {exact}");
        }
    }
}
