//! PLY files: `caustix export` writes a scene's triangles as binary PLY (and
//! OBJ and STL), and a `[[mesh]]` reads them back as the same triangles.

mod common;

use caustix::scene::Scene;
use common::{caustix, write};

/// A scene of a teapot and a sphere at a low tessellation.
const SHAPES: &str = r#"
[camera]
eye = [0.0, 2.0, 9.0]
look_at = [0.0, 1.0, 0.0]
[materials.grey]
diffuse = 0.5
[[point_light]]
position = [0.0, 6.0, 2.0]
power = 100.0
[[teapot]]
material = "grey"
subdivisions = 4
[[sphere]]
center = [3.0, 1.0, 0.0]
radius = 1.0
material = "grey"
"#;

#[test]
fn exported_meshes_load_back_as_the_same_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = write(dir.path(), "shapes.toml", SHAPES);
    let original = Scene::load(&scene_path).unwrap();
    let (positions, _, indices) = original.merged_triangles();
    for name in ["shapes.ply", "shapes.obj", "shapes.stl"] {
        let out = dir.path().join(name);
        let run = caustix(&["export".as_ref(), scene_path.as_os_str(), "-o".as_ref(), out.as_os_str()]);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        let text = SHAPES.split("[[teapot]]").next().unwrap().to_owned()
            + &format!("[[mesh]]\nfile = \"{name}\"\nmaterial = \"grey\"\n");
        let loaded = Scene::load(&write(dir.path(), "loaded.toml", &text)).unwrap();
        let (p, _, i) = loaded.merged_triangles();
        // tobj renumbers vertices; compare triangles by their corners. Binary
        // PLY keeps every bit, and so do OBJ's shortest round-trip decimals.
        let corners = |p: &[glam::Vec3], i: &[[u32; 3]]| -> Vec<[glam::Vec3; 3]> {
            i.iter().map(|t| t.map(|v| p[v as usize])).collect()
        };
        assert!(corners(&p, &i) == corners(&positions, &indices), "{name}: triangles differ");
        if name.ends_with(".ply") {
            assert!(i == indices && p == positions, "PLY keeps the vertex order");
        }
        if name.ends_with(".stl") {
            // Flat: each corner's normal is its triangle's.
            let mesh = &loaded.meshes[0];
            for (k, t) in mesh.indices.iter().enumerate() {
                let face = mesh.face_normal(k as u32);
                assert!(t.iter().all(|&v| (mesh.normals[v as usize] - face).length() < 1e-6), "triangle {k}");
            }
        }
    }
}

#[test]
fn a_ply_mesh_needs_a_material_and_a_sound_file() {
    let dir = tempfile::tempdir().unwrap();
    let head = SHAPES.split("[[teapot]]").next().unwrap();
    write(dir.path(), "tri.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    let err = Scene::load(&write(dir.path(), "a.toml", &format!("{head}[[mesh]]\nfile = \"tri.ply\"\n")))
        .unwrap_err()
        .to_string();
    assert!(err.contains("tri.ply") && err.contains("carry no materials"), "{err}");
    write(dir.path(), "cut.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0\n");
    let err = Scene::load(&write(
        dir.path(),
        "b.toml",
        &format!("{head}[[mesh]]\nfile = \"cut.ply\"\nmaterial = \"grey\"\n"),
    ))
    .unwrap_err()
    .to_string();
    assert!(err.contains("cut.ply") && err.contains("ends in vertex 2"), "{err}");
}

/// What a PLY file holds that is not read (a scan's vertex colours, its
/// confidence) is said in one warning, with what colours the mesh instead;
/// so are triangles without area, left out as an OBJ's are. A file of
/// positions and normals alone says nothing.
#[test]
fn ply_properties_not_read_and_triangles_left_out_are_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let head = SHAPES.split("[[teapot]]").next().unwrap();
    let load = |file: &str, text: &str| {
        write(dir.path(), file, text);
        let scene = format!("{head}[[mesh]]\nfile = \"{file}\"\nmaterial = \"grey\"\n");
        Scene::load(&write(dir.path(), "s.toml", &scene)).unwrap()
    };
    let scan = load(
        "scan.ply",
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property float confidence\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face 2\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0 1 255 0 0\n1 0 0 1 0 255 0\n0 1 0 1 0 0 255\n2 0 0 1 9 9 9\n3 0 1 2\n3 0 1 3\n",
    );
    assert_eq!(
        scan.warnings,
        [
            "scan.ply: vertex properties caustix does not read were left out: confidence, red, green, blue \
             (the [[mesh]]'s material colours the whole mesh)",
            "scan.ply: 1 of its 2 triangles have no area (repeated or collinear vertices) and were left out",
        ]
    );
    let plain = load(
        "plain.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n",
    );
    assert!(plain.warnings.is_empty(), "{:?}", plain.warnings);
}

/// A PLY file is read as one by its header whatever its name, in a
/// `[[mesh]]` as where a scene belongs (the error there names it a PLY mesh).
#[test]
fn a_ply_file_is_known_by_its_header() {
    let dir = tempfile::tempdir().unwrap();
    let ply =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
               element face 1\nproperty list uchar int vertex_indices\nend_header\n\
               0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    write(dir.path(), "triangle.dat", ply);
    let text = SHAPES.split("[[teapot]]").next().unwrap().to_owned()
        + "[[mesh]]\nfile = \"triangle.dat\"\nmaterial = \"grey\"\n";
    let scene = Scene::load(&write(dir.path(), "s.toml", &text)).unwrap();
    assert_eq!(scene.triangle_count(), 1);
}
