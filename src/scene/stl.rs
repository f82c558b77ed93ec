//! STL meshes, as CAD and 3D-printing tools write them: binary or ASCII, a
//! list of triangles that share no vertices. Each is shaded flat, as the
//! format means: its normal is worked out from its corners (the facets'
//! stored normals are often zero or stale, and the winding is what the
//! format defines as outward).

use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;

use glam::Vec3;

use super::winding::{self, Normals, Turned};
use crate::error::{Error, Location, Result};
use crate::numeric;

/// Triangles reserved ahead of reading them at most (a header's count
/// could be anything; memory is taken as the data arrives).
const MAX_RESERVE: usize = 1 << 22;

/// The longest line of an ASCII STL file read (its longest statement,
/// `vertex` and three numbers, takes well under a hundred bytes).
const MAX_LINE: u64 = 1 << 16;

/// A mesh read from an STL file: three vertices of its own per triangle.
pub struct StlMesh {
    /// The corners, three a triangle; one spare slot is allocated after
    /// them (for Embree).
    pub positions: Vec<Vec3>,
    /// `[3k, 3k + 1, 3k + 2]` for triangle `k`.
    pub indices: Vec<[u32; 3]>,
    /// Each corner's normal: its triangle's (zero where it has no area).
    pub normals: Vec<Vec3>,
}

/// Reads the STL file at `path`: binary where its size is that of a
/// binary file of the triangle count its header gives (some binary files
/// begin with `solid` too), else ASCII (`solid ...`).
pub fn load(path: &Path) -> Result<StlMesh> {
    crate::files::check_regular(path)?;
    let size = std::fs::metadata(path).map_err(|e| Error::io(path, e))?.len();
    let mut input =
        BufReader::with_capacity(1 << 20, std::fs::File::open(path).map_err(|e| Error::io(path, e))?);
    let head = input.fill_buf().map_err(|e| Error::io(path, e))?;
    let count = head.get(80..84).map(|b| u32::from_le_bytes(b.try_into().expect("four bytes")));
    let starts_solid = head.starts_with(b"solid");
    match count {
        Some(count) if size == 84 + 50 * count as u64 => read_binary(path, input, count),
        _ if starts_solid => read_ascii(path, input),
        Some(count) => Err(Error::input(
            path,
            format!(
                "not an STL file: binary, its header's {count} triangles would take {} bytes, but it \
                 has {size}; ASCII, it would begin with `solid`",
                84 + 50 * count as u64
            ),
        )),
        None => {
            Err(Error::input(path, format!("not an STL file: {size} bytes, shorter than a binary header")))
        }
    }
}

/// The triangles of a binary STL file of `count` triangles, `input` at its start.
fn read_binary(path: &Path, mut input: impl Read, count: u32) -> Result<StlMesh> {
    let mut mesh = StlMesh::with_capacity(count as usize);
    let mut header = [0u8; 84];
    input.read_exact(&mut header).map_err(|e| Error::io(path, e))?;
    let mut record = [0u8; 50];
    for k in 0..count {
        input.read_exact(&mut record).map_err(|e| Error::io(path, e))?;
        // The stored normal (bytes 0..12) is not read; then three corners.
        let corner = |c: usize| {
            let at = |i: usize| {
                f32::from_le_bytes(record[12 + 12 * c + 4 * i..][..4].try_into().expect("four bytes"))
            };
            Vec3::new(at(0), at(1), at(2))
        };
        let corners = [corner(0), corner(1), corner(2)];
        if !corners.iter().all(|p| p.is_finite()) {
            return Err(Error::input(path, format!("triangle {} has a corner that is not finite", k + 1)));
        }
        mesh.push(corners);
    }
    Ok(mesh)
}

