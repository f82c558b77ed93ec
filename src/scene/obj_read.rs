//! An OBJ file's statements read into objects, in parallel: the objects,
//! vertices, faces and materials `tobj::load_obj_buf` gives with
//! `single_index` and no triangulation, and the same errors, in a fraction
//! of its time (a test holds the two to each other, file by file).
//!
//! tobj reads line by line on one thread, a `Vec` per face and a hash map
//! entry per vertex: a 2.5M-triangle OBJ took 1.5 s in it, most of the
//! file's load (BENCHMARKS.md, "OBJ files read in parallel"). Here the
//! file is cut into chunks at line ends and read in three steps:
//!
//! 1. each chunk counts its lines, `v`, `vt` and `vn` statements, faces
//!    and their corners: so that a face's relative index (`-1` for the
//!    last vertex so far) resolves where it is read, and each chunk knows
//!    where in the file's arrays its numbers and faces go (allocated once:
//!    grown as read, their copies and fresh pages were a third of the time);
//! 2. each chunk reads its numbers and faces into its parts of those
//!    arrays, and notes where among the faces come the statements that
//!    start objects or name materials;
//! 3. one walk over those statements, in the file's order, loads the MTL
//!    files as `mtllib` names them, resolves `usemtl`, and cuts the faces
//!    into objects where tobj does (a new name or material after faces);
//!    then each object's vertices are numbered in their first use, on as
//!    many threads as there are objects.
//!
//! What tobj keeps and caustix does not use is read for its errors only:
//! texture coordinates and vertex colours are counted and checked, not
//! kept (the meshes' `texcoords` and `vertex_color` stay empty). One
//! difference on purpose: a texture coordinate or normal index below about
//! -4.6e18, where tobj's index arithmetic wraps around and may read some
//! other entry, is out of bounds here.

use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

use rayon::prelude::*;
use tobj::{LoadError, MTLLoadResult, Material, Mesh, Model};

/// About this many bytes of the file to a chunk (cut at the next line end).
const CHUNK_BYTES: usize = 1 << 18;

/// A face corner's index that the corner does not give (`1//3` has no
/// texture coordinate), as tobj's `usize::MAX`.
const MISSING: u32 = u32::MAX;

/// A face corner's index outside what a `u32` holds, or below 0 (`-5` with
/// three vertices read): never valid. Its exact value is kept beside
/// ([`Read::out_of_range`]), for it still tells vertices apart where the
/// file has no texture coordinates or normals to check it against.
const OUT_OF_RANGE: u32 = u32::MAX - 1;

/// Statements read so far, of each kind, and lines.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Counts {
    /// Lines (as `str::lines` counts them).
    lines: usize,
    /// `v` statements: positions.
    v: usize,
    /// `vt`: texture coordinates.
    vt: usize,
    /// `vn`: normals.
    vn: usize,
    /// `f` and `l` statements, and their corners.
    faces: usize,
    corners: usize,
    /// Vertex colour numbers (three a coloured `v`, fewer where one fails;
    /// counted as read, not in the first count).
    colors: usize,
}

impl Counts {
    fn plus(self, other: Counts) -> Counts {
        Counts {
            lines: self.lines + other.lines,
            v: self.v + other.v,
            vt: self.vt + other.vt,
            vn: self.vn + other.vn,
            faces: self.faces + other.faces,
            corners: self.corners + other.corners,
            colors: self.colors + other.colors,
        }
    }
}

/// A statement that starts an object or names materials.
#[derive(Debug)]
enum Statement {
    /// `o` or `g`, and the name.
    Name(String),
    /// `usemtl`, and the material's name.
    UseMaterial(String),
    /// `mtllib`, and the file it names.
    MaterialLibrary(String),
}

/// A [`Statement`], and the statements of each kind in the file before it
/// (so where among the faces it comes).
#[derive(Debug)]
struct Event {
    statement: Statement,
    before: Counts,
}

/// The file's arrays, each chunk's part of them filled by that chunk.
struct Arrays {
    /// Three numbers a `v`, after any `w` divided them.
    positions: Vec<f32>,
    /// Three numbers a `vn`.
    normals: Vec<f32>,
    /// Each face's corners: position, texture coordinate and normal, as
    /// indices from 0, or [`MISSING`] or [`OUT_OF_RANGE`].
    corners: Vec<[u32; 3]>,
    /// How many corners each face has (`f` and `l` alike, as tobj reads them).
    arities: Vec<u32>,
}

/// A chunk's parts of the [`Arrays`].
struct Parts<'a> {
    positions: &'a mut [f32],
    normals: &'a mut [f32],
    corners: &'a mut [[u32; 3]],
    arities: &'a mut [u32],
}

impl Arrays {
    /// Arrays for a file of `total` statements (zeroed: their pages are
    /// first touched where a chunk writes them).
    fn new(total: Counts) -> Arrays {
        Arrays {
            positions: vec![0.0; 3 * total.v],
            normals: vec![0.0; 3 * total.vn],
            corners: vec![[0; 3]; total.corners],
            arities: vec![0; total.faces],
        }
    }

