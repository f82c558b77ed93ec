//! OBJ files: their normals are used, MTL materials map onto ours, and the
//! bunny loads as the closed mesh it is.

mod common;

use std::path::Path;

use caustix::scene::Scene;
use common::{write, write_bytes, QUAD_SCENE};
use glam::Vec3;

/// An OBJ file of one triangle per material of `mtl`, each its own object
/// named after its material.
fn triangle_per_material(mtl: &str, names: &[&str]) -> String {
    let mut obj = format!("mtllib {mtl}\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
    for name in names {
        obj += &format!("o {name}\nusemtl {name}\nf 1 2 3\n");
    }
    obj
}

#[test]
fn mtl_materials_map_onto_ours() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "things.mtl",
        "newmtl matte\nKd 0.5 0.25 0.125\n\
         newmtl chrome\nillum 3\nKs 0.9 0.9 0.9\n\
         newmtl water\nillum 7\nNi 1.33\n\
         newmtl hot\nKd 0.9 0.9 0.9\nKs 0.6 0.6 0.6\nNs 30\n",
    );
    write(
        dir.path(),
        "things.obj",
        &triangle_per_material("things.mtl", &["matte", "chrome", "water", "hot"]),
    );
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"things.obj\"\n");
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();

    let material_of = |object: &str| {
        let mesh = scene.meshes.iter().find(|m| m.name == format!("things.obj:{object}")).unwrap();
        &scene.materials[mesh.material]
    };
    assert_eq!(material_of("matte").diffuse, Vec3::new(0.5, 0.25, 0.125));
    assert_eq!(material_of("matte").name, "things.obj:matte");
    let chrome = material_of("chrome");
    assert_eq!((chrome.mirror, chrome.specular), (Vec3::splat(0.9), Vec3::ZERO));
    let water = material_of("water");
    assert_eq!((water.transmittance, water.ior), (Vec3::ONE, 1.33));
    // 0.9 + 0.6 reflects 1.5x what arrives: scaled to 1, with a warning.
    let hot = material_of("hot");
    assert!((hot.total_reflectance() - Vec3::ONE).abs().max_element() < 1e-6);
    assert!((hot.diffuse.x / hot.specular.x - 1.5).abs() < 1e-6);
    assert_eq!(hot.phong_exponent, 30.0);
    // The water, one triangle of glass, closes no solid: named too.
    assert_eq!(scene.warnings.len(), 2, "{:?}", scene.warnings);
    assert!(scene.warnings[0].contains("things.obj:hot"));
    assert!(scene.warnings[1].contains("object `water`: 1 of its 1 glass triangles have an edge"));
}

/// OBJ and MTL files that are not UTF-8 (older exporters on Windows wrote
/// names in Latin-1) load, their names read as Latin-1, with a warning for
/// each file that says where; a zero byte is a binary file, an error at
/// its line.
#[test]
fn latin1_files_load_and_binary_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_bytes(dir.path(), "latin.mtl", b"# caf\xe9\nnewmtl caf\xe9\nKd 0.5 0.25 0.125\n");
    let obj = b"mtllib latin.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\no pi\xe8ce\nusemtl caf\xe9\nf 1 2 3\n";
    write_bytes(dir.path(), "latin.obj", obj);
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"latin.obj\"\n");
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    let mesh =
        scene.meshes.iter().find(|m| m.name == "latin.obj:pièce").expect("the object, by its Latin-1 name");
    assert_eq!(scene.materials[mesh.material].name, "latin.obj:café");
    assert_eq!(scene.materials[mesh.material].diffuse, Vec3::new(0.5, 0.25, 0.125));
    let said = |file: &str, at: &str| {
        scene.warnings.iter().filter(|w| w.contains(file) && w.contains(at) && w.contains("Latin-1")).count()
    };
    assert_eq!(said("latin.obj", "line 5, column 5"), 1, "{:#?}", scene.warnings);
    assert_eq!(said("latin.mtl", "line 1, column 6"), 1, "{:#?}", scene.warnings);
    assert_eq!(scene.warnings.len(), 2, "{:#?}", scene.warnings);

    write_bytes(dir.path(), "binary.obj", b"v 0 0 0\nv 1 0 0\x00\xff\n");
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"binary.obj\"\nmaterial = \"white\"\n");
    let err = Scene::load(&write(dir.path(), "b.toml", &text)).unwrap_err().to_string();
    assert!(err.contains("binary.obj:2:") && err.contains("binary file"), "{err}");
}

/// What an MTL file asks for that is not read (texture maps, statements
/// tobj does not know) is said once per kind, naming the file and
/// a material; statements that only restate the defaults are not; and
/// nothing is said when the scene gives the mesh its own material.
#[test]
fn mtl_features_not_read_are_warned_about_once_per_kind() {
    let dir = tempfile::tempdir().unwrap();
    let mut mtl = String::new();
    for i in 0..3 {
        mtl += &format!("newmtl wood{i}\nKd 0.5 0.4 0.3\nmap_Kd wood{i}.png\nKe 0 0 0\nTf 1 1 1\nTr 0\n");
    }
    mtl += "newmtl lamp\nKd 0.8 0.8 0.8\nKe 5 5 4\nPr 0.4\nnorm lamp_n.png\n";
    write(dir.path(), "room.mtl", &mtl);
    write(dir.path(), "room.obj", &triangle_per_material("room.mtl", &["wood0", "wood1", "wood2", "lamp"]));
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"room.obj\"\n");
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    let warned = |says: &str| scene.warnings.iter().filter(|w| w.contains(says)).count();
    assert_eq!(scene.warnings.len(), 2, "{:#?}", scene.warnings);
    assert_eq!(warned("room.obj: 3 of its 4 materials use texture maps (`wood0`: map_Kd `wood0.png`)"), 1);
    // The lamp's one triangle is a light.
    assert_eq!(scene.lights.iter().filter(|l| l.shape() == Some(caustix::light::Shape::Triangle)).count(), 1);
    assert_eq!(warned("were left out: Pr, norm ("), 1, "{:#?}", scene.warnings);
    // The flat colours are what renders.
    let wood = scene.meshes.iter().find(|m| m.name == "room.obj:wood1").unwrap();
    assert_eq!(scene.materials[wood.material].diffuse, Vec3::new(0.5, 0.4, 0.3));

    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"room.obj\"\nmaterial = \"white\"\n");
    let scene = Scene::load(&write(dir.path(), "s2.toml", &text)).unwrap();
    assert!(scene.warnings.is_empty(), "{:#?}", scene.warnings);
}

#[test]
fn obj_normals_are_used_when_present() {
    let dir = tempfile::tempdir().unwrap();
    // A flat triangle in z = 0 whose file normals lean outwards like a dome.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn -1 -1 1\nvn 1 0 1\nvn 0 1 1\nf 1//1 2//2 3//3\n";
    write(dir.path(), "dome.obj", obj);
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"dome.obj\"\nmaterial = \"white\"\n");
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    let mesh = scene.meshes.last().unwrap();
    assert!(mesh.normals[0].abs_diff_eq(Vec3::new(-1.0, -1.0, 1.0).normalize(), 1e-6));
    assert!(mesh.shading_normal(0, 1.0, 0.0).abs_diff_eq(Vec3::new(1.0, 0.0, 1.0).normalize(), 1e-6));
}

