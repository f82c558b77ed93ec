//! Which irradiance record a gather ray's hit reads, remembered per small
//! patch ("texel") of each triangle and side.
//!
//! A gather ray that meets a diffuse surface reads the precomputed record
//! nearest the point it meets (`PhotonMap::precomputed_radiance`). Working
//! that point out from Embree's hit and searching for its record was about
//! 140 ns of the 350 ns of CPU time a gather ray cost (BENCHMARKS.md, issue
//! 17), against Embree's 113 ns for the ray itself. Here each triangle is
//! cut, in its barycentric coordinates, into patches about a third of the
//! records' gathering radius across; the first gather ray that meets a
//! patch searches for the record at the patch's centre and keeps its
//! irradiance there, and every later one reads it from the hit's triangle
//! and barycentrics alone: one read of memory, where the record's index
//! then its value were two (each a wait on memory, in the profile).
//!
//! Where light changes within a patch (the spot a bulb a millimetre under a
//! ceiling lights, far smaller than a patch), the record at the patch's
//! centre gathered over a disc as small as the spot, or around it and
//! without it: either way the spot's light, reflected on, was lost (a
//! quarter of a Cornell box's back wall, BENCHMARKS.md). Looked up point by
//! point instead, a gather ray finds the spot rarely and then very bright:
//! fireflies. So a patch near a record narrower than half a patch holds the
//! irradiance over a disc of the records' median radius around its centre,
//! from every photon in it: the spot's light whole, spread as the records
//! spread light where it is dim.
//!
//! What a patch holds depends only on the patch and the map, never on which
//! thread got there first: two threads that race to fill it store the same
//! value, so the image stays the same whatever the thread count.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::{Hit, Ray};
use crate::config::Estimate;
use crate::integrator::Context;
use crate::photon::nearest::PointTree;
use crate::photon::{PhotonMap, PhotonMaps};
use crate::query::SurfacePoint;
use crate::scene::{Mesh, Scene};

/// A patch's edge, at most, in the records' median gathering radii. The
/// record a hit reads is that nearest the patch's centre rather than the
/// hit, which moves the borders between records' areas by up to half a
/// patch; the records' own estimates are smooth over their whole disc.
const PATCH_PER_RADIUS: f32 = 0.35;

/// A triangle is cut into at most this many patches along each edge (8
/// million in all); a larger one is looked up point by point as before.
const MOST_PER_EDGE: u32 = 4096;

/// At most this many patches a record, and in all (two sides of eight bytes
/// each: 256 MiB); a scene that needs more is looked up point by point as
/// before. Every triangle has a patch at least, so a mesh of millions of
/// triangles smaller than a patch would need as many, each met by few
/// gather rays: it would pay memory for little. The example scenes need 9
/// to 13 a record, at 100k photons and at 1M.
const MOST_PER_RECORD: u64 = 32;
const MOST_PATCHES: u64 = 1 << 24;

/// A patch not yet looked up (no packed irradiance has its top bit set).
const UNSEEN: u64 = u64::MAX;

/// A patch whose centre has no record covering it: its hits look up their
/// own points (the full estimate there).
const NO_RECORD: u64 = u64::MAX - 1;

/// A record whose gathering disc is narrower than this many patches across
/// holds light that changes within a patch ([`RecordTexels::fine_near`]).
const FINE_PER_PATCH: f32 = 0.5;

/// Each triangle's patches, and the irradiance each patch reads, per side.
pub(in crate::integrator) struct RecordTexels {
    /// Per mesh, per triangle: its first patch and the patches along an
    /// edge (0 for a triangle not cut).
    triangles: Vec<Vec<[u32; 2]>>,
    /// Per side (front, back), per patch: the record's irradiance
    /// ([`pack`]ed), [`UNSEEN`] or [`NO_RECORD`]. The sides apart, as most
    /// surfaces are seen from one side only: its patches lie closer.
    irradiance: [Vec<AtomicU64>; 2],
    /// A patch's edge, at most.
    size: f32,
    /// The records' median gathering radius.
    radius: f32,
    /// Where the records narrower than [`FINE_PER_PATCH`] patches lie, if any.
    fine: Option<PointTree<()>>,
}