    /// Each chunk's parts, for chunks of `counts` statements.
    fn parts(&mut self, counts: &[Counts]) -> Vec<Parts<'_>> {
        let (mut positions, mut normals) = (&mut self.positions[..], &mut self.normals[..]);
        let (mut corners, mut arities) = (&mut self.corners[..], &mut self.arities[..]);
        let mut parts = Vec::with_capacity(counts.len());
        for c in counts {
            let (p, rest) = std::mem::take(&mut positions).split_at_mut(3 * c.v);
            positions = rest;
            let (n, rest) = std::mem::take(&mut normals).split_at_mut(3 * c.vn);
            normals = rest;
            let (k, rest) = std::mem::take(&mut corners).split_at_mut(c.corners);
            corners = rest;
            let (a, rest) = std::mem::take(&mut arities).split_at_mut(c.faces);
            arities = rest;
            parts.push(Parts { positions: p, normals: n, corners: k, arities: a });
        }
        parts
    }
}

/// What a chunk's reading found beside its parts of the [`Arrays`].
#[derive(Debug, Default)]
struct Read {
    /// The corners holding an [`OUT_OF_RANGE`] index, by their place in
    /// the file's corners, with the indices they gave (as tobj's wrapped
    /// `usize`).
    out_of_range: Vec<(usize, [u64; 3])>,
    events: Vec<Event>,
    /// The lines (from 1) of its `f` statements of fewer than three corners.
    short_faces: Vec<usize>,
    /// Its statements of each kind, as read (with the colours).
    counts: Counts,
    /// The error of the first statement it could not read (the events
    /// before it are good).
    error: Option<LoadError>,
}

/// What an OBJ file holds, as tobj reads it.
pub(super) struct ObjText {
    /// Its objects (cut where a name or material changes after faces).
    pub models: Vec<Model>,
    /// The materials of its MTL files, or the error of one where none loaded.
    pub materials: Result<Vec<Material>, LoadError>,
    /// The lines (from 1) of its `f` statements of fewer than three corners.
    pub short_faces: Vec<usize>,
}

/// The objects and materials of the OBJ `text`, as `tobj::load_obj_buf`
/// with `single_index: true` and `triangulate: false` reads them (but for
/// texture coordinates and vertex colours, not kept), or the error tobj
/// gives; `load_materials` is called for each `mtllib`, in order, as tobj
/// calls it.
pub(super) fn read(
    text: &str,
    load_materials: impl FnMut(&Path) -> MTLLoadResult,
) -> Result<ObjText, LoadError> {
    read_in_chunks(text, CHUNK_BYTES, load_materials)
}

/// [`read`], with chunks of about `chunk_bytes`.
fn read_in_chunks(
    text: &str,
    chunk_bytes: usize,
    load_materials: impl FnMut(&Path) -> MTLLoadResult,
) -> Result<ObjText, LoadError> {
    let chunks = cut(text, chunk_bytes);
    let counted: Vec<Counts> = chunks.par_iter().map(|chunk| count(chunk)).collect();
    let (before, total) = running_totals(counted.iter().copied());
    let mut arrays = Arrays::new(total);
    let read: Vec<Read> = (chunks.par_iter().zip(&before))
        .zip(arrays.parts(&counted))
        .map(|((text, &before), parts)| read_chunk(text, before, parts))
        .collect();
    let Walked { objects, materials, stopped } = walk(&read, &before, total, load_materials);

    let out_of_range: Vec<(usize, [u64; 3])> =
        read.iter().flat_map(|r| r.out_of_range.iter().copied()).collect();
    let all = All { arrays: &arrays, out_of_range: &out_of_range };
    let meshes: Vec<Result<Mesh, LoadError>> = objects.par_iter().map(|object| all.mesh(object)).collect();
    let mut models = Vec::with_capacity(objects.len());
    for (object, mesh) in objects.into_iter().zip(meshes) {
        models.push(Model::new(mesh?, object.name));
    }
    if let Some(index) = stopped {
        return Err(read[index].error.expect("the chunk that stopped has an error"));
    }
    let short_faces = read.iter().flat_map(|r| &r.short_faces).copied().collect();
    Ok(ObjText { models, materials: materials.into_result(), short_faces })
}

/// Each chunk's statements before it, of chunks that hold `counts`, and
/// all of them.
fn running_totals(counts: impl Iterator<Item = Counts>) -> (Vec<Counts>, Counts) {
    let mut total = Counts::default();
    let before = counts
        .map(|c| {
            let before = total;
            total = total.plus(c);
            before
        })
        .collect();
    (before, total)
}

/// What the walk over the chunks' statements found.
struct Walked {
    /// The objects, as tobj cuts them.
    objects: Vec<Object>,
    materials: Materials,
    /// The chunk whose error stopped the walk, if one did.
    stopped: Option<usize>,
}

