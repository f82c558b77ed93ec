//! `caustix bench ...`: measurements.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Subcommand;

use crate::{build_accel, in_range, load, named, worker_threads, MAX_THREADS};
use caustix::accel::BvhLayout;
use caustix::config::{limits, IntegratorKind as Integrator, RenderConfig};
use caustix::scene::Scene;

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Thread scaling: Embree and native BVH builds, photon tracing and the
    /// whole render on each thread count, with speed-ups, and a check that
    /// the image is the same bit for bit. Prints a Markdown table.
    Threads {
        /// The scene file.
        scene: PathBuf,
        /// Thread counts to compare.
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<u32>,
        /// Re-tessellate every teapot at this many quads per patch edge
        /// (125 -> 1M triangles), so the builds have work to share.
        #[arg(long, allow_negative_numbers = true)]
        teapot_subdivisions: Option<u32>,
        /// Size of the render, WIDTHxHEIGHT, with the scene's other settings.
        #[arg(long, default_value = "320x240")]
        render_size: String,
    },
    /// Photon maps at scale: for each photon count, tracing time, memory per
    /// photon, kd-tree build time and k-nearest queries per second on one
    /// and on all threads. Prints a Markdown table.
    Photons {
        /// The scene file (its lights and surfaces; global photons).
        scene: PathBuf,
        /// Photons to emit, one map per count.
        #[arg(long, value_delimiter = ',', default_value = "100000,1000000,10000000")]
        counts: Vec<u32>,
        /// Neighbours per query.
        #[arg(long, allow_negative_numbers = true, default_value_t = 50)]
        k: u32,
        /// Queries per map (at stored photons' positions).
        #[arg(long, allow_negative_numbers = true, default_value_t = 1_000_000)]
        queries: u32,
        /// Write the last map's points and queries here, for
        /// scripts/bench-nanoflann.sh to answer the same queries.
        #[arg(long)]
        dump: Option<PathBuf>,
    },
    /// Rays per second for primary, shadow and diffuse rays through Embree
    /// (single rays, ray streams, and called directly) and the native BVH,
    /// with build times and memory. Prints a Markdown table.
    Rays {
        /// The scene file.
        scene: PathBuf,
        /// Re-tessellate every teapot at this many quads per patch edge
        /// (about 64 N^2 triangles: 13 -> 10k, 125 -> 1M, 395 -> 10M).
        #[arg(long, allow_negative_numbers = true)]
        teapot_subdivisions: Option<u32>,
        /// Width of the primary-ray grid.
        #[arg(long, allow_negative_numbers = true, default_value_t = 1024)]
        width: u32,
        /// Height of the primary-ray grid.
        #[arg(long, allow_negative_numbers = true, default_value_t = 1024)]
        height: u32,
        /// Runs per measurement; the fastest counts.
        #[arg(long, allow_negative_numbers = true, default_value_t = 3)]
        repeats: usize,
    },
    /// Cost against mesh size: for each teapot tessellation level, load
    /// time, Embree and native BVH build times and memory, peak memory,
    /// diffuse rays per second, and a small render's time. Prints a Markdown
    /// table and writes CSV and a log-log plot of seconds against triangles.
    Scale {
        /// The scene file (its teapots are re-tessellated at each level).
        scene: PathBuf,
        /// Teapot levels, about 64 N^2 triangles each (13 -> 10k, 125 -> 1M, 395 -> 10M, 685 -> 30M).
        #[arg(long, value_delimiter = ',', default_value = "13,125,395,685")]
        levels: Vec<u32>,
        /// Side of the square grid of camera rays whose hits send the diffuse rays.
        #[arg(long, allow_negative_numbers = true, default_value_t = 512)]
        rays: u32,
        /// Size of the render, WIDTHxHEIGHT, with the scene's other settings.
        #[arg(long, default_value = "320x240")]
        render_size: String,
        /// Where to write the table.
        #[arg(long, default_value = "scale.csv")]
        csv: PathBuf,
        /// Where to draw seconds against triangles (SVG).
        #[arg(long, default_value = "scale.svg")]
        plot: PathBuf,
        /// Embree's BVH layout (fast or compact; auto decides per level).
        #[arg(long, value_parser = named::<BvhLayout>(BvhLayout::NAMES.map(|(n, _)| n)), default_value = "fast")]
        bvh: BvhLayout,
    },
    /// Run time against error: renders the scene with each integrator at
    /// doubling budgets, compares each image with a reference, and writes a
    /// CSV table and a log-log plot of error against seconds.
    Error(ErrorArgs),
}

