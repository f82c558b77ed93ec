//! The `caustix` command line: a thin layer that parses arguments, calls
//! the library and prints. Each command's arguments and code live in their
//! own file: `render.rs`, `scale_out.rs` (photons, merge), `bench.rs`
//! (measurements), `tools.rs` (info, export, compare, denoise).

/// `print!` that returns the error instead of panicking, so that a reader
/// going away (`caustix info scene.toml | head -1`) ends the program quietly.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout().lock(), $($arg)*)?
    }};
}

/// `println!` that returns the error instead of panicking (see `out!`).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)?
    }};
}

mod bench;
mod render;
mod scale_out;
mod tools;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Parser, Subcommand};

use caustix::scene::Scene;

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
    /// Render a scene file to an image (or a tile of it).
    Render(render::RenderArgs),
    /// Trace a scene's photon maps and save them, for `render --photon-map`
    /// (takes the same settings as `render`).
    Photons(scale_out::PhotonsArgs),
    /// Assemble tiles (`render --tile I/N`) into the whole image, checking
    /// that they come from one render and cover every pixel once.
    Merge(scale_out::MergeArgs),
    /// Print what a scene holds: triangles, vertices, bounds, materials,
    /// lights. Given an OBJ, PLY or STL mesh instead: its size and materials, and
    /// a scene that frames it (`caustix info bunny.obj > bunny.toml`).
    Info {
        /// The scene file (or a mesh file).
        scene: PathBuf,
    },
    /// Write the scene's triangles, all meshes in one, as a mesh file:
    /// binary PLY (fast to load), OBJ or binary STL, by the output's extension.
    Export {
        /// The scene file.
        scene: PathBuf,
        /// The mesh file to write (.ply, .obj or .stl).
        #[arg(short, long)]
        output: PathBuf,
        /// Re-tessellate every teapot at this many quads per patch edge first
        /// (about 64 N^2 triangles: 125 -> 1M, 395 -> 10M, 685 -> 30M).
        #[arg(long, allow_negative_numbers = true)]
        teapot_subdivisions: Option<u32>,
    },
    /// Measure performance.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
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
        #[arg(long, value_parser = crate::float, allow_negative_numbers = true, default_value_t = 0.1)]
        error_scale: f32,
    },
    /// Denoise a rendered image with Intel Open Image Denoise (needs caustix
    /// built with `--features denoise`), guided by its albedo and normal
    /// components (`caustix render -o out.exr --aov emission,albedo,normal`).
    Denoise {
        /// The image: linear radiance, .exr or .hdr.
        image: PathBuf,
        #[command(flatten)]
        guides: tools::DenoiseGuides,
        /// Where to write the denoised image (.png, .exr or .hdr).
        #[arg(short, long)]
        output: PathBuf,
        /// Exposure for PNG output, in stops.
        #[arg(long, value_parser = crate::float, default_value_t = 0.0, allow_negative_numbers = true)]
        exposure: f32,
    },
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our output went away (`| head`): nothing more to say.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => render::render(args),
        Command::Photons(args) => scale_out::photons(args),
        Command::Merge(args) => scale_out::merge(args),
        Command::Info { scene } => tools::info(&scene),
        Command::Export { scene, output, teapot_subdivisions } => {
            tools::export(&scene, &output, teapot_subdivisions)
        }
        Command::Compare { image, reference, error_image, error_scale } => {
            tools::compare(&image, &reference, error_image.as_deref(), error_scale)
        }
        Command::Bench(command) => bench::run(command),
        Command::Denoise { image, guides, output, exposure } => {
            tools::denoise(&image, &guides, &output, exposure)
        }
    }
}

fn load(path: &Path) -> anyhow::Result<Scene> {
    let (scene, seconds) = with_spinner(format!("loading {}", path.display()), || Scene::load(path));
    let scene = scene?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    if seconds >= SAY_SECONDS {
        // (A mesh file's emitting faces are lights, not triangles.)
        let lights = match scene.lights.len() {
            0 | 1 => String::new(),
            n => format!(" and {n} lights"),
        };
        eprintln!("scene: {} triangles{lights} loaded in {seconds:.2} s", scene.triangle_count());
    }
    Ok(scene)
}