/// Irradiance in 63 bits: each channel's `f32` (non-negative: no sign bit)
/// rounded to its 8 exponent and top 13 mantissa bits, a relative error of
/// at most 2^-14 (far under the photon estimates' own).
fn pack(e: Vec3) -> u64 {
    let channel = |c: f32| {
        // NaN and negatives (never from an estimate) become 0; the rounding
        // carries into the exponent as it should, and infinity stays.
        let bits = u64::from(c.max(0.0).to_bits());
        ((bits + (1 << 9)) >> 10).min((0xff << 13) as u64)
    };
    channel(e.x) | (channel(e.y) << 21) | (channel(e.z) << 42)
}

/// The irradiance [`pack`] kept.
fn unpack(packed: u64) -> Vec3 {
    let channel = |shift: u32| f32::from_bits((((packed >> shift) & 0x1f_ffff) << 10) as u32);
    Vec3::new(channel(0), channel(21), channel(42))
}

/// Where a triangle of `n` patches along an edge keeps the patch holding
/// barycentrics `(u, v)`, counted from its first; and the barycentrics of
/// that patch's centre. The patches are the `n (n + 1) / 2` cells `(i, j)`
/// of an `n x n` grid over `(u, v)` with `i + j < n`: squares, but for the
/// half squares along the edge `u + v = 1` (each one's triangle inside).
fn patch(n: u32, u: f32, v: f32) -> (u32, f32, f32) {
    let scale = n as f32;
    // `as` saturates: a barycentric a rounding below 0 is in the first cell.
    let i = ((u * scale) as u32).min(n - 1);
    let j = ((v * scale) as u32).min(n - 1 - i);
    let index = j * n - j * j.saturating_sub(1) / 2 + i;
    let inside = if i + j + 1 < n { 0.5 } else { 1.0 / 3.0 };
    (index, (i as f32 + inside) / scale, (j as f32 + inside) / scale)
}

/// The patches along each edge of a triangle of `mesh`, for patches of
/// edge `size` (0 for a triangle that would need more than [`MOST_PER_EDGE`]).
fn patches_along(mesh: &Mesh, prim: u32, size: f32) -> u32 {
    let [p0, p1, p2] = mesh.indices[prim as usize].map(|i| mesh.positions[i as usize]);
    let longest = (p1 - p0).length().max((p2 - p0).length()).max((p2 - p1).length());
    let n = (longest / size).ceil();
    if n.is_finite() && n <= MOST_PER_EDGE as f32 {
        (n as u32).max(1)
    } else {
        0
    }
}

impl RecordTexels {
    /// The patches of `scene`'s triangles for the records of `global`, none
    /// yet looked up; `None` where the map has no records, or the scene
    /// would need more than [`MOST_PER_RECORD`] or [`MOST_PATCHES`].
    pub(in crate::integrator) fn new(scene: &Scene, global: &PhotonMap) -> Option<RecordTexels> {
        let radius = global.record_radius()?;
        let size = PATCH_PER_RADIUS * radius;
        let most = MOST_PATCHES.min(MOST_PER_RECORD * global.record_count() as u64);
        // A patch a triangle at least: a mesh of too many is told at once.
        if scene.meshes.iter().map(|mesh| mesh.indices.len() as u64).sum::<u64>() > most {
            return None;
        }
        let mut first = 0u64;
        let mut triangles = Vec::with_capacity(scene.meshes.len());
        for mesh in &scene.meshes {
            let along: Vec<u32> = (0..mesh.indices.len() as u32)
                .into_par_iter()
                .map(|prim| patches_along(mesh, prim, size))
                .collect();
            let mut placed = Vec::with_capacity(along.len());
            for n in along {
                placed.push([first as u32, n]);
                first += u64::from(n) * u64::from(n + 1) / 2;
                if first > most {
                    return None;
                }
            }
            triangles.push(placed);
        }
        let unseen = || (0..first).into_par_iter().map(|_| AtomicU64::new(UNSEEN)).collect();
        let narrowest2 = (FINE_PER_PATCH * size).powi(2);
        let fine: Vec<Vec3> =
            global.record_discs().filter(|&(_, r2)| r2 < narrowest2).map(|(p, _)| p).collect();
        let fine = (!fine.is_empty()).then(|| PointTree::new(&fine, &vec![(); fine.len()]));
        Some(RecordTexels { triangles, irradiance: [unseen(), unseen()], size, radius, fine })
    }

