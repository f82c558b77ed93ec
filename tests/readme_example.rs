//! The README's full scene-file example must stay a valid scene.

use caustix::scene::Scene;

#[test]
fn readme_scene_example_loads() {
    let readme = include_str!("../README.md");
    let start = readme.find("```toml\n").expect("README has a toml block") + "```toml\n".len();
    let example = &readme[start..start + readme[start..].find("```").unwrap()];
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("models")).unwrap();
    let bunny = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/data/bunny.obj");
    std::fs::copy(bunny, dir.path().join("models/bunny.obj")).unwrap();
    let path = dir.path().join("example.toml");
    std::fs::write(&path, example).unwrap();

    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("README example: {e}"));
    assert_eq!(scene.lights.len(), 3);
    assert_eq!(scene.materials.len(), 2);
    // sphere, quad, box, ring, teapot, bunny
    assert_eq!(scene.meshes.len(), 6);
    let bunny = scene.meshes.last().unwrap();
    // Its 1,839 vertices, a few copied where it folds at creases.
    assert_eq!(bunny.indices.len(), 3674);
    assert!((1839..1939).contains(&bunny.positions.len()), "{}", bunny.positions.len());
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}
