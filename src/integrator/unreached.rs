//! Light that an integrator cannot carry, however many samples it takes,
//! measured before it renders, so that the user is told rather than shown a
//! darker image.
//!
//! A point or spot light, a pinhole camera and a mirror or glass surface
//! are each reached along one direction only, so a path can join its
//! camera part and its light part only where both ends of the joining
//! segment scatter diffusely or glossily (or are the camera or a light):
//! - The path tracer and Whitted reach a point or spot light only by a
//!   shadow ray from a diffuse or glossy surface, and a mirror or glass
//!   stops shadow rays: whatever such a light sends to a mirror or through
//!   glass (its caustics; a bulb's light through its glass) is missing.
//! - Bidirectional path tracing also joins light paths to the camera, so it
//!   carries those caustics, except where they are seen in a mirror or
//!   through glass (`L S D S E`: every segment has a mirror or glass end).
//! - Light tracing joins light paths to the camera alone: whatever is seen
//!   in a mirror or through glass is missing.
//!
//! Photon mapping, SPPM and VCM carry all of it (by photons found near the
//! camera paths' surfaces). A fixed set of rays from the point and spot
//! lights (as photons leave them) and from the camera measures how much
//! of the light and of the view mirrors and glass take.

use glam::Vec2;

use crate::light::Light;
use crate::material::Material;
use crate::query::{Interaction, RayCount, SceneQuery};

/// Rays from the point and spot lights, among them by power; and rays from
/// the camera, over the image.
const RAYS: u32 = 16_384;

/// Below this share of the scene's light (or of the view), no warning: a
/// small glass object far from the light.
const WORTH_TELLING: f64 = 0.005;

/// What an integrator cannot carry ([`crate::integrator::Integrator::unreached`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unreached {
    /// What point and spot lights send to mirrors or through glass (the
    /// path tracer, Whitted).
    FromPointLightsThroughMirrors,
    /// The same, where it is seen in a mirror or through glass
    /// (bidirectional path tracing).
    FromPointLightsSeenInMirrors,
    /// All that is seen in a mirror or through glass (light tracing).
    SeenInMirrors,
}

/// The `k`-th point of the R2 sequence (Roberts 2018) in the unit square:
/// well spread, with no random numbers, so a measure is the same every run.
fn spread(k: u32) -> Vec2 {
    let (a1, a2) = (0.754_877_666_246_692_8, 0.569_840_290_998_053_2);
    Vec2::new((0.5 + a1 * k as f64).fract() as f32, (0.5 + a2 * k as f64).fract() as f32)
}

/// How much of the light meeting `m` a mirror or glass takes on: the mean
/// over the channels of their parts.
fn mirror_part(m: &Material) -> f64 {
    (m.mirror + m.transmittance).as_dvec3().element_sum() / 3.0
}

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
    // direction from the R2 sequence.
    let mut count = RayCount::default();
    let (mut light, mut below) = (0, strength(points[0]));
    let mut to_mirrors = 0.0;
    for k in 0..RAYS {
        let pick = (k as f64 + 0.5) / RAYS as f64 * from_points;
        while pick > below && light + 1 < points.len() {
            light += 1;
            below += strength(points[light]);
        }
        let (ray, power) = points[light].emit(Vec2::ZERO, spread(k));
        if let Some(Interaction::Surface(sp)) = query.first(&ray, &mut count) {
            let m = query.material(&sp);
            // The light's power over the chance of picking the light.
            let weight = from_points / strength(points[light]);
            to_mirrors += ((m.mirror + m.transmittance) * power).as_dvec3().element_sum() * weight;
        }
    }
    to_mirrors / RAYS as f64 / all
}

/// The share of a `width x height` view that mirrors and glass fill:
/// camera rays spread over the image, each weighed by the mirror's and the
/// glass's part of the first surface it meets (none where it meets a
/// light or nothing). 0 for a scene without either.
pub fn share_of_view_in_mirrors(query: &SceneQuery, width: u32, height: u32) -> f64 {
    if !query.scene.materials.iter().any(|m| m.is_specular()) {
        return 0.0;
    }
    let mut count = RayCount::default();
    let mut in_mirrors = 0.0;
    for k in 0..RAYS {
        let at = spread(k) * Vec2::new(width as f32, height as f32);
        let ray = query.scene.camera.ray(at.x, at.y, width, height);
        if let Some(Interaction::Surface(sp)) = query.first(&ray, &mut count) {
            in_mirrors += mirror_part(query.material(&sp));
        }
    }
    in_mirrors / RAYS as f64
}

