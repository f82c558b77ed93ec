//! `caustix render`.

use std::io::IsTerminal;
use std::path::PathBuf;

use indicatif::{ProgressBar, ProgressStyle};

use crate::{load, named, pool_and_accel, worker_threads};
use caustix::accel::{Backend, BvhLayout};
use caustix::config::{IntegratorKind, Region, RenderConfig};
use caustix::film::Aov;
use caustix::sampling::SamplerKind;
use caustix::Rendered;

/// `caustix render`.
#[derive(clap::Args)]
pub struct RenderArgs {
    #[command(flatten)]
    settings: SettingArgs,
    /// Output image: .png (tone-mapped sRGB), .exr or .hdr (linear radiance).
    /// Default: the scene's name with .png (.exr for a tile), in the current folder.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Render only tile I of N (1 <= I <= N): bands of whole rows, written as
    /// an .exr tile for `caustix merge`. Its pixels are bit-identical to the
    /// same pixels of the whole render.
    #[arg(long, value_parser = parse_tile, conflicts_with = "crop")]
    tile: Option<(u32, u32)>,
    /// Render only a rectangle of pixels, given as x0,y0,x1,y1: columns x0 to
    /// x1 and rows y0 to y1, x1 and y1 excluded, row 0 at the top (e.g.
    /// `--crop 0,0,256,128`). As an .exr it is a tile for `caustix merge`.
    #[arg(long, value_parser = parse_crop)]
    crop: Option<Region>,
    /// Refine for this many seconds instead of a fixed sample count: more
    /// camera samples (and gather rays) in rounds for the path tracer,
    /// Whitted and photon mapping, more passes for SPPM, VCM, BDPT and
    /// light tracing; from 1 s on, photon mapping chooses its gather rays
    /// per sample by a short pilot (overrides [render] time).
    #[arg(long, value_parser = crate::float, allow_negative_numbers = true)]
    time: Option<f32>,
    /// With a time budget: write the output image (not denoised) each time
    /// the render has refined, after each round of samples (SPPM: after
    /// passes 1, 2, 4, ...), so it can be looked at, or kept if the render is
    /// stopped.
    #[arg(long)]
    snapshots: bool,
    /// Photon maps traced beforehand by `caustix photons` (same scene and
    /// settings), used instead of tracing them.
    #[arg(long)]
    photon_map: Option<PathBuf>,
    /// Exposure for PNG output, in stops: each pixel is multiplied by 2^EXPOSURE.
    #[arg(long, value_parser = crate::float, default_value_t = 0.0, allow_negative_numbers = true)]
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
    #[arg(long, allow_negative_numbers = true)]
    threads: Option<u32>,
}

