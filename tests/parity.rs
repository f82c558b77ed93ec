//! Embree and the native BVH must agree hit for hit.
//!
//! For several meshes and kinds of rays, both backends must make the same
//! hit/miss decision, agree on `t`, the triangle, `(u, v)`, the normals, and
//! `occluded` must agree with `intersect`. The only allowed differences are
//! ties: a ray through a shared edge or vertex may hit either neighbour, and
//! coplanar overlapping triangles may be hit in either order; then the hit
//! points must agree instead. Rays aimed exactly at edges and vertices of a
//! closed mesh must never miss (watertightness).

use std::collections::HashMap;
use std::path::Path;

use caustix::accel::bvh::Bvh;
use caustix::accel::embree::{EmbreeIntersector, TriangleView};
use caustix::accel::{BvhLayout, Hit, Intersector, Ray};
use caustix::sampling::{uniform_sphere, Rng};
use caustix::scene::mesh::Mesh;
use caustix::scene::shapes::{cuboid, sphere};
use caustix::scene::teapot::{parse_bpt, tessellate, TEAPOT_BPT};
use caustix::scene::Bounds;
use glam::Vec3;

/// Barycentric distance from an edge below which a hit counts as "on" it.
const EDGE: f32 = 1e-4;

struct Case {
    name: &'static str,
    mesh: Mesh,
    closed: bool,
}

fn bunny() -> Mesh {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/data/bunny.obj");
    let contents = caustix::scene::obj::load(&path, caustix::scene::obj::MeshMaterials::All(0), &[]).unwrap();
    contents.meshes.into_iter().next().unwrap()
}

fn teapot() -> Mesh {
    let patches = parse_bpt(TEAPOT_BPT, Path::new("teapot.bpt")).unwrap();
    let (p, i) = tessellate(&patches, 6);
    Mesh::new("teapot", p, i, None, 0)
}

