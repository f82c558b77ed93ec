//! Wavefront OBJ meshes (read by `obj_read`, their MTL files by `tobj`),
//! with MTL materials mapped onto ours.

use std::borrow::Cow;
use std::io::BufReader;
use std::path::Path;
use std::str::SplitWhitespace;

use glam::Vec3;

use super::mesh::{self, FileNormals, Mesh};
use super::mesh_lights::{self, MeshLight};
use super::obj_read;
use super::polygon::{self, Concave};
use super::winding;
use crate::error::{Error, Location, Result};
use crate::material::Material;

/// Which materials a mesh file's faces take.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MeshMaterials {
    /// This one (a scene material's index) on every face, whatever the file says.
    All(usize),
    /// The file's own (MTL) materials.
    FromFile {
        /// The material of faces the file gives none (before its first
        /// `usemtl`, or after one naming a material its MTL files lack);
        /// without one such faces are an error.
        fallback: Option<usize>,
    },
}

/// Meshes read from an OBJ file, and the materials its MTL file defined.
pub struct ObjContents {
    /// One mesh per OBJ object/group; `material` indexes the scene's
    /// materials and then `materials` (see [`load`]).
    pub meshes: Vec<Mesh>,
    /// Materials from the MTL file, in the file's order.
    pub materials: Vec<Material>,
    /// Things the user should know (e.g. MTL colours rescaled to conserve energy).
    pub warnings: Vec<String>,
    /// The meshes (by name) whose faces the file gives no material, which
    /// took [`MeshMaterials::FromFile`]'s fallback.
    pub defaulted: Vec<String>,
    /// The area lights its emitting faces make ([`mesh_lights`]), in the
    /// file's coordinates; those faces are not in `meshes`.
    pub lights: Vec<MeshLight>,
}

