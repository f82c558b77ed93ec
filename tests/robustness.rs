//! Hostile but legal input: every one ends in a correct result or one clear
//! error with a non-zero exit, never a panic, a hang, or a wrong file with
//! exit 0.

mod common;

use std::ffi::OsStr;
use std::process::{Command, Stdio};

use caustix::Image;
use common::{caustix, write, QUAD_SCENE};
use glam::Vec3;

/// `caustix ARGS` must fail with exit code 1 and an `error:` line saying `says`.
fn refused(args: &[&OsStr], says: &str) {
    let run = caustix(args);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(stderr.starts_with("error: ") && !stderr.contains("panicked"), "{args:?}: {stderr}");
    assert!(stderr.contains(says), "{args:?} should say `{says}`: {stderr}");
}

#[test]
fn a_reader_that_goes_away_ends_the_output_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let image = dir.path().join("a.exr");
    Image { width: 1, height: 1, pixels: vec![Vec3::ONE] }.save(&image, 0.0).unwrap();
    let image = image.to_str().unwrap();
    for args in [vec!["info", scene.to_str().unwrap()], vec!["compare", image, image]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_caustix"))
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take()); // `| head -0`: the pipe closes before anything is read
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert_eq!(out.status.code(), Some(0), "{args:?}: {stderr}");
    }
}

#[test]
fn outputs_are_checked_before_any_work_and_never_left_half_written() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let render = |out: &OsStr, says: &str| {
        refused(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out], says);
    };
    let missing = dir.path().join("no/such/folder/x.png");
    render(missing.as_os_str(), "does not exist");
    render(dir.path().join("x.jpg").as_os_str(), "name the file .png, .exr or .hdr");
    let folder = dir.path().join("folder.png");
    std::fs::create_dir(&folder).unwrap();
    render(folder.as_os_str(), "this is a folder");
    // A full disk used to be reported as success (/dev/full behaves as one).
    let full = dir.path().join("full.png");
    if std::os::unix::fs::symlink("/dev/full", &full).is_ok() && std::path::Path::new("/dev/full").exists() {
        render(full.as_os_str(), "No space left");
        std::fs::remove_file(&full).unwrap();
    }
    // The output is checked before the scene is even read.
    let absent = dir.path().join("absent.toml");
    refused(&["render".as_ref(), absent.as_os_str(), "-o".as_ref(), missing.as_os_str()], "does not exist");
    assert!(!missing.parent().unwrap().exists());
    // Nothing but the scene is left in the folder by the failures.
    let mut left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    left.sort();
    assert_eq!(left, ["folder.png", "quad.toml"].map(std::ffi::OsString::from));
}

#[test]
fn absurd_settings_are_refused_with_their_limits() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let out = dir.path().join("x.png");
    let with = |flag: &str, value: &str, says: &str| {
        let args = [
            "render".as_ref(),
            scene.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            flag.as_ref(),
            value.as_ref(),
        ];
        refused(&args, says);
    };
    with("--threads", "100000", "--threads must be from 1 to 1024, found 100000");
    // k = 1 used to be accepted and contribute nothing: the one photon only marks the radius.
    with("--global-k", "1", "--global-k must be from 2 to");
    with("--caustic-k", "1", "--caustic-k must be from 2 to");
    let text = QUAD_SCENE.replace("[image]", "[photons]\nglobal_k = 1\n\n[image]");
    let file = write(dir.path(), "k1.toml", &text);
    refused(&["info".as_ref(), file.as_os_str()], "k1.toml:7:12: expected a whole number from 2 to");
}

#[test]
fn only_regular_files_are_read() {
    let dir = tempfile::tempdir().unwrap();
    // /dev/zero used to be read for ever; a folder or a FIFO likewise never ends well.
    refused(&["info".as_ref(), "/dev/zero".as_ref()], "not a regular file");
    refused(&["info".as_ref(), dir.path().as_os_str()], "this is a folder");
    let fifo = dir.path().join("scene.fifo");
    if Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
        refused(&["info".as_ref(), fifo.as_os_str()], "not a regular file");
    }
    let mesh = QUAD_SCENE.to_string() + "\n[[mesh]]\nfile = \"/dev/zero\"\nmaterial = \"white\"\n";
    refused(&["info".as_ref(), write(dir.path(), "m.toml", &mesh).as_os_str()], "not a regular file");
}

