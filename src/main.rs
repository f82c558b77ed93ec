//! The `caustix` command line: a thin layer that fills in settings and calls
//! the library.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use caustix::accel::{Backend, BvhLayout};
use caustix::render::{Components, Integrator, RenderSettings};
use caustix::scene::{limits, Scene};

#[derive(Parser)]
#[command(
    name = "caustix",
    version,
    about = "A photon-mapping renderer: Embree for ray hits, Rust for the light"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to an image.
    Render(RenderArgs),
    /// Print what a scene holds: triangles, vertices, bounds, materials, lights.
    Info {
        /// The scene file.
        scene: PathBuf,
    },
    /// Write the scene's triangles, all meshes in one, as a mesh file:
    /// binary PLY (fast to load) or OBJ, by the output's extension.
    Export {
        /// The scene file.
        scene: PathBuf,
        /// The mesh file to write (.ply or .obj).
        #[arg(short, long)]
        output: PathBuf,
        /// Re-tessellate every teapot at this many quads per patch edge first
        /// (about 64 N^2 triangles: 125 -> 1M, 395 -> 10M, 685 -> 30M).
        #[arg(long)]
        teapot_subdivisions: Option<u32>,
    },
    /// Measure performance.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// Compare an image with a reference: RMSE, relative MSE, mean absolute error.
    Compare {
        /// The image (.exr or .hdr for linear values; .png is decoded from sRGB).
        image: PathBuf,
        /// The reference image, same size.
        reference: PathBuf,
        /// Also write a false-colour picture of the differences (PNG).
        #[arg(long)]
        error_image: Option<PathBuf>,
        /// Absolute difference shown as full red in the error picture.
        #[arg(long, default_value_t = 0.1)]
        error_scale: f32,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
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
        #[arg(long)]
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
        #[arg(long, default_value_t = 50)]
        k: u32,
        /// Queries per map (at stored photons' positions).
        #[arg(long, default_value_t = 1_000_000)]
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
        #[arg(long)]
        teapot_subdivisions: Option<u32>,
        /// Width of the primary-ray grid.
        #[arg(long, default_value_t = 1024)]
        width: u32,
        /// Height of the primary-ray grid.
        #[arg(long, default_value_t = 1024)]
        height: u32,
        /// Runs per measurement; the fastest counts.
        #[arg(long, default_value_t = 3)]
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
        #[arg(long, default_value_t = 512)]
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
        #[arg(long, value_enum, default_value = "fast")]
        bvh: BvhLayout,
    },
    /// Run time against error: renders the scene with each integrator at
    /// doubling budgets, compares each image with a reference, and writes a
    /// CSV table and a log-log plot of error against seconds.
    Error(ErrorArgs),
}

