//! Stanford PLY meshes: ASCII, binary little-endian and binary big-endian.
//! Reads vertex positions (`x y z`), normals when present (`nx ny nz`), and
//! polygon faces (`vertex_indices` or `vertex_index`), triangulated by
//! [`polygon::triangulate`], and triangle strips (`tristrips`, as some
//! scanners' files hold).
//! Other elements and properties are read past.
//!
//! Binary files are the fast way to load big meshes: the vertex block is
//! read in one piece and decoded in parallel, and faces of three vertices
//! (nearly every file) likewise.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use super::polygon::{self, Concave};
use crate::error::{Error, Location, Result};

/// Most records reserved ahead of reading them: a header's counts could be
/// anything, and memory for them is taken only as the data arrives.
const MAX_RESERVE: usize = 1 << 24;

/// A scalar type of the PLY format.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(word: &str) -> Option<Scalar> {
        Some(match word {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The value in `bytes` (exactly `size()` of them).
    fn decode(self, bytes: &[u8], big_endian: bool) -> f64 {
        macro_rules! num {
            ($t:ty) => {{
                let raw = bytes.try_into().expect("caller passes size() bytes");
                (if big_endian { <$t>::from_be_bytes(raw) } else { <$t>::from_le_bytes(raw) }) as f64
            }};
        }
        match self {
            Scalar::I8 => num!(i8),
            Scalar::U8 => num!(u8),
            Scalar::I16 => num!(i16),
            Scalar::U16 => num!(u16),
            Scalar::I32 => num!(i32),
            Scalar::U32 => num!(u32),
            Scalar::F32 => num!(f32),
            Scalar::F64 => num!(f64),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Property {
    Scalar { name: String, kind: Scalar },
    List { name: String, count: Scalar, item: Scalar },
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar { name, .. } | Property::List { name, .. } => name,
        }
    }
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Binary { big_endian: bool },
}

/// A mesh read from a PLY file.
pub struct PlyMesh {
    /// Vertex positions; one spare slot is allocated after them (for Embree).
    pub positions: Vec<Vec3>,
    /// Triangles (polygons by [`polygon::triangulate`]).
    pub indices: Vec<[u32; 3]>,
    /// A warning if concave polygons too large to clip were fanned.
    pub concave: Option<String>,
    /// Vertex normals, when the file has them.
    pub normals: Option<Vec<Vec3>>,
    /// The vertex properties the file has that are not read (colours,
    /// texture coordinates, a scanner's confidence...), in the file's order.
    pub unread: Vec<String>,
}

/// Reads the PLY file at `path`.
pub fn load(path: &Path) -> Result<PlyMesh> {
    crate::files::check_regular(path)?;
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    read(path, BufReader::with_capacity(1 << 20, file))
}

/// Reads a PLY file from `input`; `path` names it in errors.
pub fn read(path: &Path, mut input: impl BufRead) -> Result<PlyMesh> {
    let (format, elements) = read_header(path, &mut input)?;
    let mut reader = DataReader { path, input, format, tokens: Vec::new(), token: 0 };
    let mut mesh = PlyMesh {
        positions: Vec::new(),
        indices: Vec::new(),
        normals: None,
        unread: Vec::new(),
        concave: None,
    };
    let mut vertex_count = None;
    for element in &elements {
        match element.name.as_str() {
            "vertex" => {
                let (positions, normals) = reader.vertices(element)?;
                let normals_read = normals.is_some();
                mesh.positions = positions;
                mesh.normals = normals;
                let read = |name: &str| {
                    matches!(name, "x" | "y" | "z") || normals_read && matches!(name, "nx" | "ny" | "nz")
                };
                mesh.unread = element
                    .properties
                    .iter()
                    .map(Property::name)
                    .filter(|name| !read(name))
                    .map(str::to_string)
                    .collect();
                vertex_count = Some(element.count);
            }
            "face" | "tristrips" => {
                if vertex_count.is_none() {
                    let message = format!("the {} element comes before the vertex element", element.name);
                    return Err(Error::input(path, message));
                }
                if element.name == "face" {
                    let (triangles, concave) = reader.faces(element, &mesh.positions)?;
                    mesh.indices.extend(triangles);
                    mesh.concave = concave;
                } else {
                    reader.strips(element, mesh.positions.len(), &mut mesh.indices)?;
                }
            }
            _ => reader.skip(element)?,
        }
    }
    if vertex_count.is_none() {
        return Err(Error::input(path, "no `element vertex` in the header: not a mesh"));
    }
    Ok(mesh)
}

fn read_header(path: &Path, input: &mut impl BufRead) -> Result<(Format, Vec<Element>)> {
    let mut line_number = 0;
    let mut line = String::new();
    let mut next_line = |line: &mut String| -> Result<usize> {
        let mut bytes = Vec::new();
        let read = input.read_until(b'\n', &mut bytes).map_err(|e| Error::io(path, e))?;
        line_number += 1;
        if read == 0 {
            return Err(Error::input(path, "the file ends inside the header (no `end_header`)"));
        }
        // (A comment in Latin-1, as older exporters on Windows wrote them,
        // read as such: the keywords are ASCII.)
        *line = crate::files::utf8_or_latin1(&bytes).into_owned();
        Ok(line_number)
    };
    let at = |n: usize, message: String| Error::input_at(path, Location { line: n, column: 1 }, message);

    next_line(&mut line)?;
    if line.trim_end() != "ply" {
        return Err(at(1, "not a PLY file: the first line must be `ply`".into()));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let n = next_line(&mut line)?;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            [] | ["comment" | "obj_info", ..] => {}
            ["format", kind, _version] => {
                format = Some(match *kind {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Binary { big_endian: false },
                    "binary_big_endian" => Format::Binary { big_endian: true },
                    other => return Err(at(n, format!("unknown format `{other}`"))),
                })
            }
            ["element", name, count] => {
                let count =
                    count.parse().map_err(|_| at(n, format!("element count `{count}` is not a number")))?;
                if matches!(*name, "vertex" | "face") && elements.iter().any(|e| e.name == *name) {
                    return Err(at(n, format!("a second `element {name}`: a mesh has one")));
                }
                elements.push(Element { name: name.to_string(), count, properties: Vec::new() });
            }
            ["property", rest @ ..] => {
                let Some(element) = elements.last_mut() else {
                    return Err(at(n, "a property before any element".into()));
                };
                let scalar = |w: &str| Scalar::parse(w).ok_or_else(|| at(n, format!("unknown type `{w}`")));
                let property = match rest {
                    ["list", count, item, name] => {
                        Property::List { name: name.to_string(), count: scalar(count)?, item: scalar(item)? }
                    }
                    [kind, name] => Property::Scalar { name: name.to_string(), kind: scalar(kind)? },
                    _ => return Err(at(n, format!("cannot read this property line: `{}`", line.trim_end()))),
                };
                element.properties.push(property);
            }
            _ => return Err(at(n, format!("unexpected header line `{}`", line.trim_end()))),
        }
    }
    let format = format.ok_or_else(|| Error::input(path, "the header has no `format` line"))?;
    Ok((format, elements))
}

/// Reads element data in the file's format.
struct DataReader<'p, R> {
    path: &'p Path,
    input: R,
    format: Format,
    // ASCII: the current line's words.
    tokens: Vec<String>,
    token: usize,
}