    /// Whether a record narrower than [`FINE_PER_PATCH`] patches may reach
    /// into the patch centred at `centre`: within a patch's edge of it (as
    /// far as the patch's corners) and that record's radius.
    fn fine_near(&self, centre: Vec3) -> bool {
        let reach = (1.0 + FINE_PER_PATCH) * self.size;
        // (A search bounded by the reach looks at few of the tree's nodes.)
        self.fine.as_ref().is_some_and(|fine| !fine.nearest::<1>(centre, reach * reach).as_slice().is_empty())
    }

    /// [`RecordTexels::new`] for the global map of `maps`, where final
    /// gathering reads it.
    pub(in crate::integrator) fn for_maps(ctx: &Context, maps: &PhotonMaps) -> Option<RecordTexels> {
        let global = maps.global.as_ref().filter(|_| maps.for_gathering)?;
        RecordTexels::new(ctx.query.scene, global)
    }

    /// The irradiance of the record a gather ray's hit `at` reads: that of
    /// its patch's centre. `None` where the triangle is not cut into
    /// patches, or the centre has no record covering it: there the hit's own
    /// point is looked up, as before.
    pub(in crate::integrator) fn irradiance(
        &self,
        scene: &Scene,
        global: &PhotonMap,
        estimate: &Estimate,
        at: SideHit,
    ) -> Option<Vec3> {
        let mut read = [None];
        self.irradiance_of_all(scene, global, estimate, &[Some(at)], &mut read);
        read[0]
    }

    /// [`RecordTexels::irradiance`] of every hit of `hits` (none where
    /// `None`), into `read` (as many). Every patch is read from memory
    /// before any is used: each read is likely a wait on memory, and so
    /// they wait together.
    pub(in crate::integrator) fn irradiance_of_all(
        &self,
        scene: &Scene,
        global: &PhotonMap,
        estimate: &Estimate,
        hits: &[Option<SideHit>],
        read: &mut [Option<Vec3>],
    ) {
        assert_eq!(hits.len(), read.len(), "one answer per hit");
        const CHUNK: usize = 16;
        for (hits, read) in hits.chunks(CHUNK).zip(read.chunks_mut(CHUNK)) {
            let mut kept = [None; CHUNK];
            for (at, kept) in hits.iter().zip(&mut kept) {
                *kept = at
                    .and_then(|at| self.patch(at))
                    .map(|patch| (patch, self.slot(patch).load(Ordering::Relaxed)));
            }
            for ((at, kept), read) in hits.iter().zip(kept).zip(read) {
                *read = match (at, kept) {
                    (Some(at), Some((patch, kept))) => {
                        self.resolved(scene, global, estimate, *at, patch, kept)
                    }
                    _ => None,
                };
            }
        }
    }

    /// The patch a hit falls in, if its triangle is cut into patches.
    fn patch(&self, at: SideHit) -> Option<Patch> {
        let SideHit { hit, front } = at;
        let [first, n] = self.triangles[hit.geom_id as usize][hit.prim_id as usize];
        if n == 0 {
            return None;
        }
        let (index, u, v) = patch(n, hit.u, hit.v);
        Some(Patch { side: usize::from(!front), index: (first + index) as usize, u, v })
    }

    /// Where a patch's irradiance is kept.
    fn slot(&self, patch: Patch) -> &AtomicU64 {
        &self.irradiance[patch.side][patch.index]
    }

    /// The irradiance of `patch` (of hit `at`), given what it held, `kept`:
    /// looked up at its centre on first sight, and kept.
    fn resolved(
        &self,
        scene: &Scene,
        global: &PhotonMap,
        estimate: &Estimate,
        at: SideHit,
        patch: Patch,
        mut kept: u64,
    ) -> Option<Vec3> {
        if kept == UNSEEN {
            let centre = centre(scene, at, patch);
            kept = match global.covering_record(centre.p, centre.ns, estimate) {
                Some(_) if self.fine_near(centre.p) => {
                    pack(global.irradiance_over_disc(centre.p, centre.ns, self.radius))
                }
                Some(record) => pack(global.record_irradiance(record)),
                None => NO_RECORD,
            };
            self.slot(patch).store(kept, Ordering::Relaxed);
        }
        (kept != NO_RECORD).then(|| unpack(kept))
    }
}

