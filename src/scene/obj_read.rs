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
//! 1. each chunk counts its `v`, `vt` and `vn` statements (so that a face's
//!    relative index, `-1` for the last vertex so far, resolves where it
//!    is read);
//! 2. each chunk reads its numbers and faces, and notes the statements that
//!    start objects or name materials where they come among its faces;
//! 3. one walk over those statements, in the file's order, loads the MTL
//!    files as `mtllib` names them, resolves `usemtl`, and cuts the faces
//!    into objects where tobj does (a new name or material after faces);
//!    then each object's vertices are numbered in their first use, on as
//!    many threads as there are objects.
//!
//! What tobj keeps and caustix does not use is read for its errors only:
//! texture coordinates and vertex colours are counted and checked, not
//! kept (the meshes' `texcoords` and `vertex_color` stay empty).

use std::collections::HashMap;
use std::path::Path;

use rayon::prelude::*;
use tobj::{LoadError, MTLLoadResult, Material, Mesh, Model};

/// About this many bytes of the file to a chunk (cut at the next line end).
const CHUNK_BYTES: usize = 1 << 18;

/// A face corner's index that the corner does not give (`1//3` has no
/// texture coordinate), as tobj's `usize::MAX`.
const MISSING: u32 = u32::MAX;

/// A face corner's index outside what a `u32` holds, or below 0 (`-5` with
/// three vertices read): never valid. Its exact value is kept beside the
/// chunk ([`Chunk::out_of_range`]), for it still tells vertices apart
/// where the file has no texture coordinates or normals to check it against.
const OUT_OF_RANGE: u32 = u32::MAX - 1;

/// Statements read so far, of each kind that faces index, and lines.
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
    /// Vertex colour numbers (three a coloured `v`, fewer where one fails).
    colors: usize,
}