/// Walks over the statements the chunks `read` (of which `before[i]` come
/// before chunk `i`, and `total` in all), in the file's order: loads
/// the MTL files as `mtllib` names them, and cuts the faces into objects
/// where tobj does, at a new name or material after faces; stops at the
/// first chunk that could not be read whole.
fn walk(
    read: &[Read],
    before: &[Counts],
    total: Counts,
    mut load_materials: impl FnMut(&Path) -> MTLLoadResult,
) -> Walked {
    let mut materials = Materials::default();
    let mut objects: Vec<Object> = Vec::new();
    let mut current = Object::new("unnamed_object".to_owned(), None, Counts::default());
    // (The colours only reading counts.)
    let mut colors = 0;
    for (index, chunk) in read.iter().enumerate() {
        for event in &chunk.events {
            let at = Counts { colors: colors + event.before.colors, ..before[index].plus(event.before) };
            match &event.statement {
                Statement::Name(name) => {
                    if current.has_faces(at) {
                        let next = Object::new(String::new(), current.material, at);
                        objects.push(std::mem::replace(&mut current, next).ended(at));
                    }
                    current.name.clone_from(name);
                }
                Statement::UseMaterial(name) => {
                    let material = materials.named(name);
                    if current.material != material && current.has_faces(at) {
                        let next = Object::new(current.name.clone(), material, at);
                        objects.push(std::mem::replace(&mut current, next).ended(at));
                    }
                    current.material = material;
                }
                Statement::MaterialLibrary(path) => materials.merge(load_materials(Path::new(path))),
            }
        }
        if chunk.error.is_some() {
            return Walked { objects, materials, stopped: Some(index) };
        }
        colors += chunk.counts.colors;
    }
    objects.push(current.ended(Counts { colors, ..total }));
    Walked { objects, materials, stopped: None }
}

/// `text` cut into chunks of about `bytes`, each ending at a line's end
/// (but the last).
fn cut(text: &str, bytes: usize) -> Vec<&str> {
    let mut chunks = Vec::with_capacity(text.len() / bytes.max(1) + 1);
    let mut rest = text;
    while rest.len() > bytes {
        // (A line end is one byte: never inside a character.)
        match rest.as_bytes()[bytes..].iter().position(|&b| b == b'\n') {
            Some(at) => {
                let (chunk, after) = rest.split_at(bytes + at + 1);
                chunks.push(chunk);
                rest = after;
            }
            None => break,
        }
    }
    if !rest.is_empty() {
        chunks.push(rest);
    }
    chunks
}

/// The lines, `v`, `vt` and `vn` statements, and faces and their corners
/// of a chunk (vertex colours are counted as they are read).
fn count(text: &str) -> Counts {
    let mut counts = Counts::default();
    for line in text.lines() {
        counts.lines += 1;
        let mut words = Words::of(line);
        match words.next().map(keyword) {
            Some(Keyword::Position) => counts.v += 1,
            Some(Keyword::TextureCoordinate) => counts.vt += 1,
            Some(Keyword::Normal) => counts.vn += 1,
            Some(Keyword::Face | Keyword::Line) => {
                counts.faces += 1;
                counts.corners += words.count();
            }
            _ => {}
        }
    }
    counts
}

/// Reads a chunk whose statements (and lines) come after `before` of each
/// kind into its `parts` of the file's arrays.
fn read_chunk(text: &str, before: Counts, mut parts: Parts) -> Read {
    let mut read = Read::default();
    for (i, line) in text.lines().enumerate() {
        if let Err(e) = read_line(line, before.lines + i + 1, before, &mut parts, &mut read) {
            read.error = Some(e);
            break;
        }
    }
    read
}

/// Reads one line, line `number` of the file, into `parts` (where `read`
/// counts) and `read`, as tobj's `parse_obj_line` reads it.
fn read_line(
    line: &str,
    number: usize,
    before: Counts,
    parts: &mut Parts,
    read: &mut Read,
) -> Result<(), LoadError> {
    let mut words = Words::of(line);
    let Some(first_word) = words.next() else { return Ok(()) };
    let counts = &mut read.counts;
    let mut event = |statement, counts: Counts| read.events.push(Event { statement, before: counts });
    match keyword(first_word) {
        Keyword::Position => {
            let p: [f32; 3] = numbers(&mut words).ok_or(LoadError::PositionParseError)?;
            let position = &mut parts.positions[3 * counts.v..3 * counts.v + 3];
            position.copy_from_slice(&p);
            counts.v += 1;
            // Then nothing, `w` (dividing the three), or a colour.
            let Some(first) = words.next() else { return Ok(()) };
            match (words.next(), words.next()) {
                (None, _) => {
                    let w: f32 = first.parse().map_err(|_| LoadError::PositionParseError)?;
                    if w == 0.0 {
                        return Err(LoadError::ScalingByZeroError);
                    }
                    position.iter_mut().for_each(|c| *c /= w);
                }
                (Some(_), None) => return Err(LoadError::ColorParseError),
                (Some(second), Some(third)) => {
                    if words.next().is_some() {
                        return Err(LoadError::ColorParseError);
                    }
                    // As tobj: the numbers up to the first that is none.
                    counts.colors +=
                        [first, second, third].iter().take_while(|w| w.parse::<f32>().is_ok()).count();
                }
            }
        }
        Keyword::TextureCoordinate => {
            let _: [f32; 2] = numbers(&mut words).ok_or(LoadError::TexcoordParseError)?;
            counts.vt += 1;
        }
        Keyword::Normal => {
            let n: [f32; 3] = numbers(&mut words).ok_or(LoadError::NormalParseError)?;
            parts.normals[3 * counts.vn..3 * counts.vn + 3].copy_from_slice(&n);
            counts.vn += 1;
        }
        kind @ (Keyword::Face | Keyword::Line) => {
            let so_far = before.plus(*counts);
            let start = counts.corners;
            for word in words {
                let (corner, exact) = corner(word, so_far).ok_or(LoadError::FaceParseError)?;
                if corner.contains(&OUT_OF_RANGE) {
                    read.out_of_range.push((before.corners + counts.corners, exact));
                }
                parts.corners[counts.corners] = corner;
                counts.corners += 1;
            }
            let arity = counts.corners - start;
            if kind == Keyword::Face && arity < 3 {
                read.short_faces.push(number);
            }
            parts.arities[counts.faces] = arity as u32;
            counts.faces += 1;
        }
        Keyword::Object => {
            // (As tobj: all after the line's first character, trimmed.)
            let first = line.chars().next().map_or(0, char::len_utf8);
            let name = line[first..].trim();
            let name = if name.is_empty() { "unnamed_object" } else { name };
            event(Statement::Name(name.to_owned()), *counts);
        }
        Keyword::MaterialLibrary => {
            let path = line.split_once(' ').unwrap_or_default().1.trim();
            event(Statement::MaterialLibrary(path.to_owned()), *counts);
        }
        Keyword::UseMaterial => {
            let name = line.split_once(' ').unwrap_or_default().1.trim();
            if name.is_empty() {
                return Err(LoadError::MaterialParseError);
            }
            event(Statement::UseMaterial(name.to_owned()), *counts);
        }
        Keyword::Other => {}
    }
    Ok(())
}

