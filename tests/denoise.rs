//! Denoising with Intel Open Image Denoise through the command line: the
//! denoised image is closer to a converged reference than the noisy one at a
//! low budget, `caustix denoise` on a render's components gives what
//! `render --denoise` gives, a failing denoiser still leaves the render, and
//! a build without the `denoise` feature says how to get it.

mod common;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use caustix::Image;
use common::caustix;

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml")
}

/// `caustix render` of the Cornell box at 64x64 with `args`, into `dir/name`;
/// panics with its stderr if it fails.
#[cfg(feature = "denoise")]
fn render(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let (out, scene) = (dir.join(name), cornell());
    let mut all: Vec<&OsStr> = vec!["render".as_ref(), scene.as_os_str()];
    all.extend(["--width", "64", "--height", "64", "-o"].map(OsStr::new));
    all.push(out.as_os_str());
    all.extend(args.iter().map(OsStr::new));
    let run = caustix(&all);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    out
}

#[cfg(feature = "denoise")]
fn rmse(image: &Path, reference: &Path) -> f64 {
    Image::load(image).unwrap().difference(&Image::load(reference).unwrap()).unwrap().rmse
}

#[cfg(feature = "denoise")]
#[test]
fn denoising_a_low_budget_render_brings_it_closer_to_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The reference: 1024 spp of the path tracer (its own RMSE is about 0.03).
    let args = ["--integrator", "path", "--spp", "1024", "--seed", "9", "--aov", "emission"];
    let reference = Image::load(&render(d, "ref.exr", &args)).unwrap();
    // The pixels that see no light at all, directly or through glass: there
    // the error is the surfaces' noise, which is what a denoiser removes. (At
    // 4 spp the lights' edges are aliased; that error is not noise.)
    let emission = Image::load(&d.join("ref-emission.exr")).unwrap();
    let surfaces: Vec<bool> = emission.pixels.iter().map(|e| *e == glam::Vec3::ZERO).collect();
    let errors = |name: &str, args: &[&str]| {
        let denoised = Image::load(&render(d, &format!("{name}.exr"), args)).unwrap();
        let noisy = Image::load(&d.join(format!("{name}-final.exr"))).unwrap();
        let whole = [&noisy, &denoised].map(|i| i.difference(&reference).unwrap().rmse);
        let surface = [&noisy, &denoised].map(|i| i.difference_where(&reference, &surfaces).unwrap().rmse);
        eprintln!("{name}: RMSE noisy, denoised: {whole:.4?} whole image, {surface:.4?} on surfaces");
        (whole, surface)
    };

    // 4 spp of the path tracer, noisy (written as -final) and denoised.
    let (whole, surface) =
        errors("path", &["--integrator", "path", "--spp", "4", "--denoise", "--aov", "final"]);
    // Measured 0.72 -> 0.28 (0.40x) and 0.68 -> 0.17 (0.25x); the margins:
    // 0.7x and 0.4x.
    assert!(whole[1] < 0.7 * whole[0], "{whole:?}");
    assert!(surface[1] < 0.4 * surface[0], "{surface:?}");

    // Photon mapping at 4 spp: its error is mostly low-frequency (final
    // gathering from the global map), which no denoiser removes, so the gain
    // is smaller. Measured on surfaces 0.0515 -> 0.0481 (0.93x); the margin:
    // 0.97x. (Whole image 0.230 -> 0.229: the lights' edges dominate.)
    let (_, surface) = errors("photon", &["--spp", "4", "--denoise", "--aov", "final"]);
    assert!(surface[1] < 0.97 * surface[0], "{surface:?}");
}