impl Counts {
    fn plus(self, other: Counts) -> Counts {
        Counts {
            lines: self.lines + other.lines,
            v: self.v + other.v,
            vt: self.vt + other.vt,
            vn: self.vn + other.vn,
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

/// A [`Statement`], and where among its chunk's faces it comes.
#[derive(Debug)]
struct Event {
    statement: Statement,
    /// The chunk's faces and corners before it.
    faces: usize,
    corners: usize,
    /// The chunk's statements of each kind before it.
    counts: Counts,
}

/// What a chunk of the file holds.
#[derive(Debug, Default)]
struct Chunk {
    /// Three numbers a `v`, after any `w` divided them.
    positions: Vec<f32>,
    /// Three numbers a `vn`.
    normals: Vec<f32>,
    /// Each face's corners: position, texture coordinate and normal, as
    /// indices into the whole file's, or [`MISSING`] or [`OUT_OF_RANGE`].
    corners: Vec<[u32; 3]>,
    /// How many corners each face has (`f` and `l` alike, as tobj reads them).
    arities: Vec<u32>,
    /// The corners holding an [`OUT_OF_RANGE`] index, by their place in
    /// `corners`, with the indices they gave (as tobj's wrapped `usize`).
    out_of_range: Vec<(usize, [u64; 3])>,
    events: Vec<Event>,
    /// The lines (from 1, in the whole file) of its `f` statements of
    /// fewer than three corners.
    short_faces: Vec<usize>,
    /// Its statements of each kind, all told.
    counts: Counts,
    /// The error of the first statement it could not read, and that
    /// statement's place among its events (those before it are good).
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
    let (before, _) = running_totals(counted.into_iter());
    let read: Vec<Chunk> =
        chunks.par_iter().zip(&before).map(|(text, &before)| read_chunk(text, before)).collect();
    // Again with the colours, which only reading counts (the rest the same
    // up to a chunk that stopped, where the walk stops).
    let (before, total) = running_totals(read.iter().map(|chunk| chunk.counts));
    let Walked { objects, materials, stopped } = walk(&read, &before, total, load_materials);
    let positions = joined(&read, |chunk| &chunk.positions);
    let normals = joined(&read, |chunk| &chunk.normals);
    let all = All { chunks: &read, positions: &positions, normals: &normals };
    let meshes: Vec<Result<Mesh, LoadError>> = objects.par_iter().map(|object| all.mesh(object)).collect();
    let mut models = Vec::with_capacity(objects.len());
    for (object, mesh) in objects.into_iter().zip(meshes) {
        models.push(Model::new(mesh?, object.name));
    }
    if let Some(index) = stopped {
        return Err(read[index].error.expect("the chunk that stopped has an error"));
    }
    let short_faces = read.iter().flat_map(|chunk| &chunk.short_faces).copied().collect();
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

/// Walks over the statements of the chunks `read` (of which `before[i]`
/// come before chunk `i`, and `total` in all), in the file's order: loads
/// the MTL files as `mtllib` names them, and cuts the faces into objects
/// where tobj does, at a new name or material after faces; stops at the
/// first chunk that could not be read whole.
fn walk(
    read: &[Chunk],
    before: &[Counts],
    total: Counts,
    mut load_materials: impl FnMut(&Path) -> MTLLoadResult,
) -> Walked {
    let mut materials = Materials::default();
    let mut objects: Vec<Object> = Vec::new();
    let mut current = Object::new("unnamed_object".to_owned(), None);
    for (index, chunk) in read.iter().enumerate() {
        let mut from = (0, 0);
        for event in &chunk.events {
            current.take(index, from, (event.faces, event.corners));
            from = (event.faces, event.corners);
            let counts = before[index].plus(event.counts);
            match &event.statement {
                Statement::Name(name) => {
                    if current.has_faces() {
                        let next = Object::new(String::new(), current.material);
                        objects.push(std::mem::replace(&mut current, next).ended(counts));
                    }
                    current.name.clone_from(name);
                }
                Statement::UseMaterial(name) => {
                    let material = materials.named(name);
                    if current.material != material && current.has_faces() {
                        let next = Object::new(current.name.clone(), material);
                        objects.push(std::mem::replace(&mut current, next).ended(counts));
                    }
                    current.material = material;
                }
                Statement::MaterialLibrary(path) => materials.merge(load_materials(Path::new(path))),
            }
        }
        if chunk.error.is_some() {
            return Walked { objects, materials, stopped: Some(index) };
        }
        current.take(index, from, (chunk.arities.len(), chunk.corners.len()));
    }
    objects.push(current.ended(total));
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

/// The lines and the `v`, `vt` and `vn` statements of a chunk (vertex
/// colours are counted as they are read).
fn count(text: &str) -> Counts {
    let mut counts = Counts::default();
    for line in text.lines() {
        counts.lines += 1;
        match Words::of(line).next().map(keyword) {
            Some(Keyword::Position) => counts.v += 1,
            Some(Keyword::TextureCoordinate) => counts.vt += 1,
            Some(Keyword::Normal) => counts.vn += 1,
            _ => {}
        }
    }
    counts
}

/// Reads a chunk whose statements (and lines) come after `before` of each kind.
fn read_chunk(text: &str, before: Counts) -> Chunk {
    let mut chunk = Chunk::default();
    for (i, line) in text.lines().enumerate() {
        if let Err(e) = read_line(line, before.lines + i + 1, before, &mut chunk) {
            chunk.error = Some(e);
            break;
        }
    }
    chunk
}

/// Reads one line, line `number` of the file, into `chunk`, as tobj's
/// `parse_obj_line` reads it.
fn read_line(line: &str, number: usize, before: Counts, chunk: &mut Chunk) -> Result<(), LoadError> {
    let mut words = Words::of(line);
    let event = |chunk: &mut Chunk, statement| {
        let (faces, corners, counts) = (chunk.arities.len(), chunk.corners.len(), chunk.counts);
        chunk.events.push(Event { statement, faces, corners, counts });
    };
    let Some(first_word) = words.next() else { return Ok(()) };
    match keyword(first_word) {
        Keyword::Position => {
            let p: [f32; 3] = numbers(&mut words).ok_or(LoadError::PositionParseError)?;
            chunk.positions.extend_from_slice(&p);
            chunk.counts.v += 1;
            // Then nothing, `w` (dividing the three), or a colour.
            let Some(first) = words.next() else { return Ok(()) };
            match (words.next(), words.next()) {
                (None, _) => {
                    let w: f32 = first.parse().map_err(|_| LoadError::PositionParseError)?;
                    if w == 0.0 {
                        return Err(LoadError::ScalingByZeroError);
                    }
                    let at = chunk.positions.len() - 3;
                    chunk.positions[at..].iter_mut().for_each(|c| *c /= w);
                }
                (Some(_), None) => return Err(LoadError::ColorParseError),
                (Some(second), Some(third)) => {
                    if words.next().is_some() {
                        return Err(LoadError::ColorParseError);
                    }
                    // As tobj: the numbers up to the first that is none.
                    chunk.counts.colors +=
                        [first, second, third].iter().take_while(|w| w.parse::<f32>().is_ok()).count();
                }
            }
        }
        Keyword::TextureCoordinate => {
            let _: [f32; 2] = numbers(&mut words).ok_or(LoadError::TexcoordParseError)?;
            chunk.counts.vt += 1;
        }
        Keyword::Normal => {
            let n: [f32; 3] = numbers(&mut words).ok_or(LoadError::NormalParseError)?;
            chunk.normals.extend_from_slice(&n);
            chunk.counts.vn += 1;
        }
        kind @ (Keyword::Face | Keyword::Line) => {
            let so_far = before.plus(chunk.counts);
            let start = chunk.corners.len();
            for word in words {
                let Some((corner, exact)) = corner(word, so_far) else {
                    chunk.corners.truncate(start);
                    return Err(LoadError::FaceParseError);
                };
                if corner.contains(&OUT_OF_RANGE) {
                    chunk.out_of_range.push((chunk.corners.len(), exact));
                }
                chunk.corners.push(corner);
            }
            let arity = chunk.corners.len() - start;
            if kind == Keyword::Face && arity < 3 {
                chunk.short_faces.push(number);
            }
            chunk.arities.push(arity as u32);
        }
        Keyword::Object => {
            // (As tobj: all after the line's first character, trimmed.)
            let first = line.chars().next().map_or(0, char::len_utf8);
            let name = line[first..].trim();
            let name = if name.is_empty() { "unnamed_object" } else { name };
            event(chunk, Statement::Name(name.to_owned()));
        }
        Keyword::MaterialLibrary => {
            let path = line.split_once(' ').unwrap_or_default().1.trim();
            event(chunk, Statement::MaterialLibrary(path.to_owned()));
        }
        Keyword::UseMaterial => {
            let name = line.split_once(' ').unwrap_or_default().1.trim();
            if name.is_empty() {
                return Err(LoadError::MaterialParseError);
            }
            event(chunk, Statement::UseMaterial(name.to_owned()));
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

/// One object's faces, as parts of chunks, with its name and material.
struct Object {
    name: String,
    material: Option<usize>,
    /// (chunk, faces, corners) ranges, in order.
    parts: Vec<(usize, std::ops::Range<usize>, std::ops::Range<usize>)>,
    /// The statements of each kind read when it ended.
    ended_at: Counts,
}

impl Object {
    fn new(name: String, material: Option<usize>) -> Object {
        Object { name, material, parts: Vec::new(), ended_at: Counts::default() }
    }

    /// Adds chunk `chunk`'s faces and corners from `from` up to `to`.
    fn take(&mut self, chunk: usize, from: (usize, usize), to: (usize, usize)) {
        if to.0 > from.0 {
            self.parts.push((chunk, from.0..to.0, from.1..to.1));
        }
    }

    fn has_faces(&self) -> bool {
        !self.parts.is_empty()
    }

    fn ended(mut self, counts: Counts) -> Object {
        self.ended_at = counts;
        self
    }
}

/// The chunks' `f32`s of one kind, in one list.
fn joined(chunks: &[Chunk], of: impl Fn(&Chunk) -> &Vec<f32>) -> Vec<f32> {
    let mut all = Vec::with_capacity(chunks.iter().map(|c| of(c).len()).sum());
    for chunk in chunks {
        all.extend_from_slice(of(chunk));
    }
    all
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

/// The whole file's chunks, positions and normals.
struct All<'a> {
    chunks: &'a [Chunk],
    positions: &'a [f32],
    normals: &'a [f32],
}

impl All<'_> {
    /// `object`'s mesh, its vertices numbered in the order of their first
    /// use, as tobj's `export_faces` numbers them, with its errors for an
    /// index beyond what had been read when the object ended.
    fn mesh(&self, object: &Object) -> Result<Mesh, LoadError> {
        let counts = object.ended_at;
        let used =
            || object.parts.iter().flat_map(|(c, _, corners)| &self.chunks[*c].corners[corners.clone()]);
        let mut numbering = Numbering::new(used().map(|c| c[0]).filter(|&v| (v as usize) < counts.v));
        let mut mesh = Mesh { material_id: object.material, ..Default::default() };
        let mut all_triangles = true;
        for (c, faces, corners) in &object.parts {
            let chunk = &self.chunks[*c];
            let mut at = corners.start;
            for &arity in &chunk.arities[faces.clone()] {
                for i in at..at + arity as usize {
                    let corner = chunk.corners[i];
                    let v = corner[0];
                    let exact = || match chunk.out_of_range.binary_search_by_key(&i, |&(at, _)| at) {
                        Ok(k) => chunk.out_of_range[k].1,
                        Err(_) => corner.map(|i| if i == MISSING { u64::MAX } else { u64::from(i) }),
                    };
                    if v as usize >= counts.v {
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
                at += arity as usize;
                all_triangles &= arity == 3;
                mesh.face_arities.push(arity);
            }
        }
        if all_triangles {
            mesh.face_arities = Vec::new();
        }
        Ok(mesh)
    }

    /// Adds a vertex's position and normal to `mesh`, or tobj's error for
    /// an index beyond what had been read (`counts`); a texture coordinate
    /// or colour is checked only, where the file has them.
    fn add_vertex(&self, mesh: &mut Mesh, [v, vt, vn]: [u32; 3], counts: Counts) -> Result<(), LoadError> {
        let v = v as usize;
        mesh.positions.extend_from_slice(&self.positions[3 * v..3 * v + 3]);
        if counts.vt > 0 && vt != MISSING && vt as usize >= counts.vt {
            return Err(LoadError::FaceTexCoordOutOfBounds);
        }
        if counts.vn > 0 && vn != MISSING {
            let vn = vn as usize;
            if vn >= counts.vn {
                return Err(LoadError::FaceNormalOutOfBounds);
            }
            mesh.normals.extend_from_slice(&self.normals[3 * vn..3 * vn + 3]);
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
