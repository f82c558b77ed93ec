//! Fuzzing the readers on stable Rust: proptest mutates valid files (bytes
//! replaced, inserted, deleted; lines dropped, repeated or swapped; numbers
//! swapped for extreme ones) and every reader must answer `Ok` or a clear
//! `Err`: no panic, no hang, no abort. The runs here are bounded and
//! seeded, so CI sees the same cases every time; a long run is
//!
//!     PROPTEST_CASES=100000 cargo test --release --test fuzz
//!
//! (the seed is fixed: set PROPTEST_RNG_SEED to explore other inputs).
//! Inputs a run finds are kept below as regression cases.

use std::io::Cursor;
use std::path::Path;

use caustix::scene::{obj, ply, stl, Scene};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

/// One edit of a file.
#[derive(Debug, Clone)]
enum Edit {
    Replace(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    DropLine(usize),
    RepeatLine(usize),
    SwapLines(usize, usize),
    Number(usize, &'static str),
}

/// Numbers that break arithmetic that trusts its input.
const EXTREMES: [&str; 12] = [
    "0",
    "-1",
    "1e39",
    "-1e39",
    "nan",
    "inf",
    "1e-45",
    "4294967295",
    "99999999999999999999",
    "1.5",
    "-0",
    "3",
];

fn edit() -> impl Strategy<Value = Edit> {
    let at = 0..100_000usize;
    prop_oneof![
        (at.clone(), any::<u8>()).prop_map(|(i, b)| Edit::Replace(i, b)),
        (at.clone(), prop::sample::select(b"0123456789.-e []=\"\n#,/fv".to_vec()))
            .prop_map(|(i, b)| Edit::Insert(i, b)),
        at.clone().prop_map(Edit::Delete),
        at.clone().prop_map(Edit::DropLine),
        at.clone().prop_map(Edit::RepeatLine),
        (at.clone(), at.clone()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
        (at, prop::sample::select(EXTREMES.to_vec())).prop_map(|(i, n)| Edit::Number(i, n)),
    ]
}

fn apply(bytes: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for e in edits {
        let lines =
            |out: &Vec<u8>| -> Vec<Vec<u8>> { out.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect() };
        match *e {
            Edit::Replace(i, b) if !out.is_empty() => {
                let n = out.len();
                out[i % n] = b;
            }
            Edit::Insert(i, b) => {
                let n = out.len() + 1;
                out.insert(i % n, b);
            }
            Edit::Delete(i) if !out.is_empty() => {
                let n = out.len();
                out.remove(i % n);
            }
            Edit::DropLine(i) | Edit::RepeatLine(i) => {
                let mut l = lines(&out);
                let k = i % l.len();
                if matches!(e, Edit::DropLine(_)) {
                    l.remove(k);
                } else {
                    l.insert(k, l[k].clone());
                }
                out = l.join(&b'\n');
            }
            Edit::SwapLines(a, b) => {
                let mut l = lines(&out);
                let n = l.len();
                l.swap(a % n, b % n);
                out = l.join(&b'\n');
            }
            Edit::Number(i, n) => {
                // Replace the number at or after byte i.
                let start = (i % out.len().max(1)..out.len()).find(|&k| out[k].is_ascii_digit());
                if let Some(s) = start {
                    let end = (s..out.len())
                        .find(|&k| !(out[k].is_ascii_digit() || out[k] == b'.'))
                        .unwrap_or(out.len());
                    out.splice(s..end, n.bytes());
                }
            }
            _ => {}
        }
    }
    out
}

fn config(cases: u32) -> Config {
    Config {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(cases),
        rng_seed: RngSeed::Fixed(
            std::env::var("PROPTEST_RNG_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(7),
        ),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Scene files without work that grows with a number (tessellation levels),
/// so that every case stays fast; the levels have their own limits.
fn scene_seeds() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut seeds = vec![include_str!("common/quad.toml").to_string()];
    for name in ["scenes/cornell.toml", "scenes/caustics.toml"] {
        seeds.push(std::fs::read_to_string(dir.join(name)).unwrap());
    }
    seeds
}

/// Whether a mutated scene asks for a big tessellation (slow, not wrong):
/// sphere levels above 6 or rings of more than 4096 segments.
fn asks_for_much(text: &str) -> bool {
    text.lines().any(|l| {
        let l = l.trim_start();
        let value = || l.split(['=', '#']).nth(1).and_then(|v| v.trim().parse::<f64>().ok());
        (l.starts_with("subdivisions") && value().is_some_and(|n| n > 6.0))
            || (l.starts_with("segments") && value().is_some_and(|n| n > 4096.0))
    })
}

proptest! {
    #![proptest_config(config(400))]

    #[test]
    fn scene_files_never_panic(seed in 0..3usize, edits in prop::collection::vec(edit(), 1..6)) {
        let seeds = scene_seeds();
        let bytes = apply(seeds[seed].as_bytes(), &edits);
        let text = String::from_utf8_lossy(&bytes);
        prop_assume!(!asks_for_much(&text));
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        if let Ok(scene) = Scene::from_toml(&text, &dir.join("fuzzed.toml")) {
            // A scene that loads must also pass or fail the render checks cleanly.
            let _ = caustix::integrator::check(&scene, &scene.config);
        }
    }

    #[test]
    fn ply_files_never_panic(binary in any::<bool>(), edits in prop::collection::vec(edit(), 1..6)) {
        let bytes = apply(&ply_seed(binary), &edits);
        let _ = ply::read(Path::new("fuzzed.ply"), Cursor::new(bytes));
    }
}

proptest! {
    #![proptest_config(config(150))]

    #[test]
    fn obj_files_never_panic(edits in prop::collection::vec(edit(), 1..6)) {
        let dir = tempfile::tempdir().unwrap();
        // It emits, so that its faces become lights (`mesh_lights`).
        let mtl = "newmtl red\nKd 0.8 0.1 0.1\nKs 0.1 0.1 0.1\nNs 20\nillum 2\nKe 1 0.5 0.25\n";
        std::fs::write(dir.path().join("m.mtl"), apply(mtl.as_bytes(), &edits[..1])).unwrap();
        let text = "mtllib m.mtl\no cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                    vn 0 0 1\nusemtl red\nf 1 2 3 4\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3//1 4//1 8//1\nf 4 1 5 8\n";
        let path = dir.path().join("fuzzed.obj");
        std::fs::write(&path, apply(text.as_bytes(), &edits)).unwrap();
        let _ = obj::load(&path, obj::MeshMaterials::FromFile { fallback: None }, &[]);
        let _ = obj::load(&path, obj::MeshMaterials::All(0), &[]);
    }

    #[test]
    fn stl_files_never_panic(binary in any::<bool>(), edits in prop::collection::vec(edit(), 1..6)) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fuzzed.stl");
        std::fs::write(&path, apply(&stl_seed(binary), &edits)).unwrap();
        let _ = stl::load(&path);
    }
}

/// A small valid STL mesh, ASCII or binary.
fn stl_seed(binary: bool) -> Vec<u8> {
    if binary {
        let positions = [glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y, glam::Vec3::ONE];
        let mut bytes = Vec::new();
        stl::write_binary(&mut bytes, &positions, &[[0, 1, 2], [1, 3, 2]]).unwrap();
        bytes
    } else {
        b"solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n\
          facet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 1\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n"
            .to_vec()
    }
}

/// A small valid PLY mesh, ASCII or binary.
fn ply_seed(binary: bool) -> Vec<u8> {
    let positions = [glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y, glam::Vec3::ONE];
    let normals = [glam::Vec3::Z; 4];
    let indices = [[0, 1, 2], [1, 3, 2]];
    if binary {
        let mut bytes = Vec::new();
        ply::write_binary(&mut bytes, &positions, &normals, &indices).unwrap();
        bytes
    } else {
        b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
          element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n1 1 1\n\
          3 0 1 2\n3 1 3 2\n"
            .to_vec()
    }
}

/// Inputs the fuzzing found, kept so they stay fixed.
#[test]
fn regressions() {
    // A second vertex element indexed past the first's vertices (a panic).
    let twice =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                 element vertex 1\nproperty float x\nend_header\n0 0 0\n1 0 0\n0 1 0\n0\n";
    assert!(ply::read(Path::new("t.ply"), Cursor::new(twice)).is_err());
    // An element of no properties and a huge count (a hang).
    let junk = "ply\nformat ascii 1.0\nelement junk 1000000000000000000\nend_header\n";
    assert!(ply::read(Path::new("t.ply"), Cursor::new(junk)).is_err());
    // A colour of two numbers in an MTL file (a panic inside tobj): found by
    // `obj_files_never_panic` with PROPTEST_CASES=20000.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.mtl"), "newmtl red\nKd 0.8 0.0\n").unwrap();
    let obj = dir.path().join("t.obj");
    std::fs::write(&obj, "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n").unwrap();
    let err = obj::load(&obj, obj::MeshMaterials::FromFile { fallback: None }, &[])
        .err()
        .expect("an error, not a panic")
        .to_string();
    assert!(err.contains("m.mtl:2:1: `Kd` needs three numbers"), "{err}");
}