#[test]
fn bunny_loads_closed_with_outward_normals() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/data/bunny.obj"),
        dir.path().join("bunny.obj"),
    )
    .unwrap();
    let text = format!(
        "{QUAD_SCENE}\n[[mesh]]\nfile = \"bunny.obj\"\nmaterial = \"white\"\n\
         transform = {{ scale = 0.5, translate = [10, 0, 0] }}\n"
    );
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    let bunny = scene.meshes.last().unwrap();
    // Its 1,839 vertices, some copied where it folds by more than the
    // crease angle (a normal for each side: `scene::creases`).
    let mut places: Vec<[u32; 3]> = bunny.positions.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
    places.sort_unstable();
    places.dedup();
    assert_eq!((places.len(), bunny.indices.len()), (1839, 3674));
    assert!(bunny.positions.len() - 1839 < 100, "{} copies", bunny.positions.len() - 1839);
    // Signed volume (divergence theorem) is positive for outward winding:
    // 194.29 in the file's units, times 0.5^3 after the transform.
    let volume: f32 = bunny
        .indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| bunny.positions[i as usize] - Vec3::new(10.0, 0.0, 0.0));
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    assert!((volume - 194.29 * 0.125).abs() < 0.05, "volume {volume}");
    // Smooth normals agree with the faces around them.
    for (prim, _) in bunny.indices.iter().enumerate() {
        let face = bunny.face_normal(prim as u32);
        assert!(bunny.shading_normal(prim as u32, 1.0 / 3.0, 1.0 / 3.0).dot(face) > 0.0);
    }
}

/// A concave face (an L, its corners starting in the notch, where a fan
/// from the first corner covers the notch and leaves out an arm) becomes
/// triangles that all face the L's way and add up to its area, from an
/// OBJ and from a PLY file alike.
#[test]
fn concave_faces_become_the_triangles_inside_them() {
    let dir = tempfile::tempdir().unwrap();
    let corners = [[2, 0, 1], [1, 0, 1], [1, 0, 2], [0, 0, 2], [0, 0, 0], [2, 0, 0]];
    let vertices: String = corners.iter().map(|[x, y, z]| format!("{x} {y} {z}\n")).collect();
    let obj = vertices.lines().map(|v| format!("v {v}\n")).collect::<String>() + "f 1 2 3 4 5 6\n";
    write(dir.path(), "l.obj", &obj);
    let ply = format!(
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n{vertices}6 0 1 2 3 4 5\n"
    );
    write(dir.path(), "l.ply", &ply);
    for file in ["l.obj", "l.ply"] {
        let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"{file}\"\nmaterial = \"white\"\n");
        let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
        let (positions, _, indices) = scene.merged_triangles();
        // The L's triangles are the last 4 (after the quad scene's own).
        let l = &indices[indices.len() - 4..];
        let normals: Vec<Vec3> = l
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                (b - a).cross(c - a)
            })
            .collect();
        // Corners listed clockwise seen from above: every triangle faces down.
        assert!(normals.iter().all(|n| n.y < 0.0 && n.x == 0.0 && n.z == 0.0), "{file}: {l:?}");
        let area: f32 = normals.iter().map(|n| n.length() / 2.0).sum();
        assert!((area - 3.0).abs() < 1e-5, "{file}: the L's area is 3, its triangles' {area}");
    }
}

