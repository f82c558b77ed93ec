//! Progressive photon mapping against an exact answer: indirect light inside
//! a closed sphere converges, pass by pass, with no bias left over; and the
//! image does not depend on the thread count.

mod common;

use std::f32::consts::PI;

use caustix::accel::Backend;
use caustix::config::IntegratorKind as Integrator;
use caustix::integrator::sppm::Progressive;
use caustix::integrator::Context;
use caustix::scene::Scene;
use caustix::{render, RenderConfig, Rendered};

/// The furnace of `common::furnace`, seen at 16 x 16 by progressive
/// photon mapping with 20,000 photons per pass.
fn furnace(albedo: f32) -> Scene {
    common::furnace(
        albedo,
        r#"
        [image]
        width = 16
        height = 16
        [photons]
        pass_photons = 20000
        sppm_radius = 0.4
        "#,
    )
}

fn sppm(scene: &Scene, passes: u32) -> Rendered {
    let mut settings = RenderConfig { integrator: Integrator::Sppm, ..scene.config.clone() };
    settings.photons.sppm.passes = passes;
    render_as(scene, &settings)
}

/// `scene` rendered by `config` with Embree.
fn render_as(scene: &Scene, config: &RenderConfig) -> Rendered {
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    render(scene, accel.as_ref(), config, &|_| {}).unwrap()
}

/// Measured (alpha 0.8): mean per-pixel error of the indirect light 3.30%,
/// 1.93%, 0.99% and image mean +0.82%, +0.35%, -0.17% off exact at 4, 16,
/// 64 passes (earlier, at 0.7: 3.66%, 1.92%, 1.30% and -0.99%, -0.37%,
/// -0.07%).
#[test]
fn indirect_light_converges_to_the_exact_answer() {
    let albedo = 0.5;
    let scene = furnace(albedo);
    let exact = albedo / PI * 100.0 * albedo / ((1.0 - albedo) * common::mesh_area(&scene));
    let (mut errors, mut means) = (Vec::new(), Vec::new());
    for passes in [4, 16, 64] {
        let global = sppm(&scene, passes).film.image(caustix::film::Aov::Indirect);
        let n = global.pixels.len() as f32;
        let mean = global.pixels.iter().map(|p| p.x).sum::<f32>() / n;
        let error = global.pixels.iter().map(|p| (p.x / exact - 1.0).abs()).sum::<f32>() / n;
        eprintln!(
            "{passes} passes: mean {mean:.5} vs exact {exact:.5} ({:+.2}%), per-pixel error {:.2}%",
            100.0 * (mean / exact - 1.0),
            100.0 * error
        );
        assert!((mean / exact - 1.0).abs() < 0.03, "{passes} passes: mean {mean} vs {exact}");
        errors.push(error);
        means.push(mean);
    }
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "error must keep falling: {errors:?}");
    // With alpha = 0.8 the error falls about as passes^(-alpha / 2) (Knaus
    // and Zwicker 2011): 16x the passes, 0.33x the error (measured 0.30x;
    // at 0.7, 0.38x and 0.36x). A plateau from bias would stop it; ask for
    // at least half.
    assert!(errors[2] < errors[0] * 0.5, "{errors:?}");
    // Meanwhile the bias of the mean has gone.
    assert!((means[2] / exact - 1.0).abs() < 0.01, "64 passes: mean {} vs {exact}", means[2]);
}

#[test]
fn the_image_does_not_depend_on_the_thread_count() {
    let scene = furnace(0.5);
    let with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| sppm(&scene, 3)).film.pixels
    };
    let one = with(1);
    assert!(one.iter().any(|c| c.indirect.x > 0.0), "photons must reach the pixels");
    assert_eq!(one, with(2));
    assert_eq!(one, with(3));
}

#[test]
fn cli_renders_progressively_and_says_what_it_did() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::write(dir.path(), "quad.toml", common::QUAD_SCENE);
    let out = dir.path().join("out.exr");
    let run = common::caustix(&[
        "render".as_ref(),
        scene.as_os_str(),
        "--integrator".as_ref(),
        "sppm".as_ref(),
        "--passes".as_ref(),
        "3".as_ref(),
        "--pass-photons".as_ref(),
        "1000".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("3000 emitted in 3 passes of 1000"), "{stderr}");
    assert!(stderr.contains("Sppm, 3 spp"), "{stderr}");
    // The quad is lit directly: the centre pixel is bright, the corner black.
    let image = caustix::Image::load(&out).unwrap();
    assert!(image.get(32, 32).x > 0.0 && image.get(0, 0) == glam::Vec3::ZERO);
}

