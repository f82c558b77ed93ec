//! Lights a mesh file gives by its faces: where an OBJ file's MTL material
//! emits (`Ke`), its faces become area lights of that radiance, as a scene
//! file's `[[area_light]]` would be: faces that make parallelograms (a
//! quad, or two triangles across a diagonal; the light of the Cornell box
//! as it is passed around as OBJ is one) as one panel each, and the
//! triangles left (a curved lamp's) as triangle lights ([`Shape`]).
//!
//! An area light is one-sided and blocks rays on both sides (its back is
//! black), so the faces that become lights leave the mesh; the side a
//! light faces is its faces' own: that of the file's vertex normals where
//! it gives them, else of their winding in the file (as Mitsuba and pbrt
//! read an emitting mesh; see [`panels`]).

use glam::{DMat4, DVec3, Vec3};

use crate::light::{Light, Shape};

/// An emitting panel of a mesh file, in the file's coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshLight {
    /// The mesh (file and object) it came from.
    pub mesh: String,
    /// A parallelogram or a triangle, over `center`, `u` and `v` as
    /// [`Shape`] says.
    pub shape: Shape,
    /// Its centre (a triangle's: [`Shape::Triangle`]).
    pub center: DVec3,
    /// A full edge vector: a parallelogram's corners at `center +- u/2 +-
    /// v/2`; light leaves from the side `u x v` faces.
    pub u: DVec3,
    /// The other full edge vector.
    pub v: DVec3,
    /// Radiance leaving its front (the material's `Ke`).
    pub radiance: Vec3,
}

impl MeshLight {
    /// The light where a `[[mesh]]`'s `matrix` puts it, relative to the
    /// scene's `origin`; `None` if the matrix leaves it no area. Its power is
    /// its radiance over its placed area, so a mesh scaled up sends more.
    pub fn placed(&self, matrix: &DMat4, origin: DVec3) -> Option<Light> {
        let center = (matrix.transform_point3(self.center) - origin).as_vec3();
        let (mut u, mut v) = (matrix.transform_vector3(self.u), matrix.transform_vector3(self.v));
        // A mirroring matrix turns u x v away from the faces' placed front
        // (as it turns their winding, which `Mesh::place` turns back).
        if matrix.determinant() < 0.0 {
            std::mem::swap(&mut u, &mut v);
        }
        // (Swapping a triangle's edges keeps its corners: it is the same triangle.)
        let whole = u.cross(v).length();
        if !(whole > 0.0 && whole.is_finite()) {
            return None;
        }
        let area = self.shape.area(whole);
        let power = (self.radiance.as_dvec3() * std::f64::consts::PI * area).as_vec3();
        Some(Light::panel(self.shape, center, u.as_vec3(), v.as_vec3(), power))
    }
}