/// Runs one `caustix bench` command.
pub fn run(command: BenchCommand) -> anyhow::Result<()> {
    match command {
        BenchCommand::Rays { scene, teapot_subdivisions, width, height, repeats } => {
            bench_rays(&scene, teapot_subdivisions, width, height, repeats)
        }
        BenchCommand::Error(args) => bench_error(args),
        BenchCommand::Threads { scene, threads, teapot_subdivisions, render_size } => {
            bench_threads(&scene, &threads, teapot_subdivisions, &render_size)
        }
        BenchCommand::Photons { scene, counts, k, queries, dump } => {
            bench_photons(&scene, &counts, k, queries, dump.as_deref())
        }
        BenchCommand::Scale { scene, levels, rays, render_size, csv, plot, bvh } => {
            bench_scale(&scene, &levels, rays, bvh, &render_size, &csv, &plot)
        }
    }
}

#[derive(clap::Args)]
pub struct ErrorArgs {
    /// The scene file.
    scene: PathBuf,
    /// The reference image (.exr or .hdr), e.g. a long path-traced render;
    /// every render is made at its size.
    #[arg(long)]
    reference: PathBuf,
    /// Integrators to measure (comma-separated).
    #[arg(long, value_parser = named::<Integrator>(Integrator::ALL.iter().map(|k| k.name())), value_delimiter = ',', default_value = "path,photon,sppm,vcm")]
    integrators: Vec<Integrator>,
    /// Budgets per integrator, each double the one before.
    #[arg(long, allow_negative_numbers = true, default_value_t = 6)]
    levels: u32,
    /// Where to write the table.
    #[arg(long, default_value = "error.csv")]
    csv: PathBuf,
    /// Where to draw the log-log plot of error against seconds (SVG).
    #[arg(long, default_value = "error.svg")]
    plot: PathBuf,
    /// Also denoise every render with Open Image Denoise and measure that
    /// (needs caustix built with `--features denoise`).
    #[arg(long)]
    denoise: bool,
    /// The reference's caustic component (e.g. `render --integrator path
    /// --aov caustic` beside the reference): the error is also measured
    /// where caustics make at least a quarter of the reference's light.
    #[arg(long)]
    caustic_reference: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true)]
    threads: Option<u32>,
}

fn bench_rays(
    path: &Path,
    teapot_subdivisions: Option<u32>,
    width: u32,
    height: u32,
    repeats: usize,
) -> anyhow::Result<()> {
    if let Some(level) = teapot_subdivisions {
        in_range("--teapot-subdivisions", level, 1, limits::MAX_TEAPOT_LEVEL)?;
    }
    let width = in_range("--width", width, 1, limits::MAX_IMAGE_SIDE)?;
    let height = in_range("--height", height, 1, limits::MAX_IMAGE_SIDE)?;
    let overrides = caustix::scene::Overrides { teapot_subdivisions };
    out!("{}", caustix::bench::ray_report(path, &overrides, width, height, repeats)?);
    Ok(())
}

fn bench_photons(
    path: &Path,
    counts: &[u32],
    k: u32,
    queries: u32,
    dump: Option<&Path>,
) -> anyhow::Result<()> {
    for &count in counts {
        in_range("--counts", count, 1, limits::MAX_PHOTONS)?;
    }
    let k = in_range("--k", k, 1, 10_000)? as usize;
    let queries = in_range("--queries", queries, 1, 100_000_000)? as usize;
    let scene = load(path)?;
    let accel = build_accel(&scene)?;
    eprintln!(
        "photon maps for {} at {counts:?} emitted photons, {k} nearest, on {} threads",
        path.display(),
        rayon::current_num_threads()
    );
    let rows = caustix::bench::photons::measure(
        &scene,
        accel.as_ref(),
        counts,
        k,
        queries,
        dump,
        &mut |r| {
            eprintln!(
            "{:>10} emitted, {} stored: traced in {:.2} s, tree built in {:.2} s, {:.3} M queries/s on 1 thread; \
             sum of squared distances {:.6e}",
            r.emitted, r.stored, r.trace_seconds, r.build_seconds, r.mqueries_one_thread, r.distance_sum
        )
        },
    )?;
    out!("{}", caustix::bench::photons::table(&rows));
    if let Some(dump) = dump {
        eprintln!("wrote the last map's points and queries to {}", dump.display());
    }
    Ok(())
}

