//! Turning a parsed scene file into a [`Scene`]: materials, lights, shapes
//! and mesh files, every place re-centred at the camera in `f64`, and every
//! user mistake reported with its file, line and column.

use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{DMat4, DQuat, DVec3, EulerRot, Vec3};
use toml::Spanned;

use super::mesh::{self, FileNormals};
use super::obj::MeshMaterials;
use super::values::Position;
use super::winding;
use super::{file, obj, ply, shapes, stl, teapot, Camera, Mesh, Overrides, Scene};
use crate::config::limits::{MAX_DISTANCE, MIN_EXTENT};
use crate::config::{PhotonConfig, RenderConfig, SppmConfig};
use crate::error::{Error, Location, Result};
use crate::light::Light;
use crate::light_tree::Lights;
use crate::material::Material;

/// Finds a material's index by its name in the file (an error names the known ones).
type MaterialLookup<'a> = dyn Fn(&Spanned<String>) -> Result<usize> + 'a;

/// Turns a parsed file into a [`Scene`], keeping the text for error locations.
pub(super) struct Builder<'a> {
    pub(super) text: &'a str,
    pub(super) path: &'a Path,
    pub(super) overrides: &'a Overrides,
    /// Where the camera is, in the file's coordinates: the scene's origin.
    pub(super) origin: DVec3,
    pub(super) warnings: Vec<String>,
}

