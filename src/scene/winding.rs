//! Which way a mesh file's triangles wind, made to mean one side.
//!
//! A triangle's winding (counter-clockwise seen from the front) decides
//! which side of a glass surface is inside, and the smooth normals caustix
//! works out for files without any are averages of the triangles' own
//! normals. Files do not always wind their triangles one way: exporters
//! and scans leave a part, or every other triangle, turned. Glass then
//! comes out as a bubble (inside out) or shattered, and smooth normals of
//! neighbours that disagree cancel (a diffuse sphere comes out speckled).
//! So before a file's mesh is made:
//!
//! - where smooth normals are to be worked out (a file without vertex
//!   normals), each connected part winds as most of its triangles do,
//!   every triangle as the neighbours it shares an edge with;
//! - for glass, where the file gives vertex normals, each triangle winds to
//!   face the side its corners' normals point to (as pbrt-v4 faces a
//!   triangle's geometric normal with its shading normal);
//! - for glass without normals, a file whose closed parts enclose a
//!   negative volume in all (wound clockwise seen from outside, as a
//!   mirrored export leaves them) is turned whole. Whole, not part by
//!   part: a hollow glass ball's inner surface rightly winds into its
//!   cavity, and it is the sum, not each part, that says which way the
//!   file means.
//!
//! Elsewhere the winding changes nothing in the image (surfaces that are
//! not glass look the same from both sides), and the file's is kept. What
//! is turned is reported; a file that winds one way is left as it is.
//!
//! Where the winding is worked out (glass, and smooth normals), a face the
//! file gives twice (the same three corners, in any order: exports of
//! two-sided faces write each face again wound the other way, with its
//! normals turned too) is kept once, the first. Two windings of one face
//! cannot agree: a ray met either copy, as rounding chose, so a glass
//! sphere written so rendered shattered, and the copies' normals cancelled
//! in smooth normals.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::mesh::{face_normal, position_slots};