/// `--render-size WIDTHxHEIGHT`.
fn parse_render_size(text: &str) -> anyhow::Result<(u32, u32)> {
    text.split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| {
            (1..=limits::MAX_IMAGE_SIDE).contains(&w) && (1..=limits::MAX_IMAGE_SIDE).contains(&h)
        })
        .ok_or_else(|| anyhow::anyhow!("--render-size must be WIDTHxHEIGHT, e.g. 320x240, found `{text}`"))
}

fn bench_threads(
    path: &Path,
    threads: &[u32],
    teapot_subdivisions: Option<u32>,
    render_size: &str,
) -> anyhow::Result<()> {
    let threads: Vec<usize> = threads
        .iter()
        .map(|&n| in_range("--threads", n, 1, MAX_THREADS).map(|n| n as usize))
        .collect::<Result<_, _>>()?;
    if let Some(level) = teapot_subdivisions {
        in_range("--teapot-subdivisions", level, 1, limits::MAX_TEAPOT_LEVEL)?;
    }
    let (width, height) = parse_render_size(render_size)?;
    let scene = Scene::load_with(path, &caustix::scene::Overrides { teapot_subdivisions })
        .with_context(|| format!("loading {}", path.display()))?;
    let settings = RenderConfig { width, height, ..scene.config.clone() };
    eprintln!(
        "thread scaling on {} ({} triangles, {width}x{height}, {:?} integrator) at {threads:?} threads",
        path.display(),
        scene.triangle_count(),
        settings.integrator
    );
    let rows = caustix::bench::threads::measure(&scene, &settings, &threads, &mut |r| {
        eprintln!(
            "{} threads: Embree {:.2} s, native {:.2} s, photons {:.2} s, render {:.2} s",
            r.threads, r.embree_build, r.native_build, r.photons, r.render
        )
    })?;
    out!("{}", caustix::bench::threads::table(&rows));
    anyhow::ensure!(rows.iter().all(|r| r.same_image), "the image changed with the thread count");
    Ok(())
}

fn bench_scale(
    scene: &Path,
    levels: &[u32],
    rays: u32,
    bvh: BvhLayout,
    render_size: &str,
    csv: &Path,
    plot: &Path,
) -> anyhow::Result<()> {
    use caustix::bench::scale;
    for &level in levels {
        in_range("--levels", level, 1, limits::MAX_TEAPOT_LEVEL)?;
    }
    let rays = in_range("--rays", rays, 1, limits::MAX_IMAGE_SIDE)?;
    let size = parse_render_size(render_size)?;
    check_svg("--plot", plot)?;
    let text = std::fs::read_to_string(scene).with_context(|| format!("reading {}", scene.display()))?;
    anyhow::ensure!(
        text.contains("[[teapot]]"),
        "{}: bench scale grows the scene's teapots, and this scene has no [[teapot]]",
        scene.display()
    );
    eprintln!(
        "measuring {} at teapot levels {levels:?} on {} threads, Embree's BVH layout {bvh:?}",
        scene.display(),
        rayon::current_num_threads()
    );
    let rows = scale::measure(scene, levels, rays, size, bvh, &mut |r| {
        eprintln!(
            "{:>10} triangles: load {:.2} s, Embree {:.2} s, native {:.2} s, render {:.2} s",
            r.triangles, r.load_seconds, r.embree_seconds, r.native_seconds, r.render_seconds
        )
    })?;
    out!("{}", scale::table(&rows));
    std::fs::write(csv, scale::csv(&rows)).with_context(|| format!("writing {}", csv.display()))?;
    scale::plot(&rows, plot)?;
    eprintln!("wrote {} and {}", csv.display(), plot.display());
    Ok(())
}

/// Plots are SVG: says so when `path` is named otherwise.
fn check_svg(flag: &str, path: &Path) -> anyhow::Result<()> {
    anyhow::ensure!(
        path.extension().is_some_and(|e| e.eq_ignore_ascii_case("svg")),
        "{flag} {}: the plot is written as SVG; give a file name ending in .svg",
        path.display()
    );
    Ok(())
}

