//! `caustix bench scale` from the command line: one row per teapot level,
//! triangle counts growing as the levels do, CSV and plot written.

mod common;

use common::{caustix, write};

const SCENE: &str = r#"
[camera]
eye = [0, 3, 8]
look_at = [0, 1, 0]
[materials.white]
diffuse = 0.8
[photons]
global = 2000
caustic = 0
gather_rays = 4
[[point_light]]
position = [0, 6, 2]
power = 100
[[teapot]]
material = "white"
[[quad]]
center = [0, 0, 0]
u = [8, 0, 0]
v = [0, 0, -8]
material = "white"
"#;

#[test]
fn one_row_per_level_with_growing_triangle_counts() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "teapot.toml", SCENE);
    let (csv, plot) = (dir.path().join("s.csv"), dir.path().join("s.svg"));
    let run = caustix(&[
        "bench".as_ref(),
        "scale".as_ref(),
        scene.as_os_str(),
        "--levels".as_ref(),
        "2,4,8".as_ref(),
        "--rays".as_ref(),
        "32".as_ref(),
        "--render-size".as_ref(),
        "16x12".as_ref(),
        "--csv".as_ref(),
        csv.as_os_str(),
        "--plot".as_ref(),
        plot.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.starts_with("| triangles |"), "{stdout}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<f64>> =
        text.lines().skip(1).map(|l| l.split(',').map(|c| c.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 3, "{text}");
    // About 64 n^2 teapot triangles plus the floor's 2.
    let triangles: Vec<f64> = rows.iter().map(|r| r[1]).collect();
    assert!(triangles[0] < triangles[1] && triangles[1] < triangles[2], "{triangles:?}");
    assert!((triangles[2] / triangles[1] - 4.0).abs() < 0.3, "{triangles:?}");
    for r in &rows {
        // Build times, the BVH size, ray rates and render time are measured, so positive
        // (resident-memory deltas of tiny meshes may round to nothing).
        for column in [4, 7, 8, 9, 10, 11] {
            assert!(r[column] > 0.0, "column {column} of {r:?}");
        }
    }
    assert!(std::fs::read_to_string(&plot).unwrap().contains("Embree build"));

    let cornell = write(
        dir.path(),
        "box.toml",
        &SCENE.replace("[[teapot]]", "[[sphere]]\ncenter = [0, 1, 0]\nradius = 1"),
    );
    let run = caustix(&["bench".as_ref(), "scale".as_ref(), cornell.as_os_str()]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("no [[teapot]]"));
}

#[test]
fn bench_threads_times_each_count_and_finds_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "teapot.toml", SCENE);
    let run = caustix(&[
        "bench".as_ref(),
        "threads".as_ref(),
        scene.as_os_str(),
        "--threads".as_ref(),
        "1,2".as_ref(),
        "--render-size".as_ref(),
        "24x16".as_ref(),
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let rows: Vec<&str> = stdout.lines().filter(|l| l.starts_with("| 1 ") || l.starts_with("| 2 ")).collect();
    assert_eq!(rows.len(), 2, "{stdout}");
    assert!(rows.iter().all(|r| r.ends_with("| yes |")), "{stdout}");
}

#[test]
fn bench_photons_reports_memory_and_query_rates() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "teapot.toml", SCENE);
    let dump = dir.path().join("points.bin");
    let run = caustix(&[
        "bench".as_ref(),
        "photons".as_ref(),
        scene.as_os_str(),
        "--counts".as_ref(),
        "1000,4000".as_ref(),
        "--queries".as_ref(),
        "500".as_ref(),
        "--dump".as_ref(),
        dump.as_os_str(),
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let stored: Vec<usize> = stdout
        .lines()
        .filter(|l| l.starts_with("| 1000 ") || l.starts_with("| 4000 "))
        .map(|l| l.split('|').nth(2).unwrap().trim().parse().unwrap())
        .collect();
    assert_eq!(stored.len(), 2, "{stdout}");
    assert!(stored[1] > stored[0] && stored[0] > 0, "{stdout}");
    // The dump: u64 count, that many f32 triples, u64 queries, triples, u32 k.
    let bytes = std::fs::read(&dump).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    assert_eq!(n, stored[1]);
    let q = u64::from_le_bytes(bytes[8 + 12 * n..16 + 12 * n].try_into().unwrap()) as usize;
    assert_eq!(bytes.len(), 16 + 12 * (n + q) + 4);
}