/// Loads `path`, its faces' materials chosen by `choice` (whose numbers
/// index `scene_materials`); the file's MTL materials are numbered after
/// `scene_materials` (where the caller will append `materials`).
pub fn load(path: &Path, choice: MeshMaterials, scene_materials: &[Material]) -> Result<ObjContents> {
    let first_material = scene_materials.len();
    crate::files::check_regular(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let (text, latin1) = crate::files::text_or_latin1(path, bytes)?;
    let mut warnings: Vec<String> = latin1.into_iter().collect();
    let text = logical_lines(&text);
    // The material of every face, or of those the file gives none.
    let (material_override, fallback) = match choice {
        MeshMaterials::All(id) => (Some(id), None),
        MeshMaterials::FromFile { fallback } => (None, fallback),
    };
    // Polygons come whole, to be cut where they are concave
    // (`polygon::triangulate`).
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mtl_file = std::cell::RefCell::new(None);
    let mtl_error = std::cell::RefCell::new(None);
    let mtl_warnings = std::cell::RefCell::new(Vec::new());
    let obj_read::ObjText { models, materials: mtl, short_faces } = obj_read::read(&text, |mtl_path| {
        let mut merged: tobj::MTLLoadResult = Ok(Default::default());
        for file in mtl_files(&dir, mtl_path) {
            *mtl_file.borrow_mut() = Some(file.clone());
            let mtl_text = crate::files::read_bytes(&file, crate::files::MAX_TEXT_BYTES)
                .and_then(|bytes| crate::files::text_or_latin1(&file, bytes))
                .map(|(text, latin1)| {
                    mtl_warnings.borrow_mut().extend(latin1);
                    text
                })
                .map_err(|e| match e {
                    Error::Io { cause, .. } if cause.kind() == std::io::ErrorKind::NotFound => Error::input(
                        &file,
                        format!(
                            "MTL file not found (named by `mtllib` in {}; its paths are relative to the OBJ file)",
                            path.display()
                        ),
                    ),
                    other => other,
                })
                .and_then(|t| mtl_statements(&file, &t).map(Cow::into_owned))
                .map_err(|e| {
                    *mtl_error.borrow_mut() = Some(e);
                    tobj::LoadError::MaterialParseError
                })?;
            // As tobj merges the files of several `mtllib` lines: a later
            // file's material of the same name wins.
            let (list, names) = tobj::load_mtl_buf(&mut BufReader::new(mtl_text.as_bytes()))?;
            if let Ok((all, all_names)) = &mut merged {
                let offset = all.len();
                all.extend(list);
                all_names.extend(names.into_iter().map(|(name, i)| (name, i + offset)));
            }
        }
        merged
    })
    .map_err(|e| {
        let (location, detail) = match locate_problem(&text) {
            Some((line, what)) => (Some(Location { line, column: 1 }), what),
            None => (None, String::new()),
        };
        Error::Input { path: path.to_path_buf(), location, message: format!("cannot read OBJ: {e}{detail}") }
    })?;

    let file_name = path.file_name().map_or_else(|| "obj".into(), |n| n.to_string_lossy().into_owned());
    warnings.extend(mtl_warnings.into_inner());
    // An MTL file the faces would use that could not be read is the error
    // (a file named but not used is not).
    if let (Err(e), None) = (&mtl, material_override) {
        if statements(&text, "usemtl").next().is_some() {
            return Err(match (mtl_error.into_inner(), mtl_file.into_inner()) {
                (Some(ours), _) => ours,
                (None, Some(file)) => Error::input(&file, format!("cannot read MTL: {e}")),
                (None, None) => Error::input(path, format!("cannot read its materials: {e}")),
            });
        }
    }
    let mut mtl_names = Vec::new();
    // Each MTL material's emitted radiance (`Ke`), where it emits.
    let mut emission = Vec::new();
    let materials = match (mtl, material_override) {
        (Ok(list), None) => {
            mtl_names.extend(list.iter().map(|m| m.name.clone()));
            warnings.extend(unread_mtl_features(&list, &file_name));
            emission.extend(list.iter().map(emitted));
            list.iter().map(|m| convert_material(m, &file_name, &mut warnings)).collect()
        }
        _ => Vec::new(),
    };

    // Each object's triangles, turned as `winding` says, before its mesh is
    // made.
    struct Object {
        model: String,
        name: String,
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
        normals: FileNormals,
        material: usize,
        glass: bool,
        turned: winding::Turned,
    }
    let mut objects = Vec::with_capacity(models.len());
    let mut lights = Vec::new();
    let mut enclosed = 0.0;
    let mut defaulted = Vec::new();
    let mut concave = Concave::default();
    for model in models {
        let m = &model.mesh;
        let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(Vec3::from_slice).collect();
        if positions.iter().any(|p| !p.is_finite()) {
            // tobj numbers an object's vertices its own way: say which of
            // the file's `v` lines it is.
            let fix = "give every `v` three finite numbers";
            return Err(match first_non_finite_vertex(&text) {
                Some((line, number)) => Error::input_at(
                    path,
                    Location { line, column: 1 },
                    format!("vertex {number} is not finite; {fix}"),
                ),
                None => Error::input(
                    path,
                    format!("object `{}` has a vertex that is not finite; {fix}", model.name),
                ),
            });
        }
        if m.indices.iter().any(|&i| i as usize >= positions.len()) {
            return Err(Error::input(path, format!("object `{}` has a face index out of range", model.name)));
        }
        let indices = triangles(&positions, m, &mut concave);
        let normals = (m.normals.len() == m.positions.len() && !m.normals.is_empty())
            .then(|| m.normals.chunks_exact(3).map(Vec3::from_slice).collect());
        let name = format!("{file_name}:{}", model.name);
        let scene_glass = |id: usize| is_glass(scene_materials, id);
        let (material, glass, emits) = match (material_override, m.material_id, fallback) {
            (Some(id), _, _) => (id, scene_glass(id), None),
            (None, Some(id), _) if id < materials.len() => {
                (first_material + id, materials[id].refracts(), emission[id])
            }
            (None, _, Some(id)) => {
                defaulted.push(name.clone());
                (id, scene_glass(id), None)
            }
            (None, _, None) => {
                let why = why_no_material(&text, &mtl_names);
                return Err(Error::input(path, format!("object `{}` has no material: {why}", model.name)));
            }
        };
        let mut indices = indices;
        if let Some(radiance) = emits {
            // In the file's winding, before `winding::orient` may turn it.
            // All of it becomes lights, and leaves the mesh.
            let panels = mesh_lights::panels(&positions, normals.as_deref(), &indices);
            let kept = panels.iter().map(|p| p.0.triangles()).sum();
            let who = format!("{file_name}: object `{}`", model.name);
            warnings.extend(mesh::no_area_warning(&who, indices.len(), kept));
            lights.extend(panels.into_iter().map(|(shape, center, u, v)| MeshLight {
                mesh: name.clone(),
                shape,
                center,
                u,
                v,
                radiance,
            }));
            continue;
        }
        let normals = FileNormals::of(normals, &positions);
        let turned = winding::orient(&positions, &mut indices, normals.for_winding(), glass);
        enclosed += turned.enclosed;
        objects.push(Object {
            model: model.name,
            name,
            positions,
            indices,
            normals,
            material,
            glass,
            turned,
        });
    }
    // Glass open within its object may be closed by another (`winding::open_in_file`).
    if objects.len() > 1 && objects.iter().any(|o| o.turned.open_glass > 0) {
        let meshes: Vec<_> = objects.iter().map(|o| (&o.positions[..], &o.indices[..])).collect();
        let open = winding::open_in_file(&meshes)
            .unwrap_or_else(|| objects.iter().map(|o| o.turned.open_glass).collect());
        for (object, open) in objects.iter_mut().zip(open) {
            object.turned.open_glass = if object.glass { open } else { 0 };
        }
    }
    for o in &objects {
        warnings.extend(o.turned.warnings(&format!("{file_name}: object `{}`", o.model), o.indices.len()));
    }
    // Which way the glass winds is the whole file's to say (`winding`): a
    // hollow ball may be two objects.
    if enclosed < 0.0 {
        let turned: usize =
            objects.iter_mut().filter(|o| o.glass).map(|o| winding::turn_inside_out(&mut o.indices)).sum();
        warnings.push(winding::inside_out_warning(&file_name, turned));
    }
    let mut meshes = Vec::with_capacity(objects.len());
    for Object { model, name, positions, indices, normals, material, .. } in objects {
        let faces = indices.len();
        let mesh = normals.mesh(name, positions, indices, material);
        let who = format!("{file_name}: object `{model}`");
        warnings.extend(mesh::no_area_warning(&who, faces, mesh.indices.len()));
        meshes.push(mesh);
    }
    warnings.extend(concave.warning().map(|w| format!("{file_name}: {w}")));
    if let Some(&first) = short_faces.first() {
        warnings.push(format!(
            "{file_name}: {} faces with fewer than 3 vertices were left out (the first on line {first})",
            short_faces.len()
        ));
    }
    Ok(ObjContents { meshes, materials, warnings, defaulted, lights })
}

/// Whether material `id` of `materials` refracts (a number not there, as
/// `caustix info`'s stand-in, is no glass).
pub(super) fn is_glass(materials: &[Material], id: usize) -> bool {
    materials.get(id).is_some_and(Material::refracts)
}

/// The triangles of `mesh`'s faces: triangles as they are, polygons by
/// [`polygon::triangulate`]; faces of fewer than three corners (points and
/// lines) are left out (`obj_read` tells where, as `short_faces`).
fn triangles(positions: &[Vec3], mesh: &tobj::Mesh, concave: &mut Concave) -> Vec<[u32; 3]> {
    if mesh.face_arities.is_empty() {
        return mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    }
    let mut out = Vec::with_capacity(mesh.indices.len() / 3);
    let mut start = 0;
    for &arity in &mesh.face_arities {
        let corners = &mesh.indices[start..start + arity as usize];
        start += arity as usize;
        if corners.len() >= 3 {
            concave.count(corners.len(), polygon::triangulate(positions, corners, &mut out));
        }
    }
    out
}

/// `text` without a leading byte order mark (some Windows tools write one;
/// the OBJ and MTL keywords after it would not be recognised).
fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// `text` as tobj should read it: without a byte order mark, and with each
/// statement continued over several lines (a `\\` ending a line, as the
/// OBJ format allows) joined onto its first line. The lines a statement
/// took follow it empty, so every later statement keeps its line number
/// for error messages.
fn logical_lines(text: &str) -> Cow<'_, str> {
    let text = without_bom(text);
    if !text.contains("\\\n") && !text.contains("\\\r\n") {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len());
    let mut joined = 0;
    for line in text.lines() {
        // (Not a comment's: a Windows path ending one would swallow the
        // statement after it.)
        match line.strip_suffix('\\').filter(|_| !line.trim_start().starts_with('#')) {
            Some(head) => {
                out.push_str(head);
                out.push(' ');
                joined += 1;
            }
            None => {
                out.push_str(line);
                out.push('\n');
                out.extend(std::iter::repeat_n('\n', joined));
                joined = 0;
            }
        }
    }
    out.extend(std::iter::repeat_n('\n', joined));
    Cow::Owned(out)
}

