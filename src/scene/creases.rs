//! Smooth normals for mesh files without their own, with creases kept.
//!
//! Averaged over every triangle at a vertex, the normals of a box come out
//! pointing along its diagonals, and its flat faces shade as a blob. So
//! where two triangles meet at an edge sharper than [`CREASE_DEGREES`] (a
//! box's edges; not the edges of a tessellated curved surface), the
//! surfaces on either side are smoothed apart: each vertex on such an edge
//! takes one normal for each fan of triangles around it that smooth edges
//! join, a copy of the vertex for each fan but the first. Vertices on no
//! sharp edge keep the angle-weighted average of
//! [`vertex_normals`](super::mesh::vertex_normals), bit for bit.

use std::collections::{HashMap, HashSet};

use glam::Vec3;

use super::mesh::{corner_normals, face_normal, vertex_normals_at};
use crate::numeric;

/// Triangles whose normals part by more than this many degrees meet at a
/// crease. (A box's edges are 90; the low-resolution Stanford bunny's are
/// under 30 but for 357 of 5,511, 58 of them over 60, at its sharpest
/// folds; a level-4 icosphere's 3.)
pub const CREASE_DEGREES: f64 = 60.0;

/// A mesh's positions, triangles and normals, with creases.
pub struct Creased {
    /// The positions, with the copies after them.
    pub positions: Vec<Vec3>,
    /// The triangles of some area, their corners on the copies where the
    /// copies' fans are.
    pub indices: Vec<[u32; 3]>,
    /// A unit normal per position (zero where they cancel).
    pub normals: Vec<Vec3>,
    /// Vertices copied, one for each fan of triangles beyond a vertex's first.
    pub added: usize,
}

/// Smooth normals for the triangles `indices` over `positions`, kept apart
/// across creases (the module's comment), given the vertices' places
/// `slots` (`mesh::position_slots`, as the winding pass worked them out).
/// Triangles of no area are left out, as
/// [`Mesh::new`](super::mesh::Mesh::new) leaves them.
pub fn creased(mut positions: Vec<Vec3>, mut indices: Vec<[u32; 3]>, mut slots: Vec<u32>) -> Creased {
    let (faces, kept): (Vec<Vec3>, Vec<[u32; 3]>) =
        indices.iter().filter_map(|&t| Some((face_normal(&positions, t)?, t))).unzip();
    indices = kept;
    // (A copy of a vertex is at its place too.)
    let mut normals = vertex_normals_at(&positions, &indices, &slots);
    // The triangles around each place (slot), in triangle order: a bucket
    // sort.
    let slot_count = slots.iter().max().map_or(0, |&s| s as usize + 1);
    let mut first = vec![0u32; slot_count + 1];
    for tri in &indices {
        tri.iter().for_each(|&i| first[slots[i as usize] as usize + 1] += 1);
    }
    for s in 0..slot_count {
        first[s + 1] += first[s];
    }
    let mut filled = first.clone();
    let mut around = vec![0u32; first[slot_count] as usize];
    for (t, tri) in indices.iter().enumerate() {
        for &i in tri {
            let s = slots[i as usize] as usize;
            around[filled[s] as usize] = t as u32;
            filled[s] += 1;
        }
    }
    drop(filled);

    let cos_crease = CREASE_DEGREES.to_radians().cos() as f32;
    // Within half the crease angle of the vertex's normal, every two
    // triangles are within the crease angle of each other.
    let cos_half = (0.5 * CREASE_DEGREES).to_radians().cos() as f32;
    let mut added = 0;
    for s in 0..slot_count as u32 {
        let here = &around[first[s as usize] as usize..first[s as usize + 1] as usize];
        let Some(&t0) = here.first() else { continue };
        let vertex = normals[indices[t0 as usize][corner_at(&indices, &slots, t0, s)] as usize];
        if here.iter().all(|&t| faces[t as usize].dot(vertex) >= cos_half) {
            continue;
        }
        let fans = fans_around(here, s, &indices, &slots, &faces, cos_crease);
        if fans.iter().all(|&f| f == 0) {
            continue;
        }
        // Each fan's normal, summed in triangle order as `vertex_normals`
        // sums; each index keeps its first fan's, and a copy of the vertex
        // takes each other fan's.
        let fan_count = fans.iter().max().map_or(0, |&f| f as usize + 1);
        let mut sums = vec![Vec3::ZERO; fan_count];
        for (&t, &fan) in here.iter().zip(&fans) {
            let k = corner_at(&indices, &slots, t, s);
            sums[fan as usize] += corner_normals(&positions, indices[t as usize])[k];
        }
        // (Index and fan to the index that takes them; the indices taken.
        // A vertex may have thousands of fans: a pleated disc's centre.)
        let mut copies: HashMap<(u32, u32), u32> = HashMap::new();
        let mut taken: HashSet<u32> = HashSet::new();
        for (&t, &fan) in here.iter().zip(&fans) {
            let k = corner_at(&indices, &slots, t, s);
            let i = indices[t as usize][k];
            let normal = numeric::unit(sums[fan as usize]).unwrap_or(Vec3::ZERO);
            match copies.get(&(i, fan)) {
                Some(&copy) => indices[t as usize][k] = copy,
                None if taken.insert(i) => {
                    normals[i as usize] = normal;
                    copies.insert((i, fan), i);
                }
                None => {
                    let copy = positions.len() as u32;
                    positions.push(positions[i as usize]);
                    normals.push(normal);
                    slots.push(s);
                    copies.insert((i, fan), copy);
                    indices[t as usize][k] = copy;
                    added += 1;
                }
            }
        }
    }
    Creased { positions, indices, normals, added }
}