/// The statements tobj reads, by their first word.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Keyword {
    /// `v`
    Position,
    /// `vt`
    TextureCoordinate,
    /// `vn`
    Normal,
    /// `f`
    Face,
    /// `l`
    Line,
    /// `o` or `g`
    Object,
    /// `mtllib`
    MaterialLibrary,
    /// `usemtl`
    UseMaterial,
    /// Any other (comments among them), passed over.
    Other,
}

/// The statement a line's first word starts (compared as bytes: as `str`
/// each comparison was a call to `memcmp`).
fn keyword(word: &str) -> Keyword {
    match word.as_bytes() {
        b"v" => Keyword::Position,
        b"vt" => Keyword::TextureCoordinate,
        b"vn" => Keyword::Normal,
        b"f" => Keyword::Face,
        b"l" => Keyword::Line,
        b"o" | b"g" => Keyword::Object,
        b"mtllib" => Keyword::MaterialLibrary,
        b"usemtl" => Keyword::UseMaterial,
        _ => Keyword::Other,
    }
}

/// A line's words, split where `str::split_whitespace` splits them (at
/// Unicode white space), but a byte at a time where the line is ASCII
/// (`split_whitespace` was a sixth of the file's reading).
struct Words<'a> {
    line: &'a str,
    at: usize,
    /// The line's words where it is not ASCII.
    unicode: Option<std::str::SplitWhitespace<'a>>,
}

impl<'a> Words<'a> {
    fn of(line: &'a str) -> Words<'a> {
        Words { line, at: 0, unicode: (!line.is_ascii()).then(|| line.split_whitespace()) }
    }
}

/// Whether an ASCII byte is white space, as `char::is_whitespace` says
/// (the vertical tab too, which `u8::is_ascii_whitespace` leaves out).
fn is_space(byte: u8) -> bool {
    byte == b' ' || (b'\t'..=b'\r').contains(&byte)
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a str;

    fn next(&mut self) -> Option<&'a str> {
        if let Some(words) = &mut self.unicode {
            return words.next();
        }
        let bytes = self.line.as_bytes();
        while self.at < bytes.len() && is_space(bytes[self.at]) {
            self.at += 1;
        }
        let start = self.at;
        while self.at < bytes.len() && !is_space(bytes[self.at]) {
            self.at += 1;
        }
        (self.at > start).then(|| &self.line[start..self.at])
    }
}

/// The next `N` of `words` as numbers; `None` where fewer than `N` are
/// left or one is not a number (tobj's `parse_floatn`).
fn numbers<const N: usize>(words: &mut Words) -> Option<[f32; N]> {
    let mut out = [0.0; N];
    for number in &mut out {
        *number = words.next()?.parse().ok()?;
    }
    Some(out)
}

/// A face corner `word` (`v`, `v/vt`, `v//vn` or `v/vt/vn`, each counted
/// from 1, or from the end when negative) after `so_far` statements: its
/// indices from 0 as [`Chunk::corners`] holds them, and as tobj's `usize`
/// (wrapped where below 0); `None` where it is not a corner.
fn corner(word: &str, so_far: Counts) -> Option<([u32; 3], [u64; 3])> {
    let mut exact = [u64::MAX; 3];
    // (Split at the bytes of `/`: as `str::split` it was a tenth of the
    // file's reading.)
    let mut rest = Some(word);
    let mut slot = 0;
    while let Some(parts) = rest {
        let part = match parts.bytes().position(|b| b == b'/') {
            Some(at) => {
                rest = Some(&parts[at + 1..]);
                &parts[..at]
            }
            None => {
                rest = None;
                parts
            }
        };
        if !part.is_empty() {
            let x: i64 = part.parse().ok()?;
            let size = [so_far.v, so_far.vt, so_far.vn].get(slot).copied()? as i64;
            let index = if x < 0 { size.wrapping_add(x) } else { x.wrapping_sub(1) };
            exact[slot] = index as u64;
        }
        slot += 1;
    }
    let compact = exact.map(|i| match i {
        u64::MAX => MISSING,
        i if i < u64::from(OUT_OF_RANGE) => i as u32,
        _ => OUT_OF_RANGE,
    });
    Some((compact, exact))
}

