//! Polygons into triangles, for the mesh readers (OBJ and PLY faces of four
//! or more corners).
//!
//! A convex polygon becomes a fan from its first corner, as tobj and most
//! readers make it. A fan of a concave polygon is wrong: where the first
//! corner cannot see the others, its triangles cover what is outside the
//! polygon and leave out what is inside (an L-shaped face, say, fanned from
//! the corner in its notch). Those are clipped ear by ear instead (Meisters
//! 1975), in the plane that Newell's normal gives the polygon.

use glam::{DVec2, DVec3, Vec3};

/// Concave polygons with more corners than this are fanned, with a warning:
/// ear clipping takes time growing with the cube of the corners at worst.
pub const MOST_CLIPPED_CORNERS: usize = 4096;

/// How a polygon was made into triangles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Triangulated {
    /// A fan from its first corner (a triangle, or convex, or flat: no plane).
    Fan,
    /// Ear clipping, as it is concave.
    Ears,
    /// A fan although it is concave: more corners than [`MOST_CLIPPED_CORNERS`].
    FanOfConcave,
}

/// Concave polygons too large to clip, counted over a file for one warning.
#[derive(Default)]
pub struct Concave {
    fanned: usize,
    largest: usize,
}

impl Concave {
    /// Counts a polygon of `corners` corners triangulated `how`.
    pub fn count(&mut self, corners: usize, how: Triangulated) {
        if how == Triangulated::FanOfConcave {
            self.fanned += 1;
            self.largest = self.largest.max(corners);
        }
    }

    /// The warning, if any polygon was fanned although concave.
    pub fn warning(&self) -> Option<String> {
        (self.fanned > 0).then(|| {
            format!(
                "{} concave polygons of more than {} corners (the largest {}) were fanned from their first \
                 corner, which may cover what is outside them; triangulate them before export",
                self.fanned, MOST_CLIPPED_CORNERS, self.largest
            )
        })
    }
}

/// Appends to `out` the triangles of the polygon whose corners, in order
/// around it, are `corners` (indices into `positions`, all valid), each
/// turning the way the polygon does; says how.
pub fn triangulate(positions: &[Vec3], corners: &[u32], out: &mut Vec<[u32; 3]>) -> Triangulated {
    let fan = |out: &mut Vec<[u32; 3]>| {
        out.extend(corners.windows(2).skip(1).map(|pair| [corners[0], pair[0], pair[1]]));
    };
    if corners.len() <= 3 {
        fan(out);
        return Triangulated::Fan;
    }
    let flat = match plane(positions, corners) {
        Some(flat) => flat,
        None => {
            fan(out);
            return Triangulated::Fan;
        }
    };
    let turns = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - b);
    let n = flat.len();
    let convex = (0..n).all(|i| turns(flat[(i + n - 1) % n], flat[i], flat[(i + 1) % n]) >= 0.0);
    if convex {
        fan(out);
        Triangulated::Fan
    } else if n > MOST_CLIPPED_CORNERS {
        fan(out);
        Triangulated::FanOfConcave
    } else {
        clip_ears(&flat, corners, out);
        Triangulated::Ears
    }
}

/// The corners in 2D: projected along the axis nearest the polygon's
/// normal (Newell's), turned so that the polygon runs counter-clockwise;
/// `None` where the polygon has no area to give a normal.
fn plane(positions: &[Vec3], corners: &[u32]) -> Option<Vec<DVec2>> {
    // Relative to the first corner, in f64: far from the origin the
    // differences keep their digits.
    let origin = positions[corners[0] as usize].as_dvec3();
    let points: Vec<DVec3> = corners.iter().map(|&i| positions[i as usize].as_dvec3() - origin).collect();
    let normal: DVec3 = (0..points.len()).map(|i| points[i].cross(points[(i + 1) % points.len()])).sum();
    if normal == DVec3::ZERO {
        return None;
    }
    let size = normal.abs();
    let axis = if size.x >= size.y && size.x >= size.z {
        0
    } else if size.y >= size.z {
        1
    } else {
        2
    };
    // Dropping the axis keeps the other two in cyclic order (y z, z x, x y),
    // so the polygon turns counter-clockwise where the normal points up it.
    let (u, v) = [(1, 2), (2, 0), (0, 1)][axis];
    let sign = normal[axis].signum();
    Some(points.iter().map(|p| DVec2::new(p[u], sign * p[v])).collect())
}

