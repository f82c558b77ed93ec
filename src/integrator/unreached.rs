//! Light that the path tracer and Whitted cannot carry, measured before they
//! render, so that the user is told rather than shown a darker image.
//!
//! Their camera paths reach a point or spot light only by a shadow ray from
//! a diffuse or glossy surface, and a mirror or glass stops shadow rays: so
//! whatever such a light sends to a mirror or through glass (its caustics; a
//! bulb's light through its glass) is missing from their image however many
//! samples they take. Photon mapping, SPPM, BDPT and VCM follow it from the
//! light. A fixed set of rays from the point and spot lights (as photons
//! leave them) measures how much of the scene's light that is.

use glam::Vec2;

use crate::light::Light;
use crate::query::{Interaction, RayCount, SceneQuery};

/// Rays from the point and spot lights, among them by power.
const RAYS: u32 = 16_384;

/// Below this share of the scene's light, no warning: a small glass object
/// far from the light.
const WORTH_TELLING: f64 = 0.005;

/// The share of the power of all the scene's lights that point and spot
/// lights send straight to mirrors or glass (weighed by the mirror's or the
/// glass's part of the material it meets): 0 for a scene without either.
pub fn share_to_mirrors_from_points(query: &SceneQuery) -> f64 {
    let lights: &[Light] = &query.scene.lights;
    let strength = |l: &Light| l.power().as_dvec3().element_sum();
    let all: f64 = lights.iter().map(strength).sum();
    let points: Vec<&Light> = lights.iter().filter(|l| l.is_delta() && strength(l) > 0.0).collect();
    let from_points: f64 = points.iter().map(|l| strength(l)).sum();
    if points.is_empty() || !query.scene.materials.iter().any(|m| m.is_specular()) {
        return 0.0;
    }
    // Each ray picks a light in proportion to its power (stratified) and a
    // direction from the R2 sequence (Roberts 2018), well spread over the
    // square with no random numbers: the answer is the same every run.
    let (a1, a2) = (0.754_877_666_246_692_8, 0.569_840_290_998_053_2);
    let mut count = RayCount::default();
    let (mut light, mut below) = (0, strength(points[0]));
    let mut to_mirrors = 0.0;
    for k in 0..RAYS {
        let pick = (k as f64 + 0.5) / RAYS as f64 * from_points;
        while pick > below && light + 1 < points.len() {
            light += 1;
            below += strength(points[light]);
        }
        let v = Vec2::new((0.5 + a1 * k as f64).fract() as f32, (0.5 + a2 * k as f64).fract() as f32);
        let (ray, power) = points[light].emit(Vec2::ZERO, v);
        if let Some(Interaction::Surface(sp)) = query.first(&ray, &mut count) {
            let m = query.material(&sp);
            // The light's power over the chance of picking the light.
            let weight = from_points / strength(points[light]);
            to_mirrors += ((m.mirror + m.transmittance) * power).as_dvec3().element_sum() * weight;
        }
    }
    to_mirrors / RAYS as f64 / all
}

/// For an integrator that cannot carry it, a warning when a noticeable
/// share of the scene's light leaves point or spot lights straight for
/// mirrors or glass ([`share_to_mirrors_from_points`]).
pub fn warning(query: &SceneQuery, integrator: &str) -> Option<String> {
    let share = share_to_mirrors_from_points(query);
    (share >= WORTH_TELLING).then(|| {
        format!(
            "{:.1}% of the scene's light goes from point or spot lights straight to mirrors or glass; the {integrator} \
             integrator leaves all of it out (caustics, light through glass), however many samples it takes; photon, \
             sppm, bdpt and vcm carry it",
            100.0 * share
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{build, Backend};
    use crate::scene::Scene;

    /// A floor, a glass sphere of radius 0.5 with its centre 2 below a
    /// point light of 10 W, a mirror sphere behind the light, and an area
    /// light of 10 W; `extra` adds to the file.
    fn share(extra: &str) -> f64 {
        let text = format!(
            r#"
            [camera]
            eye = [0, 1, 6]
            look_at = [0, 1, 0]
            [materials.floor]
            diffuse = 0.5
            [materials.glass]
            transmittance = 1.0
            [materials.mirror]
            mirror = 0.5
            [[quad]]
            center = [0, 0, 0]
            u = [8, 0, 0]
            v = [0, 0, -8]
            material = "floor"
            [[area_light]]
            center = [3, 4, 0]
            u = [0.5, 0, 0]
            v = [0, 0, 0.5]
            power = 10
            {extra}
            "#
        );
        let scene = Scene::from_toml(&text, std::path::Path::new("share.toml")).unwrap();
        let accel = build(Backend::Embree, &scene.triangle_views()).unwrap();
        share_to_mirrors_from_points(&SceneQuery::new(&scene, accel.as_ref()))
    }

    const SPHERES: &str = r#"
        [[sphere]]
        center = [0, 1, 0]
        radius = 0.5
        subdivisions = 6
        material = "glass"
        [[sphere]]
        center = [0, 5, 0]
        radius = 0.5
        subdivisions = 6
        material = "mirror"
    "#;

    #[test]
    fn a_point_light_sends_the_solid_angle_of_the_spheres() {
        let s = share(&format!("{SPHERES}\n[[point_light]]\nposition = [0, 3, 0]\npower = 10"));
        // Each sphere (radius 0.5, centre 2 away) covers (1 - cos) / 2 of
        // the directions, sin = 1/4; the glass takes all of it, the mirror
        // half; half the scene's power is the point light's.
        let cap = (1.0 - (1.0f64 - 1.0 / 16.0).sqrt()) / 2.0;
        let expected = 0.5 * (cap + 0.5 * cap);
        // The spheres' triangles lie inside the spheres, which they
        // approach to a fraction of a percent at 6 subdivisions.
        assert!((s / expected - 1.0).abs() < 0.02, "share {s}, expected {expected}");
    }

    #[test]
    fn a_point_light_inside_glass_sends_it_all_its_light() {
        let bulb = "[[sphere]]\ncenter = [0, 3, 0]\nradius = 0.2\nmaterial = \"glass\"\n\
                    [[point_light]]\nposition = [0, 3, 0]\npower = 30";
        assert!((share(bulb) - 0.75).abs() < 1e-6, "{}", share(bulb));
    }

    #[test]
    fn no_share_without_point_lights_or_without_mirrors() {
        assert_eq!(share(SPHERES), 0.0);
        assert_eq!(share("[[point_light]]\nposition = [0, 3, 0]\npower = 10"), 0.0);
        // A spot light aimed away from both spheres, at the floor.
        let spot =
            "[[spot_light]]\nposition = [2, 3, 0]\ndirection = [0, -1, 0]\ncone_angle = 20\npower = 10";
        assert_eq!(share(&format!("{SPHERES}\n{spot}")), 0.0);
    }
}