/// The MTL files' materials as `mtllib` statements load them (tobj's
/// `TmpMaterials`): a later file's material of a name already known wins it.
#[derive(Default)]
struct Materials {
    list: Vec<Material>,
    by_name: HashMap<String, usize>,
    error: Option<LoadError>,
}

impl Materials {
    fn merge(&mut self, loaded: MTLLoadResult) {
        match loaded {
            Ok((mut list, names)) => {
                let offset = self.list.len();
                self.list.append(&mut list);
                self.by_name.extend(names.into_iter().map(|(name, i)| (name, i + offset)));
            }
            Err(e) => self.error = Some(e),
        }
    }

    fn named(&self, name: &str) -> Option<usize> {
        self.by_name.get(name).copied()
    }

    /// The materials; an MTL file's error only where none loaded.
    fn into_result(self) -> Result<Vec<Material>, LoadError> {
        match self.error {
            Some(e) if self.list.is_empty() => Err(e),
            _ => Ok(self.list),
        }
    }
}

/// One object: a run of the file's faces, with its name and material.
struct Object {
    name: String,
    material: Option<usize>,
    /// Its faces, and their corners.
    faces: Range<usize>,
    corners: Range<usize>,
    /// The statements of each kind read when it ended.
    ended_at: Counts,
}

impl Object {
    /// An object of `name` and `material` whose faces start after `at`.
    fn new(name: String, material: Option<usize>, at: Counts) -> Object {
        Object { name, material, faces: at.faces..at.faces, corners: at.corners..at.corners, ended_at: at }
    }

    /// Whether it has faces up to `at`.
    fn has_faces(&self, at: Counts) -> bool {
        at.faces > self.faces.start
    }

    /// The object ended at `at`.
    fn ended(mut self, at: Counts) -> Object {
        self.faces.end = at.faces;
        self.corners.end = at.corners;
        self.ended_at = at;
        self
    }
}

/// An object's vertices, numbered in the order of their first use: a
/// vertex is a position, texture coordinate and normal index, as tobj's
/// `single_index` makes them. Found through a table over the positions the
/// object uses (where they lie close enough for one) and a map for the
/// rest (a position used with other texture coordinates or normals, or an
/// index out of range).
struct Numbering {
    /// The least position the object uses.
    low: u32,
    /// Each position's (from `low`) first vertex, or `u32::MAX`.
    first: Vec<u32>,
    /// Each vertex's texture coordinate and normal.
    keys: Vec<[u32; 2]>,
    /// The vertices not in `first`, by their exact indices.
    others: HashMap<[u64; 3], u32>,
}

impl Numbering {
    /// For an object using `positions` (valid ones).
    fn new(positions: impl Iterator<Item = u32>) -> Numbering {
        let (low, high, count) =
            positions.fold((u32::MAX, 0, 0), |(low, high, count), v| (low.min(v), high.max(v), count + 1));
        let low = low.min(high);
        let span = (high - low) as usize + 1;
        let first = if span <= 4 * count + 4096 { vec![u32::MAX; span] } else { Vec::new() };
        Numbering { low, first, keys: Vec::new(), others: HashMap::new() }
    }

    /// Where `corner`'s position keeps its first vertex, if the table has
    /// it (a corner with an index out of range is found by its exact
    /// indices only).
    fn slot(&self, [v, vt, vn]: [u32; 3]) -> Option<usize> {
        let slot = (v - self.low) as usize;
        (vt != OUT_OF_RANGE && vn != OUT_OF_RANGE && slot < self.first.len()).then_some(slot)
    }

    /// The vertex numbered for `corner` (whose exact indices `exact` gives), if any.
    fn find(&self, corner: [u32; 3], exact: impl Fn() -> [u64; 3]) -> Option<u32> {
        match self.slot(corner).map(|slot| self.first[slot]) {
            // (No vertex of this position yet: none in the map either.)
            Some(u32::MAX) => None,
            Some(index) if self.keys[index as usize] == [corner[1], corner[2]] => Some(index),
            _ => self.others.get(&exact()).copied(),
        }
    }

    /// Numbers `corner`'s vertex, found by [`Numbering::find`] from now on.
    fn add(&mut self, corner: [u32; 3], exact: impl Fn() -> [u64; 3]) -> u32 {
        let index = self.keys.len() as u32;
        self.keys.push([corner[1], corner[2]]);
        match self.slot(corner) {
            Some(slot) if self.first[slot] == u32::MAX => self.first[slot] = index,
            _ => {
                self.others.insert(exact(), index);
            }
        }
        index
    }
}