/// Ear clipping of a counter-clockwise simple polygon `flat`, whose corners
/// are the mesh's `corners`. A corner is an ear when it turns left and no
/// other corner left lies in the triangle it makes with its neighbours;
/// cutting it off leaves a polygon one corner shorter. Where no ear is left
/// (a polygon that crosses itself, or collapses onto a line), the rest is
/// fanned: every corner still ends in some triangle.
fn clip_ears(flat: &[DVec2], corners: &[u32], out: &mut Vec<[u32; 3]>) {
    let turns = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - b);
    let mut left: Vec<usize> = (0..flat.len()).collect();
    let mut at = 0;
    let mut tried = 0;
    while left.len() > 3 {
        let m = left.len();
        let (prev, here, next) = (left[(at + m - 1) % m], left[at], left[(at + 1) % m]);
        let (a, b, c) = (flat[prev], flat[here], flat[next]);
        let ear = turns(a, b, c) > 0.0
            && !left.iter().any(|&k| {
                let p = flat[k];
                // Corners at the ear's own places (a polygon that touches
                // itself there) do not block it.
                k != prev && k != here && k != next && p != a && p != b && p != c && inside(p, a, b, c)
            });
        if ear {
            out.push([corners[prev], corners[here], corners[next]]);
            left.remove(at);
            at %= left.len();
            tried = 0;
        } else {
            tried += 1;
            if tried > m {
                break;
            }
            at = (at + 1) % m;
        }
    }
    out.extend(left.windows(2).skip(1).map(|pair| [corners[left[0]], corners[pair[0]], corners[pair[1]]]));
}

