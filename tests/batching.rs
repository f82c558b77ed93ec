//! Rays traced in batches (Embree 3's ray streams: shadow rays of direct
//! light, final gathering's rays) give the same image, to the bit, as the
//! same rays traced one by one, for every integrator.

use caustix::accel::{Backend, Hit, Intersector, Ray};
use caustix::config::IntegratorKind;
use caustix::{render, RenderConfig, Scene};

/// Answers as the intersector it wraps, but takes batches ray by ray (the
/// trait's own `intersect_batch` and `occluded_batch`).
struct OneByOne<'a>(&'a dyn Intersector);

impl Intersector for OneByOne<'_> {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.0.intersect(ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.0.occluded(ray)
    }
    fn name(&self) -> String {
        format!("{} one by one", self.0.name())
    }
}

#[test]
fn batched_and_single_rays_render_the_same_image() {
    let dir = env!("CARGO_MANIFEST_DIR");
    for file in ["cornell.toml", "cornell-point.toml", "teapot.toml"] {
        let scene = Scene::load(std::path::Path::new(&format!("{dir}/scenes/{file}"))).unwrap();
        let embree = caustix::accel::build(Backend::Embree, &scene.triangle_views()).unwrap();
        let single = OneByOne(embree.as_ref());
        for &integrator in IntegratorKind::ALL {
            let mut config = RenderConfig {
                integrator,
                width: 24,
                height: 24,
                samples: 2,
                // Batches of 16 full and cut short: 19 shadow rays per area
                // light, up to 19 gather rays per camera sample.
                light_samples: Some(19),
                ..scene.config.clone()
            };
            config.photons.gather_rays = 19;
            config.photons.global_photons = 20_000;
            config.photons.caustic_photons = 20_000;
            config.photons.sppm.passes = 2;
            config.photons.sppm.photons_per_pass = 10_000;
            let a = render(&scene, embree.as_ref(), &config, &|_| {}).unwrap();
            let b = render(&scene, &single, &config, &|_| {}).unwrap();
            let what = format!("{file}, {}", integrator.name());
            assert_eq!(a.stats.rays, b.stats.rays, "{what}: rays counted");
            let (a, b) = (a.film.beauty().pixels, b.film.beauty().pixels);
            assert!(a.iter().any(|p| p.max_element() > 0.0), "{what}: black image");
            let same = a
                .iter()
                .zip(&b)
                .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits));
            assert!(same, "{what}: batched and single rays differ");
        }
    }
}
