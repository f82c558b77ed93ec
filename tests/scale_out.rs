//! A render spread over jobs: `caustix photons` once, `caustix render
//! --photon-map --tile I/N` per tile, `caustix merge`: the merged image is
//! bit-identical to one plain render, for every integrator. And what can go
//! wrong on the way (a corrupted or foreign map, a tile out of range, a
//! missing, doubled or foreign tile) is a clear error with no output.

mod common;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use caustix::config::{IntegratorKind, Region};
use caustix::{Image, RenderConfig, Scene};
use common::caustix;

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml")
}

/// Small settings that still exercise every part of each integrator.
const SMALL: [&str; 14] = [
    "--width",
    "40",
    "--height",
    "30",
    "--spp",
    "2",
    "--photons",
    "20000",
    "--caustic-photons",
    "20000",
    "--passes",
    "3",
    "--pass-photons",
    "5000",
];

/// `settings` then `extra`.
fn with<'a>(settings: &[&'a OsStr], extra: &[&'a OsStr]) -> Vec<&'a OsStr> {
    [settings, extra].concat()
}

/// Runs `caustix` with `args`; returns whether it succeeded and its stderr.
fn run(args: &[&OsStr]) -> (bool, String) {
    let out = caustix(args);
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// `caustix COMMAND cornell.toml SMALL... EXTRA...`, which must succeed.
fn cornell_command(command: &str, integrator: &str, extra: &[&OsStr]) {
    let scene = cornell();
    let mut args: Vec<&OsStr> =
        vec![command.as_ref(), scene.as_os_str(), "--integrator".as_ref(), integrator.as_ref()];
    args.extend(SMALL.iter().map(OsStr::new));
    args.extend_from_slice(extra);
    let (ok, stderr) = run(&args);
    assert!(ok, "caustix {command}: {stderr}");
}

fn pixels(path: &Path) -> Vec<glam::Vec3> {
    Image::load(path).unwrap().pixels
}

#[test]
fn photons_tiles_and_merge_give_the_plain_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // (Without gather rays photon mapping reads its global map directly:
    // the map loaded must be searched as the one built.)
    let no_gathering: &[&OsStr] = &["--gather-rays".as_ref(), "0".as_ref()];
    for (integrator, settings) in
        [("photon", &[][..]), ("photon", no_gathering), ("sppm", &[]), ("whitted", &[]), ("path", &[])]
    {
        let (map, whole, merged) = (d.join("m.cxpm"), d.join("whole.exr"), d.join("merged.exr"));
        cornell_command("photons", integrator, &with(settings, &["-o".as_ref(), map.as_os_str()]));
        cornell_command("render", integrator, &with(settings, &["-o".as_ref(), whole.as_os_str()]));
        let tiles: Vec<PathBuf> = (1..=3).map(|i| d.join(format!("tile-{i}.exr"))).collect();
        for (i, tile) in tiles.iter().enumerate() {
            let which = format!("{}/3", i + 1);
            let extra: [&OsStr; 6] = [
                "--tile".as_ref(),
                which.as_ref(),
                "--photon-map".as_ref(),
                map.as_os_str(),
                "-o".as_ref(),
                tile.as_os_str(),
            ];
            cornell_command("render", integrator, &with(settings, &extra));
        }
        // Merged in another order than rendered: placement is by the tiles' own record.
        let mut args: Vec<&OsStr> =
            vec!["merge".as_ref(), tiles[2].as_os_str(), tiles[0].as_os_str(), tiles[1].as_os_str()];
        args.extend(["-o".as_ref(), merged.as_os_str()]);
        let (ok, stderr) = run(&args);
        assert!(ok, "{stderr}");
        let (a, b) = (pixels(&merged), pixels(&whole));
        assert!(a.iter().any(|p| *p != glam::Vec3::ZERO), "{integrator}: a black image proves nothing");
        assert!(a == b, "{integrator}: the merged tiles differ from the plain render");
    }
}

#[test]
fn components_of_tiles_merge_into_the_components_of_the_whole() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = d.join("whole.exr");
    let aov: [&OsStr; 2] = ["--aov".as_ref(), "albedo,caustic".as_ref()];
    cornell_command("render", "path", &[aov[0], aov[1], "-o".as_ref(), whole.as_os_str()]);
    for i in 1..=2 {
        let (which, tile) = (format!("{i}/2"), d.join(format!("t{i}.exr")));
        let extra: [&OsStr; 6] =
            [aov[0], aov[1], "--tile".as_ref(), which.as_ref(), "-o".as_ref(), tile.as_os_str()];
        cornell_command("render", "path", &extra);
    }
    for component in ["albedo", "caustic"] {
        let merged = d.join(format!("merged-{component}.exr"));
        let tiles = [1, 2].map(|i| d.join(format!("t{i}-{component}.exr")));
        let (ok, e) = run(&[
            "merge".as_ref(),
            tiles[0].as_os_str(),
            tiles[1].as_os_str(),
            "-o".as_ref(),
            merged.as_os_str(),
        ]);
        assert!(ok, "{e}");
        assert!(pixels(&merged) == pixels(&d.join(format!("whole-{component}.exr"))), "{component}");
    }
}

