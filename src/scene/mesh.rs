//! Triangle meshes: shared vertex positions, smooth per-vertex normals, and
//! the smooth normal at a hit from Embree's barycentrics.

use glam::{DMat3, DMat4, DVec3, Vec3};
use rayon::prelude::*;

use super::creases;
use super::winding::Normals;
use crate::accel::embree::TriangleView;
pub use crate::bounds::Bounds;
use crate::numeric;

/// A triangle mesh with one material.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Where the mesh came from, for messages (`"sphere #2"`, `"bunny.obj"`).
    pub name: String,
    /// Vertex positions, shared between triangles. Move them only with
    /// [`Mesh::place`], which keeps the triangles' normals with them.
    pub positions: Vec<Vec3>,
    /// Unit normal per vertex (same length as `positions`).
    pub normals: Vec<Vec3>,
    /// Vertex indices, counter-clockwise seen from the front (outside).
    pub indices: Vec<[u32; 3]>,
    /// Index into the scene's materials.
    pub material: usize,
    /// Each triangle's unit normal, [`Mesh::face_normal`] worked out once,
    /// for meshes of up to [`FACE_NORMALS_UP_TO`] triangles (empty for larger).
    face_normals: Vec<Vec3>,
}

/// The normals a mesh file's triangles will shade with: the file's own,
/// or smooth ones worked out over the vertices' places
/// ([`position_slots`]), which the winding pass needs first and the
/// creases after it (worked out once for both).
pub(super) enum FileNormals {
    /// The file's vertex normals (an STL file's flat ones too).
    Given(Vec<Vec3>),
    /// None in the file: each vertex's place.
    Smooth(Vec<u32>),
}

impl FileNormals {
    /// The file's normals if it gives them, else the places of `positions`.
    pub(super) fn of(given: Option<Vec<Vec3>>, positions: &[Vec3]) -> FileNormals {
        match given {
            Some(normals) => FileNormals::Given(normals),
            None => FileNormals::Smooth(position_slots(positions)),
        }
    }

    /// What the winding pass is told of them.
    pub(super) fn for_winding(&self) -> Normals<'_> {
        match self {
            FileNormals::Given(normals) => Normals::FromFile(normals),
            FileNormals::Smooth(slots) => Normals::Smooth(slots),
        }
    }

    /// The mesh of the file's `positions` and `indices` shading with them.
    pub(super) fn mesh(
        self,
        name: impl Into<String>,
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
        material: usize,
    ) -> Mesh {
        match self {
            FileNormals::Given(normals) => Mesh::new(name, positions, indices, Some(normals), material),
            FileNormals::Smooth(slots) => Mesh::with_creases(name, positions, indices, slots, material),
        }
    }
}

/// The warning for the mesh of a file (`who`, as warnings name it) that
/// kept `kept` of its `faces` triangles: those of no area are left out
/// ([`Mesh::new`]).
pub(super) fn no_area_warning(who: &str, faces: usize, kept: usize) -> Option<String> {
    (kept < faces).then(|| {
        format!(
            "{who}: {} of its {faces} triangles have no area (repeated or collinear vertices) and were left out",
            faces - kept
        )
    })
}

/// Meshes of up to this many triangles keep each triangle's normal rather
/// than working it out (in `f64`) at every hit: 4-5% of a render's time on
/// the teapot and the Cornell box (BENCHMARKS.md, issue 17). It costs 12
/// bytes a triangle, half again the mesh's own 24; larger meshes, whose
/// memory is measured against a goal, work it out as before.
pub const FACE_NORMALS_UP_TO: usize = 4_000_000;

/// Meshes of fewer vertices or triangles than this are worked on by the
/// calling thread: handing a small mesh to the thread pool costs more than
/// it saves (an OBJ file of 20,000 objects of 4 triangles took 1.06 s to
/// load, most of it threads woken and put back to sleep; BENCHMARKS.md).
const PARALLEL_FROM: usize = 1 << 14;