/// Where lights a mesh file makes lie on an area light the scene file
/// declares, facing the same way: the scene would have that light twice
/// (as it would after declaring a mesh's light by hand, as caustix asked
/// before it read `Ke`). `declared` are the scene file's lights in order;
/// returns a warning for each declared light that mesh lights lie on,
/// naming the first of them (a lamp of many triangles is one warning).
pub fn twice_in_one_place(declared: &[Light], from_meshes: &[(String, Light)]) -> Vec<String> {
    // A panel as its centroid (the centre of a parallelogram; a triangle's
    // `center` is the midpoint of an edge) and its edges.
    let area = |light: &Light| match *light {
        Light::Area { center, u, v, .. } => {
            let (c, u, v) = (center.as_dvec3(), u.as_dvec3(), v.as_dvec3());
            let centroid = if light.shape() == Some(Shape::Triangle) { c - (u + v) / 6.0 } else { c };
            Some((centroid, u, v))
        }
        _ => None,
    };
    // The mesh lights by their centroids' x, so that a declared light
    // looks only at those over its own span of x (a lamp may make a
    // million lights, and a scene declare thousands).
    let panels: Vec<_> = from_meshes.iter().map(|(_, light)| area(light)).collect();
    let mut by_x: Vec<(f64, usize)> =
        panels.iter().enumerate().filter_map(|(i, p)| Some((p.as_ref()?.0.x, i))).collect();
    by_x.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let largest = panels.iter().flatten().map(|(_, u, v)| u.length().max(v.length())).fold(0.0, f64::max);
    let mut warnings = Vec::new();
    for (k, (c2, u2, v2)) in declared.iter().enumerate().filter_map(|(k, l)| Some((k, area(l)?))) {
        let normal2 = u2.cross(v2).normalize();
        let (uu, vv, uv) = (u2.length_squared(), v2.length_squared(), u2.dot(v2));
        let on_it = |(c, u, v): (DVec3, DVec3, DVec3)| {
            // The same way, within a twentieth of their size of the
            // declared light's plane, and its centroid on that light (a
            // twentieth of an edge over): one light, given twice.
            let size = u.length().max(v.length()).max(u2.length()).max(v2.length());
            let local = c - c2;
            let (lu, lv, det) = (local.dot(u2), local.dot(v2), uu * vv - uv * uv);
            let (a, b) = ((vv * lu - uv * lv) / det, (uu * lv - uv * lu) / det);
            normal2.dot(u.cross(v).normalize()) > 0.99
                && local.dot(normal2).abs() < 0.05 * size
                && a.abs() < 0.55
                && b.abs() < 0.55
        };
        // A centroid on the light (a twentieth of an edge over, and off
        // its plane by a twentieth of the larger light's size) lies
        // within this much of its centre along x.
        let size2 = u2.length().max(v2.length());
        let reach = 0.55 * (u2.x.abs() + v2.x.abs()) + 0.05 * largest.max(size2) * normal2.x.abs();
        let from = by_x.partition_point(|&(x, _)| x < c2.x - reach);
        let to = by_x.partition_point(|&(x, _)| x <= c2.x + reach);
        let mut twice: Vec<usize> =
            by_x[from..to].iter().map(|&(_, i)| i).filter(|&i| panels[i].is_some_and(on_it)).collect();
        twice.sort_unstable();
        let Some(&first) = twice.first() else { continue };
        let first = &from_meshes[first].0;
        let more = match twice.len() - 1 {
            0 => String::new(),
            n => format!(" (and {n} more of the mesh files' lights)"),
        };
        warnings.push(format!(
            "{first}{more} lies where the scene file's [[area_light]] #{} does, facing the same way: the \
             scene has that light twice (a mesh file's Ke makes its own lights); leave out the [[area_light]]",
            k + 1
        ));
    }
    warnings
}

/// A parallelogram as its centre and full edge vectors `u` and `v`, its
/// front the side `u x v` faces.
type Parallelogram = (DVec3, DVec3, DVec3);

/// The panels that emitting `triangles` (over `positions`) make: the
/// parallelograms they make in pairs (`parallelograms`), and each
/// triangle left as a triangle, as `(shape, center, u, v)`. A triangle
/// faces its corners' `normals` where the file gives them, else its
/// winding. Triangles of no area make none.
pub fn panels(
    positions: &[Vec3],
    normals: Option<&[Vec3]>,
    triangles: &[[u32; 3]],
) -> Vec<(Shape, DVec3, DVec3, DVec3)> {
    let (found, left) = parallelograms(positions, normals, triangles);
    let mut panels: Vec<_> = found.into_iter().map(|(c, u, v)| (Shape::Parallelogram, c, u, v)).collect();
    let corner = |i: u32| positions[i as usize].as_dvec3();
    for tri in left {
        let a = corner(tri[0]);
        let (mut u, mut v) = (corner(tri[1]) - a, corner(tri[2]) - a);
        let area = u.cross(v).length();
        if !(area > 0.0 && area.is_finite()) {
            continue;
        }
        if let Some(normals) = normals {
            let facing: DVec3 = tri.iter().map(|&i| normals[i as usize].as_dvec3()).sum();
            if facing.dot(u.cross(v)) < 0.0 {
                std::mem::swap(&mut u, &mut v);
            }
        }
        panels.push((Shape::Triangle, a + 0.5 * (u + v), u, v));
    }
    panels
}

/// A corner by its position's bits (corners written twice are one).
type Corner = [u32; 3];

/// How far two triangles' fourth corners may lie from making an exact
/// parallelogram, in the length of its longer diagonal: files give their
/// coordinates to a few digits.
const PARALLELOGRAM_TOLERANCE: f64 = 1e-4;

