//! `cargo bench --bench lookups [SCENE]`: the photon-map lookups of a
//! photon-mapped render, timed alone on one thread, at the places a render
//! makes them.
//!
//! The maps are built as a render at the default settings builds them.
//! The query points are final-gathering hits: from lit points (global
//! photons, in random order) cosine-distributed rays go out and the diffuse
//! surfaces they meet are the queries. Timed: the precomputed-record lookup
//! each gather hit makes (`PhotonMap::precomputed_radiance`), and the
//! caustic map's k-nearest estimate each camera hit makes
//! (`PhotonMap::radiance`). Prints nanoseconds a lookup and a checksum (the
//! sum of what was found; the same when answers are the same).

use std::path::Path;
use std::time::Instant;

use caustix::accel::Backend;
use caustix::config::PhotonConfig;
use caustix::integrator::Context;
use caustix::photon::build_maps;
use caustix::query::{Interaction, RayCount, SceneQuery};
use caustix::sampling::{around, cosine_hemisphere, Rng};
use caustix::scene::Scene;

const QUERIES: usize = 400_000;

fn main() {
    let path = std::env::args().skip(1).find(|a| a.ends_with(".toml")).unwrap_or_else(|| {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/teapot.toml").display().to_string()
    });
    let scene = Scene::load(Path::new(&path)).expect("a valid scene");
    let accel = caustix::accel::build(Backend::Embree, &scene.triangle_views()).expect("embree");
    let query = SceneQuery::new(&scene, accel.as_ref());
    let settings = PhotonConfig::default();
    let diagonal = Context::diagonal_of(&scene);
    let maps = build_maps(&query, &settings, scene.config.max_depth, 0, scene.config.sampler, diagonal);
    let global = maps.global.as_ref().expect("a global map");

    // Gather hits from lit points.
    let mut rng = Rng::new(7, 0);
    let photons = global.photons();
    let mut count = RayCount::default();
    let mut hits = Vec::with_capacity(QUERIES);
    while hits.len() < QUERIES {
        let photon = &photons[(rng.uniform() * photons.len() as f32) as usize % photons.len()];
        let ray = caustix::accel::Ray::new(
            photon.position + 1e-3 * photon.normal,
            around(photon.normal, cosine_hemisphere(rng.uniform2())),
        );
        if let Some(Interaction::Surface(sp)) = query.first(&ray, &mut count) {
            let m = query.material(&sp);
            if m.is_glossy_or_diffuse() {
                hits.push((sp.p, sp.ns, -ray.dir, m));
            }
        }
    }
    println!("{path}: {} stored global photons, {} queries", photons.len(), hits.len());

    let estimate = settings.global_estimate(diagonal);
    let start = Instant::now();
    let sum: f32 =
        hits.iter().map(|&(p, n, _, m)| global.precomputed_radiance(p, n, m, &estimate).element_sum()).sum();
    let ns = start.elapsed().as_secs_f64() * 1e9 / hits.len() as f64;
    println!("precomputed record at a gather hit: {ns:.0} ns a lookup (checksum {sum:.6e})");

    if let Some(caustic) = &maps.caustic {
        let estimate = settings.caustic_estimate(diagonal);
        let hits = &hits[..QUERIES / 4];
        let start = Instant::now();
        let sum: f32 =
            hits.iter().map(|&(p, n, wo, m)| caustic.radiance(p, n, wo, m, &estimate).element_sum()).sum();
        let ns = start.elapsed().as_secs_f64() * 1e9 / hits.len() as f64;
        println!(
            "caustic estimate (k = {}, {} stored): {ns:.0} ns a lookup (checksum {sum:.6e})",
            estimate.k,
            caustic.photons().len()
        );
    }
}