/// `f` of every item (and its index), in order: in parallel for
/// [`PARALLEL_FROM`] items or more, else on this thread.
fn map_all<T: Sync, U: Send>(items: &[T], f: impl Fn(usize, &T) -> U + Sync + Send) -> Vec<U> {
    if items.len() < PARALLEL_FROM {
        items.iter().enumerate().map(|(i, item)| f(i, item)).collect()
    } else {
        items.par_iter().enumerate().map(|(i, item)| f(i, item)).collect()
    }
}

/// `f` on every item, in parallel for [`PARALLEL_FROM`] items or more.
fn change_all<T: Send>(items: &mut [T], f: impl Fn(&mut T) + Sync + Send) {
    if items.len() < PARALLEL_FROM {
        items.iter_mut().for_each(f);
    } else {
        items.par_iter_mut().for_each(f);
    }
}

impl Mesh {
    /// A mesh from positions and triangles. Triangles with zero area are
    /// dropped (Embree could never hit them, and they have no normal). Without
    /// `normals`, smooth vertex normals are computed with [`vertex_normals`].
    ///
    /// Indices must be in range; callers validate user data before this.
    pub fn new(
        name: impl Into<String>,
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
        normals: Option<Vec<Vec3>>,
        material: usize,
    ) -> Mesh {
        debug_assert!(indices.iter().flatten().all(|&i| (i as usize) < positions.len()));
        let indices: Vec<[u32; 3]> =
            indices.into_iter().filter(|&t| face_normal(&positions, t).is_some()).collect();
        let normals = match normals {
            Some(n) => n.into_iter().map(|n| numeric::unit(n).unwrap_or(Vec3::ZERO)).collect(),
            None => vertex_normals(&positions, &indices),
        };
        Mesh::assembled(name.into(), positions, indices, normals, material)
    }

    /// A mesh from a file's positions and triangles, without normals of
    /// its own: smooth normals kept apart across creases
    /// ([`creases::creased`]), over the vertices' places `slots`
    /// ([`position_slots`]).
    fn with_creases(
        name: impl Into<String>,
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
        slots: Vec<u32>,
        material: usize,
    ) -> Mesh {
        debug_assert!(indices.iter().flatten().all(|&i| (i as usize) < positions.len()));
        debug_assert_eq!(slots.len(), positions.len());
        let creased = creases::creased(positions, indices, slots);
        Mesh::assembled(name.into(), creased.positions, creased.indices, creased.normals, material)
    }

    /// The mesh of triangles of some area, and their normals.
    fn assembled(
        name: String,
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
        normals: Vec<Vec3>,
        material: usize,
    ) -> Mesh {
        let mut mesh = Mesh {
            name,
            positions: pad_for_embree(positions),
            normals,
            indices,
            material,
            face_normals: Vec::new(),
        };
        mesh.keep_face_normals();
        mesh
    }