/// Splits `triangles` (over `positions`) into the parallelograms they make
/// in pairs, each as `(center, u, v)`, and the triangles left. Pairs are
/// found across shared edges (by position, so a quad's two triangles and
/// two faces given apart alike), in the order the triangles come; each
/// triangle in one pair at most.
///
/// Which side a light faces: where the file gives vertex `normals`, the
/// side its corners' normals point to (as Mitsuba's emitters face their
/// shading normals and pbrt-v4 turns a triangle to its normals), whichever
/// way its two triangles wind; without, the side both triangles wind
/// counter-clockwise about (two that wind against each other make none).
fn parallelograms(
    positions: &[Vec3],
    normals: Option<&[Vec3]>,
    triangles: &[[u32; 3]],
) -> (Vec<Parallelogram>, Vec<[u32; 3]>) {
    let corner = |i: u32| positions[i as usize].as_dvec3();
    // (`+ 0.0` makes a corner written as -0 the same as one written as 0.)
    let key = |i: u32| positions[i as usize].to_array().map(|x| (x + 0.0).to_bits());
    let edge =
        |a: u32, b: u32| if key(a) <= key(b) { ((key(a), key(b)), true) } else { ((key(b), key(a)), false) };
    // Each side of each triangle: its edge (by its corners' positions, the
    // smaller first), the triangle, and whether the edge goes smaller first
    // in that triangle's winding; sorted so that the triangles an edge
    // bounds lie together, in order. (A hash map of a list per edge took
    // most of the loading of a lamp of a million faces in allocations.)
    let mut sides: Vec<((Corner, Corner), u32, bool)> = Vec::with_capacity(3 * triangles.len());
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (e, forward) = edge(tri[k], tri[(k + 1) % 3]);
            sides.push((e, t as u32, forward));
        }
    }
    // Sorted by edge, then by triangle: each triangle's three sides keep
    // their order among its own.
    let mut order: Vec<u32> = (0..sides.len() as u32).collect();
    order.sort_unstable_by(|&x, &y| sides[x as usize].0.cmp(&sides[y as usize].0).then(x.cmp(&y)));
    // Each side's run: the sides along its edge, as a range of `order`.
    let mut runs = vec![(0u32, 0u32); sides.len()];
    let mut start = 0;
    while start < order.len() {
        let e = sides[order[start] as usize].0;
        let end = start + order[start..].iter().take_while(|&&i| sides[i as usize].0 == e).count();
        for &i in &order[start..end] {
            runs[i as usize] = (start as u32, end as u32);
        }
        start = end;
    }
    let mut paired = vec![false; triangles.len()];
    let mut lights = Vec::new();
    for (t, tri) in triangles.iter().enumerate() {
        if paired[t] {
            continue;
        }
        for k in 0..3 {
            let (a, b, p) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let forward = sides[3 * t + k].2;
            let (start, end) = runs[3 * t + k];
            // A neighbour wound the same way crosses the edge the other
            // way; with normals, either neighbour will do.
            let Some(other) = order[start as usize..end as usize].iter().find_map(|&i| {
                let (_, o, o_forward) = sides[i as usize];
                let o = o as usize;
                (o != t && !paired[o] && (normals.is_some() || o_forward != forward)).then_some(o)
            }) else {
                continue;
            };
            let Some(q) = triangles[other].iter().copied().find(|&i| key(i) != key(a) && key(i) != key(b))
            else {
                continue;
            };
            let Some((center, mut u, mut v)) = parallelogram(corner(p), corner(a), corner(q), corner(b))
            else {
                continue;
            };
            if let Some(normals) = normals {
                let facing: DVec3 = [p, a, q, b].iter().map(|&i| normals[i as usize].as_dvec3()).sum();
                if facing.dot(u.cross(v)) < 0.0 {
                    std::mem::swap(&mut u, &mut v);
                }
            }
            paired[t] = true;
            paired[other] = true;
            lights.push((center, u, v));
            break;
        }
    }
    let left = triangles.iter().zip(&paired).filter(|(_, &p)| !p).map(|(t, _)| *t).collect();
    (lights, left)
}

