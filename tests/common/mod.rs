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

/// Runs the `caustix` binary with `args`.
pub fn caustix(args: &[&std::ffi::OsStr]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_caustix")).args(args).output().unwrap()
}