    /// The triangles as an intersector reads them.
    pub fn view(&self) -> TriangleView<'_> {
        TriangleView::padded(&self.positions, &self.indices)
    }

    /// Bytes of the mesh's own arrays: positions, normals, indices and the
    /// triangles' normals where it keeps them.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.positions.as_slice())
            + std::mem::size_of_val(self.normals.as_slice())
            + std::mem::size_of_val(self.indices.as_slice())
            + std::mem::size_of_val(self.face_normals.as_slice())
    }

    /// The bounding box of the vertices.
    pub fn bounds(&self) -> Bounds {
        Bounds::of(&self.positions)
    }

    /// The total area of the triangles, in `f64` (exact at any scale), summed
    /// in parallel blocks in a fixed order (the same at any thread count).
    pub fn area(&self) -> f64 {
        let triangle = |&[i0, i1, i2]: &[u32; 3]| {
            let p0 = self.positions[i0 as usize];
            0.5 * numeric::cross_length(self.positions[i1 as usize] - p0, self.positions[i2 as usize] - p0)
        };
        // (Under `PARALLEL_FROM` triangles, one block: the same sum either way.)
        if self.indices.len() < PARALLEL_FROM {
            return self.indices.iter().map(triangle).sum::<f64>();
        }
        self.indices
            .par_chunks(1 << 16)
            .map(|block| block.iter().map(triangle).sum::<f64>())
            .collect::<Vec<f64>>()
            .iter()
            .sum()
    }

    /// Geometric normal of triangle `prim` (unit length, counter-clockwise side).
    #[inline]
    pub fn face_normal(&self, prim: u32) -> Vec3 {
        match self.face_normals.get(prim as usize) {
            Some(&n) => n,
            None => self.work_out_face_normal(prim),
        }
    }

    fn work_out_face_normal(&self, prim: u32) -> Vec3 {
        face_normal(&self.positions, self.indices[prim as usize]).unwrap_or(Vec3::Z)
    }

    /// Works out every triangle's normal once, if the mesh is small enough
    /// to keep them ([`FACE_NORMALS_UP_TO`]), in parallel.
    fn keep_face_normals(&mut self) {
        self.face_normals = Vec::new();
        if self.indices.len() <= FACE_NORMALS_UP_TO {
            self.face_normals = map_all(&self.indices, |prim, _| self.work_out_face_normal(prim as u32));
        }
    }

    /// The smooth shading normal at barycentrics `(u, v)` of triangle `prim`:
    /// the normalised blend `(1-u-v) n0 + u n1 + v n2` (Embree's convention).
    /// Falls back to the face normal where the blend cancels out.
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32) -> Vec3 {
        let [i0, i1, i2] = self.indices[prim as usize];
        let n = (1.0 - u - v) * self.normals[i0 as usize]
            + u * self.normals[i1 as usize]
            + v * self.normals[i2 as usize];
        numeric::unit(n).unwrap_or_else(|| self.face_normal(prim))
    }

    /// Places the mesh: each point `p` becomes `m p - origin`, computed in
    /// `f64`, so that a mesh far from the world's origin keeps its detail
    /// when `origin` is near it (the scene re-centres at the camera). Normals
    /// go by the inverse transpose, and a mirroring `m` flips the winding.
    pub fn place(&mut self, m: &DMat4, origin: DVec3) {
        if *m == DMat4::IDENTITY && origin == DVec3::ZERO {
            return;
        }
        change_all(&mut self.positions, |p| *p = (m.transform_point3(p.as_dvec3()) - origin).as_vec3());
        let linear = DMat3::from_mat4(*m);
        let normal_matrix = linear.inverse().transpose();
        change_all(&mut self.normals, |n| {
            *n = (normal_matrix * n.as_dvec3()).try_normalize().map_or(Vec3::ZERO, |n| n.as_vec3());
        });
        if linear.determinant() < 0.0 {
            for t in &mut self.indices {
                t.swap(1, 2);
            }
        }
        self.keep_face_normals();
    }
}

/// Makes sure one zeroed `Vec3` is allocated after the last position, so that
/// Embree can read the positions in place (see [`TriangleView::padded`]).
/// Free when the producer allocated one more than it needed; one copy otherwise.
fn pad_for_embree(mut positions: Vec<Vec3>) -> Vec<Vec3> {
    positions.reserve_exact(1);
    positions.spare_capacity_mut()[0].write(Vec3::ZERO);
    positions
}

/// The unit normal along `(p1 - p0) x (p2 - p0)`, the counter-clockwise side;
/// `None` for a triangle of no area. Exact at any scale (see [`numeric`]).
pub(super) fn face_normal(positions: &[Vec3], [i0, i1, i2]: [u32; 3]) -> Option<Vec3> {
    let p0 = positions[i0 as usize];
    numeric::unit_cross(positions[i1 as usize] - p0, positions[i2 as usize] - p0)
}

