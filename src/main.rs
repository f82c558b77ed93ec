//! The `caustix` command line: a thin layer that fills in settings and calls
//! the library.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use caustix::accel::embree::EmbreeIntersector;
use caustix::accel::Intersector;
use caustix::render::{render_preview, Preview};
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
    /// Render a scene file to an image.
    Render {
        /// The scene file (TOML; see the README for the format).
        scene: PathBuf,
        /// Output image (PNG). Default: the scene's name with `.png`, in the current folder.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Image width in pixels (overrides the scene file).
        #[arg(long)]
        width: Option<u32>,
        /// Image height in pixels (overrides the scene file).
        #[arg(long)]
        height: Option<u32>,
        /// What to show: geometry previews until the lighting integrators land.
        #[arg(long, value_enum, default_value_t = Preview::Normals)]
        preview: Preview,
    },
    /// Print what a scene holds: triangles, vertices, bounds, materials, lights.
    Info {
        /// The scene file.
        scene: PathBuf,
    },
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
        Command::Render {
            scene,
            output,
            width,
            height,
            preview,
        } => render(&scene, output, width, height, preview),
        Command::Info { scene } => info(&scene),
    }
}

fn load(path: &Path) -> anyhow::Result<Scene> {
    let scene = Scene::load(path)?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(scene)
}

fn render(
    path: &Path,
    output: Option<PathBuf>,
    width: Option<u32>,
    height: Option<u32>,
    preview: Preview,
) -> anyhow::Result<()> {
    let scene = load(path)?;
    let width = checked_side("--width", width.unwrap_or(scene.image.width))?;
    let height = checked_side("--height", height.unwrap_or(scene.image.height))?;
    let output = output.unwrap_or_else(|| {
        PathBuf::from(path.file_stem().unwrap_or_default()).with_extension("png")
    });
    let accel =
        EmbreeIntersector::build(&scene.triangle_views()).context("building the Embree scene")?;

    let bar = if std::io::stderr().is_terminal() {
        ProgressBar::new(height as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} rendering [{bar:40}] {pos}/{len} rows, {eta} left")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let (image, stats) = render_preview(&scene, &accel, preview, width, height, &|| bar.inc(1));
    bar.finish_and_clear();
    image.save_png(&output)?;
    let seconds = stats.elapsed.as_secs_f64();
    eprintln!(
        "{}: {width}x{height} {preview:?} preview in {seconds:.2} s, {} rays ({:.1} Mrays/s) with {}",
        output.display(),
        stats.rays,
        stats.rays as f64 / seconds.max(1e-9) / 1e6,
        accel.name()
    );
    Ok(())
}

fn checked_side(flag: &str, value: u32) -> anyhow::Result<u32> {
    const MAX: u32 = 16384;
    anyhow::ensure!(
        (1..=MAX).contains(&value),
        "{flag} must be from 1 to {MAX}, found {value}"
    );
    Ok(value)
}

fn info(path: &Path) -> anyhow::Result<()> {
    let scene = load(path)?;
    let b = scene.bounds();
    println!("scene     {}", path.display());
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
    let accel =
        EmbreeIntersector::build(&scene.triangle_views()).context("building the Embree scene")?;
    println!("backend   {}", accel.name());
    Ok(())
}