#[cfg(feature = "denoise")]
#[test]
fn the_denoise_command_on_the_components_gives_what_render_gives() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = ["--integrator", "path", "--spp", "2", "--aov", "final,emission,albedo,normal", "--denoise"];
    let denoised = render(d, "a.exr", &args);
    let component = |name: &str| d.join(format!("a-{name}.exr"));
    let again = d.join("b.exr");
    let run = caustix(&[
        "denoise".as_ref(),
        component("final").as_os_str(),
        "--emission".as_ref(),
        component("emission").as_os_str(),
        "--albedo".as_ref(),
        component("albedo").as_os_str(),
        "--normal".as_ref(),
        component("normal").as_os_str(),
        "-o".as_ref(),
        again.as_os_str(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let (a, b) = (Image::load(&denoised).unwrap(), Image::load(&again).unwrap());
    let d = a.difference(&b).unwrap();
    assert!(d.rmse < 1e-5, "render --denoise and caustix denoise differ by RMSE {}", d.rmse);
    // And denoising changed the image.
    assert!(rmse(&denoised, &component("final")) > 0.01);
}

#[cfg(feature = "denoise")]
#[test]
fn a_failing_denoiser_is_an_error_naming_oidn_and_the_render_is_still_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plain = render(d, "plain.exr", &["--integrator", "path", "--spp", "2"]);
    let out = d.join("failed.exr");
    // OIDN_DEVICE_CPU=0 hides OIDN's CPU device: as on a machine without a
    // device it can use.
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_caustix"))
        .env("OIDN_DEVICE_CPU", "0")
        .args(["render".as_ref(), cornell().as_os_str()])
        .args(["--width", "64", "--height", "64", "--integrator", "path", "--spp", "2", "--denoise", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        stderr.contains("Open Image Denoise: unsupported hardware: no supported devices found"),
        "{stderr}"
    );
    assert!(stderr.contains("holds the image as rendered, not denoised"), "{stderr}");
    assert_eq!(Image::load(&out).unwrap(), Image::load(&plain).unwrap());
}

#[cfg(not(feature = "denoise"))]
#[test]
fn without_the_feature_denoising_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    let cornell = cornell();
    let run = caustix(&[
        "render".as_ref(),
        cornell.as_os_str(),
        "--denoise".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("--denoise needs caustix built with `--features denoise`"), "{stderr}");
    assert!(!out.exists());

    // The same from the scene file's [render] table.
    let text = std::fs::read_to_string(&cornell).unwrap() + "\n[render]\ndenoise = true\n";
    let scene = common::write(dir.path(), "cornell.toml", &text);
    let run = caustix(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("--features denoise"));
    assert!(!out.exists());

    let image = dir.path().join("in.exr");
    Image { width: 2, height: 2, pixels: vec![glam::Vec3::ONE; 4] }.save(&image, 0.0).unwrap();
    let run = caustix(&["denoise".as_ref(), image.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("--features denoise"));
    assert!(!out.exists());
}

#[test]
fn the_denoise_command_refuses_what_it_cannot_use() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let save = |name: &str, w: u32| {
        let path = d.join(name);
        Image { width: w, height: 2, pixels: vec![glam::Vec3::ONE; 2 * w as usize] }
            .save(&path, 0.0)
            .unwrap();
        path
    };
    let (image, small, png) = (save("in.exr", 4), save("small.exr", 2), save("in.png", 4));
    let out = d.join("out.exr");
    let run = |args: &[&OsStr]| {
        let mut all: Vec<&OsStr> = vec!["denoise".as_ref()];
        all.extend_from_slice(args);
        all.extend(["-o".as_ref(), out.as_os_str()]);
        let run = caustix(&all);
        assert!(!run.status.success());
        String::from_utf8_lossy(&run.stderr).into_owned()
    };
    let e = run(&[png.as_os_str()]);
    assert!(e.contains("in.png: give the linear image (.exr or .hdr)"), "{e}");
    let e = run(&[image.as_os_str(), "--normal".as_ref(), image.as_os_str()]);
    assert!(e.contains("--normal needs --albedo too"), "{e}");
    if cfg!(feature = "denoise") {
        // (A build without the feature refuses before reading the images.)
        let e = run(&[image.as_os_str(), "--albedo".as_ref(), small.as_os_str()]);
        assert!(e.contains("the albedo is 2x2 but the image is 4x2"), "{e}");
    }
    assert!(!out.exists());
}