#[derive(clap::Args)]
struct ErrorArgs {
    /// The scene file.
    scene: PathBuf,
    /// The reference image (.exr or .hdr), e.g. a long path-traced render;
    /// every render is made at its size.
    #[arg(long)]
    reference: PathBuf,
    /// Integrators to measure (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "path,photon,sppm")]
    integrators: Vec<Integrator>,
    /// Budgets per integrator, each double the one before.
    #[arg(long, default_value_t = 6)]
    levels: u32,
    /// Where to write the table.
    #[arg(long, default_value = "error.csv")]
    csv: PathBuf,
    /// Where to draw the log-log plot of error against seconds (SVG).
    #[arg(long, default_value = "error.svg")]
    plot: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// The scene file (TOML; see the README for the format).
    scene: PathBuf,
    /// Output image: .png (tone-mapped sRGB), .exr or .hdr (linear radiance).
    /// Default: the scene's name with .png, in the current folder.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Integrator (overrides the scene file's [render] integrator).
    #[arg(long, value_enum)]
    integrator: Option<Integrator>,
    /// Ray intersector (overrides the scene file's [render] backend; default embree).
    #[arg(long, value_enum)]
    backend: Option<Backend>,
    /// Embree's BVH layout: fast, compact (about a third of the memory while
    /// building, slower rays) or auto (compact only when fast would not fit
    /// in available memory; the default). Overrides the scene's [render] bvh.
    #[arg(long, value_enum)]
    bvh: Option<BvhLayout>,
    /// Image width in pixels (overrides the scene file).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene file).
    #[arg(long)]
    height: Option<u32>,
    /// Camera samples per pixel (overrides the scene file).
    #[arg(long)]
    spp: Option<u32>,
    /// Longest chain of rays from the camera (overrides the scene file).
    #[arg(long)]
    max_depth: Option<u32>,
    /// Shadow rays per area light at each shading point (overrides the scene file).
    #[arg(long)]
    light_samples: Option<u32>,
    /// Photons emitted for the global map (overrides [photons] global; 0 skips it).
    #[arg(long)]
    photons: Option<u32>,
    /// Photons emitted for the caustic map (overrides [photons] caustic; 0 skips it).
    #[arg(long)]
    caustic_photons: Option<u32>,
    /// Nearest photons per global estimate (overrides [photons] global_k).
    #[arg(long)]
    global_k: Option<u32>,
    /// Nearest photons per caustic estimate (overrides [photons] caustic_k).
    #[arg(long)]
    caustic_k: Option<u32>,
    /// Largest search radius of a global estimate (overrides [photons] global_radius).
    #[arg(long)]
    global_radius: Option<f32>,
    /// Largest search radius of a caustic estimate (overrides [photons] caustic_radius).
    #[arg(long)]
    caustic_radius: Option<f32>,
    /// Final-gathering rays per pixel, shared over its samples; 0 shows the
    /// global map directly (overrides [photons] gather_rays).
    #[arg(long)]
    gather_rays: Option<u32>,
    /// Passes of progressive photon mapping (overrides [photons] passes).
    #[arg(long)]
    passes: Option<u32>,
    /// Photons per pass of progressive photon mapping (overrides [photons] pass_photons).
    #[arg(long)]
    pass_photons: Option<u32>,
    /// Starting radius of progressive photon mapping (overrides [photons] sppm_radius).
    #[arg(long)]
    sppm_radius: Option<f32>,
    /// Exposure for PNG output, in stops: each pixel is multiplied by 2^EXPOSURE.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Also write these components, each beside the output as NAME-COMPONENT.EXT
    /// (comma-separated: direct, specular, final).
    #[arg(long, value_delimiter = ',')]
    aov: Vec<String>,
    /// Worker threads (default: all cores). The image is the same for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Seed of every random stream: another seed, an independent image (default 0).
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => render(args),
        Command::Info { scene } => info(&scene),
        Command::Export { scene, output, teapot_subdivisions } => {
            export(&scene, &output, teapot_subdivisions)
        }
        Command::Compare { image, reference, error_image, error_scale } => {
            compare(&image, &reference, error_image.as_deref(), error_scale)
        }
        Command::Bench(BenchCommand::Rays { scene, teapot_subdivisions, width, height, repeats }) => {
            bench_rays(&scene, teapot_subdivisions, width, height, repeats)
        }
        Command::Bench(BenchCommand::Error(args)) => bench_error(args),
        Command::Bench(BenchCommand::Threads { scene, threads, teapot_subdivisions, render_size }) => {
            bench_threads(&scene, &threads, teapot_subdivisions, &render_size)
        }
        Command::Bench(BenchCommand::Photons { scene, counts, k, queries, dump }) => {
            bench_photons(&scene, &counts, k, queries, dump.as_deref())
        }
        Command::Bench(BenchCommand::Scale { scene, levels, rays, render_size, csv, plot, bvh }) => {
            bench_scale(&scene, &levels, rays, bvh, &render_size, &csv, &plot)
        }
    }
}

fn load(path: &Path) -> anyhow::Result<Scene> {
    let scene = Scene::load(path)?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(scene)
}

/// The scene's intersector, as its `[render]` table asks (backend, BVH layout).
fn build_accel(scene: &Scene) -> anyhow::Result<Box<dyn caustix::accel::Intersector + '_>> {
    caustix::accel::build_with_layout(scene.render.backend, scene.render.bvh, &scene.triangle_views())
        .context("building the ray intersector")
}

/// Checks a command-line number against the same bounds as the scene file.
fn in_range(flag: &str, value: u32, min: u32, max: u32) -> anyhow::Result<u32> {
    anyhow::ensure!((min..=max).contains(&value), "{flag} must be from {min} to {max}, found {value}");
    Ok(value)
}