/// For an integrator that cannot carry `unreached`, a warning when it is
/// likely to matter in a `width x height` render: a noticeable share of
/// the scene's light leaves point or spot lights straight for mirrors or
/// glass ([`share_to_mirrors_from_points`]), or of the view is mirrors or
/// glass ([`share_of_view_in_mirrors`]), or both, as `unreached` needs.
pub fn warning(
    query: &SceneQuery,
    (width, height): (u32, u32),
    integrator: &str,
    unreached: Unreached,
) -> Option<String> {
    let percent = |share: f64| format!("{:.1}%", 100.0 * share);
    let from_points = || Some(share_to_mirrors_from_points(query)).filter(|&s| s >= WORTH_TELLING);
    let in_view = || Some(share_of_view_in_mirrors(query, width, height)).filter(|&s| s >= WORTH_TELLING);
    match unreached {
        Unreached::FromPointLightsThroughMirrors => Some(format!(
            "{} of the scene's light goes from point or spot lights straight to mirrors or glass; the {integrator} \
             integrator leaves all of it out (caustics, light through glass), however many samples it takes; photon, \
             sppm and vcm carry it (bdpt all but what is seen in a mirror or through glass)",
            percent(from_points()?)
        )),
        Unreached::FromPointLightsSeenInMirrors => Some(format!(
            "{} of the scene's light goes from point or spot lights straight to mirrors or glass, and mirrors or \
             glass fill {} of the view; the {integrator} integrator leaves that light out where it is seen in a \
             mirror or through glass (a caustic seen in a mirror; a wall lit by a bulb in glass, seen through the \
             glass), however many samples it takes; vcm, photon and sppm carry it",
            percent(from_points()?),
            percent(in_view()?)
        )),
        Unreached::SeenInMirrors => Some(format!(
            "mirrors or glass fill {} of the view; the {integrator} integrator leaves out all that is seen in them \
             (it joins only diffuse and glossy surfaces to the camera), however many samples it takes; vcm, bdpt, \
             path, photon and sppm carry it",
            percent(in_view()?)
        )),
    }
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
        measured(extra, share_to_mirrors_from_points)
    }

    /// The share of a 64 x 48 view of the scene of [`share`] in mirrors or
    /// glass.
    fn view(extra: &str) -> f64 {
        measured(extra, |query| share_of_view_in_mirrors(query, 64, 48))
    }

    fn measured(extra: &str, measure: impl FnOnce(&SceneQuery) -> f64) -> f64 {
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
        measure(&SceneQuery::new(&scene, accel.as_ref()))
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

    /// A quad across the view between the camera and the floor, made of
    /// `material`; `left` keeps only its half left of the camera.
    fn wall(material: &str, left: bool) -> String {
        let x = if left { -50 } else { 0 };
        format!("[[quad]]\ncenter = [{x}, 1, 5]\nu = [100, 0, 0]\nv = [0, 100, 0]\nmaterial = \"{material}\"")
    }

    #[test]
    fn the_view_share_is_the_mirrors_part_of_what_the_camera_sees() {
        // Every camera ray meets the wall: its mirror's part, or all of it
        // for the glass.
        assert!((view(&wall("mirror", false)) - 0.5).abs() < 1e-9, "{}", view(&wall("mirror", false)));
        assert!((view(&wall("glass", false)) - 1.0).abs() < 1e-9);
        // Half the image's width sees the glass: the spread rays find it
        // within their spread's error.
        let half = view(&wall("glass", true));
        assert!((half - 0.5).abs() < 2e-3, "{half}");
        // A diffuse wall, or glass out of view (the spheres behind the
        // wall), takes none.
        let floor = wall("floor", false);
        assert_eq!(view(&floor), 0.0);
        assert_eq!(view(&format!("{floor}\n{SPHERES}")), 0.0);
        assert_eq!(view(""), 0.0);
    }
}
