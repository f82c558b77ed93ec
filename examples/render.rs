//! Renders a scene file with the library alone: load, build the intersector,
//! render, write the image and one component.
//!
//!     cargo run --release --example render -- scenes/cornell.toml cornell.exr

use std::path::Path;

use caustix::film::Aov;
use caustix::{RenderConfig, Scene};

fn main() -> Result<(), caustix::Error> {
    let args: Vec<String> = std::env::args().collect();
    let scene_file = args.get(1).map_or("scenes/cornell.toml", String::as_str);
    let output = Path::new(args.get(2).map_or("cornell.exr", String::as_str));

    let scene = Scene::load(Path::new(scene_file))?;
    // The file's settings, with a smaller image; validated by render().
    let config = RenderConfig { width: 320, height: 240, ..scene.config.clone() };
    let accel = caustix::accel::build_with_layout(config.backend, config.bvh, &scene.triangle_views())?;
    let rendered = caustix::render(&scene, accel.as_ref(), &config, &|_| {})?;

    let written = rendered.film.write(output, &[Aov::Caustic], 0.0)?;
    let rays = rendered.stats.rays;
    println!(
        "wrote {} and {} in {:.2} s ({} rays, {} shadow rays)",
        output.display(),
        written[0].display(),
        rendered.stats.elapsed.as_secs_f64(),
        rays.closest,
        rays.shadow
    );
    Ok(())
}