fn render(args: RenderArgs) -> anyhow::Result<()> {
    let scene = load(&args.scene)?;
    let mut settings = RenderSettings::from_scene(&scene);
    if let Some(integrator) = args.integrator {
        settings.integrator = integrator;
    }
    settings.seed = args.seed;
    settings.photons.seed = args.seed;
    settings.width = in_range("--width", args.width.unwrap_or(settings.width), 1, limits::MAX_IMAGE_SIDE)?;
    settings.height =
        in_range("--height", args.height.unwrap_or(settings.height), 1, limits::MAX_IMAGE_SIDE)?;
    settings.samples = in_range("--spp", args.spp.unwrap_or(settings.samples), 1, limits::MAX_SAMPLES)?;
    settings.max_depth =
        in_range("--max-depth", args.max_depth.unwrap_or(settings.max_depth), 1, limits::MAX_DEPTH)?;
    settings.light_samples = in_range(
        "--light-samples",
        args.light_samples.unwrap_or(settings.light_samples),
        1,
        limits::MAX_SAMPLES,
    )?;
    let p = &mut settings.photons;
    p.global_photons =
        in_range("--photons", args.photons.unwrap_or(p.global_photons), 0, limits::MAX_PHOTONS)?;
    p.caustic_photons = in_range(
        "--caustic-photons",
        args.caustic_photons.unwrap_or(p.caustic_photons),
        0,
        limits::MAX_PHOTONS,
    )?;
    p.global_estimate.k =
        in_range("--global-k", args.global_k.unwrap_or(p.global_estimate.k as u32), 1, 100_000)? as usize;
    p.caustic_estimate.k =
        in_range("--caustic-k", args.caustic_k.unwrap_or(p.caustic_estimate.k as u32), 1, 100_000)? as usize;
    p.gather_rays =
        in_range("--gather-rays", args.gather_rays.unwrap_or(p.gather_rays), 0, limits::MAX_SAMPLES)?;
    p.sppm.passes = in_range("--passes", args.passes.unwrap_or(p.sppm.passes), 1, limits::MAX_PASSES)?;
    p.sppm.photons_per_pass = in_range(
        "--pass-photons",
        args.pass_photons.unwrap_or(p.sppm.photons_per_pass),
        1,
        limits::MAX_PHOTONS,
    )?;
    for (flag, value, radius) in [
        ("--global-radius", args.global_radius, &mut p.global_estimate.max_radius),
        ("--caustic-radius", args.caustic_radius, &mut p.caustic_estimate.max_radius),
        ("--sppm-radius", args.sppm_radius, &mut p.sppm.initial_radius),
    ] {
        if let Some(r) = value {
            anyhow::ensure!(r.is_finite() && r > 0.0, "{flag} must be a distance greater than 0, found {r}");
            *radius = r;
        }
    }
    anyhow::ensure!(args.exposure.is_finite(), "--exposure must be a finite number of stops");
    for name in &args.aov {
        anyhow::ensure!(
            Components::NAMES.contains(&name.as_str()),
            "--aov: unknown component `{name}`; choose from {}",
            Components::NAMES.join(", ")
        );
    }
    let output = args
        .output
        .unwrap_or_else(|| PathBuf::from(args.scene.file_stem().unwrap_or_default()).with_extension("png"));

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let backend = args.backend.unwrap_or(scene.render.backend);
    let layout = args.bvh.unwrap_or(scene.render.bvh);
    // Inside the pool, so that --threads bounds the BVH builds too.
    let accel = pool
        .install(|| caustix::accel::build_with_layout(backend, layout, &scene.triangle_views()))
        .context("building the ray intersector")?;

    let work = caustix::render::work_units(&settings);
    let bar = if std::io::stderr().is_terminal() { ProgressBar::new(work) } else { ProgressBar::hidden() };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {percent}% {elapsed} elapsed, {eta} left",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    let rendered =
        pool.install(|| caustix::render::render(&scene, accel.as_ref(), &settings, &|n| bar.inc(n)));
    bar.finish_and_clear();

    let final_image = rendered.image("final").expect("final is a component");
    final_image.save(&output, args.exposure)?;
    for name in &args.aov {
        let path = aov_path(&output, name);
        rendered.image(name).expect("checked above").save(&path, args.exposure)?;
        eprintln!("wrote {}", path.display());
    }
    let stats = &rendered.stats;
    let seconds = stats.elapsed.as_secs_f64();
    let total_rays = stats.rays + stats.shadow_rays;
    // Previews trace one centred ray per pixel whatever the sample count.
    let spp = match settings.integrator {
        Integrator::Whitted | Integrator::Photon | Integrator::Path => settings.samples,
        Integrator::Sppm => settings.photons.sppm.passes,
        Integrator::Normals | Integrator::Depth => 1,
    };
    if let (Some(p), Integrator::Sppm) = (&stats.photons, settings.integrator) {
        eprintln!(
            "photons: {} emitted in {} passes of {}, traced and gathered in {:.2} s",
            p.global_emitted,
            settings.photons.sppm.passes,
            settings.photons.sppm.photons_per_pass,
            p.trace_seconds
        );
    } else if let Some(p) = &stats.photons {
        eprintln!(
            "photons: {} global and {} caustic emitted, traced in {:.2} s, maps built in {:.2} s",
            p.global_emitted, p.caustic_emitted, p.trace_seconds, p.build_seconds
        );
        for line in &p.skipped {
            eprintln!("photons: {line}");
        }
    }
    eprintln!(
        "{}: {}x{} {:?}, {} spp in {seconds:.2} s: {} rays + {} shadow rays ({:.2} Mrays/s) on {} threads with {}",
        output.display(),
        settings.width,
        settings.height,
        settings.integrator,
        spp,
        stats.rays,
        stats.shadow_rays,
        total_rays as f64 / seconds.max(1e-9) / 1e6,
        pool.current_num_threads(),
        accel.name()
    );
    Ok(())
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
    print!("{}", caustix::bench::ray_report(path, &overrides, width, height, repeats)?);
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
    print!("{}", caustix::bench::photons::table(&rows));
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
        .map(|&n| in_range("--threads", n, 1, 1024).map(|n| n as usize))
        .collect::<Result<_, _>>()?;
    if let Some(level) = teapot_subdivisions {
        in_range("--teapot-subdivisions", level, 1, limits::MAX_TEAPOT_LEVEL)?;
    }
    let (width, height) = parse_render_size(render_size)?;
    let scene = Scene::load_with(path, &caustix::scene::Overrides { teapot_subdivisions })
        .with_context(|| format!("loading {}", path.display()))?;
    let settings = RenderSettings { width, height, ..RenderSettings::from_scene(&scene) };
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
    print!("{}", caustix::bench::threads::table(&rows));
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
    print!("{}", scale::table(&rows));
    std::fs::write(csv, scale::csv(&rows)).with_context(|| format!("writing {}", csv.display()))?;
    scale::plot(&rows, plot)?;
    eprintln!("wrote {} and {}", csv.display(), plot.display());
    Ok(())
}

