//! `caustix render`.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};

use crate::{load, named, worker_threads};
use caustix::accel::{Backend, BvhLayout};
use caustix::config::{IntegratorKind, RenderConfig};
use caustix::film::Aov;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// The scene file (TOML; see the README for the format).
    scene: PathBuf,
    /// Output image: .png (tone-mapped sRGB), .exr or .hdr (linear radiance).
    /// Default: the scene's name with .png, in the current folder.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Integrator (overrides the scene file's [render] integrator).
    #[arg(long, value_parser = named::<IntegratorKind>(IntegratorKind::ALL.iter().map(|k| k.name())))]
    integrator: Option<IntegratorKind>,
    /// Ray intersector (overrides the scene file's [render] backend; default embree).
    #[arg(long, value_parser = named::<Backend>(Backend::NAMES.map(|(n, _)| n)))]
    backend: Option<Backend>,
    /// Embree's BVH layout: fast, compact (about a third of the memory while
    /// building, slower rays) or auto (compact only when fast would not fit
    /// in available memory; the default). Overrides the scene's [render] bvh.
    #[arg(long, value_parser = named::<BvhLayout>(BvhLayout::NAMES.map(|(n, _)| n)))]
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
    /// (comma-separated). Light: emission (lights seen, also through mirrors
    /// and glass), direct, caustic, indirect; they sum to final (with
    /// --denoise, final is the image before denoising). Geometry of the first
    /// diffuse or glossy surface: albedo, normal; depth of the first hit.
    #[arg(long, value_delimiter = ',', value_parser = named::<Aov>(Aov::ALL.map(|(n, _)| n)))]
    aov: Vec<Aov>,
    /// Denoise the image with Intel Open Image Denoise, guided by the albedo
    /// and normal components (needs caustix built with `--features denoise`;
    /// overrides [render] denoise).
    #[arg(long)]
    denoise: bool,
    /// Worker threads (default: all cores). The image is the same for any count.
    #[arg(long)]
    threads: Option<u32>,
    /// Seed of every random stream: another seed, an independent image (default 0).
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// The scene file's config with the command line's overrides, checked.
fn config(args: &RenderArgs, scene: &caustix::Scene) -> anyhow::Result<RenderConfig> {
    let mut c = scene.config.clone();
    let set = |slot: &mut u32, value: Option<u32>| *slot = value.unwrap_or(*slot);
    c.integrator = args.integrator.unwrap_or(c.integrator);
    c.backend = args.backend.unwrap_or(c.backend);
    c.bvh = args.bvh.unwrap_or(c.bvh);
    c.seed = args.seed;
    c.denoise |= args.denoise;
    set(&mut c.width, args.width);
    set(&mut c.height, args.height);
    set(&mut c.samples, args.spp);
    set(&mut c.max_depth, args.max_depth);
    set(&mut c.light_samples, args.light_samples);
    let p = &mut c.photons;
    set(&mut p.global_photons, args.photons);
    set(&mut p.caustic_photons, args.caustic_photons);
    set(&mut p.global_k, args.global_k);
    set(&mut p.caustic_k, args.caustic_k);
    set(&mut p.gather_rays, args.gather_rays);
    set(&mut p.sppm.passes, args.passes);
    set(&mut p.sppm.photons_per_pass, args.pass_photons);
    p.global_radius = args.global_radius.or(p.global_radius);
    p.caustic_radius = args.caustic_radius.or(p.caustic_radius);
    p.sppm.initial_radius = args.sppm_radius.or(p.sppm.initial_radius);
    caustix::integrator::check(scene, &c).map_err(in_flags)?;
    Ok(c)
}

/// `f`'s result and its wall-clock seconds.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let start = std::time::Instant::now();
    let value = f();
    (value, start.elapsed().as_secs_f64())
}

/// A library error, with a setting named by the flag that sets it.
fn in_flags(e: caustix::Error) -> anyhow::Error {
    match e {
        caustix::Error::Setting { name, message } => anyhow::anyhow!("{} {message}", flag(name)),
        other => other.into(),
    }
}

/// The command-line flag that sets the [`RenderConfig`] field `name`.
fn flag(name: &str) -> String {
    let flag = match name {
        "samples" => "spp",
        "global_photons" => "photons",
        other => other,
    };
    format!("--{}", flag.replace('_', "-"))
}

pub fn render(args: RenderArgs) -> anyhow::Result<()> {
    // Everything that can be refused is refused before any work.
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(args.scene.file_stem().unwrap_or_default()).with_extension("png"));
    caustix::Image::check_output(&output)?;
    anyhow::ensure!(args.exposure.is_finite(), "--exposure must be a finite number of stops");
    let threads = worker_threads(args.threads)?;
    let scene = load(&args.scene)?;
    let settings = config(&args, &scene)?;

    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("starting worker threads")?;
    // Inside the pool, so that --threads bounds the BVH builds too.
    let accel = pool
        .install(|| {
            caustix::accel::build_with_layout(settings.backend, settings.bvh, &scene.triangle_views())
        })
        .context("building the ray intersector")?;

    let work = caustix::integrator::work_units(&settings);
    let bar = if std::io::stderr().is_terminal() { ProgressBar::new(work) } else { ProgressBar::hidden() };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {percent}% {elapsed} elapsed, {eta} left",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    let rendered = pool
        .install(|| caustix::render(&scene, accel.as_ref(), &settings, &|n| bar.inc(n)))
        .map_err(in_flags)?;
    bar.finish_and_clear();

    // A failed denoise still leaves the render: written as it is, then the error.
    let (beauty, denoise_failure) = match settings.denoise.then(|| timed(|| rendered.film.denoised())) {
        None => (rendered.film.beauty(), None),
        Some((Ok(denoised), seconds)) => {
            eprintln!("denoised with Open Image Denoise in {seconds:.2} s");
            (denoised, None)
        }
        Some((Err(e), _)) => (rendered.film.beauty(), Some(e)),
    };
    beauty.save(&output, args.exposure)?;
    for path in rendered.film.write_aovs(&output, &args.aov, args.exposure)? {
        eprintln!("wrote {}", path.display());
    }
    if let Some(e) = denoise_failure {
        anyhow::bail!("{e}; {} holds the image as rendered, not denoised", output.display());
    }
    let stats = &rendered.stats;
    for note in &stats.notes {
        eprintln!("{note}");
    }
    let seconds = stats.elapsed.as_secs_f64();
    let rays = stats.rays;
    eprintln!(
        "{}: {}x{} {:?}, {} spp in {seconds:.2} s: {} rays + {} shadow rays ({:.2} Mrays/s) on {} threads with {}",
        output.display(),
        settings.width,
        settings.height,
        settings.integrator,
        caustix::integrator::samples_per_pixel(&settings),
        rays.closest,
        rays.shadow,
        (rays.closest + rays.shadow) as f64 / seconds.max(1e-9) / 1e6,
        pool.current_num_threads(),
        accel.name()
    );
    Ok(())
}
