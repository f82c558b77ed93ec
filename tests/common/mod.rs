//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

/// A square 64x64 view from z = 5 towards the origin with a 90-degree field
/// of view, so the plane z = 0 shows x and y from -5 to 5. One white quad of
/// side 5 centred there covers exactly the middle 32x32 pixels.
pub const QUAD_SCENE: &str = include_str!("quad.toml");

/// Writes `text` to `name` inside `dir` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Writes `bytes` to `name` inside `dir` and returns the path.
pub fn write_bytes(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Runs the `caustix` binary with `args`.
pub fn caustix(args: &[&std::ffi::OsStr]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_caustix")).args(args).output().unwrap()
}

/// A closed grey sphere (radius 2, seen from inside) with a 100 W point
/// light at its centre: the indirect irradiance is the same everywhere,
/// `power * a / ((1 - a) area)`. `tables` adds TOML tables (image, photons).
pub fn furnace(albedo: f32, tables: &str) -> caustix::scene::Scene {
    furnace_scaled(albedo, 1.0, tables)
}

/// [`furnace`] `scale` times the size, with `scale^2` times the power: the
/// same radiance.
pub fn furnace_scaled(albedo: f32, scale: f64, tables: &str) -> caustix::scene::Scene {
    let text = format!(
        r#"
        [camera]
        eye = [0, 0, {scale:e}]
        look_at = [0, 0, 0]
        fov = 60
        [materials.grey]
        diffuse = {albedo}
        [[point_light]]
        position = [0, 0, 0]
        power = {power:e}
        [[sphere]]
        center = [0, 0, 0]
        radius = {radius:e}
        subdivisions = 5
        material = "grey"
        {tables}
    "#,
        power = 100.0 * scale * scale,
        radius = 2.0 * scale,
    );
    caustix::scene::Scene::from_toml(&text, Path::new("furnace.toml")).unwrap()
}

/// Six area lights of radiance 1 facing in (power `pi A`, `A` = 16): the
/// walls of a closed box 4 wide around the origin, as scene-file tables.
/// Whatever inside it absorbs nothing looks exactly like them.
pub fn box_of_lights() -> String {
    let power = std::f64::consts::PI * 16.0;
    [
        ([0, 2, 0], [4, 0, 0], [0, 0, 4]),
        ([0, -2, 0], [4, 0, 0], [0, 0, -4]),
        ([-2, 0, 0], [0, 4, 0], [0, 0, 4]),
        ([2, 0, 0], [0, 0, 4], [0, 4, 0]),
        ([0, 0, -2], [4, 0, 0], [0, 4, 0]),
        ([0, 0, 2], [0, 4, 0], [4, 0, 0]),
    ]
    .map(|(center, u, v)| {
        format!("[[area_light]]\ncenter = {center:?}\nu = {u:?}\nv = {v:?}\npower = {power}\n")
    })
    .concat()
}

/// The summed area of the first mesh's triangles.
pub fn mesh_area(scene: &caustix::scene::Scene) -> f32 {
    scene.meshes[0].area() as f32
}

/// A point given in the scene file's coordinates, in the scene's own
/// (re-centred at the camera: see `Scene::origin`).
pub fn in_scene(scene: &caustix::scene::Scene, file_point: glam::Vec3) -> glam::Vec3 {
    (file_point.as_dvec3() - scene.origin).as_vec3()
}

/// A point of the scene, in the scene file's coordinates.
pub fn in_file(scene: &caustix::scene::Scene, point: glam::Vec3) -> glam::Vec3 {
    scene.in_file(point)
}

/// The indices of the middle 6 x 6 pixels of a 12 x 12 image, row by row:
/// where the tests' furnace spheres fill the view.
pub fn middle_of_12x12() -> impl Iterator<Item = usize> {
    (0..144).filter(|i| (3..9).contains(&(i / 12)) && (3..9).contains(&(i % 12)))
}
