//! Small scenes that unit tests in several modules share.

use super::Scene;

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
