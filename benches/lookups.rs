//! `cargo bench --bench lookups [SCENE]`: the photon-map lookups of a
//! photon-mapped render, timed alone on one thread, at the places a render
//! makes them.
//!
//! The maps are built as a render of the scene (at its own photon counts) builds them.
//! The query points are final-gathering hits: from lit points (global
//! photons, in random order) cosine-distributed rays go out and the diffuse
//! surfaces they meet are the queries. Timed: the precomputed-record lookup
//! each gather hit makes (`PhotonMap::precomputed_radiance`), and the
//! caustic map's k-nearest estimate each camera hit makes
//! (`PhotonMap::radiance`), at gather hits and at the diffuse surfaces the
//! camera sees; and the global map's estimate at those surfaces, as a
//! render without gather rays makes it (by the map's runs, and by kiddo's
//! tree for the ratio). Prints nanoseconds a lookup and a checksum (the
//! sum of what was found; the same when answers are the same).

use std::path::Path;
use std::time::Instant;

use caustix::accel::Backend;
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
    let settings = scene.config.photons.clone();
    let diagonal = Context::diagonal_of(&scene);
    let maps = build_maps(&query, &settings, scene.config.max_depth, 0, scene.config.sampler, diagonal);
    let global = maps.global.as_ref().expect("a global map");

    // Gather hits from lit points.
    let mut rng = Rng::new(7, 0);
    let photons = global.photons();
    let mut count = RayCount::default();
    let mut hits = Vec::with_capacity(QUERIES);
    // (In an open scene most rays leave it: give up after many.)
    for _ in 0..20 * QUERIES {
        if hits.len() == QUERIES {
            break;
        }
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
    if !hits.is_empty() {
        let start = Instant::now();
        let sum: f32 = hits
            .iter()
            .map(|&(p, n, _, m)| global.precomputed_radiance(p, n, m, &estimate).element_sum())
            .sum();
        let ns = start.elapsed().as_secs_f64() * 1e9 / hits.len() as f64;
        println!("precomputed record at a gather hit: {ns:.0} ns a lookup (checksum {sum:.6e})");
    }

    // What the camera sees: the diffuse surfaces the rays through a 256 x
    // 256 grid of the image meet first (where a render's caustic estimates
    // are made, and in caustic scenes, many in a caustic's bright focus).
    let side = 256;
    let seen: Vec<_> = (0..side * side)
        .filter_map(|i| {
            let ray = scene.camera.ray((i % side) as f32 + 0.5, (i / side) as f32 + 0.5, side, side);
            match query.first(&ray, &mut count) {
                Some(Interaction::Surface(sp)) => {
                    let m = query.material(&sp);
                    m.is_glossy_or_diffuse().then_some((sp.p, sp.ns, -ray.dir, m))
                }
                _ => None,
            }
        })
        .collect();

    // Without gather rays the global map is read directly at the camera's
    // hits, searched by its runs; kiddo's tree over the same photons for
    // the ratio (BENCHMARKS.md, "The global map read directly").
    if !seen.is_empty() {
        let estimate = settings.global_estimate(diagonal);
        let kd_tree = caustix::photon::PhotonMap::new(photons.to_vec());
        let runs = caustix::photon::PhotonMap::searched_by_runs(photons.to_vec());
        for (search, map) in [("runs", &runs), ("kd-tree", &kd_tree)] {
            let start = Instant::now();
            let sum: f32 =
                seen.iter().map(|&(p, n, wo, m)| map.radiance(p, n, wo, m, &estimate).element_sum()).sum();
            let ns = start.elapsed().as_secs_f64() * 1e9 / seen.len() as f64;
            println!(
                "global estimate at {} camera hits (k = {}, by {search}): {ns:.0} ns a lookup (checksum {sum:.6e})",
                seen.len(),
                estimate.k
            );
        }
    }

    if let Some(caustic) = &maps.caustic {
        let estimate = settings.caustic_estimate(diagonal);
        for (at, hits) in [("gather hits", &hits[..hits.len() / 4]), ("camera hits", &seen[..])] {
            if hits.is_empty() {
                continue;
            }
            let start = Instant::now();
            let sum: f32 = hits
                .iter()
                .map(|&(p, n, wo, m)| caustic.radiance(p, n, wo, m, &estimate).element_sum())
                .sum();
            let ns = start.elapsed().as_secs_f64() * 1e9 / hits.len() as f64;
            println!(
                "caustic estimate at {} {at} (k = {}, {} stored): {ns:.0} ns a lookup (checksum {sum:.6e})",
                hits.len(),
                estimate.k,
                caustic.photons().len()
            );
        }
    }
}