/// Whether `p` lies in the counter-clockwise triangle `a b c` or on its edges.
fn inside(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    (b - a).perp_dot(p - a) >= 0.0 && (c - b).perp_dot(p - b) >= 0.0 && (a - c).perp_dot(p - c) >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Twice the signed area of triangle `t` in the xy plane.
    fn area2(positions: &[Vec3], t: [u32; 3]) -> f32 {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        (b - a).cross(c - a).z
    }

    /// Whether the point lies in any of `triangles` (in the xy plane, either way round).
    fn covered(positions: &[Vec3], triangles: &[[u32; 3]], p: Vec3) -> bool {
        let p = p.truncate().as_dvec2();
        triangles.iter().any(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].truncate().as_dvec2());
            inside(p, a, b, c) || inside(p, a, c, b)
        })
    }

    /// An L whose corners start in its notch, where a fan goes wrong: the
    /// triangles cover the L and nothing else, each turning its way.
    #[test]
    fn a_concave_polygon_is_covered_exactly() {
        let l = [(2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0), (0.0, 0.0), (2.0, 0.0)];
        for flip in [false, true] {
            for start in 0..l.len() {
                let mut corners: Vec<(f32, f32)> = (0..l.len()).map(|i| l[(start + i) % l.len()]).collect();
                if flip {
                    corners.reverse();
                }
                let positions: Vec<Vec3> = corners.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect();
                let ids: Vec<u32> = (0..positions.len() as u32).collect();
                let mut out = Vec::new();
                let how = triangulate(&positions, &ids, &mut out);
                assert_eq!(how, Triangulated::Ears);
                assert_eq!(out.len(), 4, "{out:?}");
                let turn = if flip { -1.0 } else { 1.0 };
                let total: f32 = out.iter().map(|&t| turn * area2(&positions, t)).sum();
                assert!(out.iter().all(|&t| turn * area2(&positions, t) > 0.0), "{out:?}");
                assert!((total - 6.0).abs() < 1e-5, "twice the L's area is 6, got {total}");
                // The notch is not covered; the L's arms are.
                assert!(!covered(&positions, &out, Vec3::new(1.5, 1.5, 0.0)), "start {start}: {out:?}");
                assert!(covered(&positions, &out, Vec3::new(1.5, 0.5, 0.0)));
                assert!(covered(&positions, &out, Vec3::new(0.5, 1.5, 0.0)));
            }
        }
    }

    /// Convex polygons (and triangles) keep the fan tobj made of them, so
    /// meshes that had none concave load as before.
    #[test]
    fn a_convex_polygon_is_fanned_from_its_first_corner() {
        let hexagon: Vec<Vec3> = (0..6)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 6.0;
                Vec3::new(1e6 + a.cos(), 5.0, a.sin())
            })
            .collect();
        let mut out = Vec::new();
        assert_eq!(triangulate(&hexagon, &[0, 1, 2, 3, 4, 5], &mut out), Triangulated::Fan);
        assert_eq!(out, [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]);
        out.clear();
        assert_eq!(triangulate(&hexagon, &[4, 2, 0], &mut out), Triangulated::Fan);
        assert_eq!(out, [[4, 2, 0]]);
    }

    /// Tilted into 3D and far from the origin, a concave polygon is still clipped right.
    #[test]
    fn the_plane_is_the_polygons_own() {
        let star: Vec<Vec3> = (0..10)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 10.0;
                let r = if i % 2 == 0 { 1.0 } else { 0.4 };
                let (x, y) = (r * a.cos(), r * a.sin());
                // The plane x + y + z = 0, about (1e4, -2e4, 3e4).
                Vec3::new(1e4 + x, -2e4 + y, 3e4 - x - y)
            })
            .collect();
        let ids: Vec<u32> = (0..10).collect();
        let mut out = Vec::new();
        assert_eq!(triangulate(&star, &ids, &mut out), Triangulated::Ears);
        assert_eq!(out.len(), 8);
        // Each triangle's normal points the polygon's way, and the areas add up.
        let normal = Vec3::ONE.normalize();
        let area = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| star[i as usize].as_dvec3());
            (b - a).cross(c - a).dot(normal.as_dvec3()) / 2.0
        };
        assert!(out.iter().all(|t| area(t) > 0.0), "{out:?}");
        let total: f64 = out.iter().map(area).sum();
        // In the xy plane the star is 10 triangles (centre, outer, inner
        // corner) of 0.5 * 1 * 0.4 * sin(36); lifted to the tilted plane its
        // area grows by 1 / cos of the tilt, sqrt(3).
        let expected = 3f64.sqrt() * 10.0 * 0.5 * 0.4 * (36f64).to_radians().sin();
        assert!((total - expected).abs() < 1e-2 * expected, "{total} vs {expected}");
    }

    /// A concave polygon of more corners than are clipped is fanned, and
    /// the file's warning counts it.
    #[test]
    fn a_huge_concave_polygon_is_fanned_with_a_warning() {
        // A saw: teeth along x, then back along the bottom.
        let teeth = MOST_CLIPPED_CORNERS / 2;
        let mut saw: Vec<Vec3> = (0..2 * teeth)
            .map(|i| Vec3::new(i as f32 * 0.5, if i % 2 == 0 { 0.0 } else { 1.0 }, 0.0))
            .collect();
        saw.push(Vec3::new(teeth as f32, -1.0, 0.0));
        saw.push(Vec3::new(0.0, -1.0, 0.0));
        let ids: Vec<u32> = (0..saw.len() as u32).collect();
        let mut out = Vec::new();
        let how = triangulate(&saw, &ids, &mut out);
        assert_eq!((how, out.len()), (Triangulated::FanOfConcave, saw.len() - 2));
        let mut concave = Concave::default();
        assert_eq!(concave.warning(), None);
        concave.count(saw.len(), how);
        concave.count(4, Triangulated::Ears);
        let warning = concave.warning().unwrap();
        assert!(
            warning.starts_with("1 concave polygons") && warning.contains(&format!("largest {}", saw.len()))
        );
    }

    /// A polygon with no area, or one that crosses itself, still gives every
    /// corner a triangle and never loops.
    #[test]
    fn degenerate_polygons_end() {
        let line: Vec<Vec3> = (0..5).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        let mut out = Vec::new();
        assert_eq!(triangulate(&line, &[0, 1, 2, 3, 4], &mut out), Triangulated::Fan);
        assert_eq!(out.len(), 3);
        // A bow tie: two triangles meeting at a point.
        let bow = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        out.clear();
        triangulate(&bow, &[0, 1, 2, 3], &mut out);
        assert_eq!(out.len(), 2);
        // Corners repeated (a polygon that touches itself).
        let touching = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        out.clear();
        triangulate(&touching, &[0, 1, 2, 3, 4, 5], &mut out);
        assert_eq!(out.len(), 4);
    }
}