/// The normals a file's mesh will shade with.
pub enum Normals<'a> {
    /// The file's own vertex normals.
    FromFile(&'a [Vec3]),
    /// Smooth normals to be worked out from the triangles, over the
    /// vertices' places (`mesh::position_slots`), which the creases need too.
    Smooth(&'a [u32]),
    /// Each triangle's own (STL).
    Flat,
}

/// What [`orient`] turned, and what it measured.
#[derive(Debug, Default, PartialEq)]
pub struct Turned {
    /// Triangles turned to face their corners' normals.
    pub against_normals: usize,
    /// Triangles turned to agree with the neighbours they share edges with.
    pub against_neighbours: usize,
    /// Triangles of parts no winding can agree over (one-sided, as a Möbius
    /// strip), left as they were.
    pub one_sided: usize,
    /// For glass without normals: six times the volume the closed parts
    /// enclose as they wind after the turns (negative where they wind
    /// inward; 0 without a closed part).
    pub enclosed: f64,
    /// Triangles turned with the whole file ([`turn_inside_out`]).
    pub inside_out: usize,
    /// Triangles left out as copies of another: on the same three places,
    /// in any order.
    pub copies: usize,
    /// For glass: triangles with an edge that no other triangle shares, or
    /// that more than two share (the surface is not a solid's).
    pub open_glass: usize,
}

impl Turned {
    /// For a file of one mesh, `indices` as [`orient`] left them: turns
    /// them all if they wind inside out, and counts it.
    pub fn whole_file(&mut self, indices: &mut [[u32; 3]]) {
        if self.enclosed < 0.0 {
            self.inside_out = turn_inside_out(indices);
        }
    }

    /// The warnings for a mesh file named `name`, one for each kind of turn.
    pub fn warnings(&self, name: &str, triangles: usize) -> Vec<String> {
        let mut out = Vec::new();
        if self.copies > 0 {
            out.push(format!(
                "{name}: {} triangles lie on the same three corners as another (a face written twice, perhaps \
                 wound both ways) and were left out: a surface is kept once, as glass and smooth normals need",
                self.copies
            ));
        }
        if self.against_normals > 0 {
            out.push(format!(
                "{name}: {} of its {triangles} triangles wind against the file's vertex normals and were turned to \
                 face them (the side a glass surface has inside)",
                self.against_normals
            ));
        }
        if self.against_neighbours > 0 {
            out.push(format!(
                "{name}: {} of its {triangles} triangles wind against their neighbours and were turned to agree \
                 (glass and smooth normals need one winding)",
                self.against_neighbours
            ));
        }
        if self.inside_out > 0 {
            out.push(inside_out_warning(name, self.inside_out));
        }
        if self.open_glass > 0 {
            out.push(format!(
                "{name}: {} of its {triangles} glass triangles have an edge that no other triangle shares (or that \
                 more than two share): glass refracts as the surface of a solid, and an open surface closes none, so \
                 a ray bent into it through the surface is not bent back where the surface is missing; close the \
                 mesh, or give the open part a material that is not glass",
                self.open_glass
            ));
        }
        if self.one_sided > 0 {
            out.push(format!(
                "{name}: {} triangles form one-sided surfaces (no winding agrees all round) and were left as they are",
                self.one_sided
            ));
        }
        out
    }
}

/// The warning for a file `name` turned whole, `triangles` of it.
pub fn inside_out_warning(name: &str, triangles: usize) -> String {
    format!(
        "{name}: its closed glass parts enclose a negative volume, so it winds inside out (clockwise seen from \
         outside, as a mirrored export leaves it); all {triangles} of its glass triangles were turned, so that glass \
         has its inside inside"
    )
}

/// Turns every triangle of `indices`, for a file that winds inside out
/// ([`Turned::enclosed`] negative over the file); returns how many.
pub fn turn_inside_out(indices: &mut [[u32; 3]]) -> usize {
    indices.iter_mut().for_each(|t| t.swap(1, 2));
    indices.len()
}

/// Turns the triangles `indices` over `positions` of a mesh that will
/// shade with `normals` and is glass or not, as the module says (a
/// triangle turns by swapping its last two corners), and leaves out copies
/// where it works the winding out. Triangles of no area keep their
/// winding.
pub fn orient(positions: &[Vec3], indices: &mut Vec<[u32; 3]>, normals: Normals, glass: bool) -> Turned {
    match (normals, glass) {
        (Normals::FromFile(normals), true) => {
            // (The places serve the copies, where there may be any, and the open edges.)
            let places = position_slots(positions);
            let copies = if may_repeat(positions, indices) { drop_copies(&places, indices) } else { 0 };
            let turn = |t: &[u32; 3]| {
                let [p0, p1, p2] = t.map(|i| positions[i as usize].as_dvec3());
                let face = (p1 - p0).cross(p2 - p0);
                let corners: DVec3 = t.iter().map(|&i| normals[i as usize].as_dvec3()).sum();
                face.dot(corners) < 0.0
            };
            let turned = indices.iter().filter(|t| turn(t)).count();
            if turned > 0 {
                indices.iter_mut().filter(|t| turn(t)).for_each(|t| t.swap(1, 2));
            }
            let (_, open, _) = shared_edges(positions, &places, indices);
            let open_glass = open.iter().filter(|&&open| open).count();
            Turned { against_normals: turned, copies, open_glass, ..Turned::default() }
        }
        // (Files repeat a corner where its normal or texture coordinates
        // change, and STL files every corner, yet the triangles meet there.)
        (Normals::Smooth(places), measure) => coherent(positions, places, indices, measure),
        (Normals::Flat, true) => coherent(positions, &position_slots(positions), indices, true),
        (Normals::FromFile(_) | Normals::Flat, false) => Turned::default(),
    }
}

/// For a file of several meshes (`meshes`, each its positions and
/// triangles), how many triangles of each have an edge that no other
/// triangle of the whole file shares, or that more than two share: as
/// [`Turned::open_glass`] counts them within one mesh, but a mesh closed by
/// another is not open. An OBJ object whose faces change material is read
/// as one mesh per material, so a glass bottle with a metal cap is a glass
/// mesh open at its rim and a cap that closes it: a ray bent into the glass
/// meets the cap from inside, as it would the real bottle's.
///
/// `None` for a file of 2^31 triangles or more, which `shared_edges`
/// cannot number.
pub fn open_in_file(meshes: &[(&[Vec3], &[[u32; 3]])]) -> Option<Vec<usize>> {
    let triangles: usize = meshes.iter().map(|(_, t)| t.len()).sum();
    if triangles >= 1 << 31 {
        return None;
    }
    let positions: Vec<Vec3> = meshes.iter().flat_map(|&(p, _)| p.iter().copied()).collect();
    let mut indices = Vec::with_capacity(triangles);
    let mut first_vertex = 0u32;
    for &(p, triangles) in meshes {
        indices.extend(triangles.iter().map(|t| t.map(|i| i + first_vertex)));
        first_vertex += p.len() as u32;
    }
    let (_, open, _) = shared_edges(&positions, &position_slots(&positions), &indices);
    let mut open = open.into_iter();
    Some(
        meshes
            .iter()
            .map(|(_, triangles)| open.by_ref().take(triangles.len()).filter(|&o| o).count())
            .collect(),
    )
}

/// Each part of `indices` wound as most of its triangles, every triangle
/// as its neighbours; and, if asked to `measure` (glass), the volume the
/// closed parts enclose ([`Turned::enclosed`]) and the triangles at an
/// open edge ([`Turned::open_glass`]).
fn coherent(positions: &[Vec3], corner: &[u32], indices: &mut Vec<[u32; 3]>, measure: bool) -> Turned {
    // (A triangle's index and a bit share a `u32` below.)
    if indices.len() >= 1 << 31 {
        return Turned::default();
    }
    let (mut shared, mut open, crowded) = shared_edges(positions, corner, indices);
    // A face given twice puts four triangles on each edge it shares with
    // another face, and the two copies side by side on each of its own:
    // copies are looked for only where an edge has more than two, or two
    // triangles on the same three places share one.
    let places = |t: u32| places_of(corner, indices[t as usize]);
    let twins = || shared.par_iter().any(|&(a, b, _)| places(a) == places(b));
    let copies = if crowded || twins() { drop_copies(corner, indices) } else { 0 };
    if copies > 0 {
        (shared, open, _) = shared_edges(positions, corner, indices);
    }
    let n = indices.len();
    // (Measured for glass, which `measure` is.)
    let open_glass = if measure { open.iter().filter(|&&open| open).count() } else { 0 };
    // A file that winds one way, as most do, is done here, unless its
    // closed parts must be measured.
    if !measure && shared.iter().all(|&(_, _, same)| !same) {
        return Turned { copies, ..Turned::default() };
    }
    // Each triangle's links, from `first_link[t]` to `first_link[t + 1]`.
    let mut first_link = vec![0u32; n + 1];
    for &(a, b, _) in &shared {
        first_link[a as usize + 1] += 1;
        first_link[b as usize + 1] += 1;
    }
    for i in 0..n {
        first_link[i + 1] += first_link[i];
    }
    let mut filled = first_link.clone();
    let mut links = vec![(0u32, false); 2 * shared.len()];
    for &(a, b, same) in &shared {
        for (from, to) in [(a, b), (b, a)] {
            links[filled[from as usize] as usize] = (to, same);
            filled[from as usize] += 1;
        }
    }
    drop(shared);

    let mut turned = Turned { copies, open_glass, ..Turned::default() };
    let mut turn = vec![false; n];
    let mut part_of = vec![u32::MAX; n];
    let mut part = Vec::new();
    for start in 0..n {
        if part_of[start] != u32::MAX {
            continue;
        }
        // Each part from its lowest triangle, which keeps its winding; the
        // others as their neighbours ask.
        part.clear();
        part.push(start as u32);
        part_of[start] = start as u32;
        let (mut next, mut agrees, mut closed) = (0, true, true);
        while next < part.len() {
            let t = part[next] as usize;
            next += 1;
            closed &= !open[t];
            for &(u, same) in &links[first_link[t] as usize..first_link[t + 1] as usize] {
                let u = u as usize;
                let wanted = turn[t] ^ same;
                if part_of[u] == u32::MAX {
                    part_of[u] = start as u32;
                    turn[u] = wanted;
                    part.push(u as u32);
                } else if turn[u] != wanted {
                    agrees = false;
                }
            }
        }
        if !agrees {
            part.iter().for_each(|&t| turn[t as usize] = false);
            turned.one_sided += part.len();
            continue;
        }
        // Most of a part's triangles keep their winding.
        let turning = part.iter().filter(|&&t| turn[t as usize]).count();
        if 2 * turning > part.len() {
            part.iter().for_each(|&t| turn[t as usize] ^= true);
        }
        turned.against_neighbours += turning.min(part.len() - turning);
        if closed && measure {
            turned.enclosed += signed_volume(positions, indices, &part, &turn);
        }
    }
    for (t, turn) in indices.iter_mut().zip(turn) {
        if turn {
            t.swap(1, 2);
        }
    }
    turned
}

/// Whether two triangles of `indices` may lie on the same three places of
/// `positions`: false only where none do. A quick test before
/// [`drop_copies`] where the places are not otherwise needed: a hash of
/// each triangle's corners' places, the same in any order (a sum), sorted.
fn may_repeat(positions: &[Vec3], indices: &[[u32; 3]]) -> bool {
    // (splitmix64's finaliser: every bit of the place moves every bit.)
    let mix = |mut h: u64| {
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^ (h >> 31)
    };
    let place: Vec<u64> = positions
        .par_iter()
        .map(|&p| {
            // (-0 and 0 are one place, as `position_slots` has it.)
            let [x, y, z] = (p + Vec3::ZERO).to_array().map(|c| u64::from(c.to_bits()));
            mix(mix((x << 32) | y) ^ z)
        })
        .collect();
    let mut keys: Vec<u64> = indices
        .par_iter()
        .map(|tri| tri.iter().fold(0u64, |sum, &i| sum.wrapping_add(place[i as usize])))
        .collect();
    keys.par_sort_unstable();
    keys.par_windows(2).any(|pair| pair[0] == pair[1])
}

/// The places (`corner`, [`position_slots`]) of the triangle `tri`'s
/// corners, in increasing order: the same for a triangle and its copies.
fn places_of(corner: &[u32], tri: [u32; 3]) -> [u32; 3] {
    let mut places = tri.map(|i| corner[i as usize]);
    places.sort_unstable();
    places
}

/// Leaves out of `indices` every triangle whose corners lie at the same
/// three places (`corner`, [`position_slots`]) as an earlier triangle's, in
/// any order; returns how many. Triangles with a place twice (no area) are
/// left to [`Mesh::new`](super::mesh::Mesh::new).
fn drop_copies(corner: &[u32], indices: &mut Vec<[u32; 3]>) -> usize {
    let mut keyed: Vec<([u32; 3], u32)> =
        indices.par_iter().enumerate().map(|(t, &tri)| (places_of(corner, tri), t as u32)).collect();
    // Copies side by side, the earliest first.
    keyed.par_sort_unstable();
    let mut copy = vec![false; indices.len()];
    for pair in keyed.windows(2) {
        let ([a, b, c], _) = pair[0];
        if pair[1].0 == pair[0].0 && a != b && b != c {
            copy[pair[1].1 as usize] = true;
        }
    }
    let copies = copy.iter().filter(|&&c| c).count();
    if copies > 0 {
        let mut is_copy = copy.into_iter();
        indices.retain(|_| !is_copy.next().unwrap_or(false));
    }
    copies
}

/// The edges that two triangles share, each once: the two triangles, and
/// whether they run along it the same way (then one of them must turn);
/// which triangles have an edge of their own or one of more than two
/// triangles (their part is open); and whether any edge has more than two.
/// Corners at one place are one (`corner`, [`position_slots`]); triangles
/// of no area, which [`Mesh::new`](super::mesh::Mesh::new) drops, take no
/// part.
fn shared_edges(
    positions: &[Vec3],
    corner: &[u32],
    indices: &[[u32; 3]],
) -> (Vec<(u32, u32, bool)>, Vec<bool>, bool) {
    // Each edge is listed under its lower corner, with its higher corner
    // and its triangle's index times two, plus one where the triangle runs
    // along it from the higher corner: a bucket sort, each bucket a
    // vertex's few edges.
    let has_area: Vec<bool> = indices.par_iter().map(|&tri| face_normal(positions, tri).is_some()).collect();
    let edges_of = |t: usize| {
        let (c, has_area) = (indices[t].map(|i| corner[i as usize]), has_area[t]);
        (0..3).map(move |k| (c[k], c[(k + 1) % 3])).filter(move |&(a, b)| has_area && a != b)
    };
    let mut first = vec![0u32; corner.len() + 1];
    for t in 0..indices.len() {
        edges_of(t).for_each(|(a, b)| first[a.min(b) as usize + 1] += 1);
    }
    for v in 0..corner.len() {
        first[v + 1] += first[v];
    }
    let mut filled = first.clone();
    let mut under = vec![(0u32, 0u32); first[corner.len()] as usize];
    for t in 0..indices.len() {
        for (a, b) in edges_of(t) {
            let low = a.min(b) as usize;
            under[filled[low] as usize] = (a.max(b), ((t as u32) << 1) | u32::from(a > b));
            filled[low] += 1;
        }
    }
    let (mut shared, mut open, mut crowded) = (Vec::new(), vec![false; indices.len()], false);
    for v in 0..corner.len() {
        let bucket = &mut under[first[v] as usize..first[v + 1] as usize];
        bucket.sort_unstable();
        for run in bucket.chunk_by(|x, y| x.0 == y.0) {
            if let [(_, a), (_, b)] = *run {
                shared.push((a >> 1, b >> 1, (a & 1) == (b & 1)));
            } else {
                crowded |= run.len() > 2;
                run.iter().for_each(|&(_, t)| open[(t >> 1) as usize] = true);
            }
        }
    }
    (shared, open, crowded)
}

/// Six times the volume a closed part encloses, positive where its
/// triangles (as `turn` leaves them) wind counter-clockwise seen from
/// outside: the sum of the tetrahedra from its first corner to each
/// triangle, in `f64`.
fn signed_volume(positions: &[Vec3], indices: &[[u32; 3]], part: &[u32], turn: &[bool]) -> f64 {
    let origin = positions[indices[part[0] as usize][0] as usize].as_dvec3();
    part.iter()
        .map(|&t| {
            let [p0, p1, p2] = indices[t as usize].map(|i| positions[i as usize].as_dvec3() - origin);
            let v = p0.dot(p1.cross(p2));
            if turn[t as usize] {
                -v
            } else {
                v
            }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::test_scenes::unit_cube as cube;

    fn turned(t: [u32; 3]) -> [u32; 3] {
        [t[0], t[2], t[1]]
    }

    /// Glass is checked for edges that two triangles do not share, however
    /// its normals come: a closed cube has none; without one triangle,
    /// the three beside the gap have one each (two on the cube's edges, one
    /// on the face's diagonal). Surfaces that are not glass are not asked.
    #[test]
    fn open_glass_is_counted_and_named() {
        let (p, closed) = cube();
        let mut open = closed.clone();
        open.remove(5);
        let places = position_slots(&p);
        let normals: Vec<Vec3> = p.iter().map(|&q| q - Vec3::splat(0.5)).collect();
        let ways = || [Normals::Smooth(&places), Normals::Flat, Normals::FromFile(&normals)];
        for (i, normals) in ways().into_iter().enumerate() {
            assert_eq!(orient(&p, &mut closed.clone(), normals, true).open_glass, 0, "way {i}");
        }
        for (i, normals) in ways().into_iter().enumerate() {
            let done = orient(&p, &mut open.clone(), normals, true);
            assert_eq!(done.open_glass, 3, "way {i}: {done:?}");
            assert!(done.warnings("cup.obj", open.len()).iter().any(|w| w.starts_with(
                "cup.obj: 3 of its 11 glass triangles have an edge that no other triangle shares"
            )));
        }
        assert_eq!(orient(&p, &mut open.clone(), Normals::Smooth(&places), false).open_glass, 0);
    }

    /// A cube whose faces come twice (the copy wound the other way, a
    /// corner of its own at the same place, as two-sided exports write
    /// them), once more in another corner order, with a triangle of no
    /// area twice: the copies go, the first of each is kept, and the cube
    /// then winds one way, as it was.
    #[test]
    fn a_face_given_twice_is_kept_once_the_first() {
        let (mut p, cube_faces) = cube();
        let n = p.len() as u32;
        p.extend_from_within(..); // corners n.. at the same places
        let mut indices = cube_faces.clone();
        indices.extend(cube_faces.iter().map(|&[a, b, c]| [c + n, b + n, a + n]));
        indices.extend(cube_faces.iter().map(|&[a, b, c]| [b, c, a]));
        indices.extend([[0, 0, 1], [0, 0, 1]]);
        assert!(may_repeat(&p, &indices) && !may_repeat(&p, &cube_faces));
        let places = position_slots(&p);
        for normals in [Normals::Smooth(&places), Normals::Flat] {
            let mut given = indices.clone();
            let done = orient(&p, &mut given, normals, true);
            assert_eq!(done.copies, 24, "{done:?}");
            assert_eq!(&given[..12], &cube_faces[..]);
            assert_eq!(&given[12..], &[[0, 0, 1], [0, 0, 1]]);
            assert_eq!((done.against_neighbours, done.inside_out), (0, 0));
            assert!(done.warnings("cube.obj", given.len())[0]
                .contains("24 triangles lie on the same three corners"));
        }
        // A lone triangle given twice shares no edge with any other face.
        let lone = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mut twice = vec![[0, 1, 2], [2, 1, 0]];
        assert_eq!(orient(&lone, &mut twice, Normals::Smooth(&position_slots(&lone)), false).copies, 1);
        assert_eq!(twice, [[0, 1, 2]]);
        let mut given = indices.clone();
        let file_normals = vec![Vec3::ONE; p.len()];
        assert_eq!(orient(&p, &mut given, Normals::FromFile(&file_normals), true).copies, 24);
        // Not glass, with the file's normals: nothing is worked out, and
        // nothing is left out.
        let mut given = indices.clone();
        assert_eq!(orient(&p, &mut given, Normals::FromFile(&file_normals), false), Turned::default());
        assert_eq!(given, indices);
    }

    fn volume(positions: &[Vec3], indices: &[[u32; 3]]) -> f64 {
        let part: Vec<u32> = (0..indices.len() as u32).collect();
        signed_volume(positions, indices, &part, &vec![false; indices.len()])
    }

    #[test]
    fn the_cube_winds_outward() {
        let (p, t) = cube();
        assert!((volume(&p, &t) - 6.0).abs() < 1e-12);
    }

    #[test]
    fn a_mesh_that_winds_one_way_is_left_as_it_is() {
        let (p, t) = cube();
        let inward: Vec<[u32; 3]> = t.iter().map(|&t| turned(t)).collect();
        let mut same = t.clone();
        assert_eq!(orient(&p, &mut same, Normals::Smooth(&position_slots(&p)), false), Turned::default());
        assert_eq!(same, t);
        // Glass is measured: six times the unit cube's volume.
        assert_eq!(
            orient(&p, &mut same, Normals::Smooth(&position_slots(&p)), true),
            Turned { enclosed: 6.0, ..Turned::default() }
        );
        assert_eq!(same, t);
        // Inward, but not glass: the winding changes nothing seen.
        let mut same = inward.clone();
        assert_eq!(orient(&p, &mut same, Normals::Smooth(&position_slots(&p)), false), Turned::default());
        assert_eq!(same, inward);
    }

    #[test]
    fn glass_wound_inward_encloses_a_negative_volume() {
        let (p, t) = cube();
        let mut inward: Vec<[u32; 3]> = t.iter().map(|&t| turned(t)).collect();
        let done = orient(&p, &mut inward, Normals::Smooth(&position_slots(&p)), true);
        assert_eq!(done, Turned { enclosed: -6.0, ..Turned::default() });
        assert_eq!(turn_inside_out(&mut inward), 12);
        assert_eq!(inward, t);
        // With three of them outward: they turn to the other nine first.
        let mut mixed: Vec<[u32; 3]> =
            t.iter().enumerate().map(|(i, &t)| if i.is_multiple_of(4) { t } else { turned(t) }).collect();
        let done = orient(&p, &mut mixed, Normals::Smooth(&position_slots(&p)), true);
        assert_eq!(done, Turned { against_neighbours: 3, enclosed: -6.0, ..Turned::default() });
        turn_inside_out(&mut mixed);
        assert_eq!(mixed, t);
    }

    /// A hollow glass box: the outer surface winds outward, the inner one
    /// (a closed part of its own) into the cavity. The sum says outward,
    /// and nothing turns.
    #[test]
    fn a_hollow_ball_keeps_its_cavity_wound_inward() {
        let (p, t) = cube();
        let mut positions = p.clone();
        positions.extend(p.iter().map(|&q| 0.25 + 0.5 * q));
        let mut hollow = t.clone();
        hollow.extend(t.iter().map(|&tri| turned(tri.map(|i| i + 8))));
        let before = hollow.clone();
        let done = orient(&positions, &mut hollow, Normals::Smooth(&position_slots(&positions)), true);
        assert_eq!(done, Turned { enclosed: 6.0 - 6.0 / 8.0, ..Turned::default() });
        assert_eq!(hollow, before);
    }

    #[test]
    fn triangles_against_their_neighbours_turn_to_agree() {
        let (p, t) = cube();
        for glass in [false, true] {
            let mut mixed: Vec<[u32; 3]> =
                t.iter().enumerate().map(|(i, &t)| if i.is_multiple_of(4) { turned(t) } else { t }).collect();
            let done = orient(&p, &mut mixed, Normals::Smooth(&position_slots(&p)), glass);
            assert_eq!(done.against_neighbours, 3, "glass {glass}");
            assert_eq!(mixed, t);
        }
        // Flat normals (STL) turn nothing unless glass.
        let mut mixed: Vec<[u32; 3]> = t.iter().map(|&t| turned(t)).collect();
        mixed[0] = t[0];
        let before = mixed.clone();
        assert_eq!(orient(&p, &mut mixed, Normals::Flat, false), Turned::default());
        assert_eq!(mixed, before);
        let done = orient(&p, &mut mixed, Normals::Flat, true);
        assert_eq!(done, Turned { against_neighbours: 1, enclosed: -6.0, ..Turned::default() });
        assert_eq!(mixed, t.iter().map(|&t| turned(t)).collect::<Vec<_>>());
    }

    /// Corners repeated (as STL files and OBJ files with texture seams
    /// have them) are one corner where they are at one place.
    #[test]
    fn repeated_corners_at_one_place_are_one() {
        let (p, t) = cube();
        let positions: Vec<Vec3> = t.iter().flat_map(|tri| tri.map(|i| p[i as usize])).collect();
        let own: Vec<[u32; 3]> = (0..12).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        // Welded, the corners close the cube.
        let mut inward: Vec<[u32; 3]> = own.iter().map(|&t| turned(t)).collect();
        assert_eq!(orient(&positions, &mut inward, Normals::Flat, true).enclosed, -6.0);
        // -0 and 0 are one place.
        let mut signed = positions.clone();
        signed.iter_mut().filter(|p| p.x == 0.0).for_each(|p| p.x = -0.0);
        let mut inward: Vec<[u32; 3]> = own.iter().map(|&t| turned(t)).collect();
        assert_eq!(orient(&signed, &mut inward, Normals::Flat, true).enclosed, -6.0);
    }

    #[test]
    fn open_parts_keep_the_winding_of_most_of_their_triangles() {
        // A 4 x 4 grid of squares in z = 0, facing -z, 5 of 32 turned; a
        // part that is not closed has no outside to face.
        let p: Vec<Vec3> = (0..25).map(|i| Vec3::new((i % 5) as f32, (i / 5) as f32, 0.0)).collect();
        let t: Vec<[u32; 3]> = (0..16)
            .flat_map(|q| {
                let c = (q / 4) * 5 + q % 4;
                [[c, c + 5, c + 1], [c + 1, c + 5, c + 6]]
            })
            .collect();
        let mut mixed: Vec<[u32; 3]> =
            t.iter().enumerate().map(|(i, &t)| if i % 7 == 3 { turned(t) } else { t }).collect();
        for glass in [false, true] {
            let mut m = mixed.clone();
            // (The 14 at the grid's rim are open; only glass asks.)
            let open_glass = if glass { 14 } else { 0 };
            assert_eq!(
                orient(&p, &mut m, Normals::Smooth(&position_slots(&p)), glass),
                Turned { against_neighbours: 5, open_glass, ..Turned::default() }
            );
            assert_eq!(m, t);
        }
        // Most turned: the others turn to them.
        mixed.iter_mut().for_each(|t| *t = turned(*t));
        let mut m = mixed.clone();
        assert_eq!(orient(&p, &mut m, Normals::Smooth(&position_slots(&p)), true).against_neighbours, 5);
        assert_eq!(m, t.iter().map(|&t| turned(t)).collect::<Vec<_>>());
    }

    /// A triangle of no area on an edge of the cube, and a fourth triangle
    /// on another edge: the first is no neighbour, the second opens the
    /// part (three triangles on one edge have no outside to agree on).
    #[test]
    fn triangles_of_no_area_take_no_part_and_edges_of_three_open_a_part() {
        let (mut p, t) = cube();
        let mut inward: Vec<[u32; 3]> = t.iter().map(|&t| turned(t)).collect();
        inward.push([0, 1, 1]);
        let done = orient(&p, &mut inward, Normals::Smooth(&position_slots(&p)), true);
        assert_eq!(done, Turned { enclosed: -6.0, ..Turned::default() });
        p.push(Vec3::new(0.5, -1.0, 0.5));
        let mut fin: Vec<[u32; 3]> = t.iter().map(|&t| turned(t)).collect();
        fin.push([0, 1, 8]);
        let before = fin.clone();
        // (The fin and the two triangles on its edge, of three, are open.)
        let open = Turned { open_glass: 3, ..Turned::default() };
        assert_eq!(orient(&p, &mut fin, Normals::Smooth(&position_slots(&p)), true), open);
        assert_eq!(fin, before);
    }

    #[test]
    fn a_one_sided_strip_is_left_as_it_is() {
        // A Möbius strip of 12 quads: its two long edges join turned.
        let n = 12;
        let at = |k: u32, side: f32| {
            let a = std::f32::consts::TAU * k as f32 / n as f32;
            let w = side * 0.3;
            let r = 1.0 + w * (0.5 * a).cos();
            Vec3::new(r * a.cos(), r * a.sin(), w * (0.5 * a).sin())
        };
        let p: Vec<Vec3> = (0..n).flat_map(|k| [at(k, -1.0), at(k, 1.0)]).collect();
        let t: Vec<[u32; 3]> = (0..n)
            .flat_map(|k| {
                let (a, b) = (2 * k, 2 * k + 1);
                // The last quad joins the first with its sides swapped.
                let (c, d) = if k + 1 == n { (1, 0) } else { (2 * k + 2, 2 * k + 3) };
                [[a, c, b], [b, c, d]]
            })
            .collect();
        let mut m = t.clone();
        assert_eq!(
            orient(&p, &mut m, Normals::Smooth(&position_slots(&p)), true),
            Turned { one_sided: 24, open_glass: 24, ..Turned::default() }
        );
        assert_eq!(m, t);
    }

    #[test]
    fn glass_faces_the_files_normals() {
        let (p, t) = cube();
        // Each corner's normal points out from the cube's centre.
        let normals: Vec<Vec3> = p.iter().map(|&q| q - Vec3::splat(0.5)).collect();
        let mut mixed: Vec<[u32; 3]> =
            t.iter().enumerate().map(|(i, &t)| if i.is_multiple_of(3) { turned(t) } else { t }).collect();
        let before = mixed.clone();
        assert_eq!(orient(&p, &mut mixed, Normals::FromFile(&normals), false), Turned::default());
        assert_eq!(mixed, before);
        let done = orient(&p, &mut mixed, Normals::FromFile(&normals), true);
        assert_eq!(done, Turned { against_normals: 4, ..Turned::default() });
        assert_eq!(mixed, t);
    }

    #[test]
    fn the_warnings_say_what_turned() {
        let all = Turned {
            against_normals: 1,
            against_neighbours: 2,
            one_sided: 5,
            enclosed: -1.0,
            inside_out: 4,
            copies: 3,
            open_glass: 6,
        };
        let w = all.warnings("m.obj", 9);
        assert_eq!(w.len(), 6);
        assert!(w[0].starts_with("m.obj: 3 triangles lie on the same three corners as another"));
        assert!(w[1].starts_with("m.obj: 1 of its 9 triangles wind against the file's vertex normals"));
        assert!(w[2].starts_with("m.obj: 2 of its 9 triangles wind against their neighbours"));
        assert!(w[3].starts_with("m.obj: its closed glass parts enclose a negative volume"), "{}", w[3]);
        assert!(w[3].contains("all 4 of its glass triangles were turned"));
        assert!(
            w[4].starts_with("m.obj: 6 of its 9 glass triangles have an edge that no other triangle shares")
        );
        assert!(w[5].starts_with("m.obj: 5 triangles form one-sided surfaces"));
        assert!(Turned { enclosed: 6.0, ..Turned::default() }.warnings("m.obj", 9).is_empty());
    }
}