/// A time budget's last pass may be a part of one (a fraction of its
/// photons): it must weigh as that part, not as a whole pass. Four whole
/// passes and a tenth of one, in the furnace: the mean indirect light is
/// the exact answer within 3%, as four whole passes are above. Counting the
/// tenth as a whole pass makes it 19% low; giving each of its photons its
/// light's power over the tenth's own count (ten times a whole pass's
/// share), 18% high (both measured).
#[test]
fn a_part_of_a_pass_weighs_as_its_part() {
    let albedo = 0.5;
    let scene = furnace(albedo);
    let exact = albedo / PI * 100.0 * albedo / ((1.0 - albedo) * common::mesh_area(&scene));
    let settings = RenderConfig { integrator: Integrator::Sppm, ..scene.config.clone() };
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let mut run = Progressive::new(&Context::new(&scene, accel.as_ref(), &settings));
    for _ in 0..4 {
        run.run_pass();
    }
    run.run_part_of_pass(0.1);
    let rendered = run.rendered(std::time::Duration::ZERO);
    assert!(
        rendered.stats.notes.iter().any(|n| n.contains("the last of 2000")),
        "{:?}",
        rendered.stats.notes
    );
    let global = rendered.film.image(caustix::film::Aov::Indirect);
    let mean = global.pixels.iter().map(|p| p.x).sum::<f32>() / global.pixels.len() as f32;
    eprintln!("mean {mean:.5} vs exact {exact:.5} ({:+.2}%)", 100.0 * (mean / exact - 1.0));
    assert!((mean / exact - 1.0).abs() < 0.03, "mean {mean} vs {exact}");
}

/// With the Sobol sampler a pixel's camera paths over all passes stratify
/// its area, as the path tracer's samples do; independent jitter leaves
/// the pixels on a light's edge (partly light, partly wall) noisy. The
/// noise is measured as the difference between two seeds' direct light
/// over the Cornell box at 32 x 32 after 8 passes (16 paths a pixel).
/// Measured: 0.64 of the independent sampler's (0.45 with 4 paths a pass,
/// all in one stream, before the paths that leave visible points got a
/// stream of their own; BENCHMARKS.md, issue 16).
#[test]
fn sobol_camera_paths_stratify_each_pixel() {
    use caustix::film::Aov;
    use caustix::sampling::SamplerKind;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let scene = Scene::load(&path).unwrap();
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
    let direct = |sampler: SamplerKind, seed: u64| {
        let mut settings = RenderConfig {
            integrator: Integrator::Sppm,
            width: 32,
            height: 32,
            sampler,
            seed,
            ..scene.config.clone()
        };
        settings.photons.sppm.passes = 8;
        settings.photons.sppm.photons_per_pass = 2000;
        render(&scene, accel.as_ref(), &settings, &|_| {}).unwrap().film.image(Aov::Direct)
    };
    let spread = |sampler: SamplerKind| {
        let (a, b) = (direct(sampler, 1), direct(sampler, 2));
        let squares: f32 = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).length_squared()).sum();
        (squares / a.pixels.len() as f32).sqrt()
    };
    let (sobol, independent) = (spread(SamplerKind::Sobol), spread(SamplerKind::Independent));
    eprintln!("seed-to-seed RMSE of the direct light: sobol {sobol:.4}, independent {independent:.4}");
    assert!(sobol < 0.75 * independent, "sobol {sobol} against independent {independent}");
}

/// A sharp lobe (exponent 1000) in the closed box of lights of radiance 1
/// (`common::box_of_lights`).
fn shiny_glass_in_a_box_of_lights() -> Scene {
    common::shiny_glass(1000, 5000, &common::box_of_lights())
}

/// Camera paths follow a sharp glossy lobe instead of gathering photons
/// with it: the light the lobe reflects (straight from the lights, through
/// the glass, and off the lobe again inside it) agrees with the path
/// tracer in every component, with no speckle.
///
/// Measured, the middle's emission / direct / caustic / indirect: path
/// tracer (4,096 spp) 0.2556 / 0.4343 / 0.1131 / 0.1052; SPPM (256 passes)
/// 0.2555 / 0.4341 / 0.1127 / 0.1052, brightest pixel 1.007. Before, a
/// visible point on the lobe weighed the photons it found by the lobe's
/// peak: 0.2555 / 0.4503 / 0.1187 / 0.1252 (4.4% too bright in all), its
/// brightest pixel 3.2 where the lights are 1. With the light the lobe
/// finds through the glass classed as lights seen through glass, it was
/// lost at the lights' edges (the emission samples there find only
/// mirrors and glass): the middle 0.33 in all.
#[test]
fn sppm_follows_a_sharp_glossy_lobe_and_agrees_with_the_path_tracer() {
    let scene = shiny_glass_in_a_box_of_lights();
    let path_config = RenderConfig { integrator: Integrator::Path, samples: 4096, ..scene.config.clone() };
    let path = render_as(&scene, &path_config);
    common::assert_components_agree(&sppm(&scene, 256), &path, "sppm");
}