fn soup(rng: &mut Rng) -> Mesh {
    let mut p = Vec::new();
    for _ in 0..600 {
        let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0;
        for _ in 0..3 {
            p.push(c + (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5) * 2.0);
        }
    }
    let i = (0..600u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
    Mesh::new("soup", p, i, None, 0)
}

fn slivers() -> Mesh {
    // Long thin triangles fanned around the z axis, 1000:1 aspect.
    let mut p = Vec::new();
    for k in 0..200 {
        let a = k as f32 * 0.0314;
        let dir = Vec3::new(a.cos(), a.sin(), 0.0);
        let side = Vec3::new(-a.sin(), a.cos(), 0.0) * 0.005;
        p.extend([dir * 0.1, dir * 10.0, dir * 0.1 + side + Vec3::Z * 0.001 * k as f32]);
    }
    let i = (0..200u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
    Mesh::new("slivers", p, i, None, 0)
}

fn coplanar() -> Mesh {
    // Overlapping squares in the plane z = 0, shifted against each other.
    let mut p = Vec::new();
    let mut i = Vec::new();
    for k in 0..8 {
        let o = Vec3::new(k as f32 * 0.3, k as f32 * 0.2, 0.0);
        let base = p.len() as u32;
        p.extend([o, o + Vec3::X * 2.0, o + Vec3::new(2.0, 2.0, 0.0), o + Vec3::Y * 2.0]);
        i.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    }
    Mesh::new("coplanar", p, i, None, 0)
}

fn cases() -> Vec<Case> {
    let mut rng = Rng::new(42, 0);
    vec![
        Case { name: "sphere", mesh: sphere("sphere", Vec3::new(0.5, -1.0, 2.0), 3.0, 3, 0), closed: true },
        Case { name: "teapot", mesh: teapot(), closed: false },
        Case { name: "bunny", mesh: bunny(), closed: true },
        Case { name: "soup", mesh: soup(&mut rng), closed: false },
        Case {
            name: "box",
            mesh: cuboid("box", Vec3::splat(-2.0), Vec3::new(3.0, 2.0, 1.0), 0),
            closed: true,
        },
        Case { name: "slivers", mesh: slivers(), closed: false },
        Case { name: "coplanar", mesh: coplanar(), closed: false },
    ]
}

fn random_unit(rng: &mut Rng) -> Vec3 {
    uniform_sphere(rng.uniform2())
}

fn point_in(b: &Bounds, rng: &mut Rng) -> Vec3 {
    b.min + (b.max - b.min) * Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())
}

/// A point on triangle `prim` at barycentrics `(1-u-v, u, v)`.
fn on_triangle(m: &Mesh, prim: usize, u: f32, v: f32) -> Vec3 {
    let [a, b, c] = m.indices[prim].map(|i| m.positions[i as usize]);
    (1.0 - u - v) * a + u * b + v * c
}

/// The kinds of rays each mesh is tested with, by name.
fn rays(m: &Mesh, closed: bool, rng: &mut Rng) -> Vec<(&'static str, Ray)> {
    let b = m.bounds();
    let center = 0.5 * (b.min + b.max);
    let radius = (b.max - b.min).length();
    let mut out = Vec::new();
    let tri = |rng: &mut Rng| (rng.next_u32() as usize) % m.indices.len();
    for _ in 0..4000 {
        // Random: from a sphere around the mesh towards a point inside the box.
        let origin = center + random_unit(rng) * radius;
        out.push(("random", Ray::new(origin, point_in(&b, rng) - origin)));
    }
    for _ in 0..2000 {
        // Axis-aligned, from outside the box.
        let axis = Vec3::AXES[(rng.next_u32() % 3) as usize] * if rng.uniform() < 0.5 { 1.0 } else { -1.0 };
        let origin = point_in(&b, rng) - axis * radius;
        out.push(("axis", Ray::new(origin, axis)));
    }
    for _ in 0..2000 {
        // Grazing: almost in the plane of a triangle, aimed at a point on it.
        let k = tri(rng);
        let target = on_triangle(m, k, 0.3 * rng.uniform(), 0.3 * rng.uniform());
        let n = m.face_normal(k as u32);
        let tangent = n.cross(random_unit(rng)).normalize();
        let dir = (tangent + n * (0.001 + 0.01 * rng.uniform())).normalize();
        out.push(("grazing", Ray::new(target + dir * radius, -dir)));
    }
    for _ in 0..3000 {
        // At an edge or a vertex, exactly or within a hair, from a random side.
        let k = tri(rng);
        let (u, v) = match rng.next_u32() % 4 {
            0 => (0.0, 0.0),
            1 => (1.0, 0.0),
            2 => (rng.uniform(), 0.0),
            _ => {
                let u = rng.uniform();
                (u, 1.0 - u)
            }
        };
        let target = on_triangle(m, k, u, v);
        let origin = target + random_unit(rng) * radius;
        out.push(("edge", Ray::new(origin, target - origin)));
    }
    if closed {
        for _ in 0..2000 {
            out.push(("inside", Ray::new(center, random_unit(rng))));
        }
    }
    for (_, ray) in out.iter_mut().step_by(5) {
        // Some rays end before the mesh's far side.
        ray.t_max = 0.5 + rng.uniform();
    }
    out
}

/// Smallest barycentric of a hit: near zero means on an edge.
fn edge_distance(h: &Hit) -> f32 {
    h.u.min(h.v).min(1.0 - h.u - h.v)
}

/// The condition of a hit's barycentrics, `L^2 / |e1 x e2|`, and the longest
/// edge. Barycentrics are ratios of areas spanned by vertices relative to the
/// ray origin (distance up to L), so in f32 they are off by about eps times
/// the condition: large for slivers and for small triangles far away. Times
/// the longest edge it is a distance on the triangle.
fn barycentric_condition(m: &Mesh, prim: u32, ray: &Ray) -> (f32, f32) {
    let [a, b, c] = m.indices[prim as usize].map(|i| m.positions[i as usize]);
    let l = [a, b, c].iter().map(|p| (*p - ray.origin).length()).fold(0.0, f32::max);
    let edge = (b - a).length().max((c - b).length()).max((a - c).length());
    (l * l / (b - a).cross(c - a).length(), edge)
}

/// Exact (in f64, from the same f32 inputs) barycentrics of the ray's hit on
/// triangle `prim`, by Moller and Trumbore.
fn exact_uv(m: &Mesh, prim: u32, ray: &Ray) -> (f64, f64) {
    let [a, b, c] = m.indices[prim as usize].map(|i| m.positions[i as usize].as_dvec3());
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    let s = o - a;
    let q = s.cross(e1);
    (s.dot(p) / det, d.dot(q) / det)
}

#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    /// Ties among rays aimed at edges and vertices, where they are expected.
    edge_ties: usize,
    /// Ties among all other rays, which should be rare.
    other_ties: usize,
    mismatches: Vec<String>,
}