impl Builder<'_> {
    fn error_at(&self, span: Range<usize>, message: impl Into<String>) -> Error {
        Error::input_at(self.path, Location::from_offset(self.text, span.start), message)
    }

    pub(super) fn build(mut self, f: file::SceneFile) -> Result<Scene> {
        let cam = &f.camera;
        let camera = Camera::new(self.place(cam.eye), self.place(cam.look_at), cam.up.0, cam.fov.0)
            .map_err(|msg| Error::input(self.path, format!("[camera]: {msg}")))?;
        let (mut materials, material_ids) = self.materials(&f)?;
        let mut lights = self.lights(&f)?;
        let lookup = |name: &Spanned<String>| -> Result<usize> {
            material_ids.get(name.get_ref()).copied().ok_or_else(|| {
                let known: Vec<&str> = f.materials.keys().map(String::as_str).collect();
                let hint = if known.is_empty() {
                    "the file defines no materials; add a [materials.NAME] table".to_string()
                } else {
                    format!("defined materials: {}", known.join(", "))
                };
                self.error_at(name.span(), format!("unknown material `{}`; {hint}", name.get_ref()))
            })
        };
        let mut meshes = self.shapes(&f, &lookup)?;
        let mesh_warnings = self.mesh_files(&f, &lookup, &mut meshes, &mut materials, &mut lights)?;
        self.warnings.extend(mesh_warnings);

        let triangles: usize = meshes.iter().map(|m| m.indices.len()).sum();
        if triangles == 0 {
            // What the mesh files said: one may be why there is nothing.
            let said = self.warnings.iter().map(|w| format!("; {w}")).collect::<String>();
            // A lamp's mesh file may be all faces that emit, now lights.
            let only_lights = match lights.iter().filter(|l| !l.is_delta()).count() {
                0 => String::new(),
                n => format!(" (only {n} area lights, which light nothing without a surface)"),
            };
            return Err(Error::input(
                self.path,
                format!(
                    "the scene has no geometry{only_lights}: add a [[sphere]], [[quad]], [[box]], [[ring]], \
                     [[teapot]] or [[mesh]]{said}"
                ),
            ));
        }
        // One pass over the vertices: each mesh's farthest coordinate from the
        // camera, infinite if a vertex is not finite.
        let extents: Vec<f32> = meshes
            .iter()
            .map(|m| {
                m.positions.iter().fold(0.0f32, |e, p| {
                    if p.is_finite() {
                        e.max(p.abs().max_element())
                    } else {
                        f32::INFINITY
                    }
                })
            })
            .collect();
        if let Some((m, _)) = meshes.iter().zip(&extents).find(|(_, e)| e.is_infinite()) {
            return Err(Error::input(
                self.path,
                format!("{}: its transform makes vertices non-finite", m.name),
            ));
        }
        let extent = extents.iter().copied().fold(0.0f32, f32::max);
        if extent < MIN_EXTENT {
            return Err(Error::input(
                self.path,
                format!(
                    "the whole scene lies within {extent:e} of the camera, below {MIN_EXTENT:e}: too small for \
                     32-bit floats to trace; scale it up (and its lights' power by the square)"
                ),
            ));
        }
        if let Some((m, _)) = meshes.iter().zip(&extents).find(|(_, &e)| e > MAX_DISTANCE) {
            return Err(Error::input(
                self.path,
                format!(
                    "{} reaches more than {MAX_DISTANCE:e} from the camera: beyond what 32-bit floats can \
                     trace (triangle tests multiply three coordinates); scale the scene down",
                    m.name
                ),
            ));
        }
        if lights.is_empty() {
            self.warnings.push("the scene has no lights; lit renders will be black".into());
        }
        let config = self.config(&f)?;
        Ok(Scene {
            path: self.path.to_path_buf(),
            origin: self.origin,
            camera,
            config,
            materials,
            lights: Lights::new(lights),
            meshes,
            warnings: self.warnings,
        })
    }

    /// The `[image]`, `[render]` and `[photons]` tables as a [`RenderConfig`].
    fn config(&self, f: &file::SceneFile) -> Result<RenderConfig> {
        let r = &f.render;
        Ok(RenderConfig {
            width: f.image.width,
            height: f.image.height,
            samples: f.image.samples,
            integrator: r.integrator,
            backend: r.backend,
            bvh: r.bvh,
            max_depth: r.max_depth,
            light_samples: r.light_samples,
            ambient: r.ambient.map_or(Vec3::ZERO, |a| a.0),
            denoise: r.denoise,
            sampler: r.sampler,
            time: r.time,
            photons: self.photon_config(&f.photons)?,
            ..RenderConfig::default()
        })
    }

    fn photon_config(&self, p: &file::PhotonSection) -> Result<PhotonConfig> {
        let kc = p.cone_filter.get_ref().0;
        let cone_filter = match kc {
            0.0 => None,
            k if k >= 1.0 => Some(k),
            k => {
                return Err(self.error_at(
                    p.cone_filter.span(),
                    format!("cone_filter must be at least 1 (or 0 for none), found {k}"),
                ))
            }
        };
        if let Some(a) = &p.sppm_alpha {
            let alpha = a.get_ref().0;
            if !(alpha > 0.0 && alpha < 1.0) {
                return Err(self.error_at(
                    a.span(),
                    format!("sppm_alpha must lie between 0 and 1 (exclusive), found {alpha}"),
                ));
            }
        }
        Ok(PhotonConfig {
            global_photons: p.global,
            caustic_photons: p.caustic,
            global_k: p.global_k,
            caustic_k: p.caustic_k,
            global_radius: p.global_radius.map(|r| r.0),
            caustic_radius: p.caustic_radius.map(|r| r.0),
            cone_filter,
            gather_rays: p.gather_rays,
            guided_gathering: p.guided_gathering,
            max_bounces: p.max_bounces,
            sppm: SppmConfig {
                passes: p.passes,
                photons_per_pass: p.pass_photons,
                initial_radius: p.sppm_radius.map(|r| r.0),
                alpha: p.sppm_alpha.as_ref().map(|a| a.get_ref().0),
            },
        })
    }

    /// The materials, and their indices by name.
    fn materials(&self, f: &file::SceneFile) -> Result<(Vec<Material>, HashMap<String, usize>)> {
        let mut materials = Vec::with_capacity(f.materials.len());
        let mut material_ids = HashMap::new();
        for (name, section) in &f.materials {
            let material = self.material(name, section)?;
            material_ids.insert(name.clone(), materials.len());
            materials.push(material);
        }
        Ok((materials, material_ids))
    }

    fn lights(&self, f: &file::SceneFile) -> Result<Vec<Light>> {
        let mut lights = Vec::new();
        for (i, l) in f.point_light.iter().enumerate() {
            let light = Light::Point { position: self.place(l.position), power: l.power.0 };
            lights.push(self.within_reach(&format!("point light #{}", i + 1), light)?);
        }
        for (i, l) in f.area_light.iter().enumerate() {
            if crate::numeric::unit_cross(l.u.get_ref().0, l.v.0).is_none() {
                return Err(self.error_at(l.u.span(), "the area light's edges u and v are zero or parallel"));
            }
            let light = Light::area(self.place(l.center), l.u.get_ref().0, l.v.0, l.power.0);
            lights.push(self.within_reach(&format!("area light #{}", i + 1), light)?);
        }
        for (i, l) in f.spot_light.iter().enumerate() {
            let light = self.spot_light(l)?;
            lights.push(self.within_reach(&format!("spot light #{}", i + 1), light)?);
        }
        Ok(lights)
    }

    /// `light`, if it lies within the distance of the camera that meshes may
    /// reach: rays start on lights (photons, light paths), and ray tests
    /// past it lose all precision (Embree rejects such rays outright).
    fn within_reach(&self, name: &str, light: Light) -> Result<Light> {
        let b = light.bounds();
        let extent = b.min.abs().max(b.max.abs()).max_element();
        if b.min.is_finite() && b.max.is_finite() && extent <= MAX_DISTANCE {
            return Ok(light);
        }
        Err(Error::input(
            self.path,
            format!(
                "{name} reaches {extent:e} from the camera, beyond {MAX_DISTANCE:e}: more than 32-bit floats can \
                 trace; bring it closer"
            ),
        ))
    }

    /// The built-in shapes: spheres, quads, boxes, rings and teapots.
    fn shapes(&self, f: &file::SceneFile, lookup: &MaterialLookup) -> Result<Vec<Mesh>> {
        let mut meshes = Vec::new();
        // Each shape is made around the origin at unit size where it can be,
        // and placed by one f64 matrix: exact at any size and distance.
        let at = |center: Position| DMat4::from_translation(center.0);
        // The unit sphere of each level, made once: a scene of thousands of
        // spheres made each anew, and the making was most of its loading.
        let mut unit_spheres = Reused::new(f.sphere.iter().map(|s| s.subdivisions));
        for (i, s) in f.sphere.iter().enumerate() {
            let level = s.subdivisions;
            let mut m =
                unit_spheres.take(level, || Ok(shapes::sphere("unit sphere", Vec3::ZERO, 1.0, level, 0)))?;
            (m.name, m.material) = (format!("sphere #{}", i + 1), lookup(&s.material)?);
            let size = DMat4::from_scale(DVec3::splat(s.radius.0 as f64));
            m.place(&(transform_matrix(&s.transform) * at(s.center) * size), self.origin);
            meshes.push(m);
        }
        for (i, q) in f.quad.iter().enumerate() {
            if crate::numeric::unit_cross(q.u.get_ref().0, q.v.0).is_none() {
                return Err(self.error_at(q.u.span(), "the quad's edges u and v are zero or parallel"));
            }
            let mut m = shapes::quad(
                &format!("quad #{}", i + 1),
                Vec3::ZERO,
                q.u.get_ref().0,
                q.v.0,
                lookup(&q.material)?,
            );
            m.place(&(transform_matrix(&q.transform) * at(q.center)), self.origin);
            meshes.push(m);
        }
        for (i, b) in f.cuboid.iter().enumerate() {
            let half = 0.5 * b.size.0;
            let mut m = shapes::cuboid(&format!("box #{}", i + 1), -half, half, lookup(&b.material)?);
            m.place(&(transform_matrix(&b.transform) * at(b.center)), self.origin);
            meshes.push(m);
        }
        for (i, r) in f.ring.iter().enumerate() {
            let (inner, outer) = (r.inner_radius.0, r.outer_radius.get_ref().0);
            if inner >= outer {
                return Err(self.error_at(
                    r.outer_radius.span(),
                    format!("outer_radius ({outer}) must be larger than inner_radius ({inner})"),
                ));
            }
            let name = format!("ring #{}", i + 1);
            let mut m =
                shapes::ring(&name, Vec3::ZERO, inner, outer, r.height.0, r.segments, lookup(&r.material)?);
            m.place(&(transform_matrix(&r.transform) * at(r.base)), self.origin);
            meshes.push(m);
        }
        for (i, t) in f.teapot.iter().enumerate() {
            meshes.push(self.teapot(i, t, lookup(&t.material)?)?);
        }
        Ok(meshes)
    }

    fn teapot(&self, i: usize, t: &file::TeapotSection, material: usize) -> Result<Mesh> {
        // The patch file, named in errors: the built-in one by its place in the repository.
        let bpt_path = t.file.as_ref().map_or(PathBuf::from("scenes/data/teapot.bpt"), |f| self.relative(f));
        let patches = match &t.file {
            None => teapot::parse_bpt(teapot::TEAPOT_BPT, &bpt_path)?,
            Some(_) => {
                let text = crate::files::read_text(&bpt_path, crate::files::MAX_TEXT_BYTES)?;
                teapot::parse_bpt(&text, &bpt_path)?
            }
        };
        let level = self.overrides.teapot_subdivisions.unwrap_or(t.subdivisions);
        let max = crate::config::limits::MAX_TEAPOT_LEVEL;
        if !(1..=max).contains(&level) {
            return Err(Error::input(
                self.path,
                format!("teapot subdivisions must be from 1 to {max}, found {level}"),
            ));
        }
        let triangles = 2 * (level as u64).pow(2) * patches.len() as u64;
        let bytes = triangles * crate::memory::MESH_BYTES_PER_TRIANGLE;
        if let Some(available) = crate::memory::available().filter(|&a| bytes > a as u64) {
            return Err(Error::input(
                self.path,
                format!(
                    "teapot #{}: {triangles} triangles at {level} subdivisions need about {:.1} GiB, and {:.1} GiB \
                     of memory are available; ask for fewer subdivisions",
                    i + 1,
                    bytes as f64 / (1u64 << 30) as f64,
                    available as f64 / (1u64 << 30) as f64
                ),
            ));
        }
        let (positions, indices) = teapot::tessellate(&patches, level as usize);
        let mut m = Mesh::new(format!("teapot #{}", i + 1), positions, indices, None, material);
        if m.indices.is_empty() {
            // Mesh::new leaves out triangles of no area; a patch file whose
            // every patch collapses to a line or a point leaves nothing,
            // which would otherwise be reported as a scene without geometry.
            return Err(Error::input(
                &bpt_path,
                format!(
                    "every patch collapses to a line or a point (its control points are collinear or coincide), so teapot #{} \
                     has no triangle with an area; check the file's coordinates",
                    i + 1
                ),
            ));
        }
        // The data is z-up; scenes are y-up: (x, y, z) -> (x, z, -y).
        m.place(
            &(transform_matrix(&t.transform) * DMat4::from_rotation_x(-std::f64::consts::FRAC_PI_2)),
            self.origin,
        );
        Ok(m)
    }

    /// The `[[mesh]]` files (OBJ with their MTL materials, or PLY), added to
    /// `meshes` and `materials`, and the lights their emitting faces make
    /// to `lights`; returns what the files warned about.
    fn mesh_files(
        &self,
        f: &file::SceneFile,
        lookup: &MaterialLookup,
        meshes: &mut Vec<Mesh>,
        materials: &mut Vec<Material>,
        lights: &mut Vec<Light>,
    ) -> Result<Vec<String>> {
        // Each [[mesh]]'s file and the materials its faces take.
        let mut entries = Vec::with_capacity(f.mesh.len());
        for m in &f.mesh {
            let choice = match (&m.material, &m.default_material) {
                (Some(_), Some(fallback)) => {
                    return Err(self.error_at(
                        fallback.span(),
                        "this [[mesh]] has a `material` for every face: `default_material` (for the \
                         faces its file gives none) would never be used; keep one of them",
                    ))
                }
                (Some(all), None) => MeshMaterials::All(lookup(all)?),
                (None, fallback) => {
                    MeshMaterials::FromFile { fallback: fallback.as_ref().map(lookup).transpose()? }
                }
            };
            entries.push((self.relative(m.file.get_ref()), choice));
        }
        // A file that several [[mesh]] place (one model in many places) is
        // read once.
        let mut files = Reused::new(entries.iter());
        let mut obj_warnings = Vec::new();
        // The lights the files' emitting faces make, by name.
        let mut from_meshes = Vec::new();
        for (m, entry) in f.mesh.iter().zip(&entries) {
            let (obj_path, choice) = entry;
            let file_meshes = files.take(entry, || {
                let contents = load_mesh_file(obj_path, *choice, materials).map_err(|e| match e {
                    // (The mesh file's own, not an MTL file's it names.)
                    Error::Io { path, cause }
                        if &path == obj_path && cause.kind() == std::io::ErrorKind::NotFound =>
                    {
                        self.error_at(
                            m.file.span(),
                            format!(
                                "mesh file `{}` not found (paths are relative to the scene file)",
                                obj_path.display()
                            ),
                        )
                    }
                    other => other,
                })?;
                materials.extend(contents.materials);
                obj_warnings.extend(contents.warnings);
                if contents.meshes.iter().all(|mesh| mesh.indices.is_empty()) && contents.lights.is_empty() {
                    obj_warnings.push(format!(
                        "{}: no triangles (no face of three or more corners with an area): this \
                         [[mesh]] adds nothing to the scene",
                        obj_path.display()
                    ));
                }
                Ok((contents.meshes, contents.lights))
            })?;
            let matrix = transform_matrix(&m.transform);
            let (file_meshes, file_lights) = file_meshes;
            for mut mesh in file_meshes {
                mesh.place(&matrix, self.origin);
                meshes.push(mesh);
            }
            let mut flattened = Vec::new();
            for (i, light) in file_lights.iter().enumerate() {
                let name = format!("the light of {} #{}", light.mesh, i + 1);
                match light.placed(&matrix, self.origin) {
                    // As a scene file's light power is bounded (`values::MAX_POWER`).
                    Some(placed) if placed.power().max_element() as f64 > super::values::MAX_POWER => {
                        return Err(Error::input(
                            obj_path,
                            format!(
                                "{name} sends {:e} W (its Ke times pi times its area), beyond 1e30 per channel: \
                                 the light's arithmetic overflows 32-bit floats; lower its material's Ke",
                                placed.power().max_element()
                            ),
                        ))
                    }
                    Some(placed) => from_meshes.push((name.clone(), self.within_reach(&name, placed)?)),
                    None => flattened.push(name),
                }
            }
            if let Some(first) = flattened.first() {
                let more = match flattened.len() - 1 {
                    0 => String::new(),
                    n => format!(" (and {n} more of its lights)"),
                };
                obj_warnings.push(format!("{first}{more}: the [[mesh]]'s transform leaves it no area"));
            }
        }
        obj_warnings.extend(super::mesh_lights::twice_in_one_place(lights, &from_meshes));
        lights.extend(from_meshes.into_iter().map(|(_, light)| light));
        Ok(obj_warnings)
    }

    fn material(&self, name: &str, section: &Spanned<file::MaterialSection>) -> Result<Material> {
        let s = section.get_ref();
        let material = Material {
            name: name.to_string(),
            diffuse: s.diffuse.map_or(Vec3::ZERO, |c| c.0),
            specular: s.specular.map_or(Vec3::ZERO, |c| c.0),
            phong_exponent: s.phong_exponent.map_or(1.0, |p| p.0),
            mirror: s.mirror.map_or(Vec3::ZERO, |c| c.0),
            transmittance: s.transmittance.map_or(Vec3::ZERO, |c| c.0),
            ior: s.ior.map_or(1.5, |n| n.0),
        };
        material
            .check_energy()
            .map_err(|msg| self.error_at(section.span(), format!("material `{name}`: {msg}")))?;
        Ok(material)
    }

    fn spot_light(&self, l: &file::SpotLightSection) -> Result<Light> {
        let direction = l.direction.get_ref().0.try_normalize().ok_or_else(|| {
            self.error_at(l.direction.span(), "the spot light's direction is the zero vector")
        })?;
        let cone = l.cone_angle.get_ref().0;
        if cone > 180.0 {
            return Err(self.error_at(
                l.cone_angle.span(),
                format!("cone_angle is a half-angle of at most 180 degrees, found {cone}"),
            ));
        }
        let falloff = match &l.falloff_start {
            None => 0.8 * cone,
            Some(f) if (0.0..=cone).contains(&f.get_ref().0) => f.get_ref().0,
            Some(f) => {
                return Err(self.error_at(
                    f.span(),
                    format!(
                        "falloff_start must lie between 0 and cone_angle ({cone}), found {}",
                        f.get_ref().0
                    ),
                ))
            }
        };
        Ok(Light::Spot {
            position: self.place(l.position),
            direction,
            cone_angle: cone.to_radians(),
            falloff_start: falloff.to_radians(),
            power: l.power.0,
        })
    }

    /// A place in the file, relative to the camera (see [`Scene::origin`]).
    fn place(&self, p: Position) -> Vec3 {
        (p.0 - self.origin).as_vec3()
    }

    fn relative(&self, file: &str) -> PathBuf {
        self.path.parent().unwrap_or(Path::new(".")).join(file)
    }
}