#[test]
fn compare_refuses_what_it_cannot_measure() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);
    let good = Image { width: 2, height: 2, pixels: vec![Vec3::splat(0.5); 4] };
    good.save(&path("good.exr"), 0.0).unwrap();
    good.save(&path("good.png"), 0.0).unwrap();
    let mut nan = good.clone();
    nan.pixels[3] = Vec3::new(f32::NAN, 0.0, 0.0);
    nan.save(&path("nan.exr"), 0.0).unwrap();
    // NaN used to give an exit code of 0 and NaN figures.
    refused(
        &["compare".as_ref(), path("nan.exr").as_os_str(), path("good.exr").as_os_str()],
        "1 pixels are NaN or infinite, the first at (1, 1)",
    );
    // An unreadable image used to be reported as one that could not be written.
    std::fs::write(path("junk.exr"), b"not an image").unwrap();
    refused(
        &["compare".as_ref(), path("junk.exr").as_os_str(), path("good.exr").as_os_str()],
        "cannot read image",
    );
    // Display values against radiance: measured, with a word about the units.
    let run = caustix(&["compare".as_ref(), path("good.png").as_os_str(), path("good.exr").as_os_str()]);
    assert!(run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("one image is linear radiance"));
}

/// Requests that could not fit in memory are refused with figures before
/// anything is allocated (a 16384 x 16384 film and 10^8 photons used to
/// abort the program; teapot levels 0 and 1025 were accepted by export).
#[test]
fn what_would_not_fit_in_memory_is_refused_first() {
    let dir = tempfile::tempdir().unwrap();
    let cornell = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let out = dir.path().join("x.png");
    let render = |extra: &[&str], says: &str| {
        let mut args: Vec<&OsStr> =
            vec!["render".as_ref(), cornell.as_os_str(), "-o".as_ref(), out.as_os_str()];
        args.extend(extra.iter().map(|a| OsStr::new(*a)));
        refused(&args, says);
    };
    let memory = caustix::memory::available().unwrap_or(0) as u64;
    if memory < 40 << 30 {
        render(&["--width", "16384", "--height", "16384"], "--width is too large: the image needs about");
    }
    if memory < 30 << 30 {
        render(&["--photons", "100000000"], "--photons is too large: the photons need about");
    }
    assert!(!out.exists());
    let ply = dir.path().join("t.ply");
    let teapot = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/teapot.toml");
    for level in ["0", "1025"] {
        let args = ["export".as_ref(), teapot.as_os_str(), "-o".as_ref(), ply.as_os_str()];
        let mut args: Vec<&OsStr> = args.to_vec();
        args.extend(["--teapot-subdivisions".as_ref(), OsStr::new(level)]);
        refused(&args, "--teapot-subdivisions must be from 1 to 1024");
    }
}

/// Renders scene text through the library with `integrator` and `tweak`ed settings.
fn render_text(text: &str, integrator: &str, tweak: impl Fn(&mut caustix::RenderConfig)) -> Image {
    let scene = caustix::Scene::from_toml(text, std::path::Path::new("stress.toml")).unwrap();
    let accel = caustix::accel::build(caustix::accel::Backend::Embree, &scene.triangle_views()).unwrap();
    let mut config =
        caustix::RenderConfig { integrator: integrator.parse().unwrap(), ..scene.config.clone() };
    tweak(&mut config);
    caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap().film.beauty()
}

fn mean(img: &Image) -> f32 {
    img.pixels.iter().map(|p| p.element_sum() / 3.0).sum::<f32>() / img.pixels.len() as f32
}

fn brightest(img: &Image) -> f32 {
    img.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max)
}

