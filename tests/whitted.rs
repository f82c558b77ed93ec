//! The Whitted renderer against analytic answers: direct light from a point
//! light, a mirror, and the same image whatever the thread count; and the
//! shadow rays it, photon mapping and SPPM take at each surface.

mod common;

use std::f32::consts::PI;
use std::ffi::OsStr;
use std::path::Path;

use caustix::accel::embree::EmbreeIntersector;
use caustix::accel::{Backend, Intersector, Ray};
use caustix::config::IntegratorKind as Integrator;
use caustix::scene::Scene;
use caustix::{render, RenderConfig, Rendered};
use common::{caustix, write, QUAD_SCENE};
use glam::Vec3;

/// The backends every image test runs on.
fn backends(scene: &Scene) -> Vec<Box<dyn Intersector + '_>> {
    [Backend::Embree, Backend::Native]
        .map(|b| caustix::accel::build(b, &scene.triangle_views()).unwrap())
        .into()
}

fn whitted(scene: &Scene, accel: &dyn Intersector, samples: u32) -> Rendered {
    let settings = RenderConfig { integrator: Integrator::Whitted, samples, ..scene.config.clone() };
    render(scene, accel, &settings, &|_| {}).unwrap()
}

#[test]
fn diffuse_quad_under_a_point_light_has_the_analytic_radiance() {
    // QUAD_SCENE: a 5 x 5 quad at z = 0 with diffuse 0.8, a 100 W point light
    // at (0, 0, 4), the camera at (0, 0, 5) looking down -z with a 90 degree
    // view. At a point p of the quad, E = (100 / 4 pi) cos / d^2 with
    // cos = 4 / d, and the radiance towards the camera is 0.8 / pi * E.
    let scene = Scene::from_toml(QUAD_SCENE, Path::new("quad.toml")).unwrap();
    for accel in backends(&scene) {
        let image = whitted(&scene, accel.as_ref(), 1).film.beauty();
        let mut checked = 0;
        for y in 0..64 {
            for x in 0..64 {
                // The ray in the file's coordinates (the scene's are re-centred at the camera).
                let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, 64, 64);
                let ray = Ray { origin: common::in_file(&scene, ray.origin), ..ray };
                let t = -ray.origin.z / ray.dir.z;
                let p = ray.at(t);
                let expected = if p.x.abs() < 2.5 && p.y.abs() < 2.5 {
                    let d = (Vec3::new(0.0, 0.0, 4.0) - p).length();
                    let irradiance = 100.0 / (4.0 * PI) * (4.0 / d) / (d * d);
                    checked += 1;
                    0.8 / PI * irradiance
                } else {
                    0.0
                };
                let got = image.get(x, y);
                assert!(
                    (got - Vec3::splat(expected)).abs().max_element() <= 1e-4 * expected.max(1e-3),
                    "{}: pixel ({x}, {y}) is {got}, expected {expected}",
                    accel.name()
                );
            }
        }
        assert_eq!(checked, 32 * 32);
    }
}

#[test]
fn same_image_bit_for_bit_with_one_thread_and_with_many() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let scene = Scene::load(&path).unwrap();
    let accel = EmbreeIntersector::build(&scene.triangle_views()).unwrap();
    let mut settings = RenderConfig {
        width: 48,
        height: 40,
        samples: 4,
        light_samples: Some(2),
        integrator: Integrator::Photon,
        ..scene.config.clone()
    };
    // Photon mapping too: the maps must not depend on the thread count either.
    settings.photons.global_photons = 20_000;
    settings.photons.caustic_photons = 20_000;
    let with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render(&scene, &accel, &settings, &|_| {})).unwrap().film.pixels
    };
    let one = with(1);
    // Every component has something, so each is compared below.
    assert!(one.iter().any(|c| c.direct != Vec3::ZERO) && one.iter().any(|c| c.emission != Vec3::ZERO));
    assert!(one.iter().any(|c| c.caustic != Vec3::ZERO) && one.iter().any(|c| c.indirect != Vec3::ZERO));
    assert_eq!(one, with(4));
    assert_eq!(one, with(3));
}

