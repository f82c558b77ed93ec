//! `caustix photons` and `caustix merge`: the pieces of a render spread over
//! many jobs (see scripts/slurm/): photon maps traced once and saved, tiles
//! rendered from them, tiles merged into the image.

use std::path::PathBuf;
use std::time::Instant;

use crate::render::{config, in_flags, SettingArgs};
use crate::{load, pool_and_accel, worker_threads};

/// `caustix photons`.
#[derive(clap::Args)]
pub struct PhotonsArgs {
    #[command(flatten)]
    settings: SettingArgs,
    /// Where to write the photon maps. Default: the scene's name with .cxpm,
    /// in the current folder.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Worker threads (default: all cores). The maps are the same for any count.
    #[arg(long, allow_negative_numbers = true)]
    threads: Option<u32>,
}

/// `caustix merge`.
#[derive(clap::Args)]
pub struct MergeArgs {
    /// The tiles (.exr files written by `caustix render --tile` or `--crop`).
    #[arg(required = true)]
    tiles: Vec<PathBuf>,
    /// The whole image: .exr or .hdr (linear), or .png (tone-mapped sRGB).
    #[arg(short, long)]
    output: PathBuf,
    /// Exposure for PNG output, in stops.
    #[arg(long, value_parser = crate::float, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
}

pub fn photons(args: PhotonsArgs) -> anyhow::Result<()> {
    let scene_path = args.settings.scene();
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(scene_path.file_stem().unwrap_or_default()).with_extension("cxpm"));
    caustix::files::check_writable(&output)?;
    let threads = worker_threads(args.threads)?;
    let scene = load(scene_path)?;
    let settings = config(&args.settings, &scene);
    caustix::integrator::check(&scene, &settings).map_err(in_flags)?;
    let (pool, accel) = pool_and_accel(threads, &scene, &settings)?;
    let diagonal = caustix::integrator::Context::diagonal_of(&scene);
    let query = caustix::query::SceneQuery::new(&scene, accel.as_ref());
    let maps = pool.install(|| {
        caustix::photon::build_maps(
            &query,
            &settings.photons,
            settings.max_depth,
            settings.seed,
            settings.sampler,
            diagonal,
        )
    });
    let start = Instant::now();
    caustix::photon::file::save(&output, &maps, &scene, &settings, diagonal).map_err(in_flags)?;
    let s = &maps.stats;
    for line in &s.skipped {
        eprintln!("photons: {line}");
    }
    let size = std::fs::metadata(&output).map_or(0, |m| m.len());
    eprintln!(
        "{}: {} global and {} caustic photons emitted, traced in {:.2} s ({} rays), maps built in {:.2} s, \
         saved in {:.2} s ({:.1} MiB)",
        output.display(),
        s.global_emitted,
        s.caustic_emitted,
        s.trace_seconds,
        s.rays.closest,
        s.build_seconds,
        start.elapsed().as_secs_f64(),
        size as f64 / (1 << 20) as f64
    );
    Ok(())
}

pub fn merge(args: MergeArgs) -> anyhow::Result<()> {
    caustix::Image::check_output(&args.output)?;
    anyhow::ensure!(args.exposure.is_finite(), "--exposure must be a finite number of stops");
    let mut tiles = Vec::with_capacity(args.tiles.len());
    for path in &args.tiles {
        tiles.push((path.clone(), caustix::film::tile::load(path)?));
    }
    let image = caustix::film::tile::merge(&tiles)?;
    image.save(&args.output, args.exposure)?;
    eprintln!(
        "wrote {} from {} tiles ({}x{})",
        args.output.display(),
        tiles.len(),
        image.width,
        image.height
    );
    Ok(())
}