#[test]
fn a_region_renders_the_same_pixels_as_the_whole_image() {
    let scene = Scene::load(&cornell()).unwrap();
    let accel = caustix::accel::build(caustix::accel::Backend::Embree, &scene.triangle_views()).unwrap();
    for &integrator in IntegratorKind::ALL {
        let mut config =
            RenderConfig { integrator, width: 37, height: 23, samples: 2, ..scene.config.clone() };
        config.photons.global_photons = 10_000;
        config.photons.caustic_photons = 10_000;
        config.photons.sppm.passes = 2;
        config.photons.sppm.photons_per_pass = 5_000;
        let whole = caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap().film;
        let region = Region { x0: 5, y0: 3, x1: 30, y1: 19 };
        let part = caustix::render(
            &scene,
            accel.as_ref(),
            &RenderConfig { region: Some(region), ..config },
            &|_| {},
        )
        .unwrap()
        .film;
        assert_eq!((part.width, part.height), (25, 16));
        for (i, p) in part.pixels.iter().enumerate() {
            let (x, y) = region.pixel(i);
            assert_eq!(*p, whole.pixels[(y * 37 + x) as usize], "{integrator:?}: pixel ({x}, {y})");
        }
    }
}

#[test]
fn a_tile_or_photon_map_made_again_is_the_same_file() {
    // Byte for byte, header included (a tile's attributes once came out in
    // another order each run; a photon map file once held how long its
    // maps took): a job rerun on a cluster, or a checksum of its output,
    // sees the same file.
    let dir = tempfile::tempdir().unwrap();
    let files: Vec<Vec<u8>> = (0..6)
        .map(|i| {
            let tile = dir.path().join(format!("t{i}.exr"));
            let crop: [&OsStr; 4] =
                ["--crop".as_ref(), "3,2,30,17".as_ref(), "-o".as_ref(), tile.as_os_str()];
            cornell_command("render", "path", &crop);
            std::fs::read(&tile).unwrap()
        })
        .collect();
    assert!(files.iter().all(|f| *f == files[0]), "the same tile written as different bytes");
    let tile = caustix::film::tile::load(&dir.path().join("t0.exr")).unwrap();
    assert_eq!((tile.scene.as_str(), tile.size), ("cornell.toml", (40, 30)));
    let maps: Vec<Vec<u8>> = (0..2)
        .map(|i| {
            let map = dir.path().join(format!("m{i}.cxpm"));
            cornell_command("photons", "photon", &["-o".as_ref(), map.as_os_str()]);
            std::fs::read(&map).unwrap()
        })
        .collect();
    assert!(maps[0] == maps[1], "the same photon maps written as different bytes");
}

