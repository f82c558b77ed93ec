//! Built-in shapes as triangle meshes: sphere, quad, box.

use std::collections::HashMap;

use glam::Vec3;

use super::mesh::Mesh;

/// An icosphere: an icosahedron whose faces are split into four,
/// `subdivisions` times, with every vertex pushed onto the sphere.
/// It has `20 * 4^subdivisions` nearly equal triangles, is closed, and shades
/// smoothly through averaged vertex normals.
pub fn sphere(name: &str, center: Vec3, radius: f32, subdivisions: u32, material: usize) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut points: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&p| Vec3::from_array(p).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoint_of: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, points: &mut Vec<Vec3>| {
            *midpoint_of.entry((a.min(b), a.max(b))).or_insert_with(|| {
                points.push(((points[a as usize] + points[b as usize]) * 0.5).normalize());
                points.len() as u32 - 1
            })
        };
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = midpoint(a, b, &mut points);
                let bc = midpoint(b, c, &mut points);
                let ca = midpoint(c, a, &mut points);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let positions = points.iter().map(|&p| center + radius * p).collect();
    Mesh::new(name, positions, faces, None, material)
}

/// A flat parallelogram with centre `center` and full edge vectors `u` and
/// `v`. Its front (normal `u x v`) is the counter-clockwise side.
pub fn quad(name: &str, center: Vec3, u: Vec3, v: Vec3, material: usize) -> Mesh {
    let corner = center - 0.5 * (u + v);
    let positions = vec![corner, corner + u, corner + u + v, corner + v];
    let normal = u.cross(v).normalize_or_zero();
    Mesh::new(name, positions, vec![[0, 1, 2], [0, 2, 3]], Some(vec![normal; 4]), material)
}

/// An axis-aligned box from `min` to `max` with flat, outward-facing sides
/// (each side has its own four vertices so its edges stay sharp).
pub fn cuboid(name: &str, min: Vec3, max: Vec3, material: usize) -> Mesh {
    let size = max - min;
    let center = 0.5 * (min + max);
    let mut positions = Vec::with_capacity(24);
    let mut normals = Vec::with_capacity(24);
    let mut indices = Vec::with_capacity(12);
    for axis in 0..3 {
        let n = Vec3::AXES[axis];
        // Two edge vectors spanning the side, ordered so that u x v = n.
        let u = Vec3::AXES[(axis + 1) % 3] * size;
        let v = Vec3::AXES[(axis + 2) % 3] * size;
        for sign in [1.0f32, -1.0] {
            let side = quad("", center + sign * 0.5 * n * size, sign * u, v, 0);
            let base = positions.len() as u32;
            positions.extend(side.positions);
            normals.extend([sign * n; 4]);
            indices.extend(side.indices.iter().map(|t| t.map(|i| i + base)));
        }
    }
    Mesh::new(name, positions, indices, Some(normals), material)
}