/// Smooth vertex normals: at each vertex, the average of the unit normals of
/// ALL adjacent triangles, each weighted by the triangle's angle at that vertex
/// (Thürmer and Wüthrich's angle weighting: independent of how a surface is
/// split into triangles).
///
/// Vertices at bit-identical positions share one normal, so a mesh whose
/// vertices were split (e.g. by OBJ texture seams) still shades smoothly.
/// A vertex with no non-degenerate neighbour gets the zero vector.
pub fn vertex_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    vertex_normals_at(positions, indices, &position_slots(positions))
}

/// [`vertex_normals`], with the vertices' places (`position_slots`)
/// already worked out.
pub(super) fn vertex_normals_at(positions: &[Vec3], indices: &[[u32; 3]], slots: &[u32]) -> Vec<Vec3> {
    let slot_count = slots.iter().max().map_or(0, |&s| s as usize + 1);
    let mut sums = vec![Vec3::ZERO; slot_count];
    // The angle weights (an `acos` per corner) are computed in parallel a
    // block at a time; the sums are added in triangle order, so the normals
    // are the same whatever the thread count.
    const BLOCK: usize = 1 << 16;
    for block in indices.chunks(BLOCK) {
        let weighted = map_all(block, |_, &tri| corner_normals(positions, tri));
        for (tri, corners) in block.iter().zip(&weighted) {
            for (&vertex, &n) in tri.iter().zip(corners) {
                sums[slots[vertex as usize] as usize] += n;
            }
        }
    }
    slots.iter().map(|&s| numeric::unit(sums[s as usize]).unwrap_or(Vec3::ZERO)).collect()
}

/// The face's unit normal times its angle at each corner (zero for a
/// degenerate face).
pub(super) fn corner_normals(positions: &[Vec3], tri: [u32; 3]) -> [Vec3; 3] {
    let Some(face) = face_normal(positions, tri) else {
        return [Vec3::ZERO; 3];
    };
    [0, 1, 2].map(|corner| {
        let here = positions[tri[corner] as usize];
        let a = positions[tri[(corner + 1) % 3] as usize] - here;
        let b = positions[tri[(corner + 2) % 3] as usize] - here;
        numeric::angle_between(a, b) * face
    })
}