/// `caustix info` of a mesh file (the bunny, and the same as a PLY file)
/// says what a `[[mesh]]` of it holds and prints a scene that frames it:
/// rendered, the mesh fills a fair part of the image and none of its edge.
#[test]
fn info_of_a_mesh_prints_a_scene_that_frames_it() {
    let dir = tempfile::tempdir().unwrap();
    let bunny = dir.path().join("bunny.obj");
    std::fs::copy(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/data/bunny.obj"), &bunny).unwrap();
    let scene = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"bunny.obj\"\nmaterial = \"white\"\n");
    let scene = write(dir.path(), "scene.toml", &scene);
    let ply = dir.path().join("bunny.ply");
    let run = common::caustix(&["export".as_ref(), scene.as_os_str(), "-o".as_ref(), ply.as_os_str()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    for (mesh, triangles) in [(&bunny, "3674 triangles"), (&ply, "triangles")] {
        let run = common::caustix(&["info".as_ref(), mesh.as_os_str()]);
        let out = String::from_utf8_lossy(&run.stdout);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        assert!(out.contains(triangles) && out.contains("needs a `material"), "{out}");
        // The whole output is the scene (the rest is comments).
        let framing = &out[..];
        // With and without the mesh: the pixels that differ are the mesh's.
        let name = mesh.file_name().unwrap().to_str().unwrap();
        let without = framing.split("\n[[mesh]]").next().unwrap();
        let render = |text: &str| {
            let scene = Scene::load(&write(dir.path(), "framed.toml", text)).unwrap();
            let accel =
                caustix::accel::build(caustix::accel::Backend::Embree, &scene.triangle_views()).unwrap();
            let config = caustix::RenderConfig {
                integrator: "normals".parse().unwrap(),
                width: 48,
                height: 32,
                ..scene.config.clone()
            };
            caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap().film.beauty()
        };
        let (with, without) = (render(framing), render(without));
        let mesh_at: Vec<bool> = with.pixels.iter().zip(&without.pixels).map(|(a, b)| a != b).collect();
        let covered = mesh_at.iter().filter(|&&m| m).count();
        assert!(covered > mesh_at.len() / 8, "{name}: the mesh covers {covered} of {} pixels", mesh_at.len());
        let on_edge = |i: usize| [0, 47].contains(&(i % 48)) || !(48..48 * 31).contains(&i);
        assert!(
            (0..48 * 32).filter(|&i| on_edge(i)).all(|i| !mesh_at[i]),
            "{name}: the mesh reaches the image's edge"
        );
    }
}

/// The scene `caustix info` prints for a mesh names the mesh from where
/// the scene goes: from the folder of the file its output is redirected to
/// (in another folder than the mesh, a name with quotes), else as the path
/// was given, from the current folder. Each scene loads with the mesh.
#[test]
fn info_names_the_mesh_from_where_its_scene_is_saved() {
    let dir = tempfile::tempdir().unwrap();
    let models = dir.path().join("models \"q\"");
    let scenes = dir.path().join("scenes").join("deeper");
    std::fs::create_dir_all(&models).unwrap();
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::copy(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/data/bunny.obj"), models.join("bunny.obj"))
        .unwrap();
    let info = |to: std::process::Stdio, saved: &Path| {
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_caustix"))
            .args(["info", "models \"q\"/bunny.obj"])
            .current_dir(dir.path())
            .stdout(to)
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        if !run.stdout.is_empty() {
            std::fs::write(saved, &run.stdout).unwrap();
        }
        let text: toml::Value = toml::from_str(&std::fs::read_to_string(saved).unwrap()).unwrap();
        let file = text["mesh"][0]["file"].as_str().unwrap().to_string();
        let scene = Scene::load(saved).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(scene.triangle_count(), 3674 + 2, "{file}");
        file
    };
    let saved = scenes.join("bunny.toml");
    let file = info(std::fs::File::create(&saved).unwrap().into(), &saved);
    assert_eq!(file, r#"../../models "q"/bunny.obj"#);
    let piped = dir.path().join("piped.toml");
    let file = info(std::process::Stdio::piped(), &piped);
    assert_eq!(file, r#"models "q"/bunny.obj"#);
}

/// Faces an OBJ file gives no material (before its first `usemtl`, or
/// after a `usemtl` its MTL file does not define) are an error that says
/// which and where; the `[[mesh]]`'s `default_material` gives them one,
/// while the other faces keep the MTL file's. `material` and
/// `default_material` together are an error (the default would never be
/// used), and `caustix info` writes the key the file needs.
#[test]
fn faces_without_a_material_take_the_meshes_default() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "one.mtl", "newmtl matte\nKd 0.5 0.25 0.125\n");
    let before =
        "mtllib one.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\no first\nf 1 2 3\no second\nusemtl matte\nf 1 3 2\n";
    let unknown = "mtllib one.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\no first\nusemtl shiny\nf 1 2 3\no second\nusemtl matte\nf 1 3 2\n";
    // (The second object's `usemtl` after the `mtllib` finds it.)
    let late = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl matte\no first\nf 1 2 3\nmtllib one.mtl\no second\nusemtl matte\nf 1 3 2\n";
    for (file, text, says) in [
        ("before.obj", before, "faces from line 6 come before the first `usemtl` (line 8)"),
        (
            "unknown.obj",
            unknown,
            "`usemtl shiny` on line 6 names no material of its MTL files (they define matte)",
        ),
        ("late.obj", late, "its `usemtl` on line 4 comes before the `mtllib` on line 7"),
    ] {
        write(dir.path(), file, text);
        let scene = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"{file}\"\n");
        let err = Scene::load(&write(dir.path(), "s.toml", &scene)).unwrap_err().to_string();
        assert!(
            err.contains(file) && err.contains("object `first` has no material") && err.contains(says),
            "{err}"
        );
        assert!(err.contains("default_material"), "{err}");

        let scene =
            Scene::load(&write(dir.path(), "s.toml", &format!("{scene}default_material = \"white\"\n")))
                .unwrap();
        let material_of = |object: &str| {
            let mesh = scene.meshes.iter().find(|m| m.name == format!("{file}:{object}")).unwrap();
            scene.materials[mesh.material].name.clone()
        };
        assert_eq!((material_of("first"), material_of("second")), ("white".into(), format!("{file}:matte")));

        let run = common::caustix(&["info".as_ref(), dir.path().join(file).as_os_str()]);
        let out = String::from_utf8_lossy(&run.stdout);
        assert!(out.contains(&format!("none for {file}:first")), "{out}");
        assert!(out.ends_with("default_material = \"grey\"\n"), "{out}");
    }
    let both = format!(
        "{QUAD_SCENE}\n[[mesh]]\nfile = \"before.obj\"\nmaterial = \"white\"\ndefault_material = \"white\"\n"
    );
    let err = Scene::load(&write(dir.path(), "s.toml", &both)).unwrap_err().to_string();
    let line = both.lines().position(|l| l.starts_with("default_material")).unwrap() + 1;
    assert!(err.contains(&format!("s.toml:{line}:")) && err.contains("would never be used"), "{err}");
}

/// What some exporters write loads as the OBJ format means it: a byte
/// order mark before the first statement, a statement continued over lines
/// by a `\` (later errors keep their lines; a comment's `\` continues
/// nothing), and `mtllib` naming two files.
#[test]
fn byte_order_marks_continued_lines_and_two_mtl_files_on_a_line() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "a.mtl", "\u{feff}newmtl red\nKd 0.8 0 0\n");
    write(dir.path(), "b.mtl", "newmtl green\nKd 0 0.8 0\n");
    let obj = "\u{feff}mtllib a.mtl b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
               o one\nusemtl red\nf 1 2 \\\n 3\n# C:\\models\\\no two\nusemtl green\nf 2 \\\r\n 4 \\\n 3\n";
    write(dir.path(), "odd.obj", obj);
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"odd.obj\"\n");
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    let mesh = |object: &str| scene.meshes.iter().find(|m| m.name == format!("odd.obj:{object}")).unwrap();
    assert_eq!(mesh("one").indices.len(), 1);
    assert_eq!(mesh("two").indices.len(), 1);
    assert_eq!(scene.materials[mesh("one").material].diffuse, Vec3::new(0.8, 0.0, 0.0));
    assert_eq!(scene.materials[mesh("two").material].diffuse, Vec3::new(0.0, 0.8, 0.0));

    // A bad face after the continued ones is named on its own line (16).
    write(dir.path(), "odd.obj", &format!("{obj}f 1 2 9\n"));
    let err = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap_err().to_string();
    assert!(err.contains("odd.obj:16:") && err.contains("vertex 9 does not exist"), "{err}");
}

/// A model placed by several `[[mesh]]` is read once: each placement gets
/// its own copy of the meshes, moved by its own transform, and the MTL
/// materials are added once (a `[[mesh]]` giving its own `material` is a
/// read of its own). Its warnings are said once.
#[test]
fn a_model_placed_several_times_is_read_once() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.mtl", "newmtl matte\nKd 0.5 0.25 0.125\nmap_Kd wood.png\n");
    write(dir.path(), "m.obj", &triangle_per_material("m.mtl", &["matte"]));
    let mut text = format!("{QUAD_SCENE}\n");
    for x in [0, 10, 20] {
        text += &format!("[[mesh]]\nfile = \"m.obj\"\ntransform = {{ translate = [{x}, 0, 0] }}\n");
    }
    text += "[[mesh]]\nfile = \"m.obj\"\nmaterial = \"white\"\n";
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    let placed: Vec<_> = scene.meshes.iter().filter(|m| m.name == "m.obj:matte").collect();
    assert_eq!(placed.len(), 4);
    let from_file: Vec<_> = scene.materials.iter().filter(|m| m.name == "m.obj:matte").collect();
    assert_eq!(from_file.len(), 1, "the MTL materials once");
    for (mesh, x) in placed.iter().zip([0.0, 10.0, 20.0]) {
        assert_eq!(scene.materials[mesh.material].diffuse, Vec3::new(0.5, 0.25, 0.125));
        let shift = mesh.positions[1] - placed[0].positions[1];
        assert!((shift - Vec3::new(x, 0.0, 0.0)).length() < 1e-5, "{shift}");
    }
    assert_eq!(scene.materials[placed[3].material].name, "white");
    let textures = scene.warnings.iter().filter(|w| w.contains("texture maps")).count();
    assert_eq!(textures, 1, "{:?}", scene.warnings);
}