/// Steps before a render that say how long they took when they took this
/// long (a big mesh's loading and BVH build, seconds before the render's
/// progress bar starts); a small scene's take a few milliseconds, unsaid.
const SAY_SECONDS: f64 = 0.5;

/// Runs `work` with a spinner saying `message` on a terminal (nothing
/// otherwise); its value and the seconds it took.
fn with_spinner<T>(message: String, work: impl FnOnce() -> T) -> (T, f64) {
    use std::io::IsTerminal;
    let spinner = if std::io::stderr().is_terminal() {
        indicatif::ProgressBar::new_spinner()
    } else {
        indicatif::ProgressBar::hidden()
    };
    spinner.set_message(message);
    spinner.enable_steady_tick(std::time::Duration::from_millis(120));
    let start = std::time::Instant::now();
    let value = work();
    spinner.finish_and_clear();
    (value, start.elapsed().as_secs_f64())
}

/// The scene's intersector, as its `[render]` table asks (backend, BVH layout).
fn build_accel(scene: &Scene) -> anyhow::Result<Box<dyn caustix::accel::Intersector + '_>> {
    caustix::accel::build_with_layout(scene.config.backend, scene.config.bvh, &scene.triangle_views())
        .context("building the ray intersector")
}

/// A pool of `threads` workers (0: all cores) and, built inside it so that
/// `--threads` bounds the BVH build too, the intersector `settings` ask for.
fn pool_and_accel<'s>(
    threads: usize,
    scene: &'s Scene,
    settings: &caustix::RenderConfig,
) -> anyhow::Result<(rayon::ThreadPool, Box<dyn caustix::accel::Intersector + 's>)> {
    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("starting worker threads")?;
    let triangles = scene.triangle_count();
    let (accel, seconds) =
        with_spinner(format!("building the ray intersector over {triangles} triangles"), || {
            pool.install(|| {
                caustix::accel::build_with_layout(settings.backend, settings.bvh, &scene.triangle_views())
            })
        });
    let accel = accel.context("building the ray intersector")?;
    if seconds >= SAY_SECONDS {
        eprintln!("intersector: {} built over {triangles} triangles in {seconds:.2} s", accel.name());
    }
    Ok((pool, accel))
}

/// Most worker threads `--threads` may ask for (a typo like 100000 would
/// start that many).
const MAX_THREADS: u32 = 1024;

/// The worker threads `--threads` asks for (checked), or 0: all cores.
fn worker_threads(threads: Option<u32>) -> anyhow::Result<usize> {
    Ok(threads.map(|n| in_range("--threads", n, 1, MAX_THREADS)).transpose()?.unwrap_or(0) as usize)
}

/// Checks a command-line number of a measurement (render settings go
/// through [`caustix::RenderConfig::validate`] instead).
fn in_range(flag: &str, value: u32, min: u32, max: u32) -> anyhow::Result<u32> {
    anyhow::ensure!((min..=max).contains(&value), "{flag} must be from {min} to {max}, found {value}");
    Ok(value)
}

/// A parser for an `f32` flag that refuses a number beyond the floats
/// (`1e300` read as an `f32` is infinity, and the flag's own check would
/// then say it found `inf`). `inf` and `nan` as written pass, for that
/// check to refuse by the flag's own rule.
fn float(text: &str) -> Result<f32, String> {
    let wide: f64 = text.trim().parse().map_err(|_| format!("`{text}` is not a number"))?;
    if wide.is_finite() && wide.abs() > f64::from(f32::MAX) {
        return Err(format!("{text} is beyond the largest number caustix takes here ({:e})", f32::MAX));
    }
    Ok(wide as f32)
}

/// A parser for a library type named by one of `names` (what clap lists in
/// its help and errors), so the library needs no clap derives.
fn named<T: std::str::FromStr + Clone + Send + Sync + 'static>(
    names: impl IntoIterator<Item = &'static str>,
) -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(names).map(|name| match name.parse::<T>() {
        Ok(value) => value,
        Err(_) => unreachable!("`{name}` is one of the names listed for this type"),
    })
}