fn bench_error(args: ErrorArgs) -> anyhow::Result<()> {
    use caustix::bench::error;
    // Refused now, not after the first render.
    anyhow::ensure!(
        !args.denoise || cfg!(feature = "denoise"),
        "--denoise {}",
        caustix::film::denoise::NOT_BUILT
    );
    let scene = load(&args.scene)?;
    let reference = caustix::Image::load(&args.reference)?;
    let caustic_region = match &args.caustic_reference {
        None => None,
        Some(path) => {
            let caustic = caustix::Image::load(path)?;
            let region = error::caustic_region(&reference, &caustic).ok_or_else(|| {
                anyhow::anyhow!(
                    "--caustic-reference {} is {}x{} but the reference is {}x{}",
                    path.display(),
                    caustic.width,
                    caustic.height,
                    reference.width,
                    reference.height
                )
            })?;
            anyhow::ensure!(
                region.contains(&true),
                "--caustic-reference {}: no pixel has a caustic of a quarter of the reference's light; \
                 is it the caustic component of the same render?",
                path.display()
            );
            eprintln!("caustic region: {} pixels", region.iter().filter(|&&c| c).count());
            Some(region)
        }
    };
    let levels = in_range("--levels", args.levels, 1, 16)?;
    check_svg("--plot", &args.plot)?;
    let mut integrators: Vec<Integrator> = Vec::new();
    for i in &args.integrators {
        if !integrators.contains(i) {
            integrators.push(*i);
        }
    }
    if let Some(bad) = integrators.iter().find(|i| {
        !matches!(
            i,
            Integrator::Path
                | Integrator::Photon
                | Integrator::Sppm
                | Integrator::Vcm
                | Integrator::Bdpt
                | Integrator::Light
        )
    }) {
        anyhow::bail!(
            "--integrators: {} is not measured; choose from path, photon, sppm, vcm, bdpt, light",
            error::name(*bad)
        );
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(worker_threads(args.threads)?)
        .build()
        .context("starting worker threads")?;
    let accel = build_accel(&scene)?;
    let settings = scene.config.clone();
    eprintln!(
        "measuring {} at {}x{} against {}, {} levels each",
        args.scene.display(),
        reference.width,
        reference.height,
        args.reference.display(),
        levels
    );
    let plan = error::Plan { integrators, levels, denoise: args.denoise, caustic_region };
    let points = pool.install(|| {
        error::measure(&scene, accel.as_ref(), &settings, &reference, &plan, &mut |p| {
            let mut also = String::new();
            if let Some(c) = &p.caustic_error {
                also += &format!(", caustic region {:.5}", c.rmse);
            }
            if let Some(d) = &p.denoised {
                also += &format!(", denoised {:.5} (+{:.2} s)", d.error.rmse, d.seconds);
                if let Some(c) = &d.caustic_error {
                    also += &format!(", denoised caustic region {:.5}", c.rmse);
                }
            }
            eprintln!(
                "{:>6} level {}: {:>8.2} s, RMSE {:.5}, mean ratio {:.4}, fireflies {}{also}  ({})",
                error::name(p.integrator),
                p.level,
                p.seconds,
                p.error.rmse,
                p.error.means.0 / p.error.means.1,
                p.fireflies,
                p.setting
            )
        })
    })?;
    let whole = error::denoising_stops_helping(&points, |p, d| Some((p.error.rmse, d.error.rmse)));
    let caustic =
        error::denoising_stops_helping(&points, |p, d| Some((p.caustic_error?.rmse, d.caustic_error?.rmse)));
    for (region, stops) in [("", whole), (" in the caustic region", caustic)] {
        for (integrator, level) in stops {
            match level {
                Some(level) => eprintln!(
                    "{}: denoising helps{region} below level {level}; from there the noisy image is as close or closer",
                    error::name(integrator)
                ),
                None => eprintln!("{}: denoising helped{region} at every level", error::name(integrator)),
            }
        }
    }
    std::fs::write(&args.csv, error::csv(&points))
        .with_context(|| format!("writing {}", args.csv.display()))?;
    let title =
        format!("{}: error against time", args.scene.file_stem().unwrap_or_default().to_string_lossy());
    error::plot(&points, &title, &args.plot)?;
    eprintln!("wrote {} and {}", args.csv.display(), args.plot.display());
    Ok(())
}
