//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

/// A square 64x64 view from z = 5 towards the origin with a 90-degree field
/// of view, so the plane z = 0 shows x and y from -5 to 5. One white quad of
/// side 5 centred there covers exactly the middle 32x32 pixels.
pub const QUAD_SCENE: &str = r#"
[camera]
eye = [0, 0, 5]
look_at = [0, 0, 0]
fov = 90

[image]
width = 64
height = 64

[materials.white]
diffuse = 0.8

[[point_light]]
position = [0, 0, 4]
power = 100

[[quad]]
center = [0, 0, 0]
u = [5, 0, 0]
v = [0, 5, 0]
material = "white"
"#;

/// Writes `text` to `name` inside `dir` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs the `caustix` binary with `args`.
pub fn caustix(args: &[&std::ffi::OsStr]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_caustix")).args(args).output().unwrap()
}
