//! File -> scene -> Embree -> image, end to end: pixels that must be hit are
//! hit, pixels that must be missed are missed.

mod common;

use std::path::Path;

use caustix::accel::embree::EmbreeIntersector;
use caustix::config::IntegratorKind as Integrator;
use caustix::scene::Scene;
use caustix::{render, RenderConfig};
use common::{caustix, write, QUAD_SCENE};
use glam::Vec3;

/// How the backend names itself: the Embree major version of this build.
const EMBREE: &str = if cfg!(feature = "embree4") { "embree 4." } else { "embree 3." };

/// Whether pixel (x, y) of the 64x64 quad scene lies on the quad.
fn on_quad(x: u32, y: u32) -> bool {
    (16..48).contains(&x) && (16..48).contains(&y)
}

/// The quad scene rendered with `integrator`.
fn preview(integrator: Integrator) -> (Scene, caustix::Image) {
    let scene = Scene::from_toml(QUAD_SCENE, Path::new("quad.toml")).unwrap();
    let accel = EmbreeIntersector::build(&scene.triangle_views()).unwrap();
    let settings = RenderConfig { integrator, ..scene.config.clone() };
    let rendered = render(&scene, &accel, &settings, &|_| {}).unwrap();
    assert_eq!(rendered.stats.rays.closest, 64 * 64);
    drop(accel);
    (scene, rendered.film.beauty())
}

#[test]
fn quad_covers_exactly_the_expected_pixels() {
    let (scene, image) = preview(Integrator::Normals);
    // The quad faces +z, straight at the camera: normal colour 0.5 * (n + 1)
    // dimmed by 0.3 + 0.7 * cos(angle to the viewer).
    for y in 0..64 {
        for x in 0..64 {
            let p = image.get(x, y);
            if on_quad(x, y) {
                let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, 64, 64);
                let expected = Vec3::new(0.5, 0.5, 1.0) * (0.3 + 0.7 * ray.dir.dot(-Vec3::Z));
                assert!(p.abs_diff_eq(expected, 1e-5), "pixel ({x}, {y}) is {p}, expected {expected}");
            } else {
                assert_eq!(p, Vec3::ZERO, "pixel ({x}, {y}) should miss");
            }
        }
    }
}

#[test]
fn depth_preview_gets_nearer_towards_the_centre() {
    let (_, image) = preview(Integrator::Depth);
    let centre = image.get(32, 32).x;
    let corner = image.get(16, 16).x;
    assert!(centre > corner && corner > 0.0, "centre {centre}, corner {corner}");
    assert_eq!(image.get(0, 0), Vec3::ZERO);
}

/// `caustix render` of the quad scene's normals to a PNG, with `extra`
/// flags; returns the run's stderr (after checking it succeeded), the PNG's
/// path and the folder holding both.
fn render_quad_normals(extra: &[&str]) -> (String, std::path::PathBuf, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let out = dir.path().join("out.png");
    let mut args = vec![
        "render".as_ref(),
        scene.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--integrator".as_ref(),
        "normals".as_ref(),
    ];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    let run = caustix(&args);
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(run.status.success(), "{stderr}");
    (stderr, out, dir)
}

#[test]
fn cli_builds_embrees_compact_bvh_when_asked() {
    let (stderr, _, _dir) = render_quad_normals(&["--bvh", "compact"]);
    assert!(stderr.contains("(compact BVH)"), "summary names the layout: {stderr}");
}

#[test]
fn cli_renders_a_png_and_reports_what_it_did() {
    let (stderr, out, _dir) = render_quad_normals(&[]);
    assert!(stderr.contains(EMBREE), "summary names the backend: {stderr}");
    let png = image::open(&out).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (64, 64));
    assert_eq!(png.get_pixel(0, 0).0, [0, 0, 0]);
    assert_eq!(png.get_pixel(63, 63).0, [0, 0, 0]);
    let centre = png.get_pixel(32, 32).0;
    assert!(centre[2] > 250 && centre[0] > 150 && centre[0] < 200, "centre pixel {centre:?}");
}

#[test]
fn cli_size_flags_override_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let out = dir.path().join("small.png");
    let args = ["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out.as_os_str()];
    let run = caustix(
        &[&args[..], &["--width".as_ref(), "20".as_ref(), "--height".as_ref(), "10".as_ref()]].concat(),
    );
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(image::open(&out).unwrap().to_rgb8().dimensions(), (20, 10));
}

