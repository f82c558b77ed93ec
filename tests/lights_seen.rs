//! Lights seen by the camera: a pixel a light's edge crosses converges
//! within a few camera samples, because the renderer takes more samples of
//! the lights alone there (`integrator::emission`), and stays unbiased.

use std::path::Path;

use caustix::accel::Backend;
use caustix::config::IntegratorKind;
use caustix::film::Film;
use caustix::integrator::{create, Context};
use caustix::scene::Scene;
use caustix::RenderConfig;
use glam::Vec3;

/// A square light facing the camera, turned 30 degrees about the view axis
/// so its edges cross pixels slantwise, seen directly and in a mirror
/// below it; nothing else to see.
fn scene() -> Scene {
    let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let text = format!(
        r#"
        [camera]
        eye = [0, 0, 4]
        look_at = [0, 0, 0]
        fov = 40
        [materials.mirror]
        mirror = 0.9
        [[area_light]]              # u x v points at the camera
        center = [0, 0.3, 0]
        u = [{u0}, {u1}, 0]
        v = [{v0}, {v1}, 0]
        power = 5
        [[quad]]                    # a mirror tilted up at the light
        center = [0, -0.9, 0.5]
        u = [3, 0, 0]
        v = [0, 0.5, -0.6]
        material = "mirror"
    "#,
        u0 = 0.8 * c,
        u1 = 0.8 * s,
        v0 = -0.8 * s,
        v1 = 0.8 * c,
    );
    Scene::from_toml(&text, Path::new("light.toml")).unwrap()
}

/// The emission component of every pixel.
fn emission(film: &Film) -> Vec<Vec3> {
    film.pixels.iter().map(|p| p.emission).collect()
}

fn rmse(a: &[Vec3], b: &[Vec3]) -> f64 {
    let se: f64 = a.iter().zip(b).map(|(x, y)| (*x - *y).length_squared() as f64 / 3.0).sum();
    (se / a.len() as f64).sqrt()
}

#[test]
fn a_lights_edge_converges_within_a_few_samples() {
    let scene = scene();
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let base =
        RenderConfig { width: 24, height: 24, integrator: IntegratorKind::Path, ..scene.config.clone() };
    // The integrator alone, no refinement: the reference at 4096 samples,
    // and 4 samples.
    let alone = |samples: u32| {
        let config = RenderConfig { samples, ..base.clone() };
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        emission(&create(config.integrator).render(&ctx, &|_| {}).film)
    };
    let reference = alone(4096);
    let plain = alone(4);
    let lit = reference.iter().filter(|e| e.max_element() > 0.0).count();
    assert!(lit > 50, "the light covers {lit} pixels");
    for integrator in [IntegratorKind::Path, IntegratorKind::Photon, IntegratorKind::Sppm] {
        let mut config = RenderConfig { samples: 4, integrator, ..base.clone() };
        config.photons.sppm.passes = 2; // two camera paths a pass: 4 samples
        let rendered = caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap();
        let refined = emission(&rendered.film);
        let (before, after) = (rmse(&plain, &reference), rmse(&refined, &reference));
        eprintln!("{integrator:?}: emission RMSE {before:.4} at 4 samples alone, {after:.4} refined");
        assert!(after < 0.4 * before, "{integrator:?}: {after} against {before}");
        assert!(
            rendered.stats.notes.iter().any(|n| n.starts_with("lights' edges:")),
            "{:?}",
            rendered.stats.notes
        );
        // Unbiased: the light's total over the image is the reference's.
        let sum = |e: &[Vec3]| e.iter().map(|v| v.element_sum() as f64).sum::<f64>();
        let ratio = sum(&refined) / sum(&reference);
        assert!((ratio - 1.0).abs() < 0.01, "{integrator:?}: total emission {ratio} of the reference's");
    }
}

#[test]
fn pixels_away_from_a_lights_edge_are_left_alone() {
    // One sample goes through the pixel's centre: nothing to refine.
    let scene = scene();
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let config = RenderConfig { width: 24, height: 24, samples: 1, ..scene.config.clone() };
    let rendered = caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap();
    assert!(!rendered.stats.notes.iter().any(|n| n.starts_with("lights' edges:")));
    // With more, only pixels near an edge change: the light's inside and
    // the empty background keep the integrator's own values.
    let config = RenderConfig { samples: 4, ..config };
    let ctx = Context::new(&scene, accel.as_ref(), &config);
    let alone = emission(&create(config.integrator).render(&ctx, &|_| {}).film);
    let refined = emission(&caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap().film);
    let changed = alone.iter().zip(&refined).filter(|(a, b)| a != b).count();
    assert!(changed > 20, "{changed} pixels refined");
    assert!(changed < alone.len() / 3, "{changed} of {} pixels refined", alone.len());
}