/// The parallelogram of corners `p0, p1, p2, p3` in order around it (its
/// front the side they turn counter-clockwise about), as `(center, u, v)`,
/// if the diagonals meet at their midpoints within
/// [`PARALLELOGRAM_TOLERANCE`] and it has an area.
fn parallelogram(p0: DVec3, p1: DVec3, p2: DVec3, p3: DVec3) -> Option<Parallelogram> {
    let diagonal = (p2 - p0).length().max((p3 - p1).length());
    if (p0 + p2 - p1 - p3).length() > PARALLELOGRAM_TOLERANCE * diagonal {
        return None;
    }
    // Each edge the mean of the two opposite ones.
    let u = 0.5 * ((p1 - p0) + (p2 - p3));
    let v = 0.5 * ((p3 - p0) + (p2 - p1));
    let area = u.cross(v).length();
    (area > 0.0 && area.is_finite()).then_some((0.25 * (p0 + p1 + p2 + p3), u, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Vec<Vec3> {
        vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, -2.0),
            Vec3::new(0.0, 0.0, -2.0),
        ]
    }

    #[test]
    fn a_quad_split_either_way_is_one_light_facing_its_winding() {
        for triangles in [[[0, 1, 2], [0, 2, 3]], [[0, 1, 3], [1, 2, 3]]] {
            let (lights, left) = parallelograms(&square(), None, &triangles);
            assert!(left.is_empty());
            let [(center, u, v)] = lights[..] else { panic!("{lights:?}") };
            assert!((center - DVec3::new(0.5, 0.0, -1.0)).length() < 1e-12);
            // Counter-clockwise seen from +y: the front faces up.
            let normal = u.cross(v);
            assert!((normal - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-12, "{normal}");
        }
    }

    #[test]
    fn faces_given_apart_pair_by_position_and_the_rest_are_left() {
        // The square's two triangles with corners of their own, a third
        // triangle beside them, and a kite (not a parallelogram).
        let mut positions = square();
        positions.extend(square());
        positions.extend([Vec3::new(5.0, 0.0, 0.0), Vec3::new(6.0, 0.0, 0.0), Vec3::new(5.0, 0.0, -1.0)]);
        positions.extend([Vec3::new(8.0, 0.0, 0.0), Vec3::new(9.0, 0.0, -0.5), Vec3::new(8.0, 0.0, -3.0)]);
        positions.push(Vec3::new(7.5, 0.0, -0.5));
        let triangles = [[0, 1, 2], [4, 6, 7], [8, 9, 10], [11, 12, 13], [11, 13, 14]];
        let (lights, left) = parallelograms(&positions, None, &triangles);
        assert_eq!(lights.len(), 1);
        assert_eq!(left, vec![[8, 9, 10], [11, 12, 13], [11, 13, 14]]);
    }

    #[test]
    fn a_corner_written_as_minus_zero_is_the_corner_written_as_zero() {
        let mut positions = square();
        positions.push(Vec3::new(-0.0, 0.0, -0.0));
        let (lights, left) = parallelograms(&positions, None, &[[0, 1, 2], [4, 2, 3]]);
        assert_eq!((lights.len(), left.len()), (1, 0));
    }

    #[test]
    fn triangles_wound_against_each_other_make_no_light() {
        // The second triangle faces down: no one-sided light is both.
        let (lights, left) = parallelograms(&square(), None, &[[0, 1, 2], [0, 3, 2]]);
        assert!(lights.is_empty());
        assert_eq!(left.len(), 2);
    }

    #[test]
    fn with_normals_a_light_faces_them_however_its_triangles_wind() {
        // Wound against each other, or both facing up, under normals
        // pointing down: one light, facing down.
        for triangles in [[[0, 1, 2], [0, 3, 2]], [[0, 1, 2], [0, 2, 3]]] {
            let down = vec![Vec3::NEG_Y; 4];
            let (lights, left) = parallelograms(&square(), Some(&down), &triangles);
            assert!(left.is_empty());
            let [(_, u, v)] = lights[..] else { panic!("{lights:?}") };
            assert!(u.cross(v).normalize().abs_diff_eq(DVec3::NEG_Y, 1e-12), "{}", u.cross(v));
        }
    }

    #[test]
    fn triangles_left_become_triangles_facing_their_normals_or_winding() {
        // The square's two triangles pair; a triangle beside them, wound
        // to face up, and one of no area, do not.
        let mut positions = square();
        positions.extend([Vec3::new(5.0, 0.0, 0.0), Vec3::new(6.0, 0.0, 0.0), Vec3::new(5.0, 0.0, -1.0)]);
        positions.extend([Vec3::new(7.0, 0.0, 0.0), Vec3::new(8.0, 0.0, 0.0), Vec3::new(9.0, 0.0, 0.0)]);
        let triangles = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [7, 8, 9]];
        let found = panels(&positions, None, &triangles);
        assert_eq!(found.len(), 2, "{found:?}");
        assert_eq!(found[0].0, Shape::Parallelogram);
        let (shape, center, u, v) = found[1];
        assert_eq!(shape, Shape::Triangle);
        // Corner 4 at center - u/2 - v/2, the others at it + u and + v.
        let corner = center - 0.5 * (u + v);
        assert!(corner.abs_diff_eq(DVec3::new(5.0, 0.0, 0.0), 1e-12), "{corner}");
        assert!((corner + u).abs_diff_eq(DVec3::new(6.0, 0.0, 0.0), 1e-12));
        assert!((corner + v).abs_diff_eq(DVec3::new(5.0, 0.0, -1.0), 1e-12));
        assert!(u.cross(v).normalize().abs_diff_eq(DVec3::Y, 1e-12), "{}", u.cross(v));
        // With normals pointing down it faces down, on the same corners.
        let down = vec![Vec3::NEG_Y; positions.len()];
        let (_, center2, u2, v2) = panels(&positions, Some(&down), &triangles)[1];
        assert!(u2.cross(v2).normalize().abs_diff_eq(DVec3::NEG_Y, 1e-12), "{}", u2.cross(v2));
        assert_eq!((center2 - 0.5 * (u2 + v2)), corner);
    }

    /// A mesh light on a declared one is found whatever the declared
    /// light faces, off its plane by up to a twentieth of the larger
    /// light's size (here along x, which the search goes by), and named
    /// once with a count; lights elsewhere are not.
    #[test]
    fn lights_on_a_declared_light_are_said_once() {
        // Declared: a wall light facing +x (u x v = y x z = x), 1 x 1.
        let declared = [Light::area(Vec3::ZERO, Vec3::Y, Vec3::Z, Vec3::ONE)];
        // Mesh lights facing +x: a big one 0.4 off the plane (a twentieth
        // of its size 10 is 0.5), a small one on it, and two that are not:
        // off by 0.6 with size 10, and beside it.
        // A triangle facing +x of edges `size`, its centroid at (x, 0, z).
        let panel = |x: f32, z: f32, size: f32| {
            let (u, v) = (Vec3::Y * size, Vec3::Z * size);
            Light::panel(Shape::Triangle, Vec3::new(x, 0.0, z) + (u + v) / 6.0, u, v, Vec3::ONE)
        };
        let from = |x: f32, z: f32, size: f32, name: &str| (name.to_string(), panel(x, z, size));
        let meshes = [
            from(0.6, 0.0, 10.0, "off too far"),
            from(0.4, 0.0, 10.0, "big"),
            from(0.0, 0.0, 0.1, "small"),
            from(0.0, 3.0, 0.1, "beside"),
        ];
        let warnings = twice_in_one_place(&declared, &meshes);
        assert_eq!(warnings.len(), 1, "{warnings:#?}");
        assert!(
            warnings[0].starts_with("big (and 1 more of the mesh files' lights) lies where"),
            "{}",
            warnings[0]
        );
    }

    #[test]
    fn a_placed_light_keeps_its_radiance_and_its_front() {
        let light = MeshLight {
            mesh: "m".into(),
            shape: Shape::Parallelogram,
            center: DVec3::new(0.5, 2.0, -1.0),
            u: DVec3::new(1.0, 0.0, 0.0),
            v: DVec3::new(0.0, 0.0, 2.0),
            radiance: Vec3::new(17.0, 12.0, 4.0),
        };
        // u x v = (0, -2, 0): it faces down. Scaled by 3 and mirrored in x,
        // it still faces down, with nine times the power.
        let matrix = DMat4::from_scale(DVec3::new(-3.0, 3.0, 3.0));
        let placed = light.placed(&matrix, DVec3::new(0.0, 1.0, 0.0)).unwrap();
        let Light::Area { center, u, v, power, .. } = placed else { panic!() };
        assert_eq!(center, Vec3::new(-1.5, 5.0, -3.0));
        assert!(u.cross(v).normalize().abs_diff_eq(Vec3::NEG_Y, 1e-6), "{}", u.cross(v));
        let expected = Vec3::new(17.0, 12.0, 4.0) * std::f32::consts::PI * 18.0;
        assert!(power.abs_diff_eq(expected, 1e-3), "{power}");
        // A matrix that flattens it leaves no light.
        assert!(light.placed(&DMat4::from_scale(DVec3::new(1.0, 1.0, 0.0)), DVec3::ZERO).is_none());
    }
}