/// An MTL file's problems are errors at its own line, and a missing one
/// says which OBJ file named it (it used to read as the mesh file
/// missing); a colour of one number is the grey the format says it is;
/// a missing MTL file whose materials no face uses is no error.
#[test]
fn mtl_problems_are_named_in_the_mtl_file() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.obj", &triangle_per_material("m.mtl", &["paint"]));
    let text = format!("{QUAD_SCENE}\n[[mesh]]\nfile = \"m.obj\"\n");
    let scene_path = write(dir.path(), "s.toml", &text);
    let load = |mtl: &str| {
        write(dir.path(), "m.mtl", mtl);
        Scene::load(&scene_path)
    };
    let scene = load("newmtl paint\nKd 0.25\nKs 0.5\n").unwrap();
    let paint = scene.materials.iter().find(|m| m.name == "m.obj:paint").unwrap();
    assert_eq!((paint.diffuse, paint.specular), (Vec3::splat(0.25), Vec3::splat(0.5)));
    for (mtl, says) in [
        ("newmtl paint\nKd 0.8 0 0\nNs shiny\n", "m.mtl:3:1: `Ns` needs a number"),
        ("newmtl paint\nillum 300\n", "m.mtl:2:1: `illum` needs an illumination model"),
        ("newmtl\n", "m.mtl:1:1: `newmtl` needs the material's name"),
        ("newmtl paint\nKd spectral paint.rfl\n", "m.mtl:2:1: `Kd` needs three numbers (red, green, blue), or one for grey (`Kd spectral` is not read)"),
        ("newmtl paint\nmap_Kd\n", "m.mtl:2:1: `map_Kd` needs a file name"),
    ] {
        let err = load(mtl).unwrap_err().to_string();
        assert!(err.contains(says), "{mtl:?}: {err}");
    }
    std::fs::remove_file(dir.path().join("m.mtl")).unwrap();
    let err = Scene::load(&scene_path).unwrap_err().to_string();
    assert!(
        err.contains("m.mtl: MTL file not found (named by `mtllib` in") && err.contains("m.obj"),
        "{err}"
    );
    let given = format!("{text}material = \"white\"\n");
    assert!(Scene::load(&write(dir.path(), "s.toml", &given)).is_ok());
}

/// A glass sphere from an OBJ file that winds its triangles inward, or
/// turns every third, or gives every face twice (as exports of two-sided
/// faces do: the copy wound the other way, with its normals turned too),
/// renders as the sphere wound outward, with or without the file's
/// normals, and each is reported; a diffuse sphere whose triangles turn
/// every which way, or come twice, gets the same smooth normals as the one
/// wound outward. (Unturned, the inward glass sphere comes out as a bubble
/// with a ring of total internal reflection, the mixed one and the two-sided
/// one shattered, and the diffuse ones speckled.)
#[test]
fn mesh_files_wound_inward_or_every_which_way_render_as_wound_outward() {
    let dir = tempfile::tempdir().unwrap();
    let ball = "[camera]\neye = [0, 0, 4]\nlook_at = [0, 0, 0]\n[materials.m]\ndiffuse = 0.5\n\
                [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nsubdivisions = 3\nmaterial = \"m\"\n";
    let ball = write(dir.path(), "ball.toml", ball);
    let obj = dir.path().join("ball.obj");
    let run = common::caustix(&["export".as_ref(), ball.as_os_str(), "-o".as_ref(), obj.as_os_str()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let exported = std::fs::read_to_string(&obj).unwrap();
    // The file's faces, each rewritten by `face` (its index among the
    // faces and its corners), with or without the normals.
    // (The normals again, turned, after the file's: the two-sided copies'.)
    let normals_given = exported.lines().filter(|line| line.starts_with("vn ")).count();
    let turned_normals: String = exported
        .lines()
        .filter_map(|line| line.strip_prefix("vn "))
        .map(|n| {
            let n: Vec<f32> = n.split_whitespace().map(|x| x.parse().unwrap()).collect();
            format!("vn {} {} {}\n", -n[0], -n[1], -n[2])
        })
        .collect();
    // Each face as a variant writes it: one face or more, three corners each.
    type Faces = Vec<[String; 3]>;
    let variant = |name: &str, normals: bool, face: &dyn Fn(usize, [&str; 3]) -> Faces| {
        let mut text = String::new();
        let mut k = 0;
        for line in exported.lines() {
            if let Some(rest) = line.strip_prefix("f ") {
                let corners: Vec<&str> = rest.split_whitespace().collect();
                for corners in face(k, [corners[0], corners[1], corners[2]]) {
                    let corners =
                        corners.map(|c| if normals { c } else { c.split('/').next().unwrap().to_string() });
                    text += &format!("f {}\n", corners.join(" "));
                }
                k += 1;
            } else if normals || !line.starts_with("vn ") {
                text += &format!("{line}\n");
            }
        }
        if normals {
            text += &turned_normals;
        }
        write(dir.path(), name, &text);
    };
    let keep = |_: usize, c: [&str; 3]| vec![c.map(String::from)];
    let inward = |_: usize, [a, b, c]: [&str; 3]| vec![[a, c, b].map(String::from)];
    let mixed = |k: usize, [a, b, c]: [&str; 3]| {
        vec![if k.is_multiple_of(3) { [a, c, b] } else { [a, b, c] }.map(String::from)]
    };
    // `v//n` corners: the copy's normal is the turned one, `normals_given` on.
    let turned = |corner: &str| match corner.split_once("//") {
        Some((v, n)) => format!("{v}//{}", n.parse::<usize>().unwrap() + normals_given),
        None => panic!("the exported corner {corner} is not v//n"),
    };
    let two_sided = |_: usize, [a, b, c]: [&str; 3]| vec![[a, b, c].map(String::from), [c, b, a].map(turned)];
    for normals in [true, false] {
        let tag = if normals { "n" } else { "" };
        variant(&format!("out{tag}.obj"), normals, &keep);
        variant(&format!("in{tag}.obj"), normals, &inward);
        variant(&format!("mixed{tag}.obj"), normals, &mixed);
        variant(&format!("twice{tag}.obj"), normals, &two_sided);
    }
    let scene_of = |file: &str, material: &str| {
        let text = format!(
            "[camera]\neye = [0, 1, 4]\nlook_at = [0, 0.6, 0]\n[image]\nwidth = 40\nheight = 40\nsamples = 1\n\
             [render]\nintegrator = \"whitted\"\n[materials.glass]\ntransmittance = 1.0\n\
             [materials.matte]\ndiffuse = 0.7\n[materials.floor]\ndiffuse = [0.8, 0.3, 0.2]\n\
             [[point_light]]\nposition = [1, 3, 2]\npower = 100\n\
             [[quad]]\ncenter = [0, 0, 0]\nu = [6, 0, 0]\nv = [0, 0, -6]\nmaterial = \"floor\"\n\
             [[mesh]]\nfile = \"{file}\"\nmaterial = \"{material}\"\ntransform = {{ scale = 0.6, translate = [0, 0.6, 0] }}\n"
        );
        Scene::load(&write(dir.path(), "s.toml", &text)).unwrap()
    };
    let image = |scene: &Scene| {
        let accel = caustix::accel::build(caustix::accel::Backend::Embree, &scene.triangle_views()).unwrap();
        caustix::render(scene, accel.as_ref(), &scene.config, &|_| {}).unwrap().film.beauty()
    };
    // Turned triangles name their corners in another order, so Embree's
    // barycentrics round differently: the same image within rounding.
    let largest_difference = |a: &caustix::film::Image, b: &caustix::film::Image| {
        a.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).abs().max_element()).fold(0.0f32, f32::max)
    };
    for material in ["glass", "matte"] {
        for tag in ["n", ""] {
            let outward = scene_of(&format!("out{tag}.obj"), material);
            assert!(outward.warnings.is_empty(), "{:?}", outward.warnings);
            let reference = image(&outward);
            for (file, what) in [("in", "wind"), ("mixed", "wind against"), ("twice", "a face written twice")]
            {
                let scene = scene_of(&format!("{file}{tag}.obj"), material);
                let diff = largest_difference(&image(&scene), &reference);
                if material == "glass" || (file != "in" && tag.is_empty()) {
                    assert!(diff < 1e-4, "{file}{tag}.obj as {material}: {diff}");
                    assert_eq!(scene.warnings.len(), 1, "{file}{tag}.obj: {:?}", scene.warnings);
                    assert!(scene.warnings[0].contains(what), "{:?}", scene.warnings);
                } else {
                    // Matte surfaces look the same from both sides: the
                    // file's winding is kept, without a word.
                    assert!(diff < 1e-4, "{file}{tag}.obj as {material}: {diff}");
                    assert!(scene.warnings.is_empty(), "{file}{tag}.obj: {:?}", scene.warnings);
                }
            }
        }
    }
}