/// A point light inside a closed grey sphere, seen from outside over a floor:
/// no light can get out. Photon mapping and SPPM used to light pixels
/// outside (photons on the inside of the shell reached the floor's estimates).
#[test]
fn no_light_leaks_out_of_a_closed_shell() {
    let text = r#"
        [camera]
        eye = [0, 3, 8]
        look_at = [0, 0, 0]
        fov = 40
        [image]
        width = 48
        height = 36
        samples = 2
        [materials.grey]
        diffuse = 0.8
        [[point_light]]
        position = [0, 0, 0]
        power = 100
        [[sphere]]
        center = [0, 0, 0]
        radius = 1
        subdivisions = 4
        material = "grey"
        [[quad]]
        center = [0, -1.5, 0]
        u = [10, 0, 0]
        v = [0, 0, -10]
        material = "grey"
    "#;
    for integrator in ["photon", "sppm", "path", "vcm"] {
        let img = render_text(text, integrator, |c| {
            c.photons.global_photons = 50_000;
            c.photons.caustic_photons = 0;
            c.photons.sppm.passes = 8;
            c.photons.sppm.photons_per_pass = 50_000;
        });
        let lit = img.pixels.iter().filter(|p| p.max_element() > 0.0).count();
        assert_eq!(
            lit,
            0,
            "{integrator}: {lit} pixels lit from inside the shell (brightest {})",
            brightest(&img)
        );
    }
}

/// A spot light of 0.02 degrees on a floor before a wall: the beam's spot is
/// far smaller than a pixel. Photon mapping used to spread the spot's
/// irradiance over the gather radius: mean 293 against SPPM's 0.33, fireflies
/// of 1e7. Now nothing is spread: no pixel brighter than SPPM's brightest
/// (measured: mean 0.017 against SPPM's 0.058, the beam's first bounce is
/// missed by the gather rays, which never find its spot: the README says so).
#[test]
fn a_pencil_beam_is_not_spread_into_fireflies() {
    let text = r#"
        [camera]
        eye = [0, 3, 4]
        look_at = [0, 0, 0]
        fov = 40
        [image]
        width = 32
        height = 24
        samples = 2
        [materials.white]
        diffuse = 0.8
        [[spot_light]]
        position = [0, 2, 0]
        direction = [0, -1, 0]
        cone_angle = 0.02
        power = 100
        [[quad]]
        center = [0, 0, 0]
        u = [4, 0, 0]
        v = [0, 0, -4]
        material = "white"
        [[quad]]
        center = [0, 1, -2]
        u = [4, 0, 0]
        v = [0, 2, 0]
        material = "white"
    "#;
    let photon = render_text(text, "photon", |c| c.photons.caustic_photons = 0);
    let sppm = render_text(text, "sppm", |c| c.photons.sppm.passes = 16);
    eprintln!(
        "photon mean {} max {}, sppm mean {} max {}",
        mean(&photon),
        brightest(&photon),
        mean(&sppm),
        brightest(&sppm)
    );
    assert!(photon.non_finite().is_none() && sppm.non_finite().is_none());
    assert!(mean(&sppm) > 0.0, "the beam's light must reach the wall");
    assert!(mean(&photon) < 1.5 * mean(&sppm), "photon mapping must not spread the spot");
    assert!(brightest(&photon) < brightest(&sppm), "no fireflies");
}