/// The scene and the settings that decide its image (and photon maps):
/// shared by `caustix render` and `caustix photons`.
#[derive(clap::Args)]
pub struct SettingArgs {
    /// The scene file (TOML; see the README for the format).
    scene: PathBuf,
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
    /// Where camera samples and photons get their random numbers:
    /// independent (stratified pixel positions, a stream per photon) or
    /// sobol (Owen-scrambled Sobol points in every dimension of a camera
    /// sample; a light's photons stratified in position and direction
    /// together). Overrides the scene's [render] sampler.
    #[arg(long, value_parser = named::<SamplerKind>(SamplerKind::NAMES.map(|(n, _)| n)))]
    sampler: Option<SamplerKind>,
    /// Image width in pixels (overrides the scene file).
    #[arg(long, allow_negative_numbers = true)]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene file).
    #[arg(long, allow_negative_numbers = true)]
    height: Option<u32>,
    /// Camera samples per pixel (overrides the scene file); for VCM, BDPT
    /// and light tracing, passes (one camera sample per pixel each).
    #[arg(long, allow_negative_numbers = true)]
    spp: Option<u32>,
    /// Longest chain of rays from the camera (overrides the scene file).
    #[arg(long, allow_negative_numbers = true)]
    max_depth: Option<u32>,
    /// Shadow rays per area light at each shading point for whitted (default 4), photon and sppm (default 1; the other integrators ignore it); where more than 8 lights reach a point, or the scene has more than 256, it draws 8 times this many lights among them instead, each in proportion to what it could send there; overrides the scene file.
    #[arg(long, allow_negative_numbers = true)]
    light_samples: Option<u32>,
    /// Photons emitted for the global map (overrides [photons] global; 0 skips it).
    #[arg(long, allow_negative_numbers = true)]
    photons: Option<u32>,
    /// Photons emitted for the caustic map (overrides [photons] caustic; 0 skips it).
    #[arg(long, allow_negative_numbers = true)]
    caustic_photons: Option<u32>,
    /// Nearest photons per global estimate (overrides [photons] global_k).
    #[arg(long, allow_negative_numbers = true)]
    global_k: Option<u32>,
    /// Nearest photons per caustic estimate (overrides [photons] caustic_k).
    #[arg(long, allow_negative_numbers = true)]
    caustic_k: Option<u32>,
    /// Largest search radius of a global estimate (overrides [photons] global_radius).
    #[arg(long, value_parser = crate::float, allow_negative_numbers = true)]
    global_radius: Option<f32>,
    /// Largest search radius of a caustic estimate (overrides [photons] caustic_radius).
    #[arg(long, value_parser = crate::float, allow_negative_numbers = true)]
    caustic_radius: Option<f32>,
    /// Final-gathering rays per camera sample; 0 shows the global map
    /// directly; with a time budget of 1 s or more, a pilot chooses the
    /// count unless it is 0 (overrides [photons] gather_rays).
    #[arg(long, allow_negative_numbers = true)]
    gather_rays: Option<u32>,
    /// Whether gather rays favour the directions the global map's photons
    /// came from (true, the default) or follow the cosine alone (overrides
    /// [photons] guided_gathering).
    #[arg(long, value_name = "BOOL")]
    guided_gathering: Option<bool>,
    /// Passes of progressive photon mapping (overrides [photons] passes).
    #[arg(long, allow_negative_numbers = true)]
    passes: Option<u32>,
    /// Photons per pass of progressive photon mapping (overrides [photons] pass_photons).
    #[arg(long, allow_negative_numbers = true)]
    pass_photons: Option<u32>,
    /// Starting radius of progressive photon mapping (default: each pixel's
    /// own, holding 32 photons of a first batch), and of VCM's merging
    /// (overrides [photons] sppm_radius).
    #[arg(long, value_parser = crate::float, allow_negative_numbers = true)]
    sppm_radius: Option<f32>,
    /// Seed of every random stream: another seed, an independent image (default 0).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0)]
    seed: u64,
}

/// `I/N` of `--tile`.
fn parse_tile(text: &str) -> Result<(u32, u32), String> {
    let wrong = || format!("`{text}`: give the tile as I/N, with 1 <= I <= N, e.g. 3/8");
    let (i, n) = text.split_once('/').ok_or_else(wrong)?;
    let (i, n): (u32, u32) = (i.trim().parse().map_err(|_| wrong())?, n.trim().parse().map_err(|_| wrong())?);
    if i == 0 || i > n {
        return Err(wrong());
    }
    Ok((i, n))
}

/// `x0,y0,x1,y1` of `--crop`.
fn parse_crop(text: &str) -> Result<Region, String> {
    let wrong = || format!("`{text}`: give the region as x0,y0,x1,y1 (x1 > x0, y1 > y0), e.g. 0,0,256,128");
    let v: Vec<u32> =
        text.split(',').map(|p| p.trim().parse().map_err(|_| wrong())).collect::<Result<_, _>>()?;
    let [x0, y0, x1, y1] = v[..] else { return Err(wrong()) };
    if x1 <= x0 || y1 <= y0 {
        return Err(wrong());
    }
    Ok(Region { x0, y0, x1, y1 })
}

impl SettingArgs {
    /// The scene file.
    pub fn scene(&self) -> &std::path::Path {
        &self.scene
    }
}

/// The scene file's config with the command line's overrides; the caller
/// checks it (`caustix::integrator::check`) once its own settings are in.
pub fn config(args: &SettingArgs, scene: &caustix::Scene) -> RenderConfig {
    let mut c = scene.config.clone();
    let set = |slot: &mut u32, value: Option<u32>| *slot = value.unwrap_or(*slot);
    c.integrator = args.integrator.unwrap_or(c.integrator);
    c.backend = args.backend.unwrap_or(c.backend);
    c.bvh = args.bvh.unwrap_or(c.bvh);
    c.sampler = args.sampler.unwrap_or(c.sampler);
    c.seed = args.seed;
    set(&mut c.width, args.width);
    set(&mut c.height, args.height);
    set(&mut c.samples, args.spp);
    set(&mut c.max_depth, args.max_depth);
    c.light_samples = args.light_samples.or(c.light_samples);
    let p = &mut c.photons;
    set(&mut p.global_photons, args.photons);
    set(&mut p.caustic_photons, args.caustic_photons);
    set(&mut p.global_k, args.global_k);
    set(&mut p.caustic_k, args.caustic_k);
    set(&mut p.gather_rays, args.gather_rays);
    p.guided_gathering = args.guided_gathering.unwrap_or(p.guided_gathering);
    set(&mut p.sppm.passes, args.passes);
    set(&mut p.sppm.photons_per_pass, args.pass_photons);
    p.global_radius = args.global_radius.or(p.global_radius);
    p.caustic_radius = args.caustic_radius.or(p.caustic_radius);
    p.sppm.initial_radius = args.sppm_radius.or(p.sppm.initial_radius);
    c
}