/// For each vertex, a slot shared by all vertices at its bit-identical
/// position (-0 and 0 are one: files print both). Found by sorting (in
/// parallel) rather than hashing: a sorted list of 16-byte keys takes less
/// memory than a hash map of them.
pub(super) fn position_slots(positions: &[Vec3]) -> Vec<u32> {
    let mut keyed: Vec<([u32; 3], u32)> =
        map_all(positions, |i, &p| ((p + Vec3::ZERO).to_array().map(f32::to_bits), i as u32));
    // (Each key holds its vertex: no two are equal, so either sort gives one order.)
    if keyed.len() < PARALLEL_FROM {
        keyed.sort_unstable();
    } else {
        keyed.par_sort_unstable();
    }
    let mut slots = vec![0u32; positions.len()];
    let mut slot = 0;
    for (k, &(key, vertex)) in keyed.iter().enumerate() {
        if k > 0 && keyed[k - 1].0 != key {
            slot += 1;
        }
        slots[vertex as usize] = slot;
    }
    slots
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    /// A unit square split into two triangles, facing +z.
    fn square() -> Mesh {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        Mesh::new("square", p, vec![[0, 1, 2], [0, 2, 3]], None, 0)
    }

    /// A height field of `n` x `n` vertices over the unit square, its
    /// triangles facing up (+z), bent so that no two share a normal.
    fn height_field(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let at = |i: u32, j: u32| {
            let (x, y) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
            Vec3::new(x, y, 0.3 * (x * x + 2.0 * y * y * y))
        };
        let positions = (0..n * n).map(|k| at(k % n, k / n)).collect();
        let quads = (0..n - 1).flat_map(|j| (0..n - 1).map(move |i| j * n + i));
        let indices = quads.flat_map(|v| [[v, v + 1, v + n + 1], [v, v + n + 1, v + n]]).collect();
        (positions, indices)
    }

    /// Meshes big enough to be worked on in parallel get what the calling
    /// thread alone gives: the same normals, triangles' normals and area,
    /// bit for bit, as the same mesh cut into pieces of fewer triangles than
    /// the threshold (each piece keeps all the vertices, so the work by
    /// vertex, whose order cannot change the result, is parallel in both).
    #[test]
    fn big_meshes_in_parallel_match_small_ones_on_one_thread() {
        let (positions, indices) = height_field(160);
        assert!(positions.len() >= PARALLEL_FROM && indices.len() >= PARALLEL_FROM);
        let whole = Mesh::new("whole", positions.clone(), indices.clone(), None, 0);
        // Rows of the field by themselves (each vertex's neighbours are all
        // in its piece but on the pieces' shared rows, left out here).
        let rows = 40;
        for piece in 0..3u32 {
            let first = piece * (rows - 1) * 159 * 2;
            let tris: Vec<[u32; 3]> = indices[first as usize..][..((rows - 1) * 159 * 2) as usize].to_vec();
            assert!(tris.len() < PARALLEL_FROM);
            let small = Mesh::new("piece", positions.clone(), tris.clone(), None, 0);
            for (k, tri) in tris.iter().enumerate() {
                let prim = first as usize + k;
                assert_eq!(small.face_normal(k as u32), whole.face_normal(prim as u32));
                // Vertices off the piece's first and last row have all their triangles in it.
                for &v in tri {
                    let row = v / 160;
                    if row > piece * (rows - 1) && row < (piece + 1) * (rows - 1) {
                        assert_eq!(small.normals[v as usize], whole.normals[v as usize], "vertex {v}");
                    }
                }
            }
        }
        let sequential: f64 = indices
            .chunks(PARALLEL_FROM - 1)
            .map(|tris| Mesh::new("piece", positions.clone(), tris.to_vec(), None, 0).area())
            .sum();
        assert!((whole.area() - sequential).abs() < 1e-12 * sequential, "{} {sequential}", whole.area());
        // And placing it moves every vertex as one at a time would.
        let mut placed = whole.clone();
        let m = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0)) * DMat4::from_rotation_y(0.3);
        placed.place(&m, DVec3::new(0.5, 0.0, 0.0));
        for (p, q) in whole.positions.iter().zip(&placed.positions).step_by(997) {
            assert_eq!(*q, (m.transform_point3(p.as_dvec3()) - DVec3::new(0.5, 0.0, 0.0)).as_vec3());
        }
    }

    #[test]
    fn flat_mesh_normals_are_the_face_normal() {
        let m = square();
        assert!(m.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
        assert!(m.shading_normal(1, 0.3, 0.3).abs_diff_eq(Vec3::Z, 1e-6));
    }

    #[test]
    fn shading_normal_blends_with_embree_weights() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let n = vec![Vec3::Z, Vec3::X, Vec3::Y];
        let m = Mesh::new("tri", p, vec![[0, 1, 2]], Some(n), 0);
        // Weights (1-u-v, u, v): u weights vertex 1, v weights vertex 2.
        assert!(m.shading_normal(0, 1.0, 0.0).abs_diff_eq(Vec3::X, 1e-6));
        assert!(m.shading_normal(0, 0.0, 1.0).abs_diff_eq(Vec3::Y, 1e-6));
        assert!(m.shading_normal(0, 0.0, 0.0).abs_diff_eq(Vec3::Z, 1e-6));
        let mid = m.shading_normal(0, 0.5, 0.5);
        assert!(mid.abs_diff_eq(Vec3::new(1.0, 1.0, 0.0).normalize(), 1e-6));
    }

    #[test]
    fn angle_weighting_ignores_how_a_face_is_split() {
        // A corner of a cube: one +x face as 1 triangle, one +y face as 2, one
        // +z face as 3. Angle weighting gives the symmetric diagonal anyway.
        let o = Vec3::ZERO;
        let p = vec![
            o,
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.5, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        // Face in the x=0 plane (normal -x), one triangle: o, z, y.
        // Face in the y=0 plane (normal -y), two triangles: o, x, xz and o, xz, z.
        // Face in the z=0 plane (normal -z), three triangles: o, y, hy; o, hy, xy; o, xy, x.
        let tris = vec![[0, 2, 1], [0, 3, 4], [0, 4, 2], [0, 1, 5], [0, 5, 6], [0, 6, 3]];
        let n = vertex_normals(&p, &tris)[0];
        assert!(n.abs_diff_eq(-Vec3::ONE.normalize(), 1e-5), "corner normal {n}");
    }

    #[test]
    fn split_vertices_at_one_position_share_a_normal() {
        // Two triangles folded along the x axis, with the shared edge duplicated.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO, Vec3::Z, Vec3::X];
        let tris = vec![[0, 1, 2], [3, 4, 5]];
        let n = vertex_normals(&p, &tris);
        assert!(n[0].abs_diff_eq(n[3], 1e-6));
        assert!(n[1].abs_diff_eq(n[5], 1e-6));
        // The same with the second origin written -0 (as files print it).
        let mut q = p.clone();
        q[3] = -Vec3::ZERO;
        let m = vertex_normals(&q, &tris);
        assert_eq!(m[3], n[3]);
        assert_eq!(m[0], m[3]);
    }

    #[test]
    fn degenerate_triangles_are_dropped() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0];
        let m = Mesh::new("d", p, vec![[0, 1, 2], [0, 1, 3], [1, 1, 2]], None, 0);
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn transform_moves_points_and_keeps_normals_perpendicular() {
        let mut m = square();
        // Non-uniform scale then a rotation: normals need the inverse transpose.
        let tilt = Mat4::from_rotation_x(0.7) * Mat4::from_scale(Vec3::new(3.0, 1.0, 0.2));
        let mut sloped =
            Mesh::new("slope", vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1.0)], vec![[0, 1, 2]], None, 0);
        sloped.place(&tilt.as_dmat4(), DVec3::ZERO);
        let face = sloped.face_normal(0);
        assert!(sloped.normals.iter().all(|n| n.abs_diff_eq(face, 1e-5)), "{:?} vs {face}", sloped.normals);
        m.place(&Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0)).as_dmat4(), DVec3::ZERO);
        assert_eq!(m.bounds().min.z, 5.0);
        // Placed relative to an origin: the same points, moved by it.
        m.place(&DMat4::IDENTITY, DVec3::new(0.0, 0.0, 1e7));
        assert_eq!(m.bounds().min.z, 5.0 - 1e7);
    }

    #[test]
    fn mirroring_keeps_the_outside_counter_clockwise() {
        let mut m = square();
        m.place(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)).as_dmat4(), DVec3::ZERO);
        // Normals still +z, and the winding agrees with them.
        assert!(m.face_normal(0).abs_diff_eq(Vec3::Z, 1e-6));
        assert!(m.normals[0].abs_diff_eq(Vec3::Z, 1e-6));
    }

    #[test]
    fn kept_triangle_normals_are_the_ones_worked_out_after_placing() {
        let mut m = crate::scene::shapes::sphere("s", Vec3::ZERO, 1.0, 2, 0);
        let tilt = Mat4::from_rotation_y(0.3) * Mat4::from_scale(Vec3::new(-2.0, 0.5, 1.0));
        m.place(&tilt.as_dmat4(), DVec3::new(1e3, 0.0, 0.0));
        assert_eq!(m.face_normals.len(), m.indices.len());
        for prim in 0..m.indices.len() as u32 {
            assert_eq!(m.face_normal(prim).to_array(), m.work_out_face_normal(prim).to_array());
        }
    }
}