/// Scale, then rotate about x, y, z (degrees), then translate, in `f64`.
fn transform_matrix(t: &file::TransformSection) -> DMat4 {
    let scale = t.scale.map_or(DVec3::ONE, |s| s.0.as_dvec3());
    let [rx, ry, rz] = t.rotate.map_or(DVec3::ZERO, |r| r.0.as_dvec3()).to_array().map(f64::to_radians);
    let rotation = DQuat::from_euler(EulerRot::ZYX, rz, ry, rx);
    DMat4::from_scale_rotation_translation(scale, rotation, t.translate.map_or(DVec3::ZERO, |v| v.0))
}

/// What several parts of a scene share, made once: each key's value is
/// made at its first use, copied for the uses after it, and handed over
/// whole at the last (so a value used once is never copied, and none is
/// held after its last use).
struct Reused<K, V> {
    /// The uses of each key still to come.
    left: HashMap<K, usize>,
    /// The value of each key in use.
    kept: HashMap<K, V>,
}

impl<K: std::hash::Hash + Eq + Clone, V: Clone> Reused<K, V> {
    /// For the uses `keys`, in the order they will be taken.
    fn new(keys: impl IntoIterator<Item = K>) -> Self {
        let mut left = HashMap::new();
        for key in keys {
            *left.entry(key).or_default() += 1;
        }
        Reused { left, kept: HashMap::new() }
    }

