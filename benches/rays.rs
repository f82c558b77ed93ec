//! `cargo bench`: ray throughput on the teapot scene (Embree single, stream,
//! direct, and the native BVH). For other sizes use `caustix bench rays`.

fn main() {
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/teapot.toml");
    // `cargo bench` passes `--bench`; nothing else to parse.
    match caustix::bench::ray_report(&scene, &Default::default(), 512, 512, 3) {
        Ok(report) => print!("{report}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