impl<R: BufRead> DataReader<'_, R> {
    fn error(&self, message: String) -> Error {
        Error::input(self.path, message)
    }

    fn value(&mut self, kind: Scalar, what: &dyn Fn() -> String) -> Result<f64> {
        match self.format {
            Format::Binary { big_endian } => {
                let mut bytes = [0u8; 8];
                let bytes = &mut bytes[..kind.size()];
                self.input
                    .read_exact(bytes)
                    .map_err(|_| self.error(format!("the file ends in {}", what())))?;
                Ok(kind.decode(bytes, big_endian))
            }
            Format::Ascii => {
                while self.token == self.tokens.len() {
                    let mut line = String::new();
                    let read = self.input.read_line(&mut line).map_err(|e| Error::io(self.path, e))?;
                    if read == 0 {
                        return Err(self.error(format!("the file ends in {}", what())));
                    }
                    self.tokens = line.split_whitespace().map(str::to_owned).collect();
                    self.token = 0;
                }
                let word = &self.tokens[self.token];
                self.token += 1;
                word.parse::<f64>()
                    .map_err(|_| self.error(format!("`{word}` is not a number, in {}", what())))
            }
        }
    }

    /// Reads one record: scalar property `k`'s value lands in `out[k]`, the
    /// items of list property `list` (if given) in `items`; other lists are
    /// read past.
    fn record(
        &mut self,
        element: &Element,
        index: usize,
        out: &mut [f64],
        list: Option<usize>,
        items: &mut Vec<f64>,
    ) -> Result<()> {
        let what = || format!("{} {}", element.name, index + 1);
        items.clear();
        for (k, property) in element.properties.iter().enumerate() {
            match *property {
                Property::Scalar { kind, .. } => out[k] = self.value(kind, &what)?,
                Property::List { count, item, .. } => {
                    for _ in 0..self.value(count, &what)? as usize {
                        let v = self.value(item, &what)?;
                        if list == Some(k) {
                            items.push(v);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    fn skip(&mut self, element: &Element) -> Result<()> {
        if element.properties.is_empty() {
            return Ok(()); // records of nothing: whatever the count, there is nothing to read
        }
        let mut values = vec![0.0; element.properties.len()];
        for i in 0..element.count {
            self.record(element, i, &mut values, None, &mut Vec::new())?;
        }
        Ok(())
    }

    fn vertices(&mut self, element: &Element) -> Result<(Vec<Vec3>, Option<Vec<Vec3>>)> {
        let find = |name: &str| {
            element.properties.iter().position(|p| matches!(p, Property::Scalar { name: n, .. } if n == name))
        };
        let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
            return Err(self.error("the vertex element has no `x`, `y` and `z` properties".into()));
        };
        let normal = match (find("nx"), find("ny"), find("nz")) {
            (Some(a), Some(b), Some(c)) => Some([a, b, c]),
            _ => None,
        };
        // Byte offsets of the properties within a record, if all are scalars.
        let mut offsets = Vec::with_capacity(element.properties.len());
        let mut stride = Some(0);
        for p in &element.properties {
            offsets.push(stride.unwrap_or(0));
            stride = match (stride, p) {
                (Some(s), Property::Scalar { kind, .. }) => Some(s + kind.size()),
                _ => None,
            };
        }
        let scalar_at = |k: usize| match element.properties[k] {
            Property::Scalar { kind, .. } => kind,
            Property::List { .. } => unreachable!("x, y, z, nx, ny, nz are scalars"),
        };
        // A header's counts are not trusted with memory before the data is there.
        let expected = element.count.min(MAX_RESERVE);
        // One spare slot: Mesh::new pads the positions for Embree (no copy then).
        let mut positions = Vec::with_capacity(expected + 1);
        let mut normals = normal.map(|_| Vec::with_capacity(expected));
        match (self.format, stride) {
            (Format::Binary { big_endian }, Some(stride)) => {
                // The whole block at once, decoded in parallel.
                let path = self.path;
                let ends_early =
                    || Error::input(path, format!("the file ends inside the {} vertices", element.count));
                let size = element.count.checked_mul(stride).ok_or_else(ends_early)?;
                let mut bytes = Vec::with_capacity(size.min(MAX_RESERVE * 32));
                (&mut self.input)
                    .take(size as u64)
                    .read_to_end(&mut bytes)
                    .map_err(|e| Error::io(self.path, e))?;
                if bytes.len() != size {
                    return Err(ends_early());
                }
                positions.reserve_exact(element.count + 1 - expected);
                let point = |record: &[u8], [a, b, c]: [usize; 3]| {
                    let at = |k: usize| {
                        let kind = scalar_at(k);
                        kind.decode(&record[offsets[k]..offsets[k] + kind.size()], big_endian) as f32
                    };
                    Vec3::new(at(a), at(b), at(c))
                };
                let records = bytes.par_chunks_exact(stride.max(1));
                positions.par_extend(records.clone().map(|r| point(r, [x, y, z])));
                if let (Some(normals), Some(n)) = (&mut normals, normal) {
                    normals.par_extend(records.map(|r| point(r, n)));
                }
            }
            _ => {
                let mut values = vec![0.0; element.properties.len()];
                for i in 0..element.count {
                    self.record(element, i, &mut values, None, &mut Vec::new())?;
                    let point = |[a, b, c]: [usize; 3]| {
                        Vec3::new(values[a] as f32, values[b] as f32, values[c] as f32)
                    };
                    positions.push(point([x, y, z]));
                    if let (Some(normals), Some(n)) = (&mut normals, normal) {
                        normals.push(point(n));
                    }
                }
            }
        }
        if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
            let fix = "give every vertex finite x, y and z";
            return Err(self.error(format!("vertex {} (counted from 1) is not finite; {fix}", bad + 1)));
        }
        Ok((positions, normals))
    }

    /// An error unless each of `indices` is one of the `vertex_count`
    /// vertices (a whole number from 0) or the value `other`, which the
    /// error names after them; `record` says where ("face 3").
    fn check_indices(
        &self,
        indices: &[f64],
        vertex_count: usize,
        other: Option<(f64, &str)>,
        record: impl Fn() -> String,
    ) -> Result<()> {
        let valid = |i: f64| i >= 0.0 && i < vertex_count as f64 && i.fract() == 0.0;
        let Some(bad) = indices.iter().find(|&&i| !valid(i) && other.is_none_or(|(value, _)| i != value))
        else {
            return Ok(());
        };
        Err(self.error(format!(
            "{}: vertex index {bad} is not one of the {vertex_count} vertices (0 to {}){}",
            record(),
            vertex_count.saturating_sub(1),
            other.map_or("", |(_, named)| named)
        )))
    }

    /// Which of `element`'s properties lists its vertex indices.
    fn index_list(&self, element: &Element) -> Result<usize> {
        let list = element.properties.iter().position(|p| {
            matches!(p, Property::List { .. }) && matches!(p.name(), "vertex_indices" | "vertex_index")
        });
        list.ok_or_else(|| self.error(format!("the {} element has no `vertex_indices` list", element.name)))
    }

    /// The triangles of a `tristrips` element's strips, added to
    /// `triangles`: each three vertices in a row of a strip, every other
    /// one turned to keep the strip's winding; an index of -1 starts a new
    /// strip, and three in a row with one vertex twice make no triangle.
    fn strips(
        &mut self,
        element: &Element,
        vertex_count: usize,
        triangles: &mut Vec<[u32; 3]>,
    ) -> Result<()> {
        let list = self.index_list(element)?;
        let mut scalars = vec![0.0; element.properties.len()];
        let mut items: Vec<f64> = Vec::new();
        for strip in 0..element.count {
            self.record(element, strip, &mut scalars, Some(list), &mut items)?;
            self.check_indices(&items, vertex_count, Some((-1.0, " nor -1 (a new strip)")), || {
                format!("strip {}", strip + 1)
            })?;
            for run in items.split(|&i| i == -1.0) {
                for (k, w) in run.windows(3).enumerate() {
                    let [a, b, c] = [w[0] as u32, w[1] as u32, w[2] as u32];
                    // A repeated vertex joins strips on purpose: no triangle
                    // (and no warning about one without area).
                    if a != b && b != c && a != c {
                        triangles.push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
                    }
                }
            }
        }
        Ok(())
    }

    /// The faces' triangles (see [`polygon::triangulate`]), and a warning
    /// if concave polygons too large to clip were fanned.
    fn faces(&mut self, element: &Element, positions: &[Vec3]) -> Result<(Vec<[u32; 3]>, Option<String>)> {
        let vertex_count = positions.len();
        let list = self.index_list(element)?;
        let mut indices = Vec::with_capacity(element.count.min(MAX_RESERVE));
        let mut scalars = vec![0.0; element.properties.len()];
        let mut corners: Vec<f64> = Vec::new();
        let mut polygon_corners: Vec<u32> = Vec::new();
        let mut concave = Concave::default();
        for face in 0..element.count {
            self.record(element, face, &mut scalars, Some(list), &mut corners)?;
            if corners.len() < 3 {
                return Err(self.error(format!(
                    "face {} has {} vertices; a face needs 3",
                    face + 1,
                    corners.len()
                )));
            }
            self.check_indices(&corners, vertex_count, None, || format!("face {}", face + 1))?;
            polygon_corners.clear();
            polygon_corners.extend(corners.iter().map(|&i| i as u32));
            concave.count(
                polygon_corners.len(),
                polygon::triangulate(positions, &polygon_corners, &mut indices),
            );
        }
        Ok((indices, concave.warning()))
    }
}

/// Writes triangles as binary little-endian PLY: float positions and
/// normals, faces as `uchar` counts with `uint` indices.
pub fn write_binary(
    mut out: impl Write,
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[[u32; 3]],
) -> std::io::Result<()> {
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment written by caustix\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        positions.len(),
        indices.len()
    )?;
    crate::files::write_records(&mut out, positions.iter().zip(normals), |record, (p, n)| {
        for v in p.to_array().into_iter().chain(n.to_array()) {
            record.extend_from_slice(&v.to_le_bytes());
        }
    })?;
    crate::files::write_records(&mut out, indices, |record, t| {
        record.push(3);
        for i in t {
            record.extend_from_slice(&i.to_le_bytes());
        }
    })?;
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    const CUBE_ASCII: &str = "ply\nformat ascii 1.0\ncomment a unit square and a pentagon\n\
        element vertex 5\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n\
        element face 2\nproperty list uchar int vertex_indices\nproperty uchar flags\n\
        element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
        0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n0.5 2 0 9\n3 0 1 2 7\n5 0 1 2 4 3 7\n0 1\n";

    fn read_str(text: &[u8]) -> Result<PlyMesh> {
        read(Path::new("t.ply"), text)
    }

    #[test]
    fn reads_ascii_with_extra_properties_and_polygons() {
        // (A comment in Latin-1, as older exporters wrote them, is read too.)
        let mut latin1 = CUBE_ASCII.as_bytes().to_vec();
        latin1[CUBE_ASCII.find("unit").unwrap()] = 0xe9;
        assert_eq!(read_str(&latin1).unwrap().indices, read_str(CUBE_ASCII.as_bytes()).unwrap().indices);
        let m = read_str(CUBE_ASCII.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[4], Vec3::new(0.5, 2.0, 0.0));
        // A triangle, then a pentagon fanned into three.
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 1, 2], [0, 2, 4], [0, 4, 3]]);
        assert!(m.normals.is_none());
        assert!(m.positions.capacity() > m.positions.len(), "room for Embree's padding");
    }

    /// Strips turn every other triangle to keep one winding, -1 starts a
    /// new strip, a repeated vertex makes none; strips and faces in one
    /// file both count.
    #[test]
    fn reads_triangle_strips() {
        let text = "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\n\
            property float z\nelement tristrips 1\nproperty list int int vertex_indices\n\
            element face 1\nproperty list uchar int vertex_indices\nend_header\n\
            0 0 0\n0 1 0\n1 0 0\n1 1 0\n2 0 0\n2 1 0\n10 0 2 1 3 3 3 -1 3 4 5\n3 0 4 5\n";
        let m = read_str(text.as_bytes()).unwrap();
        assert_eq!(m.indices, vec![[0, 2, 1], [1, 2, 3], [3, 4, 5], [0, 4, 5]]);
        // All three of the strips' triangles face the same way (+z).
        for t in &m.indices[..3] {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!((b - a).cross(c - a).z > 0.0, "{t:?}");
        }
        let bad = text.replace("10 0 2 1 3 3 3 -1 3 4 5", "3 0 2 9");
        let e = read_str(bad.as_bytes()).err().unwrap().to_string();
        assert!(e.contains("strip 1: vertex index 9 is not one of the 6 vertices"), "{e}");
    }

    #[test]
    fn binary_round_trips_and_both_endians_read_alike() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(-1.5, 2.25, 1e-7)];
        let n = vec![Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X];
        let t = vec![[0, 1, 2], [1, 3, 2]];
        let mut bytes = Vec::new();
        write_binary(&mut bytes, &p, &n, &t).unwrap();
        let m = read_str(&bytes).unwrap();
        assert_eq!((m.positions, m.indices, m.normals), (p.clone(), t.clone(), Some(n)));

        // The same mesh big-endian, with doubles and ushort indices, by hand.
        let mut be = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\n\
            property double y\nproperty double z\nelement face 2\nproperty list uchar ushort vertex_index\nend_header\n"
            .to_vec();
        for v in &p {
            for c in v.to_array() {
                be.extend_from_slice(&(c as f64).to_be_bytes());
            }
        }
        for f in &t {
            be.push(3);
            for &i in f {
                be.extend_from_slice(&(i as u16).to_be_bytes());
            }
        }
        let m = read_str(&be).unwrap();
        assert_eq!((m.positions, m.indices), (p, t));
    }

    #[test]
    fn bad_files_say_what_is_wrong() {
        let err = |text: &str| read_str(text.as_bytes()).err().expect("should fail").to_string();
        assert!(err("solid x\n").contains("first line must be `ply`"));
        assert!(err("ply\nformat ascii 1.0\nelement vertex 1\n").contains("ends inside the header"));
        let e = err("ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\nend_header\n");
        assert!(e.contains("t.ply:4") && e.contains("unknown type `flot`"), "{e}");
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
            property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let e = err(&format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"));
        assert!(e.contains("face 1: vertex index 5 is not one of the 3 vertices (0 to 2)"), "{e}");
        // Indices that are not whole numbers are refused too (they used to become vertex 0 or 1).
        for (bad, shown) in [("nan", "NaN"), ("1.5", "1.5"), ("-1", "-1")] {
            let e = err(&format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1 {bad}\n"));
            assert!(e.contains(&format!("vertex index {shown} is not one of")), "{bad}: {e}");
        }
        // A second vertex element used to index past the first's vertices and panic.
        let e = err(&format!("{}element vertex 1\nproperty float x\nend_header\n", &head[..head.len() - 11]));
        assert!(e.contains("t.ply:9:") && e.contains("a second `element vertex`"), "{e}");
        // An element of no properties and a huge count used to loop for ever.
        let e = err("ply\nformat ascii 1.0\nelement junk 1000000000000000000\nend_header\n");
        assert!(e.contains("no `element vertex`"), "{e}");
        let e = err(&format!("{head}0 0 0\n1 0 0\n0 1 0\n"));
        assert!(e.contains("ends in face 1"), "{e}");
        let e = err(&format!("{head}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"));
        assert!(e.contains("vertex 2 (counted from 1) is not finite"), "{e}");
        let e = err(&format!("{head}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"));
        assert!(e.contains("`zero` is not a number"), "{e}");
        // Counts no file could hold are an error, not an allocation failure.
        let e =
            err("ply\nformat binary_little_endian 1.0\nelement vertex 999999999999999\nproperty float x\n\
            property float y\nproperty float z\nend_header\n\0\0");
        assert!(e.contains("ends inside the 999999999999999 vertices"), "{e}");
        // Binary data cut short.
        let mut bytes = Vec::new();
        write_binary(&mut bytes, &[Vec3::ZERO; 3], &[Vec3::Z; 3], &[[0, 1, 2]]).unwrap();
        let e = read_str(&bytes[..bytes.len() - 2]).err().unwrap().to_string();
        assert!(e.contains("ends in face 1"), "{e}");
    }
}