/// Values a scene cannot render are refused with the reason; whatever slips
/// through to an infinite pixel is an error naming the pixel, never an image
/// of infinities with exit 0.
#[test]
fn values_beyond_the_floats_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let info = |name: &str, text: &str, says: &str| {
        refused(&["info".as_ref(), write(dir.path(), name, text).as_os_str()], says);
    };
    info(
        "power.toml",
        &QUAD_SCENE.replace("power = 100", "power = 1.1e38"),
        "power.toml:15:9: expected at most 1e30",
    );
    info(
        "phong.toml",
        &QUAD_SCENE.replace("diffuse = 0.8", "diffuse = 0.5\nspecular = 0.3\nphong_exponent = 1e8"),
        "phong_exponent is 100000000; it must be above 0 and at most 1e6",
    );
    let far = QUAD_SCENE.replace("u = [5, 0, 0]", "u = [1e30, 0, 0]");
    info("far.toml", &far, "reaches more than 1e12 from the camera");
    // Lights too: photons and light paths start on them, and Embree aborts
    // the process on a ray that starts beyond its range.
    let far_light = QUAD_SCENE.replace("position = [0, 0, 4]", "position = [0, 0, 1e20]");
    info("far-light.toml", &far_light, "point light #1 reaches 1e20 from the camera, beyond 1e12");
    let wide_light = QUAD_SCENE.replace(
        "[[point_light]]\nposition = [0, 0, 4]",
        "[[area_light]]\ncenter = [0, 0, 4]\nu = [1, 0, 0]\nv = [0, -4e13, 0]",
    );
    info("wide-light.toml", &wide_light, "area light #1 reaches 2e13 from the camera");
    let tiny = QUAD_SCENE
        .replace("[0, 0, 5]", "[0, 0, 5e-14]")
        .replace("[5, 0, 0]", "[5e-14, 0, 0]")
        .replace("[0, 5, 0]", "[0, 5e-14, 0]");
    info("tiny.toml", &tiny, "below 1e-12: too small for 32-bit floats to trace");
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    let out = dir.path().join("x.png");
    refused(
        &[
            "render".as_ref(),
            scene.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--integrator".as_ref(),
            "sppm".as_ref(),
            "--sppm-radius".as_ref(),
            "1e-30".as_ref(),
        ],
        "--sppm-radius is 1e-30, below a millionth of the scene's size",
    );
    // 1e30 W lighting a wall 1e-12 across: the irradiance overflows f32.
    let blinding = QUAD_SCENE
        .replace("power = 100", "power = 1e30")
        .replace("[0, 0, 5]", "[0, 0, 5e-12]")
        .replace("[0, 0, 4]", "[0, 0, 4e-12]")
        .replace("[5, 0, 0]", "[5e-12, 0, 0]")
        .replace("[0, 5, 0]", "[0, 5e-12, 0]");
    let blinding = write(dir.path(), "blinding.toml", &blinding);
    refused(
        &[
            "render".as_ref(),
            blinding.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--integrator".as_ref(),
            "whitted".as_ref(),
        ],
        "came out NaN or infinite (its direct component), rendering with the whitted integrator and seed 0",
    );
    assert!(!out.exists(), "no image is written");

    // A flag's number beyond the floats is named as typed (an `f32` reads
    // it as infinity, which the flag's own check reported as `inf`).
    let scene = write(dir.path(), "quad.toml", QUAD_SCENE);
    for (flag, value) in [("--time", "1e300"), ("--exposure", "-1e39"), ("--caustic-radius", "4e38")] {
        let run = caustix(&["render".as_ref(), scene.as_os_str(), flag.as_ref(), value.as_ref()]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{flag} {value}: {stderr}");
        assert!(
            stderr.contains(&format!("{value} is beyond the largest number"))
                && !stderr.contains("found inf"),
            "{flag} {value}: {stderr}"
        );
    }
}

/// Faces an OBJ file loses are reported, and a missing MTL file is named.
#[test]
fn obj_faces_left_out_and_missing_materials_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nusemtl m\nf 1 2 3\nf 1 2 4\nf 1 2\n";
    write(dir.path(), "t.obj", obj);
    let camera = "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\n";
    let own = write(dir.path(), "own.toml", &format!("{camera}[[mesh]]\nfile = \"t.obj\"\n"));
    refused(&["info".as_ref(), own.as_os_str()], "missing.mtl: MTL file not found (named by `mtllib` in");
    let given =
        format!("{camera}[materials.w]\ndiffuse = 0.5\n[[mesh]]\nfile = \"t.obj\"\nmaterial = \"w\"\n");
    let run = caustix(&["info".as_ref(), write(dir.path(), "given.toml", &given).as_os_str()]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("triangles have no area"), "{stderr}");
    assert!(
        stderr.contains("1 faces with fewer than 3 vertices were left out (the first on line 9)"),
        "{stderr}"
    );
}
