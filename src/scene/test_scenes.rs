//! Small scenes that unit tests in several modules share.

use glam::Vec3;

use super::Scene;

/// A unit cube of 8 shared corners and 12 triangles, each counter-clockwise
/// seen from outside.
pub(crate) fn unit_cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let corners = (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32));
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let triangles = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    (corners.collect(), triangles)
}

/// A wide diffuse wall square to the view, 3 in front of the eye, lit by a
/// point light between them: every camera ray meets it.
pub(crate) fn wall_facing_the_camera() -> Scene {
    Scene::from_toml(
        r#"
        [camera]
        eye = [0, 0, 3]
        look_at = [0, 0, 0]
        up = [0, 1, 0]
        [materials.m]
        diffuse = 0.5
        [[quad]]
        center = [0, 0, 0]
        u = [10, 0, 0]
        v = [0, 10, 0]
        material = "m"
        [[point_light]]
        position = [0, 0, 2]
        power = 1
    "#,
        std::path::Path::new("wall.toml"),
    )
    .unwrap()
}