/// A box from an OBJ or PLY file without normals shades flat, as the built-in
/// `[[box]]` does: its faces meet at creases, which smooth normals do not
/// cross. (Averaged over all the triangles at each corner, its normals
/// pointed along the diagonals and each face shaded as a blob.)
#[test]
fn a_box_from_a_file_without_normals_shades_as_the_built_in_box() {
    let dir = tempfile::tempdir().unwrap();
    let cube = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n\
                f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    write(dir.path(), "cube.obj", cube);
    let scene_with = |name: &str, object: &str| {
        let text = format!(
            "[camera]\neye = [2.5, 2.2, 3.0]\nlook_at = [0.5, 0.4, 0.5]\nfov = 35\n\
             [image]\nwidth = 48\nheight = 36\nsamples = 1\n[render]\nintegrator = \"whitted\"\n\
             [materials.m]\ndiffuse = 0.7\n[[point_light]]\nposition = [3, 5, 2]\npower = 300\n{object}"
        );
        Scene::load(&write(dir.path(), name, &text)).unwrap()
    };
    // The same box as an ASCII PLY file, its faces from the OBJ's lines.
    let mut ply = String::from(
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n\
         element face 6\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for line in cube.lines() {
        let (kind, rest) = line.split_once(' ').unwrap();
        let numbers: Vec<i32> = rest.split(' ').map(|n| n.parse().unwrap()).collect();
        ply += &match kind {
            "v" => format!("{} {} {}\n", numbers[0], numbers[1], numbers[2]),
            _ => format!("4 {}\n", numbers.iter().map(|i| (i - 1).to_string()).collect::<Vec<_>>().join(" ")),
        };
    }
    write(dir.path(), "cube.ply", &ply);
    let built_in = scene_with("box.toml", "[[box]]\ncenter = [0.5, 0.5, 0.5]\nsize = 1\nmaterial = \"m\"\n");
    let image = |scene: &Scene| {
        let accel = caustix::accel::build(caustix::accel::Backend::Embree, &scene.triangle_views()).unwrap();
        caustix::render(scene, accel.as_ref(), &scene.config, &|_| {}).unwrap().film.beauty()
    };
    let b = image(&built_in);
    let lit = b.pixels.iter().filter(|p| p.max_element() > 0.0).count();
    assert!(lit > 300, "the box is in view: {lit} pixels");
    for file in ["cube.obj", "cube.ply"] {
        let from_file = scene_with("file.toml", &format!("[[mesh]]\nfile = \"{file}\"\nmaterial = \"m\"\n"));
        assert_eq!(from_file.meshes[0].positions.len(), 24, "{file}: each corner a vertex per face");
        let a = image(&from_file);
        for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
            let near = (*p - *q).abs().max_element() <= 1e-5 * q.max_element().max(1.0);
            assert!(near, "{file}: pixel {i}: {p} against {q}");
        }
    }
}

