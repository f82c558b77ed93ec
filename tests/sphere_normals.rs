//! Vertex normals of a tessellated sphere: averaged over all adjacent faces,
//! they must point outward and match the analytic normal closely.

use caustix::scene::shapes::sphere;
use glam::Vec3;

/// Largest angle (degrees) between a vertex normal and the analytic one.
fn worst_vertex_normal_error(subdivisions: u32) -> f32 {
    let center = Vec3::new(0.3, -1.0, 2.0);
    let s = sphere("s", center, 1.7, subdivisions, 0);
    s.positions
        .iter()
        .zip(&s.normals)
        .map(|(p, n)| {
            let analytic = (*p - center).normalize();
            assert!(n.dot(analytic) > 0.0, "normal {n} at {p} points inward");
            n.angle_between(analytic).to_degrees()
        })
        .fold(0.0, f32::max)
}

#[test]
fn vertex_normals_match_the_analytic_normal() {
    let errors: Vec<f32> = (1..=5).map(worst_vertex_normal_error).collect();
    eprintln!("worst vertex normal error by subdivision level 1..=5 (degrees): {errors:?}");
    // Measured: [0.02, 0.60, 0.30, 0.15, 0.08]. Level 1's vertices all sit on
    // the icosahedron's symmetry axes; from level 2 on, the error halves with
    // each level (first order in the edge length).
    assert!(errors.iter().all(|&e| e < 1.0), "{errors:?}");
    // The default level (4, 5120 triangles) is within 0.2 degrees.
    assert!(errors[3] < 0.2, "level 4: {} degrees", errors[3]);
    assert!(errors[1..].windows(2).all(|w| w[1] < 0.6 * w[0]), "not converging: {errors:?}");
}

#[test]
fn shading_normals_inside_triangles_are_close_to_analytic() {
    let center = Vec3::ZERO;
    let s = sphere("s", center, 1.0, 4, 0);
    let mut worst = 0.0f32;
    for (prim, tri) in s.indices.iter().enumerate() {
        for (u, v) in [(1.0 / 3.0, 1.0 / 3.0), (0.5, 0.25), (0.1, 0.8)] {
            let p = (1.0 - u - v) * s.positions[tri[0] as usize]
                + u * s.positions[tri[1] as usize]
                + v * s.positions[tri[2] as usize];
            let n = s.shading_normal(prim as u32, u, v);
            worst = worst.max(n.angle_between(p.normalize()).to_degrees());
        }
    }
    eprintln!("worst interpolated normal error at level 4: {worst} degrees");
    assert!(worst < 0.2, "{worst} degrees");
}

/// The spheres of a scene are each their own: a unit sphere of each level
/// is made once and copied, and every copy keeps its sphere's name,
/// material, centre, radius and level, with the normals of a sphere made
/// alone.
#[test]
fn spheres_of_one_level_in_a_scene_are_each_their_own() {
    let text = "[camera]\neye = [0, 0, 10]\nlook_at = [0, 0, 0]\n\
        [materials.red]\ndiffuse = [0.8, 0, 0]\n[materials.blue]\ndiffuse = [0, 0, 0.8]\n\
        [[point_light]]\nposition = [0, 5, 5]\npower = 100\n\
        [[sphere]]\ncenter = [-2, 0, 0]\nradius = 0.5\nmaterial = \"red\"\n\
        [[sphere]]\ncenter = [0, 1, 0]\nradius = 2\nsubdivisions = 2\nmaterial = \"blue\"\n\
        [[sphere]]\ncenter = [2, 0, 0]\nradius = 1\nmaterial = \"blue\"\n";
    let scene = caustix::scene::Scene::from_toml(text, std::path::Path::new("s.toml")).unwrap();
    let origin = Vec3::new(0.0, 0.0, 10.0); // positions are relative to the camera
    for (name, center, radius, level, material) in [
        ("sphere #1", Vec3::new(-2.0, 0.0, 0.0), 0.5, 4, "red"),
        ("sphere #2", Vec3::new(0.0, 1.0, 0.0), 2.0, 2, "blue"),
        ("sphere #3", Vec3::new(2.0, 0.0, 0.0), 1.0, 4, "blue"),
    ] {
        let mesh = scene.meshes.iter().find(|m| m.name == name).unwrap();
        assert_eq!(mesh.indices.len(), 20 << (2 * level), "{name}");
        assert_eq!(scene.materials[mesh.material].name, material, "{name}");
        let alone = sphere(name, center - origin, radius, level, mesh.material);
        for ((p, q), (n, m)) in
            mesh.positions.iter().zip(&alone.positions).zip(mesh.normals.iter().zip(&alone.normals))
        {
            assert!((*p - *q).length() < 1e-5 * radius, "{name}: {p} against {q}");
            assert!((*n - *m).length() < 1e-5, "{name}: {n} against {m}");
        }
    }
}