fn compare(
    m: &Mesh,
    name: &str,
    kind: &str,
    ray: &Ray,
    e: &dyn Intersector,
    n: &dyn Intersector,
    tally: &mut Tally,
) {
    tally.rays += 1;
    let tie = |tally: &mut Tally| {
        if kind == "edge" {
            tally.edge_ties += 1
        } else {
            tally.other_ties += 1
        }
    };
    let (he, hn) = (e.intersect(ray), n.intersect(ray));
    let size = (m.bounds().max - m.bounds().min).length();
    let mut fail = |what: String| {
        tally.mismatches.push(format!(
            "{name}/{kind}: {what}; ray {:?} dir {:?} t_max {}",
            ray.origin, ray.dir, ray.t_max
        ))
    };
    for (backend, hit) in [(e, &he), (n, &hn)] {
        if backend.occluded(ray) != hit.is_some() {
            fail(format!("{}: occluded disagrees with intersect", backend.name()));
        }
    }
    // How ill-conditioned a hit is: a rounding error d in the distance to the
    // plane moves the hit along the ray by d / cos(angle to the normal), so
    // grazing rays agree less closely for any two correct implementations.
    // Tolerances scale with it.
    let conditioning = |h: &Hit| 1.0 / ray.dir.normalize().dot(h.ng.normalize()).abs().max(1e-3);
    let bary_error =
        |h: &Hit| 16.0 * f32::EPSILON * conditioning(h) * barycentric_condition(m, h.prim_id, ray).0;
    let on_edge = |h: &Hit| edge_distance(h) < EDGE * conditioning(h) + bary_error(h);
    let point = |h: &Hit| on_triangle(m, h.prim_id as usize, h.u, h.v);
    match (he, hn) {
        (None, None) => {}
        (Some(h), None) | (None, Some(h)) => {
            // Allowed only for a contact on an edge, or at the end of the segment.
            if on_edge(&h) || (ray.t_max - h.t).abs() * ray.dir.length() < 1e-5 * size {
                tie(tally);
            } else {
                fail(format!("only one backend hits: {h:?}"));
            }
        }
        (Some(a), Some(b)) => {
            let c = conditioning(&a).max(conditioning(&b));
            let tolerance = 1e-5 * size * c;
            let (pa, pb) = (ray.at(a.t), ray.at(b.t));
            if (pa - pb).length() > tolerance {
                // One backend took an edge contact the other passed by.
                let nearer = if a.t < b.t { &a } else { &b };
                if on_edge(nearer) {
                    tie(tally);
                } else {
                    fail(format!("t {} vs {}", a.t, b.t));
                }
                return;
            }
            if (a.geom_id, a.prim_id) != (b.geom_id, b.prim_id) {
                // The same point on two triangles: a shared edge, or overlap.
                let coplanar = a.ng.normalize().cross(b.ng.normalize()).length() < 1e-4;
                if on_edge(&a) || on_edge(&b) || coplanar {
                    tie(tally);
                } else {
                    fail(format!("triangle {} vs {} (a {a:?}, b {b:?})", a.prim_id, b.prim_id));
                }
                return;
            }
            // (u, v) must name the same point of the triangle, compared as
            // points, within their rounding (see `barycentric_condition`).
            let edge = barycentric_condition(m, a.prim_id, ray).1;
            if (point(&a) - point(&b)).length() > tolerance + bary_error(&a).max(bary_error(&b)) * edge {
                fail(format!("(u, v) ({}, {}) vs ({}, {})", a.u, a.v, b.u, b.v));
            }
            let (na, nb) = (m.shading_normal(a.prim_id, a.u, a.v), m.shading_normal(b.prim_id, b.u, b.v));
            if na.angle_between(nb) > 1e-3 * c {
                fail(format!("smooth normals {na} vs {nb}"));
            }
            if a.ng.normalize().dot(b.ng.normalize()) < 0.9999 {
                fail(format!("geometric normals {} vs {}", a.ng, b.ng));
            }
        }
    }
}

