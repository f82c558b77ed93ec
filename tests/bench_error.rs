//! `caustix bench error` from the command line: a CSV row per render, a
//! plot with a curve per integrator, and clear refusals of bad requests.

mod common;

use std::ffi::OsStr;
use std::path::Path;

use common::{caustix, write, QUAD_SCENE};

const HEADER: &str = "integrator,level,setting,seconds,rmse,rel_mse,mae,mean_ratio,caustic_rmse,\
denoise_seconds,denoised_rmse,denoised_caustic_rmse,fireflies";

/// A CSV row's fields (the third, the setting, is quoted and holds commas).
fn columns(line: &str) -> Vec<String> {
    let (before, rest) = line.split_once(",\"").expect("a quoted setting");
    let (setting, after) = rest.split_once("\",").expect("a closing quote");
    let mut fields: Vec<String> = before.split(',').map(str::to_string).collect();
    fields.push(setting.to_string());
    fields.extend(after.split(',').map(str::to_string));
    assert_eq!(fields.len(), HEADER.split(',').count(), "{line}");
    fields
}

/// A small reference: the quad scene path-traced at 16 x 16.
fn reference(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let scene = write(dir, "quad.toml", QUAD_SCENE);
    let reference = dir.join("ref.exr");
    let run = caustix(&[
        "render".as_ref(),
        scene.as_os_str(),
        "--integrator".as_ref(),
        "path".as_ref(),
        "--width".as_ref(),
        "16".as_ref(),
        "--height".as_ref(),
        "16".as_ref(),
        "--spp".as_ref(),
        "256".as_ref(),
        "-o".as_ref(),
        reference.as_os_str(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    (scene, reference)
}

#[test]
fn writes_a_row_per_render_and_a_curve_per_integrator() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, reference) = reference(dir.path());
    let (csv, plot) = (dir.path().join("e.csv"), dir.path().join("e.svg"));
    let run = caustix(&[
        "bench".as_ref(),
        "error".as_ref(),
        scene.as_os_str(),
        "--reference".as_ref(),
        reference.as_os_str(),
        "--levels".as_ref(),
        "3".as_ref(),
        "--integrators".as_ref(),
        "path,photon,sppm".as_ref(),
        "--csv".as_ref(),
        csv.as_os_str(),
        "--plot".as_ref(),
        plot.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER));
    let rows: Vec<Vec<String>> = lines.map(columns).collect();
    assert_eq!(rows.len(), 9, "{text}");
    for (i, integrator) in ["path", "photon", "sppm"].into_iter().enumerate() {
        let curve = &rows[3 * i..3 * i + 3];
        let rmse: Vec<f64> = curve.iter().map(|r| r[4].parse().unwrap()).collect();
        for (level, row) in curve.iter().enumerate() {
            assert_eq!(row[0], integrator);
            assert_eq!(row[1], level.to_string());
            let seconds: f64 = row[3].parse().unwrap();
            assert!(seconds > 0.0 && rmse[level] > 0.0 && rmse[level].is_finite(), "{row:?}");
            // Caustic region and denoising were not asked for: empty.
            assert!(row[8..12].iter().all(String::is_empty), "{row:?}");
            // A count of fireflies, always.
            assert!(row[12].parse::<usize>().is_ok(), "{row:?}");
        }
        // The path tracer's noise falls as its budget grows (4x the samples:
        // about half the error). The quad has no indirect light, so the photon
        // mappers' errors here are at the reference's own noise: not compared.
        if integrator == "path" {
            assert!(rmse[2] < 0.7 * rmse[0], "{integrator}: {rmse:?}");
        }
    }
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg"), "not an SVG");
    for name in ["path", "photon", "sppm", "seconds"] {
        assert!(svg.contains(name), "the plot lacks `{name}`");
    }
}

#[test]
fn refuses_what_it_cannot_do_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, reference) = reference(dir.path());
    let run = |extra: &[&OsStr]| {
        let base: [&OsStr; 5] = [
            "bench".as_ref(),
            "error".as_ref(),
            scene.as_os_str(),
            "--reference".as_ref(),
            reference.as_os_str(),
        ];
        let out = caustix(&[&base[..], extra].concat());
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let png = dir.path().join("plot.png");
    let stderr = run(&["--plot".as_ref(), png.as_os_str()]);
    assert!(stderr.contains("SVG"), "{stderr}");
    let stderr = run(&["--integrators".as_ref(), "whitted".as_ref()]);
    assert!(stderr.contains("whitted is not measured"), "{stderr}");
    let stderr = run(&["--levels".as_ref(), "0".as_ref()]);
    assert!(stderr.contains("--levels must be from 1"), "{stderr}");
    // A caustic reference of another size, and one without caustics (the
    // quad has none: its reference stands in for a caustic component of 0).
    let small = dir.path().join("small.exr");
    caustix::Image { width: 4, height: 4, pixels: vec![glam::Vec3::ONE; 16] }.save(&small, 0.0).unwrap();
    let stderr = run(&["--caustic-reference".as_ref(), small.as_os_str()]);
    assert!(stderr.contains("small.exr is 4x4 but the reference is 16x16"), "{stderr}");
    let black = dir.path().join("black.exr");
    caustix::Image { width: 16, height: 16, pixels: vec![glam::Vec3::ZERO; 256] }.save(&black, 0.0).unwrap();
    let stderr = run(&["--caustic-reference".as_ref(), black.as_os_str()]);
    assert!(stderr.contains("no pixel has a caustic"), "{stderr}");
    if !cfg!(feature = "denoise") {
        let stderr = run(&["--denoise".as_ref()]);
        assert!(stderr.contains("--denoise needs caustix built with `--features denoise`"), "{stderr}");
    }
    let missing = dir.path().join("missing.exr");
    let out = caustix(&[
        "bench".as_ref(),
        "error".as_ref(),
        scene.as_os_str(),
        "--reference".as_ref(),
        missing.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("missing.exr"), "{stderr}");
}

#[test]
fn measures_the_caustic_region_and_the_denoised_image_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, reference) = reference(dir.path());
    // Every lit pixel counts as caustic when the "caustic component" is the
    // reference itself: the quad's 8 x 8 pixels. Outside it both images are
    // exactly black, so the region's squared error is the whole image's
    // times 256 / 64: its RMSE twice the whole image's.
    let csv = dir.path().join("e.csv");
    let mut args: Vec<&OsStr> = vec![
        "bench".as_ref(),
        "error".as_ref(),
        scene.as_os_str(),
        "--reference".as_ref(),
        reference.as_os_str(),
        "--caustic-reference".as_ref(),
        reference.as_os_str(),
        "--levels".as_ref(),
        "2".as_ref(),
        "--integrators".as_ref(),
        "path".as_ref(),
        "--csv".as_ref(),
        csv.as_os_str(),
        "--plot".as_ref(),
    ];
    let plot = dir.path().join("e.svg");
    args.push(plot.as_os_str());
    if cfg!(feature = "denoise") {
        args.push("--denoise".as_ref());
    }
    let run = caustix(&args);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("caustic region: 64 pixels"), "{stderr}");
    let text = std::fs::read_to_string(&csv).unwrap();
    for row in text.lines().skip(1).map(columns) {
        let number = |i: usize| row[i].parse::<f64>().unwrap();
        assert!((number(8) - 2.0 * number(4)).abs() <= 1e-4 * number(4), "{row:?}");
        if cfg!(feature = "denoise") {
            assert!(number(9) > 0.0 && number(10) > 0.0 && number(10).is_finite(), "{row:?}");
            assert!(number(11) > 0.0 && number(11).is_finite(), "{row:?}");
        } else {
            assert!(row[9..12].iter().all(String::is_empty), "{row:?}");
        }
    }
    if cfg!(feature = "denoise") {
        assert!(std::fs::read_to_string(&plot).unwrap().contains("path + denoise"));
        assert!(
            stderr.contains("path: denoising helped at every level")
                || stderr.contains("path: denoising helps below level"),
            "{stderr}"
        );
    }
}