/// What the CLI prints rendering `scene` with `integrator` at 16 x 16 and a
/// sample a pixel into `out`; the render must succeed.
fn small_render_stderr(scene: &Path, integrator: &str, out: &Path) -> String {
    let args = ["render", "--integrator", integrator, "--width", "16", "--height", "16", "--spp", "1"];
    let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
    let run = caustix(&[&args[..], &[scene.as_os_str(), "-o".as_ref(), out.as_os_str()]].concat());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    String::from_utf8_lossy(&run.stderr).into_owned()
}

/// A point light in a glass bulb lights the quad only through the glass:
/// the path tracer and Whitted render it black, and say so before they
/// start. With the bulb in view, bidirectional path tracing leaves out the
/// quad seen through the glass, and light tracing all that is seen in it;
/// with the bulb behind the camera they carry everything and say nothing.
/// The integrators that carry all of it say nothing; `info` gives the
/// shares.
#[test]
fn cli_warns_when_the_integrator_leaves_out_a_lights_light_through_glass() {
    let dir = tempfile::tempdir().unwrap();
    let bulb_at = |z: f32| {
        let bulb = format!(
            "[materials.glass]\ntransmittance = 1.0\n[[sphere]]\ncenter = [0, 0, {z}]\nradius = 0.3\nmaterial = \"glass\"\n"
        );
        let scene = QUAD_SCENE.replace("position = [0, 0, 4]", &format!("position = [0, 0, {z}]"));
        write(dir.path(), &format!("bulb-{z}.toml"), &format!("{scene}\n{bulb}"))
    };
    let (seen, behind) = (bulb_at(4.0), bulb_at(5.5));
    let out = dir.path().join("bulb.png");
    let through_glass =
        "100.0% of the scene's light goes from point or spot lights straight to mirrors or glass";
    for scene in [&seen, &behind] {
        for integrator in ["path", "whitted"] {
            let stderr = small_render_stderr(scene, integrator, &out);
            let leaves_out = format!("the {integrator} integrator leaves all of it out");
            assert!(stderr.contains(through_glass) && stderr.contains(&leaves_out), "{stderr}");
        }
        for integrator in ["sppm", "vcm", "photon"] {
            assert!(!small_render_stderr(scene, integrator, &out).contains("warning"), "{integrator}");
        }
    }
    let bdpt = small_render_stderr(&seen, "bdpt", &out);
    let bdpt_leaves =
        "the bdpt integrator leaves that light out where it is seen in a mirror or through glass";
    assert!(bdpt.contains(through_glass) && bdpt.contains(bdpt_leaves), "{bdpt}");
    let light = small_render_stderr(&seen, "light", &out);
    assert!(light.contains("the light integrator leaves out all that is seen in them"), "{light}");
    for integrator in ["bdpt", "light"] {
        assert!(!small_render_stderr(&behind, integrator, &out).contains("warning"), "{integrator}");
    }
    let info = caustix(&["info".as_ref(), seen.as_os_str()]);
    let stdout = String::from_utf8_lossy(&info.stdout);
    assert!(stdout.contains("caustics  100.0% of the light goes from point or spot lights"), "{stdout}");
    assert!(stdout.contains("of the view is mirrors or glass"), "{stdout}");
    let info = caustix(&["info".as_ref(), behind.as_os_str()]);
    assert!(!String::from_utf8_lossy(&info.stdout).contains("of the view"));
}

/// A scene with lights that renders black (here its light is shut inside a
/// closed sphere) gets a warning; one with light in it, and a preview
/// (which shows no light), do not.
#[test]
fn cli_warns_when_a_scene_with_lights_renders_black() {
    let dir = tempfile::tempdir().unwrap();
    let shell = "[[sphere]]\ncenter = [0, 0, 4]\nradius = 0.3\nmaterial = \"white\"\n";
    let shut = write(dir.path(), "shut.toml", &format!("{QUAD_SCENE}\n{shell}"));
    let open = write(dir.path(), "open.toml", QUAD_SCENE);
    let out = dir.path().join("out.png");
    let stderr_of = |scene: &Path, integrator: &str| small_render_stderr(scene, integrator, &out);
    for integrator in ["path", "photon"] {
        let stderr = stderr_of(&shut, integrator);
        assert!(stderr.contains("shut.toml: every pixel is black"), "{integrator}: {stderr}");
        assert!(!stderr_of(&open, integrator).contains("black"), "{integrator}");
    }
    assert!(!stderr_of(&shut, "normals").contains("black"));
}