#[test]
fn embree_and_native_agree_hit_for_hit() {
    let mut rng = Rng::new(7, 7);
    let mut report = Vec::new();
    let mut all_mismatches = Vec::new();
    for case in cases() {
        let view = [TriangleView::new(&case.mesh.positions, &case.mesh.indices)];
        let embree = EmbreeIntersector::build(&view).unwrap();
        let native = Bvh::build(&view);
        let mut tally = Tally::default();
        for (kind, ray) in rays(&case.mesh, case.closed, &mut rng) {
            compare(&case.mesh, case.name, kind, &ray, &embree, &native, &mut tally);
        }
        report.push(format!(
            "{:>9}: {:>5} triangles, {} rays, ties: {} among 3000 aimed at edges/vertices, {} among the rest; {} mismatches",
            case.name,
            case.mesh.indices.len(),
            tally.rays,
            tally.edge_ties,
            tally.other_ties,
            tally.mismatches.len()
        ));
        all_mismatches.extend(tally.mismatches.clone());
        // Away from edges a tie needs coplanar triangles or a graze: rare.
        let others = tally.rays - 3000;
        if case.name != "coplanar" {
            assert!(
                tally.other_ties * 200 < others,
                "{}: {} ties in {others} rays",
                case.name,
                tally.other_ties
            );
        }
    }
    eprintln!("{}", report.join("\n"));
    let mut kinds: std::collections::BTreeMap<String, usize> = Default::default();
    for m in &all_mismatches {
        let key: String = m.split(':').take(2).collect::<Vec<_>>().join(":").chars().take(40).collect();
        *kinds.entry(key).or_default() += 1;
    }
    eprintln!("mismatches by kind: {kinds:?}");
    assert!(
        all_mismatches.is_empty(),
        "{} mismatches, first ones:\n{}",
        all_mismatches.len(),
        all_mismatches.iter().take(10).cloned().collect::<Vec<_>>().join("\n")
    );
}

/// Embree's compact BVH (leaves index our shared vertex buffer) answers as
/// the fast one (leaves hold vertex copies) does.
#[test]
fn embrees_compact_layout_finds_the_same_hits() {
    let mut rng = Rng::new(5, 3);
    for case in cases() {
        let m = &case.mesh;
        let fast = EmbreeIntersector::build_with_layout(&[m.view()], BvhLayout::Fast).unwrap();
        let compact = EmbreeIntersector::build_with_layout(&[m.view()], BvhLayout::Compact).unwrap();
        assert!(compact.name().ends_with("(compact BVH)"), "{}", compact.name());
        let mut tally = Tally::default();
        for (kind, ray) in rays(m, case.closed, &mut rng) {
            compare(m, case.name, kind, &ray, &fast, &compact, &mut tally);
        }
        assert!(tally.mismatches.is_empty(), "{}: {:?}", case.name, &tally.mismatches[..1]);
        // One kernel on the same vertices: ties only at edges and between
        // the coplanar case's overlapping triangles.
        if case.name != "coplanar" {
            assert!(tally.other_ties * 200 < tally.rays, "{}: {} ties", case.name, tally.other_ties);
        }
    }
}

/// Against the exact answer (f64 from the same inputs, rays at least 10
/// degrees off the surface), the native BVH's (u, v) is at least as accurate
/// as Embree's, on every mesh.
#[test]
fn native_barycentrics_are_at_least_as_accurate_as_embrees() {
    let mut rng = Rng::new(11, 2);
    let mut report = Vec::new();
    for case in cases() {
        let m = &case.mesh;
        let view = [TriangleView::new(&m.positions, &m.indices)];
        let (e, n) = (EmbreeIntersector::build(&view).unwrap(), Bvh::build(&view));
        let (mut worst_e, mut worst_n, mut sum_e, mut sum_n, mut count) = (0f64, 0f64, 0f64, 0f64, 0);
        for (_, ray) in rays(m, case.closed, &mut rng) {
            let (Some(a), Some(b)) = (e.intersect(&ray), n.intersect(&ray)) else { continue };
            if a.prim_id != b.prim_id || ray.dir.normalize().dot(a.ng.normalize()).abs() < 0.17 {
                continue;
            }
            let (u, v) = exact_uv(m, a.prim_id, &ray);
            let err = |h: &Hit| (h.u as f64 - u).abs().max((h.v as f64 - v).abs());
            worst_e = worst_e.max(err(&a));
            worst_n = worst_n.max(err(&b));
            sum_e += err(&a);
            sum_n += err(&b);
            count += 1;
        }
        report.push(format!(
            "{:>9}: {count} hits, (u, v) error mean/worst: embree {:.1e}/{:.1e}, native {:.1e}/{:.1e}",
            case.name,
            sum_e / count as f64,
            worst_e,
            sum_n / count as f64,
            worst_n
        ));
        assert!(sum_n <= 1.5 * sum_e + 1e-9 * count as f64, "{}", report.last().unwrap());
    }
    eprintln!("{}", report.join("\n"));
}