fn export(scene_path: &Path, output: &Path, teapot_subdivisions: Option<u32>) -> anyhow::Result<()> {
    let extension = output.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    anyhow::ensure!(
        matches!(extension.as_deref(), Some("ply" | "obj")),
        "--output {}: write .ply (binary, fast to load) or .obj",
        output.display()
    );
    let start = std::time::Instant::now();
    let scene = Scene::load_with(scene_path, &caustix::scene::Overrides { teapot_subdivisions })?;
    let (positions, normals, indices) = scene.merged_triangles();
    let file = std::fs::File::create(output).with_context(|| format!("creating {}", output.display()))?;
    let out = std::io::BufWriter::with_capacity(1 << 20, file);
    if extension.as_deref() == Some("ply") {
        caustix::scene::ply::write_binary(out, &positions, &normals, &indices)
    } else {
        caustix::scene::obj::write(out, &positions, &normals, &indices)
    }
    .with_context(|| format!("writing {}", output.display()))?;
    eprintln!(
        "wrote {}: {} triangles, {} vertices in {:.1} s",
        output.display(),
        indices.len(),
        positions.len(),
        start.elapsed().as_secs_f64()
    );
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
    let scene = load(&args.scene)?;
    let reference = caustix::render::image::Image::load(&args.reference)?;
    let levels = in_range("--levels", args.levels, 1, 16)?;
    check_svg("--plot", &args.plot)?;
    let mut integrators: Vec<Integrator> = Vec::new();
    for i in &args.integrators {
        if !integrators.contains(i) {
            integrators.push(*i);
        }
    }
    if let Some(bad) =
        integrators.iter().find(|i| !matches!(i, Integrator::Path | Integrator::Photon | Integrator::Sppm))
    {
        anyhow::bail!("--integrators: {} is not measured; choose from path, photon, sppm", error::name(*bad));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let accel = build_accel(&scene)?;
    let settings = RenderSettings::from_scene(&scene);
    eprintln!(
        "measuring {} at {}x{} against {}, {} levels each",
        args.scene.display(),
        reference.width,
        reference.height,
        args.reference.display(),
        levels
    );
    let points = pool.install(|| {
        error::measure(&scene, accel.as_ref(), &settings, &reference, &integrators, levels, &mut |p| {
            eprintln!(
                "{:>6} level {}: {:>8.2} s, RMSE {:.5}, mean ratio {:.4}  ({})",
                error::name(p.integrator),
                p.level,
                p.seconds,
                p.error.rmse,
                p.error.means.0 / p.error.means.1,
                p.setting
            )
        })
    });
    std::fs::write(&args.csv, error::csv(&points))
        .with_context(|| format!("writing {}", args.csv.display()))?;
    let title =
        format!("{}: error against time", args.scene.file_stem().unwrap_or_default().to_string_lossy());
    error::plot(&points, &title, &args.plot)?;
    eprintln!("wrote {} and {}", args.csv.display(), args.plot.display());
    Ok(())
}

fn compare(image: &Path, reference: &Path, error_image: Option<&Path>, scale: f32) -> anyhow::Result<()> {
    use caustix::render::image::Image;
    let (a, b) = (Image::load(image)?, Image::load(reference)?);
    let d = a.difference(&b).ok_or_else(|| {
        anyhow::anyhow!("the images differ in size: {}x{} and {}x{}", a.width, a.height, b.width, b.height)
    })?;
    println!("rmse     {:.6}", d.rmse);
    println!("rel_mse  {:.6}", d.rel_mse);
    println!("mae      {:.6}", d.mae);
    println!("mean     {:.6} (reference {:.6}, ratio {:.4})", d.means.0, d.means.1, d.means.0 / d.means.1);
    if let Some(out) = error_image {
        anyhow::ensure!(scale.is_finite() && scale > 0.0, "--error-scale must be greater than 0");
        a.error_image(&b, scale).save(out, 0.0)?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// `out.png` with component `direct` -> `out-direct.png`.
fn aov_path(output: &Path, name: &str) -> PathBuf {
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let extension = output.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    output.with_file_name(format!("{stem}-{name}{extension}"))
}

fn info(path: &Path) -> anyhow::Result<()> {
    let start = std::time::Instant::now();
    let scene = load(path)?;
    let load_seconds = start.elapsed().as_secs_f64();
    let b = scene.bounds();
    println!("scene     {} (loaded in {load_seconds:.2} s)", path.display());
    println!(
        "image     {}x{}, {} samples per pixel",
        scene.image.width, scene.image.height, scene.image.samples
    );
    println!(
        "camera    eye {}, looking along {}, fov {:.1} deg",
        scene.camera.eye,
        -scene.camera.w,
        2.0 * scene.camera.tan_half_fov.atan().to_degrees()
    );
    println!(
        "geometry  {} triangles, {} vertices in {} meshes",
        scene.triangle_count(),
        scene.vertex_count(),
        scene.meshes.len()
    );
    println!("bounds    {} to {}", b.min, b.max);
    let bytes: usize = scene.meshes.iter().map(|m| m.bytes()).sum();
    println!(
        "memory    {:.1} MiB of positions, normals and indices ({:.1} bytes per triangle)",
        bytes as f64 / (1024.0 * 1024.0),
        bytes as f64 / scene.triangle_count().max(1) as f64
    );
    for m in &scene.meshes {
        println!(
            "  mesh    {:<24} {:>9} triangles  material {}",
            m.name,
            m.indices.len(),
            scene.materials[m.material].name
        );
    }
    println!("materials {}", scene.materials.len());
    for m in &scene.materials {
        println!(
            "  {:<22} diffuse {} specular {} (exp {}) mirror {} transmit {} ior {}",
            m.name, m.diffuse, m.specular, m.phong_exponent, m.mirror, m.transmittance, m.ior
        );
    }
    println!("lights    {}", scene.lights.len());
    for l in &scene.lights {
        println!("  {}", l.describe());
    }
    let start = std::time::Instant::now();
    let accel = build_accel(&scene)?;
    println!("backend   {} (built in {:.2} s)", accel.name(), start.elapsed().as_secs_f64());
    Ok(())
}