/// Why faces of an OBJ file (its `text`, whose MTL files define
/// `mtl_names`) have no material, and what to give the `[[mesh]]`: a
/// `usemtl` naming a material the MTL files lack, or faces before the
/// first `usemtl`, or no `usemtl` at all.
fn why_no_material(text: &str, mtl_names: &[String]) -> String {
    // The name as tobj reads it: all after the keyword's first space.
    let uses = || {
        text.lines()
            .enumerate()
            .filter(|(_, line)| line.split_whitespace().next() == Some("usemtl"))
            .map(|(i, line)| (i + 1, line.split_once(' ').map_or("", |(_, name)| name.trim())))
    };
    let unknown = uses().find(|(_, name)| !mtl_names.iter().any(|n| n == name));
    let first_use = uses().next().map(|(line, _)| line);
    let first_face = statements(text, "f").next().map(|(line, _)| line);
    let either = "give the [[mesh]] `default_material = \"...\"` for the faces the file gives none, \
                  or `material = \"...\"` for every face";
    match (unknown, first_use, first_face) {
        (Some((line, name)), _, _) => {
            let defined = match mtl_names.len() {
                0 => "they define none".to_string(),
                n if n <= 8 => format!("they define {}", mtl_names.join(", ")),
                n => format!("they define {n}, among them {}", mtl_names[..8].join(", ")),
            };
            format!("`usemtl {name}` on line {line} names no material of its MTL files ({defined}); {either}")
        }
        (None, Some(used), Some(face)) if face < used => {
            format!("its faces from line {face} come before the first `usemtl` (line {used}); {either}")
        }
        (None, None, _) => {
            "the file names none (it has no `usemtl`); give the [[mesh]] a `material = \"...\"`".to_string()
        }
        // tobj knows a material only from the `mtllib` before its `usemtl`.
        (None, Some(used), _) => match statements(text, "mtllib").next() {
            Some((library, _)) if library > used => format!(
                "its `usemtl` on line {used} comes before the `mtllib` on line {library}: move the `mtllib` \
                 up, or {either}"
            ),
            _ => format!("some of its faces have none; {either}"),
        },
    }
}