#[test]
fn bad_maps_and_tiles_are_clear_errors_with_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let map = d.join("m.cxpm");
    cornell_command("photons", "photon", &["-o".as_ref(), map.as_os_str()]);
    let out = d.join("out.exr");
    let render_with = |map: &Path, extra: &[&str]| {
        let scene = cornell();
        let mut args: Vec<&OsStr> = vec!["render".as_ref(), scene.as_os_str()];
        args.extend(SMALL.iter().map(OsStr::new));
        args.extend(extra.iter().map(OsStr::new));
        args.extend(["--photon-map".as_ref(), map.as_os_str(), "-o".as_ref(), out.as_os_str()]);
        let (ok, stderr) = run(&args);
        assert!(!ok, "{extra:?} should fail");
        assert!(!out.exists(), "{extra:?}: no output after an error");
        stderr
    };
    let bytes = std::fs::read(&map).unwrap();

    // Corrupted: one bit flipped in the middle. Truncated: half of it.
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 0x10;
    let corrupted = common::write_bytes(d, "corrupted.cxpm", &flipped);
    assert!(render_with(&corrupted, &[]).contains("checksum does not match"));
    let truncated = common::write_bytes(d, "truncated.cxpm", &bytes[..bytes.len() / 2]);
    assert!(render_with(&truncated, &[]).contains("truncated or corrupted"));
    let other = common::write_bytes(d, "other.cxpm", b"P6 not a photon map");
    assert!(render_with(&other, &[]).contains("not a caustix photon map"));

    // Other settings, named with both values; another scene.
    let e = render_with(&map, &["--seed", "3"]);
    assert!(e.contains("made with other photon settings (--seed 0 in the file, 3 now)"), "{e}");
    let e = render_with(&map, &["--sampler", "independent"]);
    assert!(e.contains("--sampler sobol in the file, independent now"), "{e}");
    let scene_text = std::fs::read_to_string(cornell()).unwrap();
    let brighter = common::write(d, "cornell.toml", &brighten_first_light(&scene_text));
    let scene = brighter.clone();
    let mut args: Vec<&OsStr> = vec!["render".as_ref(), scene.as_os_str()];
    args.extend(SMALL.iter().map(OsStr::new));
    args.extend(["--photon-map".as_ref(), map.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    let (ok, e) = run(&args);
    assert!(!ok && e.contains("made for another scene"), "{e}");
    assert!(!out.exists());

    // A tile out of range.
    for tile in ["4/3", "0/3"] {
        let (ok, e) = run(&[
            "render".as_ref(),
            cornell().as_os_str(),
            "--tile".as_ref(),
            tile.as_ref(),
            "-o".as_ref(),
            out.as_os_str(),
        ]);
        assert!(!ok && e.contains("1 <= I <= N"), "{tile}: {e}");
    }
    assert!(!out.exists());

    // Tiles: missing, doubled, of another render.
    let tile = |name: &str, which: &str, seed: &str| {
        let path = d.join(name);
        let extra: [&OsStr; 6] = [
            "--tile".as_ref(),
            which.as_ref(),
            "--seed".as_ref(),
            seed.as_ref(),
            "-o".as_ref(),
            path.as_os_str(),
        ];
        cornell_command("render", "whitted", &extra);
        path
    };
    let (t1, t2, t3) = (tile("t1.exr", "1/3", "0"), tile("t2.exr", "2/3", "0"), tile("t3.exr", "3/3", "0"));
    let foreign = tile("f3.exr", "3/3", "1");
    let merged = d.join("merged.exr");
    let merge = |tiles: &[&PathBuf]| {
        let mut args: Vec<&OsStr> = vec!["merge".as_ref()];
        args.extend(tiles.iter().map(|t| t.as_os_str()));
        args.extend(["-o".as_ref(), merged.as_os_str()]);
        let (ok, e) = run(&args);
        assert!(!ok, "{tiles:?} should not merge");
        assert!(!merged.exists());
        e
    };
    let e = merge(&[&t1, &t2]);
    assert!(e.contains("uncovered") && e.contains("a tile is missing"), "{e}");
    let e = merge(&[&t1, &t2, &t2, &t3]);
    assert!(e.contains("t2.exr: overlaps") && e.contains("t2.exr at pixel"), "{e}");
    let e = merge(&[&t1, &t2, &foreign]);
    assert!(e.contains("f3.exr: rendered from another scene (cornell.toml) or with other settings"), "{e}");
    let plain = d.join("plain.exr");
    Image { width: 40, height: 30, pixels: vec![glam::Vec3::ONE; 1200] }.save(&plain, 0.0).unwrap();
    let e = merge(&[&t1, &plain]);
    assert!(e.contains("not a caustix tile"), "{e}");
}

/// The scene text with its first light's power doubled (`power = X` -> `power = 2X`).
fn brighten_first_light(text: &str) -> String {
    let start = text.find("power = ").expect("the Cornell box has a light with a power") + "power = ".len();
    let end = start + text[start..].find(['\n', '#']).unwrap();
    let value = text[start..end].trim();
    let doubled = if value.starts_with('[') {
        let parts: Vec<f64> = value
            .trim_matches(|c| c == '[' || c == ']')
            .split(',')
            .map(|p| p.trim().parse().unwrap())
            .collect();
        format!("[{}]", parts.iter().map(|p| (2.0 * p).to_string()).collect::<Vec<_>>().join(", "))
    } else {
        (2.0 * value.parse::<f64>().unwrap()).to_string()
    };
    format!("{}{}{}", &text[..start], doubled, &text[end..])
}