/// A mirror facing a lit diffuse quad: what the camera sees in the mirror is
/// the quad's radiance times the mirror's reflectance. It is direct light
/// (light, diffuse wall, mirror, eye), the albedo is the wall's seen in the
/// mirror, and the depth is the mirror's.
#[test]
fn a_mirror_shows_what_it_faces_times_its_reflectance() {
    let scene_text = r#"
        [camera]
        eye = [0, 0, 5]
        look_at = [0, 0, 0]
        fov = 20
        [image]
        width = 8
        height = 8
        samples = 1
        [materials.mirror]
        mirror = 0.6
        [materials.white]
        diffuse = 0.8
        [[point_light]]
        position = [0, 0, 3]
        power = 100
        [[quad]]             # the mirror, facing the camera
        center = [0, 0, 0]
        u = [4, 0, 0]
        v = [0, 4, 0]
        material = "mirror"
        [[quad]]             # a big white wall behind the camera, facing the mirror
        center = [0, 0, 8]
        u = [0, 40, 0]
        v = [40, 0, 0]
        material = "white"
    "#;
    let scene = Scene::from_toml(scene_text, Path::new("mirror.toml")).unwrap();
    for accel in backends(&scene) {
        let rendered = whitted(&scene, accel.as_ref(), 1);
        for y in 0..8 {
            for x in 0..8 {
                // The camera ray reflects straight back to the wall at z = 8.
                let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, 8, 8);
                let ray = Ray { origin: common::in_file(&scene, ray.origin), ..ray };
                let p_mirror = ray.at(-ray.origin.z / ray.dir.z);
                let back = Vec3::new(ray.dir.x, ray.dir.y, -ray.dir.z);
                let p_wall = p_mirror + back * ((8.0 - p_mirror.z) / back.z);
                let to_light = Vec3::new(0.0, 0.0, 3.0) - p_wall;
                let d = to_light.length();
                let wall = 0.8 / PI * 100.0 / (4.0 * PI) * (-to_light.z / d) / (d * d);
                let c = rendered.film.pixels[(y * 8 + x) as usize];
                assert_eq!((c.emission, c.caustic, c.indirect), (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO));
                assert!(
                    (c.direct.x - 0.6 * wall).abs() < 1e-4 * wall,
                    "({x}, {y}): {} vs {}",
                    c.direct.x,
                    0.6 * wall
                );
                assert!(c.albedo.abs_diff_eq(Vec3::splat(0.6 * 0.8), 1e-6), "{}", c.albedo);
                assert!(
                    (c.normal + 0.6 * Vec3::Z).length() < 1e-3,
                    "the wall faces the mirror (-z): {}",
                    c.normal
                );
                assert!((c.depth - (p_mirror - ray.origin).length()).abs() < 1e-4, "{}", c.depth);
            }
        }
    }
}

#[test]
fn both_backends_render_the_cornell_box_alike() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let scene = Scene::load(&path).unwrap();
    let settings = RenderConfig {
        width: 64,
        height: 64,
        samples: 4,
        integrator: Integrator::Whitted,
        ..scene.config.clone()
    };
    let [a, b] = [Backend::Embree, Backend::Native].map(|backend| {
        let accel = caustix::accel::build(backend, &scene.triangle_views()).unwrap();
        render(&scene, accel.as_ref(), &settings, &|_| {}).unwrap().film.beauty()
    });
    // Same random streams, so only ties on edges can make pixels differ.
    let differing =
        a.pixels.iter().zip(&b.pixels).filter(|(p, q)| (**p - **q).abs().max_element() > 1e-4).count();
    let mean = |img: &caustix::Image| img.pixels.iter().sum::<Vec3>() / img.pixels.len() as f32;
    eprintln!("pixels differing: {differing} of {}", a.pixels.len());
    assert!(differing * 100 <= a.pixels.len(), "{differing} pixels differ");
    assert!((mean(&a) - mean(&b)).abs().max_element() < 1e-3 * mean(&a).max_element());
}

#[test]
fn both_backends_photon_map_the_cornell_box_alike() {
    // Photon paths branch on every tie, so pixels may differ; the images
    // must agree on average.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let scene = Scene::load(&path).unwrap();
    let mut settings = RenderConfig { width: 48, height: 48, samples: 2, ..scene.config.clone() };
    settings.integrator = Integrator::Photon;
    settings.photons.global_photons = 50_000;
    settings.photons.caustic_photons = 50_000;
    let [a, b] = [Backend::Embree, Backend::Native].map(|backend| {
        let accel = caustix::accel::build(backend, &scene.triangle_views()).unwrap();
        render(&scene, accel.as_ref(), &settings, &|_| {}).unwrap().film.beauty()
    });
    let mean = |img: &caustix::Image| img.pixels.iter().sum::<Vec3>() / img.pixels.len() as f32;
    let (ma, mb) = (mean(&a), mean(&b));
    eprintln!("mean radiance: embree {ma}, native {mb}");
    assert!((ma - mb).abs().max_element() < 0.01 * ma.max_element(), "{ma} vs {mb}");
}