/// The MTL files an `mtllib` statement names, in `dir`: the name as a
/// whole where such a file exists (names may hold spaces, and tobj reads
/// them so), else each word of it (the OBJ format lets one statement name
/// several files).
fn mtl_files(dir: &Path, named: &Path) -> Vec<std::path::PathBuf> {
    let whole = dir.join(named);
    let words: Vec<&str> = named.to_str().map_or_else(Vec::new, |n| n.split_whitespace().collect());
    if whole.exists() || words.len() < 2 {
        return vec![whole];
    }
    words.into_iter().map(|w| dir.join(w)).collect()
}

/// An MTL file's `text` as tobj should read it, or the first statement it
/// would refuse (or, for colours of fewer than three numbers, panic on),
/// with its line: without a byte order mark, and with a colour given as one
/// number (`Kd 0.8`, which the format reads as grey) written as three.
fn mtl_statements<'t>(path: &Path, text: &'t str) -> Result<Cow<'t, str>> {
    let text = without_bom(text);
    let mut grey = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let at = |message: String| Error::input_at(path, Location { line: i + 1, column: 1 }, message);
        let numbers =
            |words: std::str::SplitWhitespace| words.map(|w| w.parse::<f32>().ok()).collect::<Vec<_>>();
        let problem = match words.next() {
            Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) => match numbers(words.clone())[..] {
                [Some(_), Some(_), Some(_), ..] => None,
                [Some(_)] => {
                    grey.push(i);
                    None
                }
                _ => {
                    let form = words.next().filter(|w| matches!(*w, "spectral" | "xyz"));
                    let what = form.map_or_else(String::new, |f| format!(" (`{key} {f}` is not read)"));
                    Some(format!("`{key}` needs three numbers (red, green, blue), or one for grey{what}"))
                }
            },
            Some(key @ ("Ns" | "Ni" | "d")) if !matches!(numbers(words.clone())[..], [Some(_), ..]) => {
                Some(format!("`{key}` needs a number"))
            }
            Some("illum") if words.next().is_none_or(|w| w.parse::<u8>().is_err()) => {
                Some("`illum` needs an illumination model: a whole number from 0 to 10".into())
            }
            Some("newmtl") if words.next().is_none() => Some("`newmtl` needs the material's name".into()),
            // (The maps tobj reads; it keeps others' words as they are.)
            Some(
                key @ ("map_Ka" | "map_Kd" | "map_Ks" | "map_Bump" | "map_bump" | "map_Ns" | "map_ns"
                | "map_NS" | "bump" | "map_d"),
            ) if words.next().is_none() => Some(format!("`{key}` needs a file name")),
            _ => None,
        };
        if let Some(problem) = problem {
            return Err(at(problem));
        }
    }
    if grey.is_empty() {
        return Ok(Cow::Borrowed(text));
    }
    let mut out = String::with_capacity(text.len() + 16 * grey.len());
    for (i, line) in text.lines().enumerate() {
        match grey.binary_search(&i) {
            Ok(_) => {
                let mut words = line.split_whitespace();
                let (key, value) = (words.next().unwrap_or_default(), words.next().unwrap_or_default());
                out.push_str(&format!("{key} {value} {value} {value}"));
            }
            Err(_) => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(Cow::Owned(out))
}

/// The line and the number (from 1, as faces count them) of the file's
/// first `v` statement with a coordinate that is not finite (`nan`, `inf`,
/// or beyond `f32`'s range), if any.
fn first_non_finite_vertex(text: &str) -> Option<(usize, usize)> {
    statements(text, "v").enumerate().find_map(|(number, (line, words))| {
        let finite = words.take(3).all(|w| w.parse::<f32>().is_ok_and(f32::is_finite));
        (!finite).then_some((line, number + 1))
    })
}

/// The file's statements of one `kind` (`v`, `f`, ...): each one's line
/// (from 1) and the words after the keyword.
fn statements<'t>(text: &'t str, kind: &'t str) -> impl Iterator<Item = (usize, SplitWhitespace<'t>)> + 't {
    text.lines().enumerate().filter_map(move |(i, line)| {
        let mut words = line.split_whitespace();
        (words.next() == Some(kind)).then_some((i + 1, words))
    })
}