/// The triangles of an ASCII STL file: every `vertex x y z` line, three to
/// a facet (`facet ... endfacet`); any other line is read past. A file
/// that ends inside a facet was cut short: an error, not a facet lost.
fn read_ascii(path: &Path, mut input: impl BufRead) -> Result<StlMesh> {
    let mut mesh = StlMesh::with_capacity(0);
    let mut corners = Vec::with_capacity(3);
    // The line of the facet read, until its `endfacet`.
    let mut facet_line = None;
    let mut bytes = Vec::new();
    for i in 0.. {
        let at = |message: String| Error::input_at(path, Location { line: i + 1, column: 1 }, message);
        // A line at most `MAX_LINE` long: a file of one endless line is
        // not held in memory.
        bytes.clear();
        let read =
            (&mut input).take(MAX_LINE).read_until(b'\n', &mut bytes).map_err(|e| Error::io(path, e))?;
        if read == 0 {
            if let Some(facet_line) = facet_line {
                return Err(at(format!(
                    "the file ends inside the facet from line {facet_line} (no `endfacet`): is it cut short?"
                )));
            }
            break;
        }
        if read as u64 == MAX_LINE && !bytes.ends_with(b"\n") {
            return Err(at(format!("a line longer than {MAX_LINE} bytes: not an ASCII STL file")));
        }
        // Text in Latin-1 (a solid's name, as older exporters on Windows
        // wrote it) is read as such; a zero byte is no text.
        if bytes.contains(&0) {
            return Err(at(
                "not text: neither a binary STL file (its size does not match its count) nor an ASCII one"
                    .into(),
            ));
        }
        let line = crate::files::utf8_or_latin1(&bytes);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("facet") => {
                corners.clear();
                facet_line = Some(i + 1);
            }
            Some("vertex") => {
                let numbers: Vec<f32> = words.map_while(|w| w.parse().ok()).collect();
                match numbers[..] {
                    [x, y, z] if [x, y, z].iter().all(|c| c.is_finite()) => corners.push(Vec3::new(x, y, z)),
                    _ => return Err(at("`vertex` needs three finite numbers".into())),
                }
            }
            Some("endfacet") => {
                let [a, b, c] = corners[..] else {
                    let from = facet_line.map_or_else(String::new, |line| format!(" from line {line}"));
                    return Err(at(format!("the facet{from} has {} vertices; a facet has 3", corners.len())));
                };
                mesh.push([a, b, c]);
                facet_line = None;
            }
            _ => {}
        }
    }
    Ok(mesh)
}

impl StlMesh {
    /// For glass, turns the triangles that wind against their neighbours,
    /// and the whole mesh if it winds inside out ([`winding`]), with their
    /// normals.
    pub fn orient(&mut self, glass: bool) -> Turned {
        let mut turned = winding::orient(&self.positions, &mut self.indices, Normals::Flat, glass);
        turned.whole_file(&mut self.indices);
        // Each triangle's corners are its own three, in order until turned
        // (copies left out leave theirs unused).
        for &[first, second, _] in &self.indices {
            if second != first + 1 {
                let first = first as usize;
                self.normals[first..first + 3].iter_mut().for_each(|n| *n = -*n);
            }
        }
        turned
    }

    fn with_capacity(triangles: usize) -> StlMesh {
        let triangles = triangles.min(MAX_RESERVE);
        StlMesh {
            positions: Vec::with_capacity(3 * triangles + 1),
            indices: Vec::with_capacity(triangles),
            normals: Vec::with_capacity(3 * triangles),
        }
    }

    /// Adds a triangle of `corners`, with its own normal at each.
    fn push(&mut self, corners: [Vec3; 3]) {
        let first = self.positions.len() as u32;
        let [a, b, c] = corners;
        let normal = numeric::unit_cross(b - a, c - a).unwrap_or(Vec3::ZERO);
        self.positions.extend(corners);
        self.normals.extend([normal; 3]);
        self.indices.push([first, first + 1, first + 2]);
    }
}