/// A hollow glass box as two OBJ objects: the outer surface wound outward,
/// the inner one into the cavity. As it is, nothing turns; mirrored (every
/// face reversed, as a mirrored export leaves it), the whole file turns
/// back, the cavity with it, and says so once.
#[test]
fn a_hollow_glass_box_in_two_objects_turns_as_one_file() {
    let dir = tempfile::tempdir().unwrap();
    let quads = [[1, 3, 4, 2], [5, 6, 8, 7], [1, 2, 6, 5], [3, 7, 8, 4], [1, 5, 7, 3], [2, 4, 8, 6]];
    let mut obj = String::from("o outer\n");
    for i in 0..8 {
        obj += &format!("v {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1);
    }
    quads.iter().for_each(|[a, b, c, d]| obj += &format!("f {a} {b} {c} {d}\n"));
    obj += "o inner\n";
    for i in 0..8 {
        let at = |bit: i32| 0.25 + 0.5 * ((i >> bit) & 1) as f32;
        obj += &format!("v {} {} {}\n", at(0), at(1), at(2));
    }
    quads.iter().for_each(|[a, b, c, d]| obj += &format!("f {} {} {} {}\n", d + 8, c + 8, b + 8, a + 8));
    let mirrored: String = obj
        .lines()
        .map(|line| match line.strip_prefix("f ") {
            Some(corners) => {
                format!("f {}\n", corners.split_whitespace().rev().collect::<Vec<_>>().join(" "))
            }
            None => format!("{line}\n"),
        })
        .collect();
    write(dir.path(), "hollow.obj", &obj);
    write(dir.path(), "mirrored.obj", &mirrored);
    let scene_of = |file: &str| {
        let text = format!(
            "{QUAD_SCENE}\n[materials.glass]\ntransmittance = 1.0\n[[mesh]]\nfile = \"{file}\"\nmaterial = \"glass\"\n"
        );
        Scene::load(&write(dir.path(), "s.toml", &text)).unwrap()
    };
    let (hollow, turned) = (scene_of("hollow.obj"), scene_of("mirrored.obj"));
    assert!(hollow.warnings.is_empty(), "{:?}", hollow.warnings);
    assert_eq!(turned.warnings.len(), 1, "{:?}", turned.warnings);
    assert!(turned.warnings[0].contains("mirrored.obj: its closed glass parts enclose a negative volume"));
    assert!(
        turned.warnings[0].contains("all 24 of its glass triangles were turned"),
        "{}",
        turned.warnings[0]
    );
    // Each object's signed volume (positive wound outward): the outer
    // box's 1, the cavity's -1/8, in both (the mirrored file's quads split
    // along their other diagonals).
    let volumes = |scene: &Scene| {
        let origin = common::in_scene(scene, Vec3::ZERO);
        let volume = |m: &caustix::scene::mesh::Mesh| {
            let corner = |i: u32| (m.positions[i as usize] - origin).as_dvec3();
            m.indices.iter().map(|t| corner(t[0]).dot(corner(t[1]).cross(corner(t[2]))) / 6.0).sum::<f64>()
        };
        scene.meshes.iter().skip(1).map(volume).collect::<Vec<f64>>()
    };
    for scene in [&hollow, &turned] {
        let v = volumes(scene);
        assert!((v[0] - 1.0).abs() < 1e-5 && (v[1] + 0.125).abs() < 1e-5, "{v:?}");
    }
}

/// A glass mesh with a hole (a cube without its top face) is named in a
/// warning: glass refracts as a solid's surface, and this one closes none.
/// The closed cube, and the open one as a matte surface, give no warning.
#[test]
fn open_glass_meshes_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let corners = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n";
    let sides = "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 1 5 7 3\nf 2 4 8 6\n";
    write(dir.path(), "closed.obj", &format!("{corners}{sides}f 3 7 8 4\n"));
    write(dir.path(), "open.obj", &format!("{corners}{sides}"));
    let warnings = |file: &str, material: &str| {
        let text = format!(
            "[camera]\neye = [2.5, 2.2, 3.0]\nlook_at = [0.5, 0.4, 0.5]\n[materials.glass]\ntransmittance = 1.0\n\
             [materials.matte]\ndiffuse = 0.7\n[[point_light]]\nposition = [3, 5, 2]\npower = 300\n\
             [[mesh]]\nfile = \"{file}\"\nmaterial = \"{material}\"\n"
        );
        Scene::load(&write(dir.path(), "s.toml", &text)).unwrap().warnings
    };
    assert!(warnings("closed.obj", "glass").is_empty(), "{:?}", warnings("closed.obj", "glass"));
    assert!(warnings("open.obj", "matte").is_empty(), "{:?}", warnings("open.obj", "matte"));
    let open = warnings("open.obj", "glass");
    assert_eq!(open.len(), 1, "{open:?}");
    assert!(
        open[0].contains("open.obj")
            && open[0].contains("4 of its 10 glass triangles have an edge that no other"),
        "{open:?}"
    );

    // A glass box with a metal lid: `usemtl` splits the object into two
    // meshes, and the lid closes the glass. Without the lid, or with the
    // lid as a second object, the count is the file's.
    write(dir.path(), "box.mtl", "newmtl glass\nillum 7\nNi 1.5\nnewmtl metal\nKd 0.5 0.5 0.5\n");
    let file_materials = |file: &str| {
        let text = format!(
            "[camera]\neye = [2.5, 2.2, 3.0]\nlook_at = [0.5, 0.4, 0.5]\n[[point_light]]\nposition = [3, 5, 2]\n\
             power = 300\n[[mesh]]\nfile = \"{file}\"\n"
        );
        Scene::load(&write(dir.path(), "s.toml", &text)).unwrap().warnings
    };
    let glass = format!("mtllib box.mtl\n{corners}usemtl glass\n{sides}");
    let lid = "usemtl metal\nf 3 7 8 4\n";
    write(dir.path(), "lidded.obj", &format!("o box\n{glass}{lid}"));
    assert!(file_materials("lidded.obj").is_empty(), "{:?}", file_materials("lidded.obj"));
    write(dir.path(), "lid_apart.obj", &format!("o box\n{glass}o lid\n{lid}"));
    assert!(file_materials("lid_apart.obj").is_empty(), "{:?}", file_materials("lid_apart.obj"));
    // A lid over half the top leaves two glass triangles on the edges of
    // the other half; the lid is not named (it is not glass).
    write(dir.path(), "half_lid.obj", &format!("{glass}usemtl metal\nf 3 7 8\n"));
    let half = file_materials("half_lid.obj");
    assert_eq!(half.len(), 1, "{half:?}");
    assert!(half[0].contains("2 of its 10 glass triangles"), "{half:?}");
}

/// The Cornell box as OBJ files pass it around: walls, and a light that is
/// a quad of a material with `Ke` (facing down by its winding).
const CORNELL_MTL: &str = "newmtl white\nKd 0.725 0.71 0.68\n\
    newmtl red\nKd 0.63 0.065 0.05\n\
    newmtl green\nKd 0.14 0.45 0.091\n\
    newmtl light\nKd 0.78 0.78 0.78\nKe 17 12 4\n";
const CORNELL_WALLS: &str = "mtllib box.mtl\n\
    o floor\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nusemtl white\nf -4 -3 -2 -1\n\
    o ceiling\nv -1 2 1\nv -1 2 -1\nv 1 2 -1\nv 1 2 1\nusemtl white\nf -4 -3 -2 -1\n\
    o back\nv -1 0 -1\nv 1 0 -1\nv 1 2 -1\nv -1 2 -1\nusemtl white\nf -4 -3 -2 -1\n\
    o right\nv 1 0 -1\nv 1 0 1\nv 1 2 1\nv 1 2 -1\nusemtl green\nf -4 -3 -2 -1\n\
    o left\nv -1 0 1\nv -1 0 -1\nv -1 2 -1\nv -1 2 1\nusemtl red\nf -4 -3 -2 -1\n";
/// The light, as one quad and as two triangles given apart (its corners
/// written twice), both wound to face down.
const CORNELL_LIGHT_QUAD: &str = "o light\nv -0.24 1.98 0.16\nv -0.24 1.98 -0.22\nv 0.23 1.98 -0.22\n\
    v 0.23 1.98 0.16\nusemtl light\nf -4 -3 -2 -1\n";
const CORNELL_LIGHT_TRIANGLES: &str = "o light\nv -0.24 1.98 0.16\nv -0.24 1.98 -0.22\nv 0.23 1.98 -0.22\n\
    v -0.24 1.98 0.16\nv 0.23 1.98 -0.22\nv 0.23 1.98 0.16\nusemtl light\nf 21 22 23\nf 24 25 26\n";
/// The light as four triangles meeting at its centre, none pairing into a
/// parallelogram, wound to face down.
const CORNELL_LIGHT_FAN: &str = "o light\nv -0.24 1.98 0.16\nv -0.24 1.98 -0.22\nv 0.23 1.98 -0.22\n\
    v 0.23 1.98 0.16\nv -0.005 1.98 -0.03\nusemtl light\nf 25 21 22\nf 25 22 23\nf 25 23 24\nf 25 24 21\n";
const CORNELL_CAMERA: &str = "[camera]\neye = [0, 1, 3.9]\nlook_at = [0, 1, 0]\nfov = 33\n\
    [image]\nwidth = 24\nheight = 24\n";

/// The walls of the Cornell box with its light declared as an
/// `[[area_light]]` of `power`, where the light's quad lies.
fn walls_under_a_declared_light(power: Vec3) -> String {
    format!(
        "{CORNELL_CAMERA}[[mesh]]\nfile = \"walls.obj\"\n\
         [[area_light]]\ncenter = [-0.005, 1.98, -0.03]\nu = [0.47, 0, 0]\nv = [0, 0, 0.38]\n\
         power = [{}, {}, {}]\n",
        power.x, power.y, power.z
    )
}

