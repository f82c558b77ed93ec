//! `caustix info`, `caustix export`, `caustix compare` and `caustix denoise`.

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::{build_accel, load};
use caustix::scene::Scene;

pub fn export(scene_path: &Path, output: &Path, teapot_subdivisions: Option<u32>) -> anyhow::Result<()> {
    let extension = output.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    anyhow::ensure!(
        matches!(extension.as_deref(), Some("ply" | "obj" | "stl")),
        "--output {}: write .ply (binary, fast to load), .obj or .stl (binary; its triangles shade flat)",
        output.display()
    );
    if let Some(level) = teapot_subdivisions {
        crate::in_range("--teapot-subdivisions", level, 1, caustix::config::limits::MAX_TEAPOT_LEVEL)?;
    }
    caustix::files::check_writable(output)?;
    let start = std::time::Instant::now();
    let scene = Scene::load_with(scene_path, &caustix::scene::Overrides { teapot_subdivisions })?;
    let (positions, normals, indices) = scene.merged_triangles();
    caustix::files::write_with(output, |out| match extension.as_deref() {
        Some("ply") => caustix::scene::ply::write_binary(out, &positions, &normals, &indices),
        Some("stl") => caustix::scene::stl::write_binary(out, &positions, &indices),
        _ => caustix::scene::obj::write(out, &positions, &normals, &indices),
    })?;
    eprintln!(
        "wrote {}: {} triangles, {} vertices in {:.1} s",
        output.display(),
        indices.len(),
        positions.len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

pub fn compare(image: &Path, reference: &Path, error_image: Option<&Path>, scale: f32) -> anyhow::Result<()> {
    use caustix::Image;
    let (a, b) = (Image::load(image)?, Image::load(reference)?);
    for (img, path) in [(&a, image), (&b, reference)] {
        if let Some(((x, y), count)) = img.non_finite() {
            anyhow::bail!(
                "{}: {count} pixels are NaN or infinite, the first at ({x}, {y}); no error measure means anything then",
                path.display()
            );
        }
    }
    if Image::holds_radiance(image) != Image::holds_radiance(reference) {
        eprintln!(
            "note: one image is linear radiance (.exr, .hdr) and the other display values (PNG: exposed, \
             clamped to 1, decoded from sRGB): they differ wherever the PNG was clipped, whatever the render"
        );
    }
    let d = a.difference(&b).ok_or_else(|| {
        anyhow::anyhow!("the images differ in size: {}x{} and {}x{}", a.width, a.height, b.width, b.height)
    })?;
    outln!("rmse     {:.6}", d.rmse);
    outln!("rel_mse  {:.6}", d.rel_mse);
    outln!("mae      {:.6}", d.mae);
    outln!("mean     {:.6} (reference {:.6}, ratio {:.4})", d.means.0, d.means.1, d.means.0 / d.means.1);
    let fireflies = a.fireflies_beyond(&b).expect("sizes checked");
    outln!("fireflies {fireflies} (pixels over 10x their 3x3 median where the reference's are not)");
    // Bit for bit (EXR files of the same pixels need not be the same bytes).
    let differ = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| p.to_array().into_iter().zip(q.to_array()))
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    match differ {
        0 => outln!("identical yes: every value bit for bit"),
        n => outln!("identical no: {n} of {} values differ", a.pixels.len() * 3),
    }
    if let Some(out) = error_image {
        anyhow::ensure!(scale.is_finite() && scale > 0.0, "--error-scale must be greater than 0");
        a.error_image(&b, scale).save(out, 0.0)?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// The components `caustix denoise` takes beside the image.
#[derive(clap::Args)]
pub struct DenoiseGuides {
    /// The emission component (lights seen directly), kept out of the filter
    /// and added back, as `render --denoise` does: e.g. out-emission.exr.
    #[arg(long)]
    emission: Option<PathBuf>,
    /// The albedo of the first diffuse surface (.exr or .hdr), e.g. out-albedo.exr.
    #[arg(long)]
    albedo: Option<PathBuf>,
    /// The shading normal of the first diffuse surface (.exr or .hdr); needs --albedo.
    #[arg(long)]
    normal: Option<PathBuf>,
}

/// `caustix denoise`: filters a linear image with Open Image Denoise,
/// guided by albedo and normal images (e.g. a render's `--aov albedo,normal`
/// at `.exr`), and writes the result.
pub fn denoise(image: &Path, guides: &DenoiseGuides, output: &Path, exposure: f32) -> anyhow::Result<()> {
    use caustix::Image;
    let DenoiseGuides { emission, albedo, normal } = guides;
    caustix::Image::check_output(output)?;
    anyhow::ensure!(exposure.is_finite(), "--exposure must be a finite number of stops");
    anyhow::ensure!(
        normal.is_none() || albedo.is_some(),
        "--normal needs --albedo too (Open Image Denoise takes normals only with an albedo)"
    );
    let inputs = [Some(image), emission.as_deref(), albedo.as_deref(), normal.as_deref()];
    for path in inputs.iter().flatten() {
        anyhow::ensure!(
            Image::holds_radiance(path),
            "{}: give the linear image (.exr or .hdr); a PNG is exposed, clamped and sRGB-encoded, \
             and its normals lose their sign",
            path.display()
        );
    }
    anyhow::ensure!(cfg!(feature = "denoise"), "caustix denoise {}", caustix::film::denoise::NOT_BUILT);
    let load = |path: Option<&Path>| path.map(Image::load).transpose();
    let [beauty, emission, albedo, normal] = inputs.map(load);
    let beauty = beauty?.expect("the image is always given");
    let (emission, albedo, normal) = (emission?, albedo?, normal?);
    let start = std::time::Instant::now();
    let denoised =
        caustix::film::denoise::denoise(&beauty, emission.as_ref(), albedo.as_ref(), normal.as_ref())
            .with_context(|| format!("denoising {}", image.display()))?;
    denoised.save(output, exposure)?;
    eprintln!("wrote {} (denoised in {:.2} s)", output.display(), start.elapsed().as_secs_f64());
    Ok(())
}

pub fn info(path: &Path) -> anyhow::Result<()> {
    let start = std::time::Instant::now();
    let scene = match load(path) {
        Ok(scene) => scene,
        Err(_) if caustix::scene::is_mesh_file(path) => return mesh_info(path),
        Err(e) => return Err(e),
    };
    let load_seconds = start.elapsed().as_secs_f64();
    let b = scene.bounds();
    outln!("scene     {} (loaded in {load_seconds:.2} s)", path.display());
    outln!(
        "image     {}x{}, {} samples per pixel",
        scene.config.width,
        scene.config.height,
        scene.config.samples
    );
    outln!(
        "camera    eye {}, looking along {}, fov {:.1} deg",
        scene.origin.as_vec3(),
        -scene.camera.w,
        2.0 * scene.camera.tan_half_fov.atan().to_degrees()
    );
    outln!(
        "geometry  {} triangles, {} vertices in {} meshes",
        scene.triangle_count(),
        scene.vertex_count(),
        scene.meshes.len()
    );
    outln!("bounds    {} to {}", scene.in_file(b.min), scene.in_file(b.max));
    let bytes: usize = scene.meshes.iter().map(|m| m.bytes()).sum();
    outln!(
        "memory    {:.1} MiB of positions, normals and indices ({:.1} bytes per triangle)",
        bytes as f64 / (1024.0 * 1024.0),
        bytes as f64 / scene.triangle_count().max(1) as f64
    );
    for m in &scene.meshes {
        outln!(
            "  mesh    {:<24} {:>9} triangles  material {}",
            m.name,
            m.indices.len(),
            scene.materials[m.material].name
        );
    }
    outln!("materials {}", scene.materials.len());
    for m in &scene.materials {
        outln!(
            "  {:<22} diffuse {} specular {} (exp {}) mirror {} transmit {} ior {}",
            m.name,
            m.diffuse,
            m.specular,
            m.phong_exponent,
            m.mirror,
            m.transmittance,
            m.ior
        );
    }
    outln!("lights    {}", scene.lights.len());
    for l in scene.lights.iter().take(LISTED_LIGHTS) {
        outln!("  {}", l.describe(scene.origin));
    }
    if scene.lights.len() > LISTED_LIGHTS {
        outln!("  and {} more", scene.lights.len() - LISTED_LIGHTS);
    }
    let start = std::time::Instant::now();
    let accel = build_accel(&scene)?;
    outln!("backend   {} (built in {:.2} s)", accel.name(), start.elapsed().as_secs_f64());
    let query = caustix::query::SceneQuery::new(&scene, accel.as_ref());
    let share = caustix::integrator::unreached::share_to_mirrors_from_points(&query);
    if share > 0.0 {
        outln!(
            "caustics  {:.1}% of the light goes from point or spot lights straight to mirrors or glass (path and \
             whitted leave it out, bdpt where it is seen in them)",
            100.0 * share
        );
    }
    let (width, height) = (scene.config.width, scene.config.height);
    let view = caustix::integrator::unreached::share_of_view_in_mirrors(&query, width, height);
    if view > 0.0 {
        outln!(
            "mirrors   {:.1}% of the view is mirrors or glass (light tracing leaves out what is seen in them)",
            100.0 * view
        );
    }
    Ok(())
}

/// The lights `caustix info` describes one by one, at most: a mesh file's
/// emitting faces may make a million.
const LISTED_LIGHTS: usize = 8;

/// `caustix info` of a mesh file: what a `[[mesh]]` of it would hold, and a
/// scene that frames it, to paste into a scene file (a new mesh's size and
/// place are what a camera needs and a user seldom knows).
fn mesh_info(path: &Path) -> anyhow::Result<()> {
    let start = std::time::Instant::now();
    // The MTL files' materials, and a fallback for faces they leave without
    // one (a PLY file's, always); only which meshes took it is read here.
    let choice = caustix::scene::obj::MeshMaterials::FromFile { fallback: Some(0) };
    let contents = caustix::scene::load_mesh_file(path, choice)?;
    // (Each names its mesh file already.)
    for w in &contents.warnings {
        eprintln!("warning: {w}");
    }
    let meshes = &contents.meshes;
    let triangles: usize = meshes.iter().map(|m| m.indices.len()).sum();
    let vertices: usize = meshes.iter().map(|m| m.positions.len()).sum();
    // The lights where a [[mesh]] without a transform puts them, in the
    // file's coordinates: as a scene's lights, to frame and describe.
    let lights: Vec<(&str, caustix::light::Light)> = contents
        .lights
        .iter()
        .filter_map(|l| Some((l.mesh.as_str(), l.placed(&glam::DMat4::IDENTITY, glam::DVec3::ZERO)?)))
        .collect();
    let b = meshes.iter().fold(caustix::bounds::Bounds::EMPTY, |b, m| b.union(m.bounds()));
    let b = lights.iter().fold(b, |b, (_, light)| b.union(light.bounds()));
    // Every line a TOML comment but the scene's: `caustix info bunny.obj >
    // bunny.toml` is a scene to render as it is.
    outln!("# mesh      {} (loaded in {:.2} s)", path.display(), start.elapsed().as_secs_f64());
    outln!("# geometry  {triangles} triangles, {vertices} vertices in {} meshes", meshes.len());
    // (A lamp's file may hold nothing but the faces that became its lights.)
    anyhow::ensure!(
        triangles > 0 || !lights.is_empty(),
        "{}: no triangles or lights to show",
        path.display()
    );
    outln!("# bounds    {} to {} (size {})", b.min, b.max, b.max - b.min);
    for m in meshes {
        outln!("#   mesh    {:<24} {:>9} triangles", m.name, m.indices.len());
    }
    if !lights.is_empty() {
        let n = lights.len();
        let triangles =
            lights.iter().filter(|(_, l)| l.shape() == Some(caustix::light::Shape::Triangle)).count();
        let of_them = match triangles {
            0 => String::new(),
            t if t == n => ", all triangles".to_string(),
            t => format!(", {t} of them triangles"),
        };
        outln!(
            "# lights    {n} area light{}, from faces that emit (Ke){of_them}",
            if n == 1 { "" } else { "s" }
        );
        for (mesh, light) in lights.iter().take(LISTED_LIGHTS) {
            outln!("#   light   {mesh:<24} {}", light.describe(glam::DVec3::ZERO));
        }
        if n > LISTED_LIGHTS {
            outln!("#   and {} more", n - LISTED_LIGHTS);
        }
    }
    // Which key the [[mesh]] needs, if any.
    let needs = if contents.defaulted.is_empty() {
        None
    } else if contents.materials.is_empty() {
        outln!("# materials none: its [[mesh]] needs a `material = \"...\"`");
        Some("material")
    } else {
        Some("default_material")
    };
    if !contents.materials.is_empty() {
        outln!("# materials {} (from its MTL files)", contents.materials.len());
        for m in &contents.materials {
            outln!("#   {}", m.name);
        }
    }
    if needs == Some("default_material") {
        let meshes = contents.defaulted.join(", ");
        outln!("#   none for {meshes}: its [[mesh]] needs a `default_material = \"...\"`");
    }
    let (file, saved) = match stdout_file().and_then(|out| path_from_folder_of(&out, path)) {
        Some(file) => (file, " (its mesh named from this file's folder): render it"),
        None => (
            path.to_path_buf(),
            ", to save as a .toml file in the current folder (its mesh is named from there) and render",
        ),
    };
    let file = file.to_string_lossy();
    outln!("#\n# A scene that frames it{saved}.\n");
    out!("{}", framing_scene(b, &file, needs, lights.is_empty()));
    Ok(())
}

/// The regular file standard output writes to, where the system says
/// (Linux's `/proc`): not a terminal or a pipe.
fn stdout_file() -> Option<PathBuf> {
    let out = std::fs::read_link("/proc/self/fd/1").ok()?;
    out.metadata().ok()?.is_file().then_some(out)
}

/// `target`'s path from the folder of the file `from` (a scene file names
/// its meshes from its own folder): through `..` where they part, or from
/// the root where they share nothing else; `None` where either cannot be
/// resolved.
fn path_from_folder_of(from: &Path, target: &Path) -> Option<PathBuf> {
    let folder = from.canonicalize().ok()?.parent()?.to_path_buf();
    let target = target.canonicalize().ok()?;
    let shared = folder.components().zip(target.components()).take_while(|(a, b)| a == b).count();
    if shared <= 1 {
        return Some(target);
    }
    let up = folder.components().skip(shared).map(|_| std::path::Component::ParentDir);
    Some(up.chain(target.components().skip(shared)).collect())
}

/// Scene text that shows a mesh whose box is `b`: the camera (40 degrees)
/// back from the box's centre along a view from the front, above and to the
/// right, far enough that the box's sphere fills the height; a point light
/// above and in front (if `point_light`: a mesh with lights of its own has
/// none); a grey floor under the box, four times its size; the grey as the
/// mesh's `needs` key (`material`, `default_material`) if any.
fn framing_scene(b: caustix::bounds::Bounds, file: &str, needs: Option<&str>, point_light: bool) -> String {
    use glam::Vec3;
    let centre = 0.5 * (b.min + b.max);
    let radius = (0.5 * (b.max - b.min).length()).max(f32::MIN_POSITIVE.sqrt());
    let view = Vec3::new(0.35, 0.45, 1.0).normalize();
    let eye = centre + view * (1.1 * radius / 20f32.to_radians().tan());
    let light = centre + radius * Vec3::new(0.8, 2.5, 1.5);
    // About 1.5 W/m^2 a channel at the box's centre (grey 0.7 then shows at
    // about a third of white: the default exposure leaves it unclipped).
    let power = 1.5 * 4.0 * std::f32::consts::PI * (light - centre).length_squared();
    let point = |p: Vec3| format!("[{}, {}, {}]", p.x, p.y, p.z);
    let material = needs.map_or_else(String::new, |key| format!("{key} = \"grey\"\n"));
    let light = if point_light {
        format!("[[point_light]]\nposition = {}\npower = {power}\n\n", point(light))
    } else {
        "# (lit by the mesh's own lights)\n\n".to_string()
    };
    format!(
        "[camera]\neye = {}\nlook_at = {}\nfov = 40.0\n\n\
         [materials.grey]\ndiffuse = 0.7\n\n\
         {light}\
         [[quad]]\ncenter = {}\nu = [{}, 0.0, 0.0]\nv = [0.0, 0.0, {}]\nmaterial = \"grey\"\n\n\
         [[mesh]]\nfile = {}\n{material}",
        point(eye),
        point(centre),
        point(Vec3::new(centre.x, b.min.y, centre.z)),
        8.0 * radius,
        -8.0 * radius,
        // (Quoted as TOML would: a path may hold quotes or backslashes.)
        toml::Value::String(file.to_string()),
    )
}