/// The file's arrays, and the exact indices of corners out of range.
struct All<'a> {
    arrays: &'a Arrays,
    out_of_range: &'a [(usize, [u64; 3])],
}

impl All<'_> {
    /// `object`'s mesh, its vertices numbered in the order of their first
    /// use, as tobj's `export_faces` numbers them, with its errors for an
    /// index beyond what had been read when the object ended.
    fn mesh(&self, object: &Object) -> Result<Mesh, LoadError> {
        let counts = object.ended_at;
        let corners = &self.arrays.corners[object.corners.clone()];
        let mut numbering = Numbering::new(corners.iter().map(|c| c[0]).filter(|&v| (v as usize) < counts.v));
        let mut mesh = Mesh { material_id: object.material, ..Default::default() };
        for (i, &corner) in object.corners.clone().zip(corners) {
            let exact = || match self.out_of_range.binary_search_by_key(&i, |&(at, _)| at) {
                Ok(k) => self.out_of_range[k].1,
                Err(_) => corner.map(|i| if i == MISSING { u64::MAX } else { u64::from(i) }),
            };
            if corner[0] as usize >= counts.v {
                return Err(LoadError::FaceVertexOutOfBounds);
            }
            let index = match numbering.find(corner, exact) {
                Some(index) => index,
                None => {
                    self.add_vertex(&mut mesh, corner, counts)?;
                    numbering.add(corner, exact)
                }
            };
            mesh.indices.push(index);
        }
        let arities = &self.arrays.arities[object.faces.clone()];
        if arities.iter().any(|&a| a != 3) {
            mesh.face_arities = arities.to_vec();
        }
        Ok(mesh)
    }

    /// Adds a vertex's position and normal to `mesh`, or tobj's error for
    /// an index beyond what had been read (`counts`); a texture coordinate
    /// or colour is checked only, where the file has them.
    fn add_vertex(&self, mesh: &mut Mesh, [v, vt, vn]: [u32; 3], counts: Counts) -> Result<(), LoadError> {
        let v = v as usize;
        mesh.positions.extend_from_slice(&self.arrays.positions[3 * v..3 * v + 3]);
        if counts.vt > 0 && vt != MISSING && vt as usize >= counts.vt {
            return Err(LoadError::FaceTexCoordOutOfBounds);
        }
        if counts.vn > 0 && vn != MISSING {
            let vn = vn as usize;
            if vn >= counts.vn {
                return Err(LoadError::FaceNormalOutOfBounds);
            }
            mesh.normals.extend_from_slice(&self.arrays.normals[3 * vn..3 * vn + 3]);
        }
        if counts.colors > 0 && 3 * v + 2 >= counts.colors {
            return Err(LoadError::FaceColorOutOfBounds);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::RngSeed;

    /// `cases` cases from a fixed seed (the same files in every run, as
    /// `tests/fuzz.rs` does; `PROPTEST_CASES` and `PROPTEST_RNG_SEED` for
    /// more or others), none written to disk.
    fn config(cases: u32) -> ProptestConfig {
        let var = |name: &str| std::env::var(name).ok().and_then(|v| v.parse().ok());
        ProptestConfig {
            cases: var("PROPTEST_CASES").map_or(cases, |c: u64| c as u32),
            rng_seed: RngSeed::Fixed(var("PROPTEST_RNG_SEED").unwrap_or(7)),
            failure_persistence: None,
            ..ProptestConfig::default()
        }
    }

    /// The MTL files the test files may name: two that share a name, and
    /// one that is not there.
    fn materials(path: &Path) -> MTLLoadResult {
        let text = match path.to_str() {
            Some("a.mtl") => "newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\n",
            Some("b.mtl") => "newmtl green\nKd 0 0.5 0\nnewmtl blue\nKd 0 0 1\n",
            _ => return Err(LoadError::OpenFileFailed),
        };
        tobj::load_mtl_buf(&mut text.as_bytes())
    }

    /// Where `read_in_chunks` with chunks of `chunk_bytes` and tobj read
    /// `text` differently, said; both fail alike or give the same objects
    /// (texture coordinates and vertex colours aside: not kept here).
    fn differs(text: &str, chunk_bytes: usize) -> Option<String> {
        let options = tobj::LoadOptions { triangulate: false, single_index: true, ..Default::default() };
        let theirs = tobj::load_obj_buf(&mut text.as_bytes(), &options, materials);
        let ours = read_in_chunks(text, chunk_bytes, materials);
        let (theirs, ours) = match (theirs, ours) {
            (Err(a), Err(b)) => return (a != b).then(|| format!("errors {a:?} and {b:?}")),
            (Ok(a), Ok(b)) => {
                // Faces of fewer than three corners, by line.
                let short: Vec<usize> = text
                    .lines()
                    .enumerate()
                    .filter(|(_, line)| {
                        let mut words = line.split_whitespace();
                        words.next() == Some("f") && words.count() < 3
                    })
                    .map(|(i, _)| i + 1)
                    .collect();
                if b.short_faces != short {
                    return Some(format!("short faces on lines {:?}, not {short:?}", b.short_faces));
                }
                (a, (b.models, b.materials))
            }
            (a, b) => return Some(format!("tobj {:?}, ours {:?}", a.err(), b.err())),
        };
        let names = |m: &Result<Vec<Material>, LoadError>| {
            m.as_ref().map(|list| list.iter().map(|m| m.name.clone()).collect::<Vec<_>>()).map_err(|e| *e)
        };
        if names(&theirs.1) != names(&ours.1) {
            return Some(format!("materials {:?} and {:?}", names(&theirs.1), names(&ours.1)));
        }
        if theirs.0.len() != ours.0.len() {
            return Some(format!("{} objects and {}", theirs.0.len(), ours.0.len()));
        }
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for (i, (a, b)) in theirs.0.iter().zip(&ours.0).enumerate() {
            let (m, n) = (&a.mesh, &b.mesh);
            let same = a.name == b.name
                && bits(&m.positions) == bits(&n.positions)
                && bits(&m.normals) == bits(&n.normals)
                && m.indices == n.indices
                && m.face_arities == n.face_arities
                && m.material_id == n.material_id;
            if !same {
                return Some(format!("object {i}: tobj {a:?}\nours {b:?}"));
            }
        }
        None
    }

    /// `text` read alike by tobj and here, whatever the chunks' size.
    fn assert_read_alike(text: &str) {
        for chunk_bytes in [0, 1, 7, 40, CHUNK_BYTES] {
            if let Some(what) = differs(text, chunk_bytes) {
                panic!("chunks of {chunk_bytes} bytes: {what}\nin:\n{text}");
            }
        }
    }

    #[test]
    fn files_read_as_tobj_reads_them() {
        let files = [
            "",
            "# nothing\n\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            // Relative indices, texture coordinates and normals in each form.
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\nf -3/-2/-1 -2/-1/-1 -1//-1\nf 1/1 2/2 3/2\n",
            // A position used with two normals is two vertices.
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\nf 1//2 3//2 2//2\nf 1//1 2//1 3//1\n",
            // Objects, groups and materials cut the faces where tobj does.
            "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\no first\nusemtl red\nf 1 2 3\nusemtl red\nf 1 2 3\n\
             usemtl green\nf 3 2 1\ng\nf 1 2 3\no  spaced  name \r\nusemtl unknown\nf 1 2 3\n",
            // A later MTL file's material of the same name; one not there.
            "mtllib a.mtl b.mtl\nmtllib missing.mtl\nmtllib b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl green\nf 1 2 3\n",
            "usemtl red\nmtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl red\nf 1 2 3\n",
            // Points, lines, quads, polygons and an empty face.
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\nf 1\nl 1 2\nf 1 2 3 4\nf 1 2 3 5 4\nf\n",
            // `w`, colours, and the colours' check.
            "v 2 4 6 2\nv 1 0 0 1 0.5 0.25\nv 0 1 0 1 1 1\nf 1 2 3\n",
            "v 0 0 0 1 1 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0 1 1 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\no next\nf 1 1 1\n",
            // Forward references within an object, and past its end.
            "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n",
            "f 1 2 3\no next\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            // Errors.
            "v 0 0\n",
            "v 0 0 0 0\n",
            "v 0 0 0 1 1\n",
            "vt 0\n",
            "vn 0 0 x\n",
            "v 0 0 0\nf 1 2 x\n",
            "v 0 0 0\nf 1/1/1/1 1 1\n",
            "v 0 0 0\nf 0 1 1\n",
            "v 0 0 0\nf -2 1 1\n",
            "v 0 0 0\nvt 0 0\nf 1/2 1/1 1/1\n",
            "v 0 0 0\nvn 0 0 1\nf 1//2 1//1 1//1\n",
            "usemtl\n",
            "usemtl\tred\n",
            // Indices out of range where the file has none of their kind.
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/9/9 2/-7/9 3/0/-5\nf 1/9/9 2/-8/9 3/0/-5\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/99999999999 2 3\nf 1/99999999999 2 3\nf 1/99999999998 2 3\n",
            // An error after objects that ended: the first error wins.
            "v 0 0 0\nf 1 2 3\no b\nv 1 1\n",
            "\u{feff}v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n",
        ];
        for text in files {
            assert_read_alike(text);
        }
    }

    /// A number as a file may write it.
    fn number() -> BoxedStrategy<String> {
        prop_oneof![(-3i32..4).prop_map(|n| n.to_string()), (-100.0f32..100.0).prop_map(|x| x.to_string())]
            .boxed()
    }

    /// An index of a face corner into `n` statements of its kind, from 1
    /// or from the end; with `hostile`, sometimes out of range or no number.
    fn index(n: i64, hostile: bool) -> BoxedStrategy<String> {
        let n = n.max(1);
        let good = prop_oneof![(1..=n).prop_map(|i| i.to_string()), (-n..=-1).prop_map(|i| i.to_string())];
        let bad = prop_oneof![
            (-2 * n - 2..3 * n + 2).prop_map(|i| i.to_string()),
            Just("99999999999".to_string()),
            Just("x".to_string()),
        ];
        if hostile {
            prop_oneof![12 => good, 1 => bad].boxed()
        } else {
            good.boxed()
        }
    }

    /// A statement of an OBJ file that starts with `v` positions, `t`
    /// texture coordinates and `n` normals; with `hostile`, sometimes one
    /// tobj refuses.
    fn statement(v: i64, t: i64, n: i64, hostile: bool) -> BoxedStrategy<String> {
        let corner = (index(v, hostile), index(t, hostile), index(n, hostile), 0..4usize)
            .prop_map(|(v, t, n, form)| match form {
                0 => v,
                1 => format!("{v}/{t}"),
                2 => format!("{v}//{n}"),
                _ => format!("{v}/{t}/{n}"),
            })
            .boxed();
        let name = prop_oneof![Just("red"), Just("green"), Just("blue"), Just("grey")];
        let bad = prop_oneof![
            prop::collection::vec(prop_oneof![number(), Just("x".to_string())], 0..8)
                .prop_map(|n| format!("v {}", n.join(" "))),
            Just("vt 1".to_string()),
            Just("vn 0 x 1".to_string()),
            Just("usemtl".to_string()),
            Just("v 1 2 3 0".to_string()),
            (number(), number(), number()).prop_map(|(a, b, c)| format!("v {a} {b} {c} 0.5 1 0.25")),
            prop::collection::vec(corner.clone(), 0..3).prop_map(|c| format!("f {}", c.join(" "))),
        ];
        let good = prop_oneof![
            4 => (number(), number(), number()).prop_map(|(a, b, c)| format!("v {a} {b} {c}")),
            1 => (number(), number(), number(), 1..4i32).prop_map(|(a, b, c, w)| format!("v {a} {b} {c} {w}")),
            1 => (number(), number()).prop_map(|(a, b)| format!("vt {a} {b}")),
            1 => (number(), number(), number()).prop_map(|(a, b, c)| format!("vn {a} {b} {c}")),
            12 => prop::collection::vec(corner.clone(), 3..6).prop_map(|c| format!("f {}", c.join(" "))),
            1 => prop::collection::vec(corner, 1..3).prop_map(|c| format!("l {}", c.join(" "))),
            2 => (prop_oneof![Just("o"), Just("g"), Just("  o"), Just("g ")], name.clone())
                .prop_map(|(kind, n)| format!("{kind} {n}")),
            3 => name.prop_map(|n| format!("usemtl {n}")),
            1 => prop_oneof![Just("mtllib a.mtl"), Just("mtllib b.mtl"), Just("mtllib missing.mtl")]
                .prop_map(String::from),
            1 => prop_oneof![Just("# comment"), Just(""), Just("s 1"), Just("f"), Just("o")].prop_map(String::from),
        ];
        if hostile {
            prop_oneof![28 => good, 1 => bad].boxed()
        } else {
            good.boxed()
        }
    }

    /// An OBJ file: some positions, texture coordinates and normals, then
    /// statements of every kind; one in four hostile.
    fn file() -> impl Strategy<Value = String> {
        (3..10i64, 0..4i64, 0..4i64, prop::bool::weighted(0.25), any::<bool>()).prop_flat_map(
            |(v, t, n, hostile, crlf)| {
                let head: Vec<String> = (0..v)
                    .map(|i| format!("v {i} {} 0", i % 3))
                    .chain((0..t).map(|i| format!("vt {i} 0")))
                    .chain((0..n).map(|i| format!("vn 0 {i} 1")))
                    .collect();
                prop::collection::vec(statement(v, t, n, hostile), 0..40).prop_map(move |body| {
                    let lines: Vec<&str> = head.iter().chain(&body).map(String::as_str).collect();
                    lines.join(if crlf { "\r\n" } else { "\n" })
                })
            },
        )
    }

    proptest! {
        #![proptest_config(config(256))]
        #[test]
        fn words_split_where_split_whitespace_splits(
            chars in prop_oneof![
                // ASCII lines (split a byte at a time), and others.
                prop::collection::vec(
                    prop_oneof![
                        Just(' '), Just('\t'), Just('\u{0b}'), Just('\u{0c}'), Just('\r'), Just('\n'),
                        Just('\u{1f}'), Just('!'), Just('a'), Just('/'), Just('1'),
                    ],
                    0..24,
                ),
                prop::collection::vec(
                    prop_oneof![
                        Just(' '), Just('\t'), Just('\u{0b}'), Just('\u{85}'), Just('\u{a0}'), Just('\u{2003}'),
                        Just('\u{3000}'), Just('\u{feff}'), Just('é'), Just('a'),
                    ],
                    0..24,
                ),
            ]
        ) {
            let line: String = chars.into_iter().collect();
            let ours: Vec<&str> = Words::of(&line).collect();
            prop_assert_eq!(ours, line.split_whitespace().collect::<Vec<_>>());
        }
    }

    proptest! {
        #![proptest_config(config(400))]
        #[test]
        fn any_file_is_read_as_tobj_reads_it(text in file()) {
            for chunk_bytes in [0, 9, CHUNK_BYTES] {
                let what = differs(&text, chunk_bytes);
                prop_assert!(what.is_none(), "chunks of {chunk_bytes} bytes: {}\nin:\n{text}", what.unwrap());
            }
        }
    }
}
