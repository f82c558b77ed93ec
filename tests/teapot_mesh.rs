//! The tessellated Utah teapot: closed where the patch data is closed,
//! consistently oriented, and the size the data says.

use std::collections::HashMap;
use std::path::Path;

use caustix::scene::mesh::Mesh;
use caustix::scene::teapot::{parse_bpt, tessellate, Patch, TEAPOT_BPT};
use glam::Vec3;

fn patches() -> Vec<Patch> {
    parse_bpt(TEAPOT_BPT, Path::new("teapot.bpt")).unwrap()
}

/// The four boundary curves of a patch, as their 4 control points each.
fn patch_edges(p: &Patch) -> [[Vec3; 4]; 4] {
    [
        [p[0], p[1], p[2], p[3]],
        [p[12], p[13], p[14], p[15]],
        [p[0], p[4], p[8], p[12]],
        [p[3], p[7], p[11], p[15]],
    ]
}

/// Patch boundary curves that no other patch shares (in either direction)
/// and that do not collapse to a point: the data's open boundary.
fn open_patch_edges(patches: &[Patch]) -> usize {
    let key = |e: &[Vec3; 4]| e.map(|p| p.to_array().map(f32::to_bits));
    let mut uses: HashMap<_, usize> = HashMap::new();
    for p in patches {
        for e in patch_edges(p) {
            let mut r = e;
            r.reverse();
            *uses.entry(key(&e).min(key(&r))).or_default() += 1;
        }
    }
    patches
        .iter()
        .flat_map(patch_edges)
        .filter(|e| e.iter().any(|p| *p != e[0]))
        .filter(|e| {
            let mut r = *e;
            r.reverse();
            uses[&key(e).min(key(&r))] == 1
        })
        .count()
}

/// Undirected edge -> (uses as i->j with i<j, uses as j->i).
fn edge_uses(mesh: &Mesh) -> HashMap<(u32, u32), (usize, usize)> {
    let mut uses: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
    for t in &mesh.indices {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            let entry = uses.entry((a.min(b), a.max(b))).or_default();
            if a < b {
                entry.0 += 1
            } else {
                entry.1 += 1
            }
        }
    }
    uses
}

#[test]
fn seams_are_welded_so_only_the_datas_open_curves_are_open() {
    let patches = patches();
    assert_eq!(patches.len(), 32);
    let open_curves = open_patch_edges(&patches);
    // Level 1 is excluded on purpose: the handle and spout are tubes of two
    // patches, so one quad per patch flattens each tube end into two
    // coincident segments.
    assert_eq!(open_curves, 16, "rim top, lid bottom, handle and spout ends");
    for level in 2..=16 {
        let (positions, indices) = tessellate(&patches, level);
        let mesh = Mesh::new("teapot", positions, indices, None, 0);
        let uses = edge_uses(&mesh);
        let boundary = uses.values().filter(|(a, b)| a + b == 1).count();
        assert_eq!(boundary, open_curves * level, "level {level}: open edges beyond the data's open curves");
        // Consistent orientation: a shared edge is used once in each direction.
        let same_way = uses.values().filter(|(a, b)| *a > 1 || *b > 1).count();
        assert_eq!(same_way, 0, "level {level}: neighbouring triangles disagree on the outside");
    }
}

#[test]
fn bounding_box_matches_the_data() {
    let (positions, _) = tessellate(&patches(), 16);
    let b = caustix::scene::Bounds::of(&positions);
    // From shared/data/README.md: x -3.000..3.434, y -2..2, z 0..3.15 (z up).
    let (min, max) = (Vec3::new(-3.0, -2.0, 0.0), Vec3::new(3.434, 2.0, 3.15));
    assert!(b.min.abs_diff_eq(min, 2e-3), "min {}", b.min);
    assert!(b.max.abs_diff_eq(max, 2e-3), "max {}", b.max);
}

#[test]
fn vertex_normals_point_out_of_the_body() {
    // On the body (patches 5-12) the surface surrounds the z axis: the smooth
    // normal must point away from it.
    let body: Vec<Patch> = patches()[4..12].to_vec();
    let (positions, indices) = tessellate(&body, 8);
    let mesh = Mesh::new("body", positions, indices, None, 0);
    for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
        let radial = Vec3::new(p.x, p.y, 0.0);
        assert!(n.dot(radial) > 0.0, "normal {n} at {p} points inward");
    }
}