/// Which corner of triangle `t` lies at place `s`.
fn corner_at(indices: &[[u32; 3]], slots: &[u32], t: u32, s: u32) -> usize {
    indices[t as usize]
        .iter()
        .position(|&i| slots[i as usize] == s)
        .expect("the triangle is around the place")
}

/// The fans of the triangles `here` around place `s`: for each, the number
/// of its fan, from 0 in the order of their first triangles. Two triangles
/// are of one fan where they share an edge from `s` (even one that more
/// triangles share, as a fin) and their normals part by less than the
/// crease (`cos_crease`).
fn fans_around(
    here: &[u32],
    s: u32,
    indices: &[[u32; 3]],
    slots: &[u32],
    faces: &[Vec3],
    cos_crease: f32,
) -> Vec<u32> {
    // Each triangle under the other ends of its two edges from `s`, sorted
    // so that the triangles of one edge come together.
    let mut ends: Vec<(u32, u32)> = here
        .iter()
        .enumerate()
        .flat_map(|(a, &t)| indices[t as usize].map(|i| (slots[i as usize], a as u32)))
        .filter(|&(w, _)| w != s)
        .collect();
    ends.sort_unstable();
    // Union-find over `here`.
    let mut parent: Vec<usize> = (0..here.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for edge in ends.chunk_by(|x, y| x.0 == y.0) {
        for (k, &(_, a)) in edge.iter().enumerate() {
            for &(_, b) in &edge[k + 1..] {
                let (a, b) = (a as usize, b as usize);
                if faces[here[a] as usize].dot(faces[here[b] as usize]) >= cos_crease {
                    let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
    }
    // Numbered in the order of their first triangles.
    let (mut number_of_root, mut fans) = (vec![u32::MAX; here.len()], 0);
    (0..here.len())
        .map(|i| {
            let r = root(&mut parent, i);
            if number_of_root[r] == u32::MAX {
                number_of_root[r] = fans;
                fans += 1;
            }
            number_of_root[r]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`creased`], the places worked out here.
    fn creased_anew(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Creased {
        let slots = crate::scene::mesh::position_slots(&positions);
        creased(positions, indices, slots)
    }
    use crate::scene::mesh::vertex_normals;
    use crate::scene::test_scenes::unit_cube as cube;

    #[test]
    fn a_box_keeps_its_faces_flat() {
        let (p, t) = cube();
        let c = creased_anew(p.clone(), t);
        // Each corner, on three faces, is three vertices.
        assert_eq!((c.added, c.positions.len()), (16, 24));
        for tri in &c.indices {
            let face = face_normal(&c.positions, *tri).unwrap();
            for &i in tri {
                assert_eq!(c.normals[i as usize], face, "corner {i}");
            }
        }
        // The copies are at the corners they copy, three at each.
        for corner in &p {
            assert_eq!(c.positions.iter().filter(|q| *q == corner).count(), 3);
        }
    }

    #[test]
    fn a_curved_surface_keeps_the_smooth_normals_bit_for_bit() {
        let sphere = crate::scene::shapes::sphere("s", Vec3::ZERO, 1.0, 3, 0);
        let smooth = vertex_normals(&sphere.positions, &sphere.indices);
        let c = creased_anew(sphere.positions.clone(), sphere.indices.clone());
        assert_eq!(c.added, 0);
        assert_eq!(c.indices, sphere.indices);
        assert_eq!(c.normals, smooth);
    }

    /// Two triangles folded along the x axis: smooth across at 45 degrees
    /// between their normals, apart at 90.
    #[test]
    fn a_fold_is_a_crease_beyond_the_crease_angle() {
        let fold = |degrees: f32| {
            let (s, c) = degrees.to_radians().sin_cos();
            let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, c, s)];
            creased_anew(p, vec![[0, 1, 3], [0, 2, 1]])
        };
        let gentle = fold(45.0);
        assert_eq!(gentle.added, 0);
        let sharp = fold(90.0);
        assert_eq!(sharp.added, 2);
        for tri in &sharp.indices {
            let face = face_normal(&sharp.positions, *tri).unwrap();
            assert!(tri.iter().all(|&i| sharp.normals[i as usize].abs_diff_eq(face, 1e-6)));
        }
        // At 90 degrees, split corners written once at 0 and once at -0 are
        // one place, and each index keeps its own fan: nothing copied.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, -1.0, 0.0), -Vec3::ZERO, Vec3::X, Vec3::Z];
        let seam = creased_anew(p, vec![[3, 4, 5], [0, 2, 1]]);
        assert_eq!(seam.added, 0);
        assert!(seam.normals[3].abs_diff_eq(Vec3::new(0.0, -1.0, 0.0), 1e-6), "{}", seam.normals[3]);
        assert!(seam.normals[0].abs_diff_eq(Vec3::Z, 1e-6), "{}", seam.normals[0]);
    }

    /// Three triangles on one edge (a fin): the two that meet gently are
    /// smooth, the one standing at 90 degrees apart.
    #[test]
    fn a_fin_is_smooth_where_it_meets_gently() {
        let p = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.5, 1.0, 0.0),
            Vec3::new(0.5, -1.0, 0.1),
            Vec3::new(0.5, 0.0, 1.0),
        ];
        let c = creased_anew(p, vec![[0, 1, 2], [0, 3, 1], [0, 1, 4]]);
        // The edge's two corners each take a second normal.
        assert_eq!(c.added, 2);
        assert_eq!(c.normals[c.indices[2][0] as usize], Vec3::new(0.0, -1.0, 0.0));
        assert!(c.normals[0].z > 0.9, "{}", c.normals[0]);
    }

    /// A pleated disc: its triangles fold sharply at every edge, so its
    /// centre takes a normal for each triangle, and each corner on the rim
    /// one for each of its two. (A list searched for each corner made this
    /// quadratic in the fans: 100,000 of them took 4.4 s to load.)
    #[test]
    fn a_vertex_of_many_fans_takes_a_normal_for_each() {
        let n = 2000;
        let rim = (0..n).map(|i| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            Vec3::new(a.cos(), a.sin(), if i % 2 == 0 { 0.05 } else { -0.05 })
        });
        let positions: Vec<Vec3> = std::iter::once(Vec3::ZERO).chain(rim).collect();
        let indices: Vec<[u32; 3]> = (0..n).map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect();
        let c = creased_anew(positions, indices);
        assert_eq!(c.added, (n as usize - 1) + n as usize);
        for tri in &c.indices {
            let face = face_normal(&c.positions, *tri).unwrap();
            assert!(tri.iter().all(|&i| c.normals[i as usize].abs_diff_eq(face, 1e-5)));
        }
    }
}