/// A closed thick-walled ring (a napkin ring, or a cup without a bottom):
/// the solid between two coaxial cylinders of radii `inner < outer`, from
/// `base` up `height` along +y. Walls are smooth (`segments` around), the
/// flat top and bottom annuli keep sharp edges. A mirror ring under a low
/// light focuses a cardioid caustic on the floor inside it.
pub fn ring(
    name: &str,
    base: Vec3,
    inner: f32,
    outer: f32,
    height: f32,
    segments: u32,
    material: usize,
) -> Mesh {
    let segments = segments.max(3);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    let around = |k: u32| {
        let a = std::f32::consts::TAU * k as f32 / segments as f32;
        Vec3::new(a.cos(), 0.0, -a.sin())
    };
    let up = Vec3::Y * height;
    // Each band is a strip of quads between two circles (bottom edge a, top edge b).
    let mut band = |a: &dyn Fn(u32) -> Vec3, b: &dyn Fn(u32) -> Vec3, n: &dyn Fn(u32) -> Vec3| {
        let start = positions.len() as u32;
        for k in 0..segments {
            positions.extend([base + a(k), base + b(k)]);
            normals.extend([n(k), n(k)]);
        }
        for k in 0..segments {
            let (a0, b0) = (start + 2 * k, start + 2 * k + 1);
            let (a1, b1) = (start + 2 * ((k + 1) % segments), start + 2 * ((k + 1) % segments) + 1);
            indices.extend([[a0, a1, b1], [a0, b1, b0]]);
        }
    };
    // Counter-clockwise seen from outside: outer wall faces out, inner wall in.
    band(&|k| outer * around(k), &|k| outer * around(k) + up, &around);
    band(&|k| inner * around(k) + up, &|k| inner * around(k), &|k| -around(k));
    band(&|k| outer * around(k) + up, &|k| inner * around(k) + up, &|_| Vec3::Y);
    band(&|k| inner * around(k), &|k| outer * around(k), &|_| -Vec3::Y);
    Mesh::new(name, positions, indices, Some(normals), material)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_faces_u_cross_v() {
        let q = quad("q", Vec3::ZERO, Vec3::X * 2.0, Vec3::Y, 0);
        assert_eq!(q.indices.len(), 2);
        assert!(q.face_normal(0).abs_diff_eq(Vec3::Z, 1e-6));
        assert!(q.face_normal(1).abs_diff_eq(Vec3::Z, 1e-6));
        assert_eq!(q.bounds().min, Vec3::new(-1.0, -0.5, 0.0));
    }

    #[test]
    fn box_sides_face_outward() {
        let b = cuboid("b", Vec3::splat(-1.0), Vec3::new(1.0, 2.0, 3.0), 0);
        assert_eq!(b.indices.len(), 12);
        let center = Vec3::new(0.0, 0.5, 1.0);
        for prim in 0..12u32 {
            let [i0, ..] = b.indices[prim as usize];
            let outward = b.positions[i0 as usize] - center;
            let n = b.face_normal(prim);
            assert!(n.dot(outward) > 0.0, "triangle {prim} faces inward");
            assert!(b.shading_normal(prim, 0.2, 0.2).abs_diff_eq(n, 1e-6));
        }
        assert_eq!(b.bounds().max, Vec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn ring_is_closed_and_faces_outward() {
        let r = ring("r", Vec3::ZERO, 0.8, 1.0, 0.5, 48, 0);
        assert_eq!(r.indices.len(), 4 * 2 * 48);
        // Outward: each face normal points away from the wall's mid-surface
        // (radius 0.9, height 0.25) on the side its triangle lies.
        for prim in 0..r.indices.len() as u32 {
            let [a, b, c] = r.indices[prim as usize].map(|i| r.positions[i as usize]);
            let centroid = (a + b + c) / 3.0;
            let radial = Vec3::new(centroid.x, 0.0, centroid.z).normalize();
            let mid = 0.9 * radial + Vec3::Y * 0.25;
            assert!(r.face_normal(prim).dot(centroid - mid) > 0.0, "triangle {prim} faces inward");
        }
        // Closed: every edge is shared by exactly two triangles, once each way.
        let mut directed = std::collections::HashSet::new();
        let key = |i: u32| r.positions[i as usize].to_array().map(f32::to_bits);
        for t in &r.indices {
            for e in 0..3 {
                assert!(directed.insert((key(t[e]), key(t[(e + 1) % 3]))), "edge used twice one way");
            }
        }
        assert!(directed.iter().all(|(a, b)| directed.contains(&(*b, *a))), "open edge");
    }

    #[test]
    fn icosphere_counts_and_radius() {
        let s = sphere("s", Vec3::new(1.0, 2.0, 3.0), 2.0, 3, 0);
        assert_eq!(s.indices.len(), 20 * 4usize.pow(3));
        // Closed: V - E + F = 2 with E = 3F/2.
        let f = s.indices.len() as i64;
        assert_eq!(s.positions.len() as i64 - 3 * f / 2 + f, 2);
        for p in &s.positions {
            assert!(((*p - Vec3::new(1.0, 2.0, 3.0)).length() - 2.0).abs() < 1e-5);
        }
    }
}