/// `f`'s result and its wall-clock seconds.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let start = std::time::Instant::now();
    let value = f();
    (value, start.elapsed().as_secs_f64())
}

/// A library error, with a setting named by the flag that sets it.
pub fn in_flags(e: caustix::Error) -> anyhow::Error {
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
        "region" => "crop",
        other => other,
    };
    format!("--{}", flag.replace('_', "-"))
}

pub fn render(args: RenderArgs) -> anyhow::Result<()> {
    // Everything that can be refused is refused before any work.
    let scene_path = &args.settings.scene;
    let part = args.tile.is_some() || args.crop.is_some();
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = scene_path.file_stem().unwrap_or_default().to_string_lossy();
        match args.tile {
            Some((i, n)) => PathBuf::from(format!("{stem}-tile-{i}-of-{n}.exr")),
            None => PathBuf::from(stem.as_ref()).with_extension("png"),
        }
    });
    caustix::Image::check_output(&output)?;
    let tile_file = part && output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    anyhow::ensure!(
        args.tile.is_none() || tile_file,
        "--tile writes an .exr tile for `caustix merge` (it records where the tile belongs); name the output .exr"
    );
    anyhow::ensure!(
        !(part && args.denoise),
        "--denoise works on the whole image: denoise after `caustix merge`"
    );
    anyhow::ensure!(args.exposure.is_finite(), "--exposure must be a finite number of stops");
    let threads = worker_threads(args.threads)?;
    let scene = load(scene_path)?;
    let mut settings = config(&args.settings, &scene);
    settings.denoise |= args.denoise;
    settings.time = args.time.or(settings.time);
    settings.region = match args.tile {
        Some((i, n)) => {
            anyhow::ensure!(
                n <= settings.height,
                "--tile {i}/{n}: the image has only {} rows; use at most that many tiles",
                settings.height
            );
            Some(Region::tile(i - 1, n, settings.width, settings.height))
        }
        None => args.crop,
    };
    caustix::integrator::check(&scene, &settings).map_err(in_flags)?;
    // The previews draw geometry into the final image; they carry no light
    // and no albedo, so those components would be black files.
    if settings.integrator.is_preview() {
        if let Some(aov) = args.aov.iter().find(|aov| !matches!(aov, Aov::Final | Aov::Normal | Aov::Depth)) {
            anyhow::bail!(
                "--aov {}: the {} integrator draws geometry, not light; its components are final, normal and \
                 depth (render with another integrator for {})",
                aov.name(),
                settings.integrator.name(),
                aov.name()
            );
        }
    }
    anyhow::ensure!(
        !args.snapshots || settings.time.is_some(),
        "--snapshots shows a render to a time budget as it refines: give --time SECONDS (or [render] time)"
    );
    let maps = match &args.photon_map {
        Some(path) if settings.integrator == IntegratorKind::Photon => {
            let diagonal = caustix::integrator::Context::diagonal_of(&scene);
            let (maps, seconds) = timed(|| caustix::photon::file::load(path, &scene, &settings, diagonal));
            eprintln!("photon maps loaded from {} in {seconds:.2} s", path.display());
            Some(maps?)
        }
        Some(path) => {
            eprintln!(
                "note: the {} integrator does not read photon maps; {} is not used",
                settings.integrator.name(),
                path.display()
            );
            None
        }
        None => None,
    };

    let (pool, accel) = pool_and_accel(threads, &scene, &settings)?;
    if let Some(unreached) = caustix::integrator::create(settings.integrator).unreached() {
        let query = caustix::query::SceneQuery::new(&scene, accel.as_ref());
        let size = (settings.width, settings.height);
        if let Some(w) =
            caustix::integrator::unreached::warning(&query, size, settings.integrator.name(), unreached)
        {
            eprintln!("warning: {}: {w}", scene_path.display());
        }
    }

    let work = caustix::integrator::work_units(&settings);
    let bar = if std::io::stderr().is_terminal() { ProgressBar::new(work) } else { ProgressBar::hidden() };
    let style = match settings.time {
        // The work a time budget allows is not known ahead.
        Some(seconds) => ProgressStyle::with_template(&format!(
            "{{spinner}} rendering for {seconds} s: {{elapsed}} elapsed, {{pos}} pixel samples"
        )),
        None => ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {percent}% {elapsed} elapsed, {eta} left",
        ),
    };
    bar.set_style(style.expect("valid template").progress_chars("=> "));
    if settings.time.is_some() {
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
    }
    // Each snapshot overwrites the output; one that fails to write is
    // reported and the render goes on (the final write reports again).
    let sppm = settings.integrator == IntegratorKind::Sppm;
    let snapshot = |film: &caustix::film::Film, samples: u32| {
        let written = if tile_file {
            caustix::film::tile::save(&output, &film.beauty(), &scene, &settings)
        } else {
            film.beauty().save(&output, args.exposure)
        };
        bar.suspend(|| match written {
            Ok(()) => {
                let unit = match (sppm, samples) {
                    (true, 1) => "pass",
                    (true, _) => "passes",
                    (false, _) => "samples per pixel",
                };
                eprintln!("snapshot: {} after {samples} {unit}", output.display())
            }
            Err(e) => eprintln!("snapshot not written: {e}"),
        });
    };
    let rendered = pool
        .install(|| {
            caustix::integrator::render_with_maps(
                &scene,
                accel.as_ref(),
                &settings,
                maps.as_ref(),
                &|n| bar.inc(n),
                args.snapshots.then_some(&snapshot as &caustix::integrator::Snapshot),
            )
        })
        .map_err(in_flags)?;
    bar.finish_and_clear();
    if tile_file {
        // The components as tiles too, so that `merge` assembles them (for
        // `caustix denoise` after merging, say).
        caustix::film::tile::save(&output, &rendered.film.beauty(), &scene, &settings)?;
        for &aov in &args.aov {
            let path = caustix::film::aov_path(&output, aov.name());
            caustix::film::tile::save(&path, &rendered.film.image(aov), &scene, &settings)?;
            eprintln!("wrote {}", path.display());
        }
        summary(&output, &settings, &rendered, pool.current_num_threads(), accel.name());
        return Ok(());
    }

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
    // A black image from a scene with lights is most often a scene mistake
    // (a light inside a closed mesh, or facing away), not what was meant.
    let lit = !settings.integrator.is_preview();
    if lit
        && settings.region.is_none()
        && !scene.lights.is_empty()
        && beauty.pixels.iter().all(|p| *p == glam::Vec3::ZERO)
    {
        eprintln!(
            "warning: {}: every pixel is black: no light reached what the camera sees (is a light inside a \
             closed mesh, or facing away from the scene? `caustix info` lists the lights)",
            scene_path.display()
        );
    }
    for path in rendered.film.write_aovs(&output, &args.aov, args.exposure)? {
        eprintln!("wrote {}", path.display());
    }
    if let Some(e) = denoise_failure {
        anyhow::bail!("{e}; {} holds the image as rendered, not denoised", output.display());
    }
    summary(&output, &settings, &rendered, pool.current_num_threads(), accel.name());
    Ok(())
}

