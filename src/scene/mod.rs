//! Scenes: the TOML scene file turned into meshes, materials, lights and a
//! camera, with every user mistake reported as an [`Error`] that names the
//! file and line.

mod build;
pub mod camera;
pub mod creases;
mod file;
pub mod mesh;
pub mod mesh_lights;
pub mod obj;
mod obj_read;
pub mod ply;
pub mod polygon;
pub mod shapes;
pub mod stl;
pub mod teapot;
mod values;
pub mod winding;

#[cfg(test)]
pub(crate) mod test_scenes;

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

use crate::accel::embree::TriangleView;
use crate::config::RenderConfig;
use crate::error::{Error, Location, Result};
use crate::light_tree::Lights;
use crate::material::Material;
use build::Builder;
pub use camera::Camera;
pub use mesh::{Bounds, Mesh};

/// The kinds of file a user may name where a scene file belongs: meshes,
/// and what caustix itself writes (images, saved photon maps).
#[derive(Debug, Clone, Copy, PartialEq)]
enum NotAScene {
    Obj,
    Ply,
    Stl,
    Patches,
    /// An image, by the name of its format.
    Image(&'static str),
    PhotonMap,
}

impl NotAScene {
    /// The kind the file's extension names, if any.
    fn named(path: &Path) -> Option<NotAScene> {
        let extension = path.extension()?.to_str()?.to_ascii_lowercase();
        match extension.as_str() {
            "obj" => Some(NotAScene::Obj),
            "ply" => Some(NotAScene::Ply),
            "stl" => Some(NotAScene::Stl),
            "bpt" => Some(NotAScene::Patches),
            "exr" => Some(NotAScene::Image("an OpenEXR")),
            "png" => Some(NotAScene::Image("a PNG")),
            "hdr" => Some(NotAScene::Image("a Radiance HDR")),
            "cxpm" => Some(NotAScene::PhotonMap),
            _ => None,
        }
    }

    /// The kind named, or else the kind its first bytes say (a PLY header,
    /// an image's or a photon map's magic number), whatever its name;
    /// `None` for anything else, or anything but a regular file (opening a
    /// FIFO would wait for a writer for ever).
    fn sniffed(path: &Path) -> Option<NotAScene> {
        use std::io::Read;
        if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
            return None;
        }
        NotAScene::named(path).or_else(|| {
            let mut head = [0u8; 4];
            let file = std::fs::File::open(path).ok()?;
            file.take(4).read_exact(&mut head).ok()?;
            match &head {
                b"ply\n" | b"ply\r" => Some(NotAScene::Ply),
                b"\x76\x2f\x31\x01" => Some(NotAScene::Image("an OpenEXR")),
                b"\x89PNG" => Some(NotAScene::Image("a PNG")),
                b"#?RA" | b"#?RG" => Some(NotAScene::Image("a Radiance HDR")),
                b"CXPM" => Some(NotAScene::PhotonMap),
                _ => None,
            }
        })
    }
}

/// Whether `path` is a mesh file a `[[mesh]]` reads (OBJ, PLY or STL), by
/// its name or a PLY header.
pub fn is_mesh_file(path: &Path) -> bool {
    matches!(NotAScene::sniffed(path), Some(NotAScene::Obj | NotAScene::Ply | NotAScene::Stl))
}

/// A mesh file read as a `[[mesh]]` reads it (PLY by its name or header,
/// STL by its name, OBJ otherwise), in the file's own coordinates, its
/// faces' materials chosen by `choice` (PLY and STL files, which have
/// none, need one given); the materials of its MTL files are numbered
/// from 0.
pub fn load_mesh_file(path: &Path, choice: obj::MeshMaterials) -> Result<obj::ObjContents> {
    build::load_mesh_file(path, choice, &[])
}

/// The error for a file given where a scene file belongs (`caustix render
/// bunny.obj`, `caustix info image.exr`): what the file is and what to do
/// with it, instead of what the TOML parser makes of its first line.
fn not_a_scene(path: &Path, kind: Option<NotAScene>) -> Option<Error> {
    let kind = kind?;
    let name =
        path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let scene = "caustix renders scene files (TOML)";
    let message = match kind {
        NotAScene::Obj | NotAScene::Ply | NotAScene::Stl | NotAScene::Patches => {
            let mesh = format!("`[[mesh]]` with `file = \"{name}\"` and a `material`");
            let (what, entry) = match kind {
                NotAScene::Obj => ("a Wavefront OBJ mesh", mesh),
                NotAScene::Ply => ("a PLY mesh", mesh),
                NotAScene::Stl => ("an STL mesh", mesh),
                _ => ("a Bezier patch file (.bpt)", format!("`[[teapot]]` with `file = \"{name}\"`")),
            };
            let framing = match kind {
                NotAScene::Patches => String::new(),
                _ => format!("; `caustix info {name} > scene.toml` writes one that frames it"),
            };
            format!(
                "this is {what}, not a scene: {scene}; name it in one as {entry}, beside a `[camera]` \
                 and a light (README, \"Scene files\"; `scenes/` has examples){framing}"
            )
        }
        NotAScene::Image(format) => format!(
            "this is {format} image, not a scene: {scene}; `caustix compare {name} REFERENCE` \
             measures an image against another"
        ),
        NotAScene::PhotonMap => format!(
            "this is a photon map saved by `caustix photons`, not a scene: {scene}; render with \
             it as `caustix render SCENE --photon-map {name}`, SCENE the scene it was traced for"
        ),
    };
    Some(Error::input(path, message))
}

