//! `cargo bench --bench photons`: what skipping and aiming photon work saves.
//!
//! 1. A caustic pass on a scene with no mirror or glass stores nothing; the
//!    renderer skips it. This times the pass anyway (diffuse-only Cornell box).
//! 2. Caustic photons from point lights are aimed at mirrors and glass. On a
//!    ball lens 20 radii from a point light, uniform emission would send
//!    R^2 / (4 d^2) = 1/1600 of the photons at the ball.

use std::path::Path;
use std::time::Instant;

use caustix::accel::Backend;
use caustix::photon::{trace, Pass};
use caustix::query::SceneQuery;
use caustix::scene::Scene;

const BALL: &str = r#"
[camera]
eye = [0, 5, 5]
look_at = [0, 0, 0]
[materials.glass]
transmittance = 1
ior = 1.5
[materials.white]
diffuse = 0.8
[[point_light]]
position = [6, 21.0788, 0]
power = 1000
[[sphere]]
center = [0, 2, 0]
radius = 1
subdivisions = 6
material = "glass"
[[quad]]
center = [0, 0.4, 0]
u = [8, 0, 0]
v = [0, 0, -8]
material = "white"
"#;

fn main() {
    let cornell = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml"))
        .expect("scenes/cornell.toml")
        .replace("transmittance = 1.0\nior = 1.5", "diffuse = 0.5")
        .replace("mirror = 0.95", "diffuse = 0.5");
    let scene = Scene::from_toml(&cornell, Path::new("cornell-diffuse.toml")).expect("valid scene");
    assert!(!scene.materials.iter().any(|m| m.is_specular()), "the spheres were made diffuse");
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).expect("embree");
    let start = Instant::now();
    let stored =
        trace(&SceneQuery::new(&scene, accel.as_ref()), Pass::Caustic, 200_000, 16, 0, scene.config.sampler)
            .0
            .len();
    println!(
        "caustic pass on the diffuse-only Cornell box (skipped by the renderer): {:.3} s for 200000 photons, {stored} stored",
        start.elapsed().as_secs_f64()
    );

    let scene = Scene::from_toml(BALL, Path::new("ball.toml")).expect("valid scene");
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).expect("embree");
    let start = Instant::now();
    let stored =
        trace(&SceneQuery::new(&scene, accel.as_ref()), Pass::Caustic, 400_000, 16, 3, scene.config.sampler)
            .0
            .len();
    println!(
        "ball lens, caustic photons aimed at the ball: {stored} stored of 400000 emitted in {:.3} s \
         (uniform emission: about {} would reach the ball)",
        start.elapsed().as_secs_f64(),
        400_000 / 1600
    );
}