/// The render's notes and its summary line.
fn summary(
    output: &std::path::Path,
    settings: &RenderConfig,
    rendered: &Rendered,
    threads: usize,
    accel: String,
) {
    let stats = &rendered.stats;
    for note in &stats.notes {
        eprintln!("{note}");
    }
    let seconds = stats.elapsed.as_secs_f64();
    // Every pixel takes a sample (SPPM a pass), after the photon maps the
    // scene asks for, whatever the budget: say so where that, not the
    // budget, set the time.
    if let Some(budget) = settings.time.filter(|&b| seconds > 1.25 * f64::from(b) + 0.1) {
        eprintln!(
            "note: the render took {seconds:.2} s, over its budget of {budget} s: every pixel takes at \
             least one sample (SPPM one pass), after the photon maps the scene's settings ask for, and \
             here that took longer; give a longer budget, a smaller image or fewer photons to keep to it"
        );
    }
    let rays = stats.rays;
    let region = settings.region.map_or(String::new(), |r| format!(" (pixels {r})"));
    eprintln!(
        "{}: {}x{}{region} {:?}, {} spp in {seconds:.2} s: {} rays + {} shadow rays ({:.2} Mrays/s) on {threads} threads with {accel}",
        output.display(),
        settings.width,
        settings.height,
        settings.integrator,
        rendered.stats.samples_per_pixel,
        rays.closest,
        rays.shadow,
        (rays.closest + rays.shadow) as f64 / seconds.max(1e-9) / 1e6,
    );
}