/// Everything needed to render: geometry, materials, lights, camera.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The file it was read from.
    pub path: PathBuf,
    /// Where the camera stands in the file's coordinates. Every position in
    /// the scene (meshes, lights, the camera at zero) is relative to it,
    /// computed in `f64` at load: 32-bit floats near the camera keep the
    /// scene's detail however far from the file's origin it lies.
    pub origin: DVec3,
    /// The camera.
    pub camera: Camera,
    /// How the file asks to be rendered: its `[image]`, `[render]` and
    /// `[photons]` tables over [`RenderConfig::default`].
    pub config: RenderConfig,
    /// Materials; meshes refer to them by index.
    pub materials: Vec<Material>,
    /// Light sources, with what finds the area lights a ray crosses.
    pub lights: Lights,
    /// Triangle meshes; a mesh's index is its Embree geometry id.
    pub meshes: Vec<Mesh>,
    /// Things worth telling the user that are not errors.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Reads and validates a scene file. Relative paths inside it (OBJ and
    /// `.bpt` files) are taken relative to the file's folder.
    pub fn load(path: &Path) -> Result<Scene> {
        Scene::load_with(path, &Overrides::default())
    }

    /// [`Scene::load`] with some of the file's settings replaced.
    pub fn load_with(path: &Path, overrides: &Overrides) -> Result<Scene> {
        // A binary mesh or image fails as text before its name is looked at.
        let text = crate::files::read_text(path, crate::files::MAX_TEXT_BYTES)
            .map_err(|e| not_a_scene(path, NotAScene::sniffed(path)).unwrap_or(e))?;
        Scene::from_toml_with(&text, path, overrides)
    }

    /// Parses scene text; `path` names it in errors and anchors relative paths.
    pub fn from_toml(text: &str, path: &Path) -> Result<Scene> {
        Scene::from_toml_with(text, path, &Overrides::default())
    }

    /// [`Scene::from_toml`] with some of the file's settings replaced.
    pub fn from_toml_with(text: &str, path: &Path, overrides: &Overrides) -> Result<Scene> {
        let parsed: file::SceneFile = toml::from_str(text).map_err(|e| {
            if let Some(err) = not_a_scene(path, NotAScene::named(path)) {
                return err;
            }
            let location = e.span().map(|s| Location::from_offset(text, s.start));
            Error::Input {
                path: path.to_path_buf(),
                location,
                // toml's messages may span lines; keep ours to one.
                message: e.message().trim_end().replace('\n', "; "),
            }
        })?;
        // Every place is kept relative to the camera (see `Scene::origin`).
        let origin = parsed.camera.eye.0;
        Builder { text, path, overrides, origin, warnings: Vec::new() }.build(parsed)
    }

    /// A point of the scene (relative to the camera) in the scene file's
    /// coordinates.
    pub fn in_file(&self, p: Vec3) -> Vec3 {
        (p.as_dvec3() + self.origin).as_vec3()
    }

    /// All meshes' positions (in the file's coordinates), normals and
    /// triangles in one set (for export).
    pub fn merged_triangles(&self) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
        let (mut positions, mut normals, mut indices) = (Vec::new(), Vec::new(), Vec::new());
        for m in &self.meshes {
            let offset = positions.len() as u32;
            positions.extend(m.positions.iter().map(|&p| self.in_file(p)));
            normals.extend_from_slice(&m.normals);
            indices.extend(m.indices.iter().map(|t| t.map(|i| i + offset)));
        }
        (positions, normals, indices)
    }

    /// All meshes as an intersector reads them, in geometry-id order.
    pub fn triangle_views(&self) -> Vec<TriangleView<'_>> {
        self.meshes.iter().map(Mesh::view).collect()
    }

    /// Total triangles.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }

    /// Total vertices.
    pub fn vertex_count(&self) -> usize {
        self.meshes.iter().map(|m| m.positions.len()).sum()
    }

    /// A 64-bit fingerprint of what light in the scene depends on: where it
    /// stands (its origin), its meshes (positions, normals, triangles,
    /// materials), materials and lights. Stable across runs and machines
    /// ([`crate::hash`]): saved photon maps and tiles carry it.
    pub fn fingerprint(&self) -> u64 {
        let mut h = crate::hash::Fnv64::default();
        h.u64(self.origin.x.to_bits()).u64(self.origin.y.to_bits()).u64(self.origin.z.to_bits());
        h.bytes(format!("{:?}{:?}", self.materials, self.lights).as_bytes());
        for m in &self.meshes {
            h.u64(m.material as u64).u64(m.positions.len() as u64).vec3s(&m.positions).vec3s(&m.normals);
            for t in &m.indices {
                h.word(t[0]).word(t[1]).word(t[2]);
            }
        }
        h.finish()
    }

    /// Bounding box of all geometry.
    pub fn bounds(&self) -> Bounds {
        self.meshes.iter().fold(Bounds::EMPTY, |b, m| b.union(m.bounds()))
    }
}

/// Settings that replace what a scene file says (for benchmarks at scale).
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// Quads per patch edge for every `[[teapot]]`.
    pub teapot_subdivisions: Option<u32>,
}