/// Points inside a closed mesh: a point is inside when every probe ray from
/// it first meets the mesh from the back (the inside of the surface).
fn inside_points(m: &Mesh, accel: &dyn Intersector, rng: &mut Rng, count: usize) -> Vec<Vec3> {
    let b = m.bounds();
    let mut points = Vec::new();
    while points.len() < count {
        let p = point_in(&b, rng);
        let inside = (0..8).all(|_| {
            let dir = random_unit(rng);
            accel.intersect(&Ray::new(p, dir)).is_some_and(|h| h.ng.dot(dir) > 0.0)
        });
        if inside {
            points.push(p);
        }
    }
    points
}

/// Rays from inside closed meshes aimed exactly at their vertices and at
/// points along their edges (as pbrt-v4's `Triangle.Watertight` does): each
/// must hit the mesh no later than its target. (From outside, a ray aimed at
/// an edge of a convex solid may only touch it, so missing there is allowed.)
#[test]
fn closed_meshes_do_not_leak_through_edges_or_vertices() {
    let mut rng = Rng::new(3, 1);
    let mut report = Vec::new();
    let mut leaks_total = 0;
    for case in cases().into_iter().filter(|c| c.closed) {
        let m = &case.mesh;
        let view = [TriangleView::new(&m.positions, &m.indices)];
        let backends: [Box<dyn Intersector>; 2] =
            [Box::new(EmbreeIntersector::build(&view).unwrap()), Box::new(Bvh::build(&view))];
        let origins = inside_points(m, backends[0].as_ref(), &mut rng, 4);
        // Faces around each vertex and each edge, by position (the box's
        // sides have their own vertices at shared positions).
        let key = |i: u32| m.positions[i as usize].to_array().map(f32::to_bits);
        let mut around_vertex: HashMap<[u32; 3], Vec<u32>> = HashMap::new();
        let mut around_edge: HashMap<([u32; 3], [u32; 3]), Vec<u32>> = HashMap::new();
        for (f, tri) in m.indices.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (key(tri[k]), key(tri[(k + 1) % 3]));
                around_vertex.entry(a).or_default().push(f as u32);
                around_edge.entry((a.min(b), a.max(b))).or_default().push(f as u32);
            }
        }
        // (target, the faces that meet there)
        let mut targets: Vec<(Vec3, &Vec<u32>)> = Vec::new();
        for tri in &m.indices {
            let [k0, k1, k2] = tri.map(key);
            let [p0, p1, p2] = tri.map(|i| m.positions[i as usize]);
            targets.push((p0, &around_vertex[&k0]));
            for s in [0.5f32, 0.25, 0.001] {
                targets.push((p0 + s * (p1 - p0), &around_edge[&(k0.min(k1), k0.max(k1))]));
                targets.push((p1 + s * (p2 - p1), &around_edge[&(k1.min(k2), k1.max(k2))]));
            }
        }
        for backend in &backends {
            let (mut leaks, mut rays, mut tangential) = (0, 0, 0);
            for &origin in &origins {
                for &(target, faces) in &targets {
                    // Only rays that leave through every face meeting at the
                    // target, clearly off the surface, must hit there; a
                    // tangential touch of a non-convex surface proves nothing.
                    let dir = (target - origin).normalize();
                    if faces.iter().any(|&f| m.face_normal(f).dot(dir) < 0.05) {
                        tangential += 1;
                        continue;
                    }
                    // t = 1 at the target; allow rounding just past it.
                    let ray = Ray { t_max: 1.0 + 1e-4, ..Ray::new(origin, target - origin) };
                    rays += 1;
                    if backend.intersect(&ray).is_none() || !backend.occluded(&ray) {
                        leaks += 1;
                    }
                }
            }
            report.push(format!(
                "{:>7} {:<14}: {rays} rays at edges and vertices, {leaks} leaks ({tangential} tangential set aside)",
                case.name,
                backend.name()
            ));
            if backend.name() == "native bvh" {
                leaks_total += leaks;
            } else {
                // Embree 3.13.5 (Debian 12) and 4.4.0 alike, even with
                // RTC_SCENE_FLAG_ROBUST, let a few rays through exactly at
                // vertices: measured 2 of 35840 (sphere) and 67 of 82568
                // (bunny) with both, each confirmed (3.13.5) to find no hit
                // at all with unbounded t. Bound the rate.
                assert!(leaks * 1000 <= rays, "{}: {leaks} leaks in {rays} rays", backend.name());
            }
        }
    }
    eprintln!("{}", report.join("\n"));
    assert_eq!(leaks_total, 0, "the native BVH leaked:\n{}", report.join("\n"));
}