/// Maps an MTL material onto ours: `Kd` diffuse, `Ks`/`Ns` glossy lobe,
/// illumination models 3 and 5 turn `Ks` into a mirror, 4, 6, 7 and 9 (or a
/// dissolve below 1) make the surface a dielectric with `Ni` as its index.
/// Parts that sum above 1 are scaled down, with a warning.
fn convert_material(m: &tobj::Material, file: &str, warnings: &mut Vec<String>) -> Material {
    let rgb = |c: Option<[f32; 3]>| Vec3::from_array(c.unwrap_or([0.0; 3])).clamp(Vec3::ZERO, Vec3::ONE);
    let mut out = Material {
        name: format!("{file}:{}", m.name),
        diffuse: rgb(m.diffuse),
        specular: rgb(m.specular),
        phong_exponent: m
            .shininess
            .filter(|s| s.is_finite())
            .unwrap_or(1.0)
            .clamp(1.0, Material::MAX_PHONG_EXPONENT),
        ior: m.optical_density.filter(|n| n.is_finite() && *n > 0.0).unwrap_or(1.5),
        ..Material::default()
    };
    let illum = m.illumination_model.unwrap_or(2);
    if matches!(illum, 3 | 5) {
        out.mirror = std::mem::take(&mut out.specular);
    }
    let dissolve = m.dissolve.filter(|d| d.is_finite()).unwrap_or(1.0).clamp(0.0, 1.0);
    if matches!(illum, 4 | 6 | 7 | 9) || dissolve < 1.0 {
        out.transmittance = Vec3::splat(if dissolve < 1.0 { 1.0 - dissolve } else { 1.0 });
        out.specular = Vec3::ZERO;
    }
    let total = out.total_reflectance().max_element();
    if total > 1.0 {
        let k = 1.0 / total;
        out.diffuse *= k;
        out.specular *= k;
        out.mirror *= k;
        out.transmittance *= k;
        warnings.push(format!(
            "material `{}` reflects {total:.2} of the light it receives; scaled to 1 to conserve energy",
            out.name
        ));
    }
    out
}

