//! Every kind of bad input gives one clear error naming the file, the line
//! where known, and what is wrong; the CLI exits non-zero and never panics.

mod common;

use std::path::Path;

use caustix::scene::Scene;
use common::{caustix, write, QUAD_SCENE};

/// The 1-based line of the first occurrence of `needle` in `text`.
fn line_of(text: &str, needle: &str) -> usize {
    let at = text.find(needle).unwrap_or_else(|| panic!("`{needle}` not in the test scene"));
    text[..at].matches('\n').count() + 1
}

/// The error for `text` read as `bad.toml`, which must fail.
fn error_for(text: &str) -> String {
    match Scene::from_toml(text, Path::new("bad.toml")) {
        Ok(_) => panic!("accepted a bad scene:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Asserts the error points at the line holding `marker` and says `says`.
fn assert_error_at(text: &str, marker: &str, says: &str) {
    let err = error_for(text);
    let prefix = format!("bad.toml:{}:", line_of(text, marker));
    assert!(err.starts_with(&prefix), "expected `{prefix}...`, got: {err}");
    assert!(err.contains(says), "expected it to say `{says}`, got: {err}");
}

/// The quad scene with `from` replaced by `to` (which must occur).
fn edit(from: &str, to: &str) -> String {
    assert!(QUAD_SCENE.contains(from));
    QUAD_SCENE.replacen(from, to, 1)
}

#[test]
fn toml_syntax_error() {
    let text = edit("[image]", "[image");
    assert_error_at(&text, "[image", "invalid table header");
}

#[test]
fn unknown_field() {
    let text = edit("diffuse = 0.8", "colour = 0.8");
    assert_error_at(&text, "colour", "unknown field `colour`");
}

#[test]
fn unknown_section() {
    let text = format!("{QUAD_SCENE}\n[[cylinder]]\nradius = 1\n");
    assert_error_at(&text, "[[cylinder]]", "unknown field `cylinder`");
}

#[test]
fn material_that_does_not_exist() {
    let text = edit(r#"material = "white""#, r#"material = "whit""#);
    assert_error_at(&text, "\"whit\"", "unknown material `whit`; defined materials: white");
}

#[test]
fn non_finite_numbers() {
    assert_error_at(&edit("fov = 90", "fov = nan"), "fov", "finite");
    assert_error_at(&edit("position = [0, 0, 4]", "position = [0, inf, 4]"), "position", "finite");
    assert_error_at(&edit("power = 100", "power = -inf"), "power = ", "finite");
    // Finite in TOML but beyond single precision.
    assert_error_at(&edit("u = [5, 0, 0]", "u = [5e39, 0, 0]"), "u = ", "finite");
}

#[test]
fn negative_and_zero_sizes() {
    let sphere = "\n[[sphere]]\ncenter = [0, 0, 0]\nradius = -1\nmaterial = \"white\"\n";
    assert_error_at(&format!("{QUAD_SCENE}{sphere}"), "radius = -1", "greater than 0");
    let cube = "\n[[box]]\ncenter = [0, 0, 0]\nsize = [1, -2, 1]\nmaterial = \"white\"\n";
    assert_error_at(&format!("{QUAD_SCENE}{cube}"), "size =", "greater than 0");
    assert_error_at(&edit("width = 64", "width = -64"), "width", "from 1 to");
    assert_error_at(&edit("height = 64", "height = 0"), "height", "from 1 to");
    let scaled = edit("material = \"white\"", "material = \"white\"\ntransform = { scale = [1, 0, 1] }");
    assert_error_at(&scaled, "transform", "non-zero scale");
    assert_error_at(&edit("power = 100", "power = [1, -2, 3]"), "power = ", "not negative");
}

#[test]
fn wrong_shapes_of_values() {
    assert_error_at(&edit("eye = [0, 0, 5]", "eye = [0, 5]"), "eye", "array of 3 numbers");
    assert_error_at(&edit("eye = [0, 0, 5]", "eye = 5"), "eye", "array of 3 numbers");
    assert_error_at(&edit("diffuse = 0.8", "diffuse = 1.2"), "diffuse", "between 0 and 1");
}

#[test]
fn impossible_geometry_and_physics() {
    assert_error_at(&edit("v = [0, 5, 0]", "v = [10, 0, 0]"), "u = [5, 0, 0]", "parallel");
    let bright = edit("diffuse = 0.8", "diffuse = 0.8\nmirror = 0.5");
    assert_error_at(&bright, "[materials.white]", "at most 1");
    let ring = "\n[[ring]]\nbase = [0, 0, 0]\ninner_radius = 2\nouter_radius = 1\nheight = 1\nmaterial = \"white\"\n";
    assert_error_at(&format!("{QUAD_SCENE}{ring}"), "outer_radius", "larger than inner_radius");
    let err = error_for(&edit("look_at = [0, 0, 0]", "look_at = [0, 0, 5]"));
    assert!(err.starts_with("bad.toml: [camera]") && err.contains("same point"), "{err}");
    let err = error_for(&edit("eye = [0, 0, 5]", "eye = [0, 5, 0]\nup = [0, 2, 0]"));
    assert!(err.contains("parallel to the viewing direction"), "{err}");
}

#[test]
fn empty_scene() {
    let text = QUAD_SCENE[..QUAD_SCENE.find("[[quad]]").unwrap()].to_string();
    let err = error_for(&text);
    assert!(err.starts_with("bad.toml: the scene has no geometry"), "{err}");
    let err = error_for("");
    assert!(err.contains("missing field `camera`"), "{err}");
}

#[test]
fn missing_files() {
    let err = Scene::load(Path::new("does/not/exist.toml")).unwrap_err().to_string();
    assert!(err.starts_with("does/not/exist.toml: ") && err.contains("No such file"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"nothere.obj\"\n");
    let path = write(dir.path(), "scene.toml", &text);
    let err = Scene::load(&path).unwrap_err().to_string();
    let line = line_of(&text, "nothere.obj");
    assert!(err.contains(&format!("scene.toml:{line}:")) && err.contains("not found"), "{err}");
}

#[test]
fn obj_that_fails_to_parse() {
    let dir = tempfile::tempdir().unwrap();
    let obj = write(dir.path(), "broken.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n");
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"broken.obj\"\nmaterial = \"white\"\n");
    let scene = write(dir.path(), "scene.toml", &text);
    let err = Scene::load(&scene).unwrap_err().to_string();
    let expected = format!("{}:5:", obj.display());
    assert!(err.starts_with(&expected) && err.contains("vertex 9 does not exist"), "{err}");

    let garbled = write(dir.path(), "garbled.obj", "v 0 0 0\nv 1 zero 0\n");
    let err = Scene::load(&write(dir.path(), "s2.toml", &text.replace("broken.obj", "garbled.obj")))
        .unwrap_err()
        .to_string();
    assert!(err.starts_with(&format!("{}:2:", garbled.display())) && err.contains("`zero`"), "{err}");
}

#[test]
fn obj_without_materials_needs_one_in_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"tri.obj\"\n");
    let err = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap_err().to_string();
    assert!(err.contains("tri.obj") && err.contains("has no material"), "{err}");
    // With one given, it loads.
    let text = format!("{text}material = \"white\"\n");
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    assert_eq!(scene.triangle_count(), 3);
}

#[test]
fn bpt_errors_name_the_bpt_file() {
    let dir = tempfile::tempdir().unwrap();
    let bpt = write(dir.path(), "bad.bpt", "1\n3 3\n0 0 0\n");
    let text = format!("{QUAD_SCENE}\n[[teapot]]\nfile = \"bad.bpt\"\nmaterial = \"white\"\n");
    let err = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap_err().to_string();
    assert!(err.starts_with(&format!("{}:", bpt.display())) && err.contains("file ends"), "{err}");
}

/// A patch file whose every patch collapses (control points on a line or
/// at one point) tessellates into triangles of no area, all left out: the
/// error names the patch file, not "the scene has no geometry". One such
/// patch beside a whole one is fine (the teapot's own lid collapses at its
/// knob).
#[test]
fn a_patch_file_of_collapsed_patches_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let patch = |point: &dyn Fn(usize) -> [f32; 3]| -> String {
        let rows: Vec<String> = (0..16).map(point).map(|[x, y, z]| format!("{x} {y} {z}\n")).collect();
        format!("3 3\n{}", rows.concat())
    };
    let on_a_line = patch(&|i| [i as f32, 0.0, 0.0]);
    let at_a_point = patch(&|_| [1.0, 2.0, 3.0]);
    let square = patch(&|i| [(i % 4) as f32, (i / 4) as f32, 0.0]);
    let scene = |bpt: &str| -> Result<caustix::scene::Scene, caustix::Error> {
        write(dir.path(), "flat.bpt", bpt);
        let text = format!("{QUAD_SCENE}\n[[teapot]]\nfile = \"flat.bpt\"\nmaterial = \"white\"\n");
        Scene::load(&write(dir.path(), "s.toml", &text))
    };
    for collapsed in [format!("1\n{on_a_line}"), format!("2\n{on_a_line}{at_a_point}")] {
        let err = scene(&collapsed).unwrap_err().to_string();
        let named = format!("{}:", dir.path().join("flat.bpt").display());
        assert!(err.starts_with(&named) && err.contains("every patch collapses"), "{err}");
    }
    let with_a_square = scene(&format!("2\n{on_a_line}{square}")).unwrap();
    assert!(with_a_square.triangle_count() > 2);
}

/// A mesh named where a scene belongs (`caustix render bunny.obj`) is told
/// apart from a broken scene: the error says what the file is and how to
/// render it, not what TOML makes of its first line. A binary PLY is known
/// by its header whatever its name; so are the images and photon maps
/// caustix writes (`caustix info image.exr` said "not UTF-8 text").
#[test]
fn mesh_image_or_photon_map_given_as_a_scene() {
    let dir = tempfile::tempdir().unwrap();
    let obj = write(dir.path(), "bunny.OBJ", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n".to_vec();
    ply.extend([0xffu8, 0xfe, 0x00, 0x80]);
    let ply = common::write_bytes(dir.path(), "model.dat", &ply);
    let bpt = write(dir.path(), "pot.bpt", "1\n3 3\n");
    let stl = common::write_bytes(dir.path(), "part.stl", &[0u8; 84]);
    let exr = common::write_bytes(dir.path(), "render.out", b"\x76\x2f\x31\x01\x02\x00\x00\x00\xff");
    let png = common::write_bytes(dir.path(), "render.png", b"\x89PNG\r\n\x1a\n\x00");
    let map = common::write_bytes(dir.path(), "maps.bin", b"CXPM\x01\x00\x00\x00\xff");
    for (path, what, entry) in [
        (&obj, "a Wavefront OBJ mesh", "`[[mesh]]` with `file = \"bunny.OBJ\"`"),
        (&ply, "a PLY mesh", "`[[mesh]]` with `file = \"model.dat\"`"),
        (&stl, "an STL mesh", "`[[mesh]]` with `file = \"part.stl\"`"),
        (&bpt, "a Bezier patch file", "`[[teapot]]` with `file = \"pot.bpt\"`"),
        (&exr, "an OpenEXR image", "`caustix compare render.out REFERENCE`"),
        (&png, "a PNG image", "`caustix compare render.png REFERENCE`"),
        (&map, "a photon map saved by `caustix photons`", "`caustix render SCENE --photon-map maps.bin`"),
    ] {
        let err = Scene::load(path).unwrap_err().to_string();
        let says = format!("{}: this is {what}", path.display());
        assert!(err.starts_with(&says) && err.contains(entry), "{err}");
    }
    // A scene file whose name says mesh is still a scene, and a broken
    // TOML file is still reported as TOML.
    let named_obj = write(dir.path(), "scene.obj", QUAD_SCENE);
    assert!(Scene::load(&named_obj).is_ok());
    let broken = write(dir.path(), "scene.toml", "v 0 0 0\n");
    let err = Scene::load(&broken).unwrap_err().to_string();
    assert!(err.contains("scene.toml:1:") && !err.contains("mesh"), "{err}");
}

/// Every bad input through the binary: exit code 1, one `error:` line, no panic.
#[test]
fn cli_reports_errors_without_panicking() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "broken.obj", "v 0 0 0\nf 1 2 3\n");
    let cases = [
        edit("[image]", "[image"),
        edit("diffuse = 0.8", "colour = 0.8"),
        edit(r#"material = "white""#, r#"material = "whit""#),
        edit("fov = 90", "fov = nan"),
        edit("width = 64", "width = -64"),
        format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"broken.obj\"\nmaterial = \"white\"\n"),
        QUAD_SCENE[..QUAD_SCENE.find("[[quad]]").unwrap()].to_string(),
        "\u{0}\u{1}binary junk".to_string(),
    ];
    for (i, text) in cases.iter().enumerate() {
        let path = write(dir.path(), &format!("case{i}.toml"), text);
        for command in ["render", "info"] {
            let out = dir.path().join("out.png");
            let run = caustix(
                &[command.as_ref(), path.as_os_str(), "-o".as_ref(), out.as_os_str()]
                    [..if command == "info" { 2 } else { 4 }],
            );
            let stderr = String::from_utf8_lossy(&run.stderr);
            assert_eq!(run.status.code(), Some(1), "case {i} ({command}): {stderr}");
            assert!(stderr.starts_with("error: ") && !stderr.contains("panicked"), "case {i}: {stderr}");
            assert!(
                stderr.contains(&format!("case{i}.toml")) || stderr.contains("broken.obj"),
                "case {i}: {stderr}"
            );
        }
    }
    let run = caustix(&["render".as_ref(), dir.path().join("absent.toml").as_os_str()]);
    assert_eq!(run.status.code(), Some(1));
    let run = caustix(&[
        "render".as_ref(),
        write(dir.path(), "ok.toml", QUAD_SCENE).as_os_str(),
        "--width".as_ref(),
        "0".as_ref(),
    ]);
    assert_eq!(run.status.code(), Some(1), "{}", String::from_utf8_lossy(&run.stderr));
}

/// A mesh file without a triangle (vertices only, or faces without area)
/// is said, not silently dropped; when it was the scene's only geometry the
/// error says why there is none.
#[test]
fn a_mesh_file_without_triangles_is_said() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    let mesh = "[[mesh]]\nfile = \"points.obj\"\nmaterial = \"white\"\n";
    let scene = Scene::load(&write(dir.path(), "s.toml", &format!("{QUAD_SCENE}\n{mesh}"))).unwrap();
    assert!(scene.warnings.iter().any(|w| w.contains("points.obj: no triangles")), "{:?}", scene.warnings);
    let alone = format!("{}{mesh}", &QUAD_SCENE[..QUAD_SCENE.find("[[quad]]").unwrap()]);
    let err = Scene::load(&write(dir.path(), "s.toml", &alone)).unwrap_err().to_string();
    assert!(err.contains("no geometry") && err.contains("points.obj: no triangles"), "{err}");
}