/// Path traced (in `dir`, 64 samples a pixel), the scene text `from_file`
/// renders as `declared` does: the image's sum within 1%, and the light
/// seen directly (red radiance `red`) in the same pixels.
fn renders_as(dir: &std::path::Path, from_file: &str, declared: &str, red: f32) {
    let image = |text: &str| {
        let scene = Scene::load(&write(dir, "r.toml", text)).unwrap();
        let accel = caustix::accel::build(caustix::accel::Backend::Embree, &scene.triangle_views()).unwrap();
        let config = caustix::RenderConfig {
            integrator: "path".parse().unwrap(),
            samples: 64,
            ..scene.config.clone()
        };
        caustix::render(&scene, accel.as_ref(), &config, &|_| {}).unwrap().film.beauty()
    };
    let (a, b) = (image(from_file), image(declared));
    let sum = |img: &caustix::film::Image| img.pixels.iter().map(|p| p.element_sum()).sum::<f32>();
    let ratio = sum(&a) / sum(&b);
    assert!((ratio - 1.0).abs() < 0.01, "image from the file's light / declared light: {ratio}");
    // The light itself is seen at its radiance, in the top centre's pixels.
    let lit = |img: &caustix::film::Image| img.pixels.iter().filter(|p| p.x > 0.5 * red).count();
    assert!(lit(&a) > 0, "the light is not seen");
    assert_eq!(lit(&a), lit(&b));
}

/// The area light a scene holds, as (centre in the file, u x v, power).
fn only_area_light(scene: &Scene) -> (Vec3, Vec3, Vec3) {
    let lights: Vec<_> = scene.lights.iter().collect();
    let [caustix::light::Light::Area { center, u, v, power, .. }] = lights[..] else {
        panic!("not one area light: {lights:?}")
    };
    (common::in_file(scene, *center), u.cross(*v), *power)
}

/// An OBJ face of a material that emits (`Ke`) and makes a parallelogram
/// becomes an area light of that radiance facing the side its winding
/// does, as a scene file's `[[area_light]]` in its place: the box renders
/// as the same walls with that light declared. Placed by the [[mesh]]'s
/// transform, the light keeps its radiance (power by its area) and its
/// front, mirrored or not.
#[test]
fn faces_that_emit_become_area_lights() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "box.mtl", CORNELL_MTL);
    write(dir.path(), "quad.obj", &format!("{CORNELL_WALLS}{CORNELL_LIGHT_QUAD}"));
    write(dir.path(), "triangles.obj", &format!("{CORNELL_WALLS}{CORNELL_LIGHT_TRIANGLES}"));
    write(dir.path(), "walls.obj", CORNELL_WALLS);
    let (width, depth) = (0.47f32, 0.38f32);
    let radiance = Vec3::new(17.0, 12.0, 4.0);
    for file in ["quad.obj", "triangles.obj"] {
        let text = format!("{CORNELL_CAMERA}[[mesh]]\nfile = \"{file}\"\n");
        let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
        assert!(scene.warnings.is_empty(), "{file}: {:#?}", scene.warnings);
        let (center, facing, power) = only_area_light(&scene);
        assert!(center.abs_diff_eq(Vec3::new(-0.005, 1.98, -0.03), 1e-5), "{file}: {center}");
        assert!(facing.abs_diff_eq(Vec3::new(0.0, -width * depth, 0.0), 1e-5), "{file}: {facing}");
        let expected = radiance * std::f32::consts::PI * width * depth;
        assert!(power.abs_diff_eq(expected, 1e-3 * expected.max_element()), "{file}: {power}");
        // Its faces left the mesh: 5 walls of 2 triangles.
        assert!(scene.meshes.iter().all(|m| !m.name.ends_with(":light")), "{file}");
        assert_eq!(scene.triangle_count(), 10, "{file}");

        // Scaled by 2 and mirrored in x: the same radiance over 4 times the
        // area, still facing down.
        let text =
            format!("{CORNELL_CAMERA}[[mesh]]\nfile = \"{file}\"\ntransform = {{ scale = [-2, 2, 2] }}\n");
        let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
        let (center, facing, power) = only_area_light(&scene);
        assert!(center.abs_diff_eq(Vec3::new(0.01, 3.96, -0.06), 1e-5), "{file}: {center}");
        assert!(facing.normalize().abs_diff_eq(Vec3::NEG_Y, 1e-6), "{file}: {facing}");
        assert!(power.abs_diff_eq(4.0 * expected, 4e-3 * expected.max_element()), "{file}: {power}");
    }

    // Declared by hand as well (as caustix asked before it read Ke), a
    // millimetre below: said, as the light is then there twice. A light
    // declared elsewhere is not.
    let twice = format!(
        "{CORNELL_CAMERA}[[mesh]]\nfile = \"quad.obj\"\n\
         [[area_light]]\ncenter = [0, 0.01, 0]\nu = [0.2, 0, 0]\nv = [0, 0, -0.2]\npower = 1\n\
         [[area_light]]\ncenter = [0, 1.979, 0]\nu = [0.5, 0, 0]\nv = [0, 0, 0.4]\npower = 10\n"
    );
    let scene = Scene::load(&write(dir.path(), "s.toml", &twice)).unwrap();
    assert_eq!(scene.lights.len(), 3);
    assert_eq!(scene.warnings.len(), 1, "{:#?}", scene.warnings);
    assert!(
        scene.warnings[0]
            .contains("the light of quad.obj:light #1 lies where the scene file's [[area_light]] #2 does"),
        "{:#?}",
        scene.warnings
    );

    // The render: the walls with the light declared where the quad was.
    let from_file = format!("{CORNELL_CAMERA}[[mesh]]\nfile = \"quad.obj\"\n");
    let power = radiance * std::f32::consts::PI * width * depth;
    let declared = walls_under_a_declared_light(power);
    renders_as(dir.path(), &from_file, &declared, radiance.x);
}