/// Writes triangles as a binary STL file: each with its normal and
/// corners. (Vertex normals have no place in the format: read back, the
/// triangles shade flat.)
pub fn write_binary(mut out: impl Write, positions: &[Vec3], indices: &[[u32; 3]]) -> std::io::Result<()> {
    let count = u32::try_from(indices.len()).map_err(|_| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, "STL counts at most 2^32 - 1 triangles")
    })?;
    // (Not beginning with `solid`: readers that go by that take it for ASCII.)
    let mut header = b"binary STL written by caustix".to_vec();
    header.resize(80, b' ');
    header.extend_from_slice(&count.to_le_bytes());
    out.write_all(&header)?;
    crate::files::write_records(&mut out, indices, |record, t| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let normal = numeric::unit_cross(b - a, c - a).unwrap_or(Vec3::ZERO);
        for v in [normal, a, b, c] {
            v.to_array().iter().for_each(|x| record.extend_from_slice(&x.to_le_bytes()));
        }
        record.extend_from_slice(&[0, 0]);
    })?;
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load_bytes(bytes: &[u8]) -> Result<StlMesh> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.stl");
        std::fs::write(&path, bytes).unwrap();
        load(&path)
    }

    /// A binary file of `triangles`, its header beginning with `header`.
    fn binary(header: &[u8], triangles: &[[Vec3; 3]]) -> Vec<u8> {
        let mut bytes = header.to_vec();
        bytes.resize(80, b' ');
        bytes.extend((triangles.len() as u32).to_le_bytes());
        for t in triangles {
            bytes.extend([0u8; 12]); // a zero normal, as many files have
            for c in t {
                c.to_array().iter().for_each(|x| bytes.extend(x.to_le_bytes()));
            }
            bytes.extend([0u8; 2]);
        }
        bytes
    }

    const SQUARE: [[Vec3; 3]; 2] =
        [[Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]];

    #[test]
    fn binary_and_ascii_read_alike_with_flat_normals() {
        let ascii = "solid square\n facet normal 0 0 0\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n\
                     vertex 0 1 0\n  endloop\n endfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\n\
                     vertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid square\n";
        // A binary file whose header begins with `solid` is still binary;
        // an ASCII one whose name is in Latin-1 (`caf\xe9`) is read.
        let latin1 = [&b"solid caf\xe9"[..], &ascii.as_bytes()["solid square".len()..]].concat();
        for bytes in
            [binary(b"solid but binary", &SQUARE), binary(b"", &SQUARE), ascii.as_bytes().to_vec(), latin1]
        {
            let m = load_bytes(&bytes).unwrap();
            assert_eq!(m.positions, SQUARE.concat());
            assert_eq!(m.indices, vec![[0, 1, 2], [3, 4, 5]]);
            assert_eq!(m.normals, vec![Vec3::Z; 6]);
            assert!(m.positions.capacity() > m.positions.len(), "room for Embree's padding");
        }
    }

    #[test]
    fn bad_files_say_what_is_wrong() {
        let err = |bytes: &[u8]| load_bytes(bytes).err().expect("should fail").to_string();
        let mut short = binary(b"", &SQUARE);
        short.truncate(short.len() - 1);
        let e = err(&short);
        assert!(e.contains("would take 184 bytes, but it has 183"), "{e}");
        assert!(err(b"abc").contains("shorter than a binary header"));
        let e = err(b"solid x\nfacet\nvertex 0 0 0\nvertex 1 0 0\nendfacet\n");
        assert!(e.contains("t.stl:5:1: the facet from line 2 has 2 vertices"), "{e}");
        let e = err(b"solid x\nfacet\nvertex 0 nan 0\n");
        assert!(e.contains("t.stl:3:1: `vertex` needs three finite numbers"), "{e}");
        let mut bad = binary(b"", &SQUARE);
        bad[84 + 50 + 12..][..4].copy_from_slice(&f32::INFINITY.to_le_bytes());
        assert!(err(&bad).contains("triangle 2 has a corner that is not finite"));
        let mut garbled = b"solid x\nfacet\n".to_vec();
        garbled.extend([0xff, 0x00, b'\n']);
        assert!(err(&garbled).contains("t.stl:3:1: not text"));
        let e = err(b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n");
        assert!(e.contains("t.stl:6:1: the file ends inside the facet from line 2"), "{e}");
        let mut endless = b"solid x\n".to_vec();
        endless.resize(1 << 20, b'x');
        let e = err(&endless);
        assert!(e.contains("t.stl:2:1: a line longer than 65536 bytes"), "{e}");
    }

    /// A tetrahedron wound inward, each triangle with corners of its own:
    /// as glass its triangles turn outward, and their normals with them.
    #[test]
    fn glass_turns_outward_with_its_normals() {
        let [a, b, c, d] = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let mut stl = StlMesh::with_capacity(4);
        for corners in [[a, b, c], [a, d, b], [a, c, d], [b, d, c]] {
            stl.push(corners);
        }
        let centre = Vec3::splat(0.25);
        let outward = |stl: &StlMesh| {
            (0..4).all(|k| {
                let [i, _, _] = stl.indices[k];
                stl.normals[3 * k..3 * k + 3].iter().all(|n| n.dot(stl.positions[i as usize] - centre) > 0.0)
            })
        };
        let inward =
            |stl: &StlMesh| (0..4).all(|k| stl.normals[3 * k].dot(stl.positions[3 * k] - centre) < 0.0);
        assert!(inward(&stl));
        let before = stl.indices.clone();
        assert_eq!(stl.orient(false), Turned::default());
        assert_eq!(stl.indices, before);
        assert_eq!(stl.orient(true).inside_out, 4);
        assert!(outward(&stl));
        // Each triangle's normal is the one its new winding gives.
        for (k, [i, j, l]) in stl.indices.iter().enumerate() {
            let [p, q, r] = [i, j, l].map(|&v| stl.positions[v as usize]);
            assert_eq!(stl.normals[3 * k], numeric::unit_cross(q - p, r - p).unwrap());
        }
    }
}