#[test]
fn cli_writes_each_requested_component() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let out = dir.path().join("quad.exr");
    let run = caustix(&[
        "render".as_ref(),
        scene.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--aov".as_ref(),
        "direct,emission,albedo,depth".as_ref(),
        "--threads".as_ref(),
        "1".as_ref(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let load = |name: &str| caustix::Image::load(&dir.path().join(name)).unwrap();
    let (total, direct, emission) = (load("quad.exr"), load("quad-direct.exr"), load("quad-emission.exr"));
    assert!(emission.pixels.iter().all(|p| *p == Vec3::ZERO), "no light is in view");
    assert_eq!(total, direct, "a diffuse quad under a point light: all its light is direct");
    // The quad (diffuse 0.8, common/quad.toml) covers the middle 32x32 pixels, 5 units away.
    let (albedo, depth) = (load("quad-albedo.exr"), load("quad-depth.exr"));
    assert!(albedo.get(32, 32).abs_diff_eq(Vec3::splat(0.8), 1e-6) && albedo.get(0, 0) == Vec3::ZERO);
    assert!(
        (depth.get(31, 31).x - 5.0).abs() < 0.01 && depth.get(0, 0) == Vec3::ZERO,
        "{}",
        depth.get(31, 31)
    );
    assert!(stderr.contains("on 1 threads"), "{stderr}");
    let bad = caustix(&["render".as_ref(), scene.as_os_str(), "--aov".as_ref(), "glow".as_ref()]);
    assert_eq!(bad.status.code(), Some(2));
    let says = String::from_utf8_lossy(&bad.stderr);
    assert!(says.contains("invalid value 'glow'") && says.contains("indirect"), "{says}");
    // The previews draw no light and no albedo: asking for those is an
    // error, not a black file; their geometry components are written.
    for (integrator, aov, ok) in
        [("normals", "albedo", false), ("depth", "caustic", false), ("normals", "depth,normal", true)]
    {
        let out = dir.path().join(format!("{integrator}.exr"));
        let args = ["render", "--integrator", integrator, "--aov", aov, "-o"].map(OsStr::new);
        let run = caustix(&[&args[..1], &[scene.as_os_str()], &args[1..], &[out.as_os_str()]].concat());
        let says = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.success(), ok, "{integrator} --aov {aov}: {says}");
        if !ok {
            assert!(
                says.contains(&format!("--aov {aov}: the {integrator} integrator draws geometry")),
                "{says}"
            );
            assert!(!out.exists());
        }
    }
}

/// Shadow rays per area light at each surface a camera ray meets: four for
/// Whitted, whose samples are all its direct light gets; one for photon
/// mapping and SPPM, whose gather rays or passes hold most of the noise;
/// what the settings say for all three.
#[test]
fn shadow_rays_per_camera_ray_are_the_integrators_unless_told() {
    // A wall that fills the view, lit by a small area light beside the view:
    // every camera ray meets the wall, in the light.
    let scene_text = r#"
[camera]
eye = [0, 0, 3]
look_at = [0, 0, 0]
[materials.m]
diffuse = 0.5
[[quad]]
center = [0, 0, 0]
u = [10, 0, 0]
v = [0, 10, 0]
material = "m"
[[area_light]]
center = [2, 0, 1]
u = [0, 0.1, 0]
v = [0.1, 0, 0]
power = 1
"#;
    let scene = Scene::from_toml(scene_text, Path::new("lit-wall.toml")).unwrap();
    assert_eq!(scene.config.light_samples, None, "left to the integrator");
    let told =
        Scene::from_toml(&format!("[render]\nlight_samples = 3\n{scene_text}"), Path::new("told.toml"));
    assert_eq!(told.unwrap().config.light_samples, Some(3));
    let accel = caustix::accel::build(Backend::Native, &scene.triangle_views()).unwrap();
    // Camera rays: 6 pixels, 2 samples each (SPPM: 2 passes of 2 paths).
    for (integrator, light_samples, per_ray, camera_rays) in [
        (Integrator::Whitted, None, 4, 12),
        (Integrator::Photon, None, 1, 12),
        (Integrator::Sppm, None, 1, 24),
        (Integrator::Whitted, Some(3), 3, 12),
        (Integrator::Photon, Some(3), 3, 12),
        (Integrator::Sppm, Some(3), 3, 24),
    ] {
        let mut settings = RenderConfig {
            integrator,
            width: 3,
            height: 2,
            samples: 2,
            light_samples,
            ..scene.config.clone()
        };
        // No gather rays: the closest-hit rays are camera rays (and the
        // lights' edges' first look, which takes no shadow rays).
        settings.photons.gather_rays = 0;
        settings.photons.global_photons = 2_000;
        settings.photons.sppm.passes = 2;
        settings.photons.sppm.photons_per_pass = 2_000;
        let rendered = render(&scene, accel.as_ref(), &settings, &|_| {}).unwrap();
        let what = format!("{}, {light_samples:?}", integrator.name());
        assert!(rendered.film.pixels.iter().all(|c| c.direct.min_element() > 0.0), "{what}: unlit pixels");
        let rays = rendered.stats.rays;
        assert!(rays.closest >= camera_rays, "{what}: {rays:?}");
        assert_eq!(rays.shadow, camera_rays * per_ray, "{what}");
    }
}