/// A gather ray's hit on a surface whose record it reads, and on which side
/// (front as `SurfacePoint` has it: against the face's normal).
#[derive(Debug, Clone, Copy)]
pub(in crate::integrator) struct SideHit {
    pub hit: Hit,
    pub front: bool,
}

impl SideHit {
    /// `ray`'s hit, on the side the ray comes from.
    pub(in crate::integrator) fn of(ray: &Ray, hit: Hit) -> SideHit {
        SideHit { hit, front: hit.ng.dot(ray.dir) < 0.0 }
    }
}

/// A patch of one side of a triangle: where its irradiance is kept, and its
/// centre's barycentrics.
#[derive(Debug, Clone, Copy)]
struct Patch {
    side: usize,
    index: usize,
    u: f32,
    v: f32,
}

/// The surface point at the centre of `patch`, of the hit `at`, on the side
/// `at` met it.
fn centre(scene: &Scene, at: SideHit, patch: Patch) -> SurfacePoint {
    let SideHit { hit, front } = at;
    let mesh = &scene.meshes[hit.geom_id as usize];
    SurfacePoint::facing(mesh, &Hit { u: patch.u, v: patch.v, ..hit }, mesh.face_normal(hit.prim_id), front)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::query::{Interaction, RayCount};
    use crate::sampling::{uniform_sphere, Rng};

    /// Gather-like rays from inside the point-lit Cornell box (whose
    /// indirect light varies the most of the example scenes): each diffuse
    /// hit reads exactly the record covering its patch's centre (so no two
    /// patches share a slot, whoever filled it first), mostly the record its
    /// own point would read, and on average the same light; or, near the hot
    /// spot's records narrower than half a patch, exactly the disc's
    /// estimate at the centre.
    #[test]
    fn hits_read_the_record_at_their_patchs_centre_and_on_average_their_points_own() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-point.toml");
        let scene = Scene::load(&file).unwrap();
        let accel = crate::accel::build(crate::accel::Backend::Native, &scene.triangle_views()).unwrap();
        let mut config = crate::RenderConfig { width: 16, height: 16, ..scene.config.clone() };
        config.photons.global_photons = 20_000;
        let ctx = Context::new(&scene, accel.as_ref(), &config);
        let maps = super::super::maps_for_tests(&ctx);
        let global = maps.global.as_ref().filter(|_| maps.for_gathering).expect("a map for gathering");
        let texels = RecordTexels::for_maps(&ctx, &maps).expect("records to read");
        let estimate = config.photons.global_estimate(ctx.diagonal);
        let bounds = scene.bounds();
        let mut rng = Rng::new(7, 0);
        let (mut read_sum, mut point_sum) = (Vec3::ZERO, Vec3::ZERO);
        let (mut hits, mut same_record, mut fine_hits) = (0, 0, 0);
        for _ in 0..40_000 {
            // From a random point in the box's inner half, in any direction.
            let inside = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 0.5 + 0.25;
            let origin = bounds.min + inside * (bounds.max - bounds.min);
            let ray = Ray::new(origin, uniform_sphere(rng.uniform2()));
            let Some(Interaction::Surface(hit)) = ctx.query.first_meeting(&ray, &mut RayCount::default())
            else {
                continue;
            };
            if !ctx.query.hit_material(&hit).is_glossy_or_diffuse() {
                continue;
            }
            let at = SideHit::of(&ray, hit);
            let read = texels.irradiance(&scene, global, &estimate, at);
            let patch = texels.patch(at).expect("the box's triangles are cut into patches");
            let centre = centre(&scene, at, patch);
            let (fine, centre_p, centre_n) = (texels.fine_near(centre.p), centre.p, centre.ns);
            let centre = global.covering_record(centre.p, centre.ns, &estimate);
            assert_eq!(read.is_some(), centre.is_some());
            let sp = SurfacePoint::new(&scene, &ray, &hit);
            let (Some(read), Some(centre), Some(point)) =
                (read, centre, global.covering_record(sp.p, sp.ns, &estimate))
            else {
                continue;
            };
            // Near records narrower than half a patch, the disc's estimate;
            // elsewhere the centre's record.
            let exact = if fine {
                global.irradiance_over_disc(centre_p, centre_n, texels.radius)
            } else {
                global.record_irradiance(centre)
            };
            assert!(
                (read - exact).abs().max_element() <= exact.max_element() * 2f32.powi(-14),
                "{read} for {exact}"
            );
            if fine {
                fine_hits += 1;
                continue;
            }
            assert_eq!(sp.front, at.front);
            hits += 1;
            same_record += usize::from(centre == point);
            read_sum += read;
            point_sum += global.record_irradiance(point);
        }
        assert!(hits > 20_000, "{hits} hits");
        let same = same_record as f64 / hits as f64;
        let ratio = read_sum / point_sum;
        assert!(same > 0.5, "the patch's record is the point's at {same} of the hits");
        assert!((ratio - 1.0).abs().max_element() < 0.01, "read / point's own: {ratio}");
        eprintln!("{hits} hits; the same record at {same:.3}; read / point's own {ratio}; {fine_hits} near narrow records");
        assert!(fine_hits > 0, "the hot spot above the light has records narrower than half a patch");
    }

    #[test]
    fn irradiance_packs_to_within_two_to_the_minus_14() {
        let mut x = 0.37_f32;
        for _ in 0..2000 {
            // Values over many decades, and each channel on its own scale.
            x = (x * 7.13).fract() + 1e-3;
            let e = Vec3::new(x * 1e-20, x, x * 1e20) * Vec3::new(1.0, 3.0, 0.5);
            let back = unpack(pack(e));
            for c in 0..3 {
                assert!((back[c] - e[c]).abs() <= e[c] * 2f32.powi(-14), "{e} -> {back}");
            }
            assert!(pack(e) < NO_RECORD);
        }
        assert_eq!(unpack(pack(Vec3::ZERO)), Vec3::ZERO);
        assert_eq!(
            unpack(pack(Vec3::new(f32::NAN, -1.0, f32::INFINITY))),
            Vec3::new(0.0, 0.0, f32::INFINITY)
        );
        // Rounding up past the largest finite value gives infinity, as in f32.
        assert_eq!(unpack(pack(Vec3::splat(f32::MAX))), Vec3::splat(f32::INFINITY));
    }

    #[test]
    fn every_point_of_a_triangle_falls_in_one_patch_whose_centre_is_inside_it() {
        for n in [1, 2, 3, 7, 255, MOST_PER_EDGE] {
            let count = n * (n + 1) / 2;
            let mut seen = vec![false; count as usize];
            let steps = 400;
            for a in 0..=steps {
                for b in 0..=(steps - a) {
                    let (u, v) = (a as f32 / steps as f32, b as f32 / steps as f32);
                    let (index, cu, cv) = patch(n, u, v);
                    assert!(index < count, "n {n}: ({u}, {v}) in patch {index} of {count}");
                    seen[index as usize] = true;
                    assert!(cu > 0.0 && cv > 0.0 && cu + cv < 1.0, "centre ({cu}, {cv}) inside");
                    // The centre lies within one patch's width of the point.
                    let width = 1.0 / n as f32;
                    assert!(
                        (cu - u).abs() <= width && (cv - v).abs() <= width,
                        "n {n}: ({u}, {v}) -> ({cu}, {cv})"
                    );
                    // And it is a centre of the same patch.
                    assert_eq!(patch(n, cu, cv).0, index);
                }
            }
            if n <= 7 {
                assert!(seen.iter().all(|&s| s), "n {n}: every patch holds a point");
            }
        }
        // Barycentrics a rounding outside the triangle still find a patch.
        for (u, v) in [(-1e-7, 0.5), (0.5, -1e-7), (1.0 + 1e-7, 0.0), (0.5, 0.5 + 1e-7), (f32::NAN, 0.2)] {
            assert!(patch(4, u, v).0 < 10);
        }
    }
}