#[test]
fn cli_info_lists_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let run = caustix(&["info".as_ref(), scene.as_os_str()]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success());
    for expected in ["2 triangles, 4 vertices in 1 meshes", "white", "point at [0, 0, 4]", EMBREE] {
        assert!(stdout.contains(expected), "missing `{expected}` in:\n{stdout}");
    }
    // Of many lights, the first eight and a count (a mesh file's emitting
    // faces may make a million).
    let many: String =
        (0..10).map(|i| format!("[[point_light]]\nposition = [{i}, 1, 4]\npower = 1\n")).collect();
    let scene = write(dir.path(), "many.toml", &format!("{QUAD_SCENE}\n{many}"));
    let run = caustix(&["info".as_ref(), scene.as_os_str()]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.contains("lights    11\n"), "{stdout}");
    assert_eq!(stdout.matches("  point at").count(), 8, "{stdout}");
    assert!(stdout.contains("  and 3 more\n"), "{stdout}");
}

#[test]
fn shipped_scenes_load() {
    for name in ["teapot", "cornell", "ring"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.toml"));
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(scene.triangle_count() > 0 && !scene.lights.is_empty(), "{name}");
        assert!(scene.warnings.is_empty(), "{name}: {:?}", scene.warnings);
    }
}

#[test]
fn cli_bench_rays_prints_a_table_for_every_method() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let run = caustix(&[
        "bench".as_ref(),
        "rays".as_ref(),
        scene.as_os_str(),
        "--width".as_ref(),
        "32".as_ref(),
        "--height".as_ref(),
        "32".as_ref(),
        "--repeats".as_ref(),
        "1".as_ref(),
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    for row in ["| primary | 1024 |", "| shadow |", "| diffuse |", "embree direct", "native bvh: build"] {
        assert!(stdout.contains(row), "missing `{row}` in:\n{stdout}");
    }
    // All methods found the same hits (the report flags any difference).
    assert!(!stdout.contains("hits differ"), "{stdout}");
}

#[test]
fn cli_compare_measures_differences_and_refuses_mismatched_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let render = |name: &str, width: &str| {
        let out = dir.path().join(name);
        let run = caustix(&[
            "render".as_ref(),
            scene.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--width".as_ref(),
            width.as_ref(),
            "--height".as_ref(),
            "16".as_ref(),
        ]);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        out
    };
    let (a, b, small) = (render("a.exr", "16"), render("b.exr", "16"), render("c.exr", "8"));
    let same = caustix(&["compare".as_ref(), a.as_os_str(), b.as_os_str()]);
    let stdout = String::from_utf8_lossy(&same.stdout);
    assert!(same.status.success() && stdout.contains("rmse     0.000000"), "{stdout}");
    assert!(stdout.contains("identical yes"), "{stdout}");
    // One value off by one unit in the last place: not identical, though the
    // rounded figures show no difference.
    let mut nudged = caustix::Image::load(&a).unwrap();
    nudged.pixels[100].y = f32::from_bits(nudged.pixels[100].y.to_bits() + 1);
    let d = dir.path().join("d.exr");
    nudged.save(&d, 0.0).unwrap();
    let other = caustix(&["compare".as_ref(), a.as_os_str(), d.as_os_str()]);
    let stdout = String::from_utf8_lossy(&other.stdout);
    assert!(
        stdout.contains("rmse     0.000000") && stdout.contains("identical no: 1 of 768 values differ"),
        "{stdout}"
    );
    let err_png = dir.path().join("err.png");
    let with_image = caustix(&[
        "compare".as_ref(),
        a.as_os_str(),
        b.as_os_str(),
        "--error-image".as_ref(),
        err_png.as_os_str(),
    ]);
    assert!(with_image.status.success() && err_png.exists());
    let bad = caustix(&["compare".as_ref(), a.as_os_str(), small.as_os_str()]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("differ in size: 16x16 and 8x16"));
}

/// A library caller gets the command line's checks: a setting out of range
/// is an error naming it, not a panic deep inside a render.
#[test]
fn the_library_refuses_settings_out_of_range() {
    let scene = Scene::from_toml(QUAD_SCENE, Path::new("quad.toml")).unwrap();
    let accel = EmbreeIntersector::build(&scene.triangle_views()).unwrap();
    let mut no_samples = scene.config.clone();
    no_samples.samples = 0;
    let mut no_passes = RenderConfig { integrator: Integrator::Sppm, ..scene.config.clone() };
    no_passes.photons.sppm.passes = 0;
    for (config, name) in [(no_samples, "samples"), (no_passes, "passes")] {
        match render(&scene, &accel, &config, &|_| {}) {
            Err(caustix::Error::Setting { name: found, message }) => {
                assert_eq!(found, name);
                assert!(message.contains("from 1 to"), "{message}");
            }
            other => panic!("{name} = 0 must be refused, got {:?}", other.map(|r| r.stats)),
        }
    }
}
