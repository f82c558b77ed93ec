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

/// A unit sphere of the material `material` (the lines of its TOML table),
/// filling the middle of a 12 x 12 view from 1.8 away, inside
/// `surroundings` (scene-file tables); paths and photons of up to `depth`
/// bounces, `pass_photons` photons a pass.
pub fn sphere_seen_close(
    material: &str,
    depth: u32,
    pass_photons: u32,
    surroundings: &str,
) -> caustix::scene::Scene {
    let text = format!(
        r#"
        [camera]
        eye = [0, 0, 1.8]
        look_at = [0, 0, 0]
        fov = 70
        [image]
        width = 12
        height = 12
        [render]
        max_depth = {depth}
        [photons]
        max_bounces = {depth}
        pass_photons = {pass_photons}
        [materials.sphere]
        {material}
        [[sphere]]
        center = [0, 0, 0]
        radius = 1
        subdivisions = 5
        material = "sphere"
        {surroundings}
    "#
    );
    caustix::scene::Scene::from_toml(&text, Path::new("sphere.toml")).unwrap()
}

/// A unit sphere, half glossy reflection of Phong exponent `exponent` and
/// half clear glass, seen at 12 x 12 from inside `surroundings` (scene-file
/// tables) with `pass_photons` photons a pass ([`sphere_seen_close`]).
pub fn shiny_glass(exponent: u32, pass_photons: u32, surroundings: &str) -> caustix::scene::Scene {
    let material = format!("specular = 0.5\nphong_exponent = {exponent}\ntransmittance = 0.5");
    sphere_seen_close(&material, 32, pass_photons, surroundings)
}

/// Each component's mean over the middle 6 x 6 pixels (all sphere), and
/// the whole image's largest pixel.
pub fn middle_components(rendered: &caustix::Rendered) -> ([f32; 4], f32) {
    let film = &rendered.film;
    let middle: Vec<usize> = middle_of_12x12().collect();
    let mean = |part: &dyn Fn(&caustix::film::Sample) -> glam::Vec3| {
        middle.iter().map(|&i| part(&film.pixels[i]).element_sum() / 3.0).sum::<f32>() / middle.len() as f32
    };
    let components =
        [mean(&|s| s.emission), mean(&|s| s.direct), mean(&|s| s.caustic), mean(&|s| s.indirect)];
    let image = film.beauty();
    let brightest = image.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max);
    (components, brightest)
}

/// A broader lobe (exponent 20) in a closed box of grey walls under a
/// point light: much of the light the lobe reflects is the point light's,
/// focused onto the sphere's inside by its glass, which no camera path can
/// meet.
pub fn shiny_glass_under_a_point_light() -> caustix::scene::Scene {
    let light = "[[point_light]]\nposition = [0.6, 1.5, 1.2]\npower = 30";
    shiny_glass(20, 20000, &grey_box_lit_by(light))
}

/// A closed grey box 4 wide (diffuse 0.5) around the origin, lit by
/// `light` (a scene-file table), as surroundings for [`sphere_seen_close`].
pub fn grey_box_lit_by(light: &str) -> String {
    format!("[materials.wall]\ndiffuse = 0.5\n[[box]]\ncenter = [0, 0, 0]\nsize = 4\nmaterial = \"wall\"\n{light}\n")
}

/// Asserts that `found`, rendered by `who`, agrees with `reference` (the
/// path tracer's) over the middle of a furnace sphere lit by lights of
/// radiance 1: every component within 5%, their sum within 1%, and no
/// pixel of the image above 1.05.
pub fn assert_components_agree(found: &caustix::Rendered, reference: &caustix::Rendered, who: &str) {
    let ((expected, _), (found, brightest)) = (middle_components(reference), middle_components(found));
    eprintln!("path tracer {expected:?}, {who} {found:?}, brightest {brightest}");
    for (part, (e, f)) in ["emission", "direct", "caustic", "indirect"].iter().zip(expected.iter().zip(found))
    {
        assert!((f - e).abs() < 0.05 * e, "{part}: {who} {f}, path tracer {e}");
    }
    let (e, f) = (expected.iter().sum::<f32>(), found.iter().sum::<f32>());
    assert!((f / e - 1.0).abs() < 0.01, "{who} {f}, path tracer {e}");
    assert!(brightest < 1.05, "{who}: brightest pixel {brightest}");
}
