//! Lights seen by the camera: a pixel a light's edge crosses converges
//! within a few camera samples, because the renderer takes more samples of
//! the lights alone there (`integrator::emission`), and stays unbiased.

use std::path::Path;

use caustix::accel::Backend;
use caustix::accel::Intersector;
use caustix::config::IntegratorKind;
use caustix::film::Film;
use caustix::integrator::{create, Context, Rendered};
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

/// The emission of `base`'s integrator alone, no refinement, at `samples`
/// a pixel.
fn alone(scene: &Scene, accel: &dyn Intersector, base: &RenderConfig, samples: u32) -> Vec<Vec3> {
    let config = RenderConfig { samples, ..base.clone() };
    let ctx = Context::new(scene, accel, &config);
    emission(&create(config.integrator).render(&ctx, &|_| {}).film)
}

/// Checks a render that refined its lights' edges: the note says so, its
/// emission's RMSE against `reference` is under `most` times `plain`'s,
/// and the light's total over the image is the reference's (unbiased).
fn check_refined(rendered: &Rendered, plain: &[Vec3], reference: &[Vec3], most: f64) {
    let notes = &rendered.stats.notes;
    assert!(notes.iter().any(|n| n.starts_with("lights' edges:")), "{notes:?}");
    let refined = emission(&rendered.film);
    let (before, after) = (rmse(plain, reference), rmse(&refined, reference));
    eprintln!("  emission RMSE {before:.4} alone, {after:.4} refined");
    assert!(after < most * before, "{after} against {before}; {notes:?}");
    let total = |e: &[Vec3]| e.iter().map(|v| v.element_sum() as f64).sum::<f64>();
    let ratio = total(&refined) / total(reference);
    assert!((ratio - 1.0).abs() < 0.01, "total emission {ratio} of the reference's; {notes:?}");
}

#[test]
fn a_lights_edge_converges_within_a_few_samples() {
    let scene = scene();
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let base =
        RenderConfig { width: 24, height: 24, integrator: IntegratorKind::Path, ..scene.config.clone() };
    let reference = alone(&scene, accel.as_ref(), &base, 4096);
    let plain = alone(&scene, accel.as_ref(), &base, 4);
    let lit = reference.iter().filter(|e| e.max_element() > 0.0).count();
    assert!(lit > 50, "the light covers {lit} pixels");
    for integrator in [IntegratorKind::Path, IntegratorKind::Photon, IntegratorKind::Sppm] {
        let mut config = RenderConfig { samples: 4, integrator, ..base.clone() };
        config.photons.sppm.passes = 2; // two camera paths a pass: 4 samples
        eprintln!("{integrator:?}, 4 samples a pixel");
        let rendered = caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap();
        check_refined(&rendered, &plain, &reference, 0.4);
    }
}

#[test]
fn a_time_budget_leaves_time_for_a_lights_edge() {
    // Rounds of camera samples (the path tracer) and SPPM's passes end in
    // time for the refinement, which averages its samples with each pixel's
    // own count. What is asserted does not hang on this machine's speed:
    // the refinement happened, it is unbiased, and it is better than as
    // many camera samples alone (some hundred a pixel here; the
    // refinement's are eight times as many).
    let scene = scene();
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let base =
        RenderConfig { width: 96, height: 96, integrator: IntegratorKind::Path, ..scene.config.clone() };
    // The reference: 1024 samples a pixel, and 8192 more at the edges
    // (the refinement the test above holds to the integrator alone), of
    // another seed: the same one's samples would be the renders' own.
    let config = RenderConfig { samples: 1024, seed: base.seed + 1, ..base.clone() };
    let reference = emission(&caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap().film);
    for integrator in [IntegratorKind::Path, IntegratorKind::Sppm] {
        let mut config = RenderConfig { integrator, time: Some(0.2), ..base.clone() };
        config.photons.sppm.photons_per_pass = 1_000;
        let rendered = caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap();
        let counts = rendered.stats.pixel_samples.as_ref().expect("each pixel's count");
        let mean = counts.iter().sum::<u32>() as f64 / counts.len() as f64;
        eprintln!("{integrator:?}: {mean:.1} samples a pixel");
        let plain = alone(&scene, accel.as_ref(), &base, mean.round() as u32);
        check_refined(&rendered, &plain, &reference, 0.6);
    }
}

#[test]
fn a_budget_overrun_leaves_a_lights_edge_its_fewest_samples() {
    // A budget of a millisecond: the first look and the first round of
    // camera samples (or pass) already take longer, so no time is left at
    // the end. The edge's pixels still take the fewest samples the rounds
    // plan for them (64), which cost little: without them, a pixel that
    // one camera sample of a few found on the light stays far too bright.
    let scene = scene();
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let base = RenderConfig { width: 24, height: 24, time: Some(0.001), ..scene.config.clone() };
    for integrator in [IntegratorKind::Path, IntegratorKind::Photon, IntegratorKind::Sppm] {
        let mut config = RenderConfig { integrator, ..base.clone() };
        config.photons.sppm.photons_per_pass = 1_000;
        let rendered = caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap();
        let notes = &rendered.stats.notes;
        let took = notes
            .iter()
            .find_map(|n| n.strip_prefix("lights' edges: "))
            .and_then(|n| n.split(" more samples").next()?.rsplit(' ').next()?.parse::<u32>().ok());
        assert!(took.is_some_and(|n| n >= 64), "{integrator:?}: {notes:?}");
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