/// Where camera paths follow a glossy lobe, the point light's caustic
/// photons are still gathered by the lobe, at every such point a path
/// meets: the image agrees with VCM, which carries every path.
///
/// Measured, the middle's direct / caustic / indirect and all: VCM (4,096
/// spp) 0.0093 / 0.0176 / 0.0945, 0.1214; SPPM (256 passes) 0.0091 /
/// 0.0171 / 0.0960, 0.1222 (with the visible point's radius at every lobe
/// point, 0.0091 / 0.0164 / 0.0955, 0.1211). Not gathered: the caustic
/// 0.00002, all 0.1013. (Gathered only where the path stopped at the
/// surface, a tenth of the lobe's chance, the caustic's error was 3.3
/// times as large.)
#[test]
fn sppm_gathers_a_point_lights_caustic_where_it_follows_a_lobe() {
    let scene = common::shiny_glass_under_a_point_light();
    let vcm_config = RenderConfig { integrator: Integrator::Vcm, samples: 4096, ..scene.config.clone() };
    let vcm = render_as(&scene, &vcm_config);
    let progressive = sppm(&scene, 256);
    let ((expected, _), (found, _)) =
        (common::middle_components(&vcm), common::middle_components(&progressive));
    eprintln!("vcm {expected:?}, sppm {found:?}");
    let (e, f) = (expected.iter().sum::<f32>(), found.iter().sum::<f32>());
    assert!((f / e - 1.0).abs() < 0.02, "sppm {f}, vcm {e}");
}

/// A glass sphere with a sharp glossy coat (exponent 1000) and no diffuse
/// part, in a grey box under a spot light whose cone takes in only part of
/// it: the light the glass focuses onto the sphere's inside ends at the
/// cone's edge. A camera path that meets the coat's lobe gathers the
/// spot's caustic photons there within a radius of its own, the one a
/// visible point there would start with, shrinking pass by pass. With the
/// radius of the pixel's visible point (on the wall behind, where light is
/// thin) it gathered photons from far across that edge, each weighed by
/// the lobe at its own direction: a blot of light where there is none.
///
/// Measured (64 passes; VCM 1,024 spp merging within 0.03): the caustic
/// over the middle, SPPM 0.00004 (0.0227 before), VCM 0.00000; over the
/// whole image, SPPM 0.00068 (0.0064 before), VCM 0.00064.
#[test]
fn sppm_gathers_a_lobe_within_a_radius_of_its_own() {
    let spot = "[[spot_light]]\nposition = [0.6, 1.5, 1.2]\ndirection = [-0.6, -0.2, -1.2]\n\
                cone_angle = 25\nfalloff_start = 20\npower = 30";
    let coat = "specular = 0.3\nphong_exponent = 1000\ntransmittance = 0.3";
    let scene = common::sphere_seen_close(coat, 32, 20000, &common::grey_box_lit_by(spot));
    let mut vcm_config = RenderConfig { integrator: Integrator::Vcm, samples: 1024, ..scene.config.clone() };
    vcm_config.photons.sppm.initial_radius = Some(0.03);
    let vcm = render_as(&scene, &vcm_config);
    let progressive = sppm(&scene, 64);
    let caustic = |rendered: &Rendered, pixels: &[usize]| {
        let film = &rendered.film;
        pixels.iter().map(|&i| film.pixels[i].caustic.element_sum() / 3.0).sum::<f32>() / pixels.len() as f32
    };
    let (middle, all): (Vec<usize>, Vec<usize>) = (common::middle_of_12x12().collect(), (0..144).collect());
    let (vcm_middle, sppm_middle) = (caustic(&vcm, &middle), caustic(&progressive, &middle));
    let (vcm_all, sppm_all) = (caustic(&vcm, &all), caustic(&progressive, &all));
    eprintln!("caustic: middle vcm {vcm_middle}, sppm {sppm_middle}; all vcm {vcm_all}, sppm {sppm_all}");
    assert!(sppm_middle < vcm_middle + 0.1 * vcm_all, "middle: sppm {sppm_middle}, vcm {vcm_middle}");
    assert!((sppm_all / vcm_all - 1.0).abs() < 0.15, "all: sppm {sppm_all}, vcm {vcm_all}");
}