    /// The value of `key` (made by `make` at its first use), for one of
    /// the uses given to [`Reused::new`].
    fn take<E>(
        &mut self,
        key: K,
        make: impl FnOnce() -> std::result::Result<V, E>,
    ) -> std::result::Result<V, E> {
        let value = match self.kept.remove(&key) {
            Some(value) => value,
            None => make()?,
        };
        let left = self.left.get_mut(&key).expect("a use counted in `new`");
        *left -= 1;
        if *left > 0 {
            self.kept.insert(key, value.clone());
        }
        Ok(value)
    }
}

/// Meshes from an OBJ, PLY or STL file (PLY by its extension or its
/// header, STL by its extension, OBJ otherwise). PLY and STL files have no
/// materials, so their `[[mesh]]` must name one.
pub(super) fn load_mesh_file(
    path: &Path,
    choice: MeshMaterials,
    scene_materials: &[Material],
) -> Result<obj::ObjContents> {
    let kind = super::NotAScene::sniffed(path);
    let format = match kind {
        Some(super::NotAScene::Ply) => "PLY",
        Some(super::NotAScene::Stl) => "STL",
        _ => return obj::load(path, choice, scene_materials),
    };
    let (material, defaulted) = match choice {
        MeshMaterials::All(id) => (id, false),
        MeshMaterials::FromFile { fallback: Some(id) } => (id, true),
        MeshMaterials::FromFile { fallback: None } => {
            return Err(Error::input(
                path,
                format!("{format} files carry no materials; give the [[mesh]] a `material = \"...\"`"),
            ))
        }
    };
    let name = path.file_name().map_or_else(|| format.to_lowercase(), |n| n.to_string_lossy().into_owned());
    let mut warnings = Vec::new();
    let (positions, indices, normals) = if kind == Some(super::NotAScene::Stl) {
        let mut stl = stl::load(path)?;
        warnings
            .extend(stl.orient(obj::is_glass(scene_materials, material)).warnings(&name, stl.indices.len()));
        (stl.positions, stl.indices, FileNormals::Given(stl.normals))
    } else {
        let ply = ply::load(path)?;
        if !ply.unread.is_empty() {
            let colours =
                ply.unread.iter().any(|p| matches!(p.as_str(), "red" | "green" | "blue" | "r" | "g" | "b"));
            warnings.push(format!(
                "{name}: vertex properties caustix does not read were left out: {}{}",
                ply.unread.join(", "),
                if colours { " (the [[mesh]]'s material colours the whole mesh)" } else { "" }
            ));
        }
        warnings.extend(ply.concave.map(|w| format!("{name}: {w}")));
        let mut indices = ply.indices;
        let normals = FileNormals::of(ply.normals, &ply.positions);
        let glass = obj::is_glass(scene_materials, material);
        let mut turned = winding::orient(&ply.positions, &mut indices, normals.for_winding(), glass);
        turned.whole_file(&mut indices);
        warnings.extend(turned.warnings(&name, indices.len()));
        (ply.positions, indices, normals)
    };
    let faces = indices.len();
    // (STL's flat normals come with the file; PLY's are the file's own, or
    // smooth with creases.)
    let mesh = normals.mesh(name.clone(), positions, indices, material);
    warnings.extend(mesh::no_area_warning(&name, faces, mesh.indices.len()));
    let defaulted = if defaulted { vec![mesh.name.clone()] } else { Vec::new() };
    Ok(obj::ObjContents {
        meshes: vec![mesh],
        materials: Vec::new(),
        warnings,
        defaulted,
        lights: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each key's value is made once, copied for the uses after the first
    /// but the last (which takes it), and nothing is kept afterwards.
    #[test]
    fn reused_values_are_made_once_and_copied_only_while_needed() {
        use std::cell::Cell;
        thread_local!(static CLONES: Cell<usize> = const { Cell::new(0) });
        #[derive(Debug, PartialEq)]
        struct Counted(u32);
        impl Clone for Counted {
            fn clone(&self) -> Self {
                CLONES.with(|c| c.set(c.get() + 1));
                Counted(self.0)
            }
        }
        let uses = ["a", "b", "a", "a"];
        let mut reused = Reused::new(uses);
        let mut made = 0;
        for key in uses {
            let value = reused
                .take(key, || {
                    made += 1;
                    Ok::<_, ()>(Counted(made))
                })
                .unwrap();
            assert_eq!(value, Counted(if key == "a" { 1 } else { 2 }));
        }
        assert_eq!(made, 2);
        assert_eq!(CLONES.with(Cell::get), 2, "a's first two uses leave a copy; b's only use none");
        assert!(reused.kept.is_empty());
    }

    #[test]
    fn rotation_order_is_x_then_y_then_z() {
        let t = file::TransformSection {
            rotate: Some(crate::scene::values::Point(Vec3::new(90.0, 90.0, 0.0))),
            ..Default::default()
        };
        // X by 90 takes +y to +z; then Y by 90 takes +z to +x.
        let p = transform_matrix(&t).transform_point3(DVec3::Y);
        assert!(p.abs_diff_eq(DVec3::X, 1e-12), "{p}");
    }
}