/// The radiance an MTL material emits (`Ke`), if it is a colour of no
/// negative or infinite part with some light in it.
fn emitted(m: &tobj::Material) -> Option<Vec3> {
    let ke = Vec3::from_array(m.emissive?);
    (ke.is_finite() && ke.min_element() >= 0.0 && ke.max_element() > 0.0).then_some(ke)
}

/// What the MTL materials of `file` ask for that caustix does not read,
/// one warning per kind (not per material: a model may have hundreds):
/// texture maps (the flat colours are used), emission that is not a
/// colour (`Ke` with a negative or infinite part), and statements tobj keeps as unknown
/// (`Pr`, `norm`, `Tr`, ...), but for those that say nothing beyond the
/// defaults (`Tf 1 1 1`, `Tr 0`).
fn unread_mtl_features(list: &[tobj::Material], file: &str) -> Vec<String> {
    let mut warnings = Vec::new();
    let textured: Vec<(&str, &str, &str)> = list
        .iter()
        .filter_map(|m| {
            let maps = [
                ("map_Kd", &m.diffuse_texture),
                ("map_Ks", &m.specular_texture),
                ("bump", &m.normal_texture),
                ("map_Ns", &m.shininess_texture),
                ("map_d", &m.dissolve_texture),
                ("map_Ka", &m.ambient_texture),
            ];
            let (kind, map) = maps.into_iter().find_map(|(kind, map)| Some((kind, map.as_deref()?)))?;
            Some((m.name.as_str(), kind, map))
        })
        .collect();
    if let Some(&(name, kind, map)) = textured.first() {
        warnings.push(format!(
            "{file}: {} of its {} materials {} texture maps (`{name}`: {kind} `{map}`), which caustix \
             does not read: their flat colours (Kd, Ks) are used instead",
            textured.len(),
            list.len(),
            if textured.len() == 1 { "uses" } else { "use" }
        ));
    }
    let not_colours: Vec<&str> = list
        .iter()
        .filter(|m| m.emissive.is_some_and(|e| e.iter().any(|&c| c != 0.0)) && emitted(m).is_none())
        .map(|m| m.name.as_str())
        .collect();
    if let Some(name) = not_colours.first() {
        warnings.push(format!(
            "{file}: {} of its {} materials {} an emission (Ke) with a negative or infinite part (as `{name}` \
             does), which is no light: {} not emit",
            not_colours.len(),
            list.len(),
            if not_colours.len() == 1 { "gives" } else { "give" },
            if not_colours.len() == 1 { "its faces do" } else { "their faces do" },
        ));
    }
    let says_nothing = |key: &str, value: &str| {
        let numbers: Vec<f32> = value.split_whitespace().filter_map(|w| w.parse().ok()).collect();
        match key {
            "Tf" => numbers.iter().all(|&x| x == 1.0),
            "Tr" => numbers.iter().all(|&x| x == 0.0),
            _ => false,
        }
    };
    let mut unknown: Vec<&str> = list
        .iter()
        .flat_map(|m| m.unknown_param.iter())
        .filter(|(key, value)| !says_nothing(key, value))
        .map(|(key, _)| key.as_str())
        .collect();
    unknown.sort_unstable();
    unknown.dedup();
    if !unknown.is_empty() {
        warnings.push(format!(
            "{file}: MTL statements caustix does not read were left out: {} (it reads Kd, Ks, Ns, Ni, d \
             and illum)",
            unknown.join(", ")
        ));
    }
    warnings
}