/// Emitting faces that make no parallelogram become triangle lights: the
/// Cornell box's light as four triangles about its centre is four lights
/// of its power between them, facing down (mirrored too), and the box
/// renders as with the light declared as one quad.
#[test]
fn emitting_triangles_become_triangle_lights() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "box.mtl", CORNELL_MTL);
    write(dir.path(), "fan.obj", &format!("{CORNELL_WALLS}{CORNELL_LIGHT_FAN}"));
    let radiance = Vec3::new(17.0, 12.0, 4.0);
    let power = radiance * std::f32::consts::PI * 0.47 * 0.38;
    for (transform, scale) in [("", 1.0), ("transform = { scale = [-2, 2, 2] }\n", 4.0)] {
        let text = format!("{CORNELL_CAMERA}[[mesh]]\nfile = \"fan.obj\"\n{transform}");
        let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
        assert!(scene.warnings.is_empty(), "{:#?}", scene.warnings);
        assert_eq!(scene.lights.len(), 4);
        assert_eq!(scene.triangle_count(), 10);
        for light in scene.lights.iter() {
            assert_eq!(light.shape(), Some(caustix::light::Shape::Triangle));
            assert!(light.facing().abs_diff_eq(Vec3::NEG_Y, 1e-6), "{transform}: {}", light.facing());
            assert!((light.front_radiance() - radiance).abs().max_element() < 1e-3 * radiance.x);
        }
        let total: Vec3 = scene.lights.iter().map(|l| l.power()).sum();
        assert!(total.abs_diff_eq(scale * power, 1e-3 * scale * power.x), "{transform}: {total}");
    }
    let declared = walls_under_a_declared_light(power);
    write(dir.path(), "walls.obj", CORNELL_WALLS);
    // Declared as well, or scaled past what f64 areas hold: one warning for the four.
    let both = declared.replace("walls.obj", "fan.obj");
    let scene = Scene::load(&write(dir.path(), "s.toml", &both)).unwrap();
    let twice = "the light of fan.obj:light #1 (and 3 more of the mesh files' lights) lies where the scene \
                 file's [[area_light]] #1 does";
    assert_eq!(scene.warnings.iter().filter(|w| w.contains(twice)).count(), 1, "{:#?}", scene.warnings);
    let flat = format!(
        "{CORNELL_CAMERA}[[mesh]]\nfile = \"fan.obj\"\ntransform = {{ scale = [1e-200, 1, 1e-200] }}\n"
    );
    let scene = Scene::load(&write(dir.path(), "s.toml", &flat)).unwrap();
    let flattened = "the light of fan.obj:light #1 (and 3 more of its lights): the [[mesh]]'s transform leaves it no area";
    assert_eq!(scene.warnings.iter().filter(|w| w.contains(flattened)).count(), 1, "{:#?}", scene.warnings);
    assert!(scene.lights.is_empty());
    let fan = format!("{CORNELL_CAMERA}[[mesh]]\nfile = \"fan.obj\"\n");
    renders_as(dir.path(), &fan, &declared, radiance.x);
}

/// An emitting object of parallelograms and triangles alike is lit whole
/// (a face of no area is said, as a surface's is), and an emission that is
/// no colour is said.
#[test]
fn emission_of_any_faces_makes_lights_and_a_wrong_one_is_said() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "box.mtl", &format!("{CORNELL_MTL}newmtl wrong\nKe 1 -1 0\n"));
    // A lamp of the light's material, a square, a triangle beside it and
    // one of no area, and a triangle of the wrong one.
    let extra = "o lamp\nv 0 1.9 0\nv 0.1 1.9 0\nv 0.1 1.9 0.1\nv 0 1.9 0.1\nv 0.2 1.9 0\n\
                 usemtl light\nf -5 -2 -3 -4\nf -4 -3 -1\nf -5 -4 -1\n\
                 o odd\nv 0 1 0\nv 0.1 1 0\nv 0 1 0.1\nusemtl wrong\nf -3 -1 -2\n";
    write(dir.path(), "b.obj", &format!("{CORNELL_WALLS}{CORNELL_LIGHT_QUAD}{extra}"));
    let text = format!("{CORNELL_CAMERA}[[mesh]]\nfile = \"b.obj\"\n");
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    // The box's light, the lamp's square and the triangle beside it.
    let shapes: Vec<_> = scene.lights.iter().filter_map(|l| l.shape()).collect();
    use caustix::light::Shape::{Parallelogram, Triangle};
    assert_eq!(shapes, [Parallelogram, Parallelogram, Triangle]);
    assert_eq!(scene.warnings.len(), 2, "{:#?}", scene.warnings);
    // A face of no area (three corners on a line) makes no light, and is said.
    let no_area = "b.obj: object `lamp`: 1 of its 4 triangles have no area";
    assert!(scene.warnings.iter().any(|w| w.contains(no_area)), "{:#?}", scene.warnings);
    assert!(
        scene.warnings.iter().any(|w| w.contains(
            "1 of its 5 materials gives an emission (Ke) with a negative or infinite part (as `wrong` does)"
        )),
        "{:#?}",
        scene.warnings
    );
    // The lamp left the mesh, whole.
    assert!(scene.meshes.iter().all(|m| m.name != "b.obj:lamp"));

    // A light brighter than 32-bit floats can carry is refused, as a scene
    // file's is.
    let mtl = CORNELL_MTL.replace("Ke 17 12 4", "Ke 1e38 12 4");
    write(dir.path(), "box.mtl", &format!("{mtl}newmtl wrong\nKe 1 -1 0\n"));
    let Err(error) = Scene::load(&write(dir.path(), "s.toml", &text)) else {
        panic!("a light of 1e38 loaded")
    };
    assert!(error.to_string().contains("the light of b.obj:light #1 sends"), "{error}");
    assert!(error.to_string().contains("beyond 1e30 per channel"), "{error}");
}

/// `caustix info` of a mesh file with lights of its own lists them, and the
/// scene it prints is lit by them alone (no point light of its own).
#[test]
fn info_of_a_mesh_with_lights_frames_it_lit_by_them() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "box.mtl", CORNELL_MTL);
    let obj = write(dir.path(), "box.obj", &format!("{CORNELL_WALLS}{CORNELL_LIGHT_QUAD}"));
    let run = common::caustix(&["info".as_ref(), obj.as_os_str()]);
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(out.contains("# lights    1 area light, from faces that emit (Ke)"), "{out}");
    assert!(!out.contains("[[point_light]]"), "{out}");
    let scene = Scene::load(&write(dir.path(), "framed.toml", &out)).unwrap();
    assert_eq!(scene.lights.len(), 1);

    // A lamp's file of nothing but faces that emit, none pairing: framed
    // by its lights.
    let lamp = "mtllib box.mtl\no lamp\nv 0 1 0\nv 1 1 0\nv 0 1 1\nv 1 2 1\nusemtl light\nf 1 2 3\nf 2 4 3\n";
    let obj = write(dir.path(), "lamp.obj", lamp);
    let run = common::caustix(&["info".as_ref(), obj.as_os_str()]);
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(out.contains("# geometry  0 triangles"), "{out}");
    assert!(out.contains("# bounds    [0, 1, 0] to [1, 2, 1]"), "{out}");
    assert!(out.contains("# lights    2 area lights, from faces that emit (Ke), all triangles"), "{out}");
    // (Wound clockwise seen from above: facing down.)
    assert!(out.contains("triangle at [0, 1, 0], [1, 1, 0], [0, 1, 1], facing [0, -1, 0]"), "{out}");
    let scene = Scene::load(&write(dir.path(), "framed.toml", &out)).unwrap();
    assert_eq!(scene.lights.len(), 2);
    // Alone in a scene, it has nothing to light, and the error says why.
    let alone = format!("{CORNELL_CAMERA}[[mesh]]\nfile = \"lamp.obj\"\n");
    let error = Scene::load(&write(dir.path(), "alone.toml", &alone)).unwrap_err().to_string();
    assert!(
        error.contains(
            "the scene has no geometry (only 2 area lights, which light nothing without a surface)"
        ),
        "{error}"
    );
}