/// Finds the first line `tobj` most likely failed on, since its errors carry
/// no line number: a `v`/`vn`/`vt` with a non-number or too few numbers, or
/// an `f` whose vertex, texture or normal reference is not a number or
/// points outside those read so far.
pub fn locate_problem(text: &str) -> Option<(usize, String)> {
    // Vertices, texture coordinates and normals read so far.
    let (mut v, mut vt, mut vn): (i64, i64, i64) = (0, 0, 0);
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let line_no = i + 1;
        let at = |what: String| Some((line_no, format!(" (line {line_no}: {what})")));
        match words.next() {
            Some(kind @ ("v" | "vn" | "vt")) => {
                let numbers: Vec<&str> = words.collect();
                if let Some(bad) = numbers.iter().find(|w| w.parse::<f32>().is_err()) {
                    return at(format!("`{kind}` has `{bad}`, not a number"));
                }
                let (needs, count) = match kind {
                    "v" => (3, &mut v),
                    "vn" => (3, &mut vn),
                    _ => (2, &mut vt),
                };
                if numbers.len() < needs {
                    return at(format!("`{kind}` needs {needs} numbers, has {}", numbers.len()));
                }
                *count += 1;
            }
            Some("f") => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return at("a face needs at least 3 vertices".into());
                }
                for r in refs {
                    let mut parts = r.split('/');
                    let vertex = parts.next().unwrap_or("");
                    let Ok(k) = vertex.parse::<i64>() else {
                        return at(format!("`{r}` is not a vertex reference"));
                    };
                    if !(1..=v).contains(&k) && !(-v..=-1).contains(&k) {
                        return at(format!("vertex {k} does not exist; {v} read so far"));
                    }
                    // `v/vt`, `v//vn` or `v/vt/vn`: the texture and normal references.
                    for (part, what, read, kind) in
                        [(parts.next(), "texture coordinate", vt, "vt"), (parts.next(), "normal", vn, "vn")]
                    {
                        let Some(part) = part.filter(|p| !p.is_empty()) else { continue };
                        match part.parse::<i64>() {
                            Ok(k) if (1..=read).contains(&k) || (-read..=-1).contains(&k) => {}
                            Ok(k) => {
                                return at(format!("{what} {k} does not exist; {read} `{kind}` read so far"))
                            }
                            Err(_) => return at(format!("`{r}` has `{part}`, not a {what} reference")),
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// Writes triangles as OBJ text: `v`, `vn` and `f v//vn` lines.
pub fn write(
    mut out: impl std::io::Write,
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[[u32; 3]],
) -> std::io::Result<()> {
    for p in positions {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for n in normals {
        writeln!(out, "vn {} {} {}", n.x, n.y, n.z)?;
    }
    for t in indices {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}")?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locates_bad_vertices_and_faces() {
        let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        let at = |text: &str| locate_problem(text).map(|(line, what)| (line, what.trim().to_string()));
        assert_eq!(
            at(&format!("{tri}vn 0 0 1\nf 1//1 2//1 3//5\n")),
            Some((5, "(line 5: normal 5 does not exist; 1 `vn` read so far)".into()))
        );
        assert_eq!(at(&format!("{tri}vt 0 0\nf 1/1 2/1 3/7\n")).map(|p| p.0), Some(5));
        assert_eq!(at(&format!("{tri}vt 0 0\nf 1/1 2/1 3/x\n")).map(|p| p.0), Some(5));
        assert_eq!(at(&format!("{tri}vt 0 0\nvn 0 0 1\nf 1/1/1 2/-1/-1 3//1\n")), None);
        assert_eq!(at("v 0 0\n"), Some((1, "(line 1: `v` needs 3 numbers, has 2)".into())));
        assert_eq!(at(&format!("{tri}vn 0 1\n")).map(|p| p.0), Some(4));
        assert_eq!(locate_problem("v 0 0 0\nv 1 x 0\n").map(|p| p.0), Some(2));
        assert_eq!(locate_problem("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").map(|p| p.0), Some(4));
        assert_eq!(locate_problem("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -3\n"), None);
        // References to texture coordinates and normals the file lacks.
        assert_eq!(locate_problem("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2//3 3\n").map(|p| p.0), Some(4));
    }

    #[test]
    fn a_vertex_that_is_not_finite_is_named_as_the_file_numbers_it() {
        // The faces use vertex 4 before vertex 3, so tobj numbers the file's
        // vertex 3 (`nan`, on line 4) fourth; the error must name the file's.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.obj");
        let text = "# a comment\nv 0 0 0\nv 1 0 0 # a comment\nv nan 1 0\nv 0 1 0\nf 1 2 4\nf 1 2 3\n";
        std::fs::write(&path, text).unwrap();
        let message = load(&path, MeshMaterials::All(0), &[]).err().expect("a NaN vertex in use").to_string();
        assert!(message.contains("bad.obj:4:1: vertex 3 is not finite"), "{message}");
        // Overflowing `f32` counts too; a non-finite vertex no face uses does not matter.
        assert_eq!(first_non_finite_vertex("v 0 0 0\nvn 0 0 1\nv 1e39 0 0\n"), Some((3, 2)));
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv inf 0 0\nf 1 2 3\n").unwrap();
        assert!(load(&path, MeshMaterials::All(0), &[]).is_ok());
    }
}
