//! Embree behind a safe interface: the only module with `unsafe` code. One
//! build uses one major version, Embree 3 or (feature `embree4`) Embree 4;
//! `ffi` hides their differences, and nothing outside this module knows
//! which is in use ([`Device::version`] and the intersector's name say it).
//!
//! Ownership follows Embree's reference counting: [`Device`] owns one
//! `RTCDevice` and [`EmbreeIntersector`] owns one committed `RTCScene` plus the
//! device it was made on; each handle is released exactly once, in `Drop`.
//! Embree's error callback writes into a sink owned by the `Device`, and every
//! fallible call drains it into a Rust [`Error`], so a failure never turns into
//! a silently black image.

// The one module where `unsafe` is allowed (the crate denies it elsewhere).
#![allow(unsafe_code)]

mod ffi;

use std::ffi::{c_char, c_void, CStr, CString};
use std::marker::PhantomData;
use std::sync::Mutex;

use glam::Vec3;

use super::{BvhLayout, Hit, Intersector, Ray};
use crate::error::{Error, Result};

/// Triangles as Embree reads them: shared positions and index triples.
///
/// Embree reads a vertex buffer with 16-byte loads, so it can use our
/// positions in place (no copy) only when 4 readable bytes follow the last
/// vertex. [`TriangleView::padded`] knows when they do; other views are copied.
#[derive(Debug, Clone, Copy)]
pub struct TriangleView<'a> {
    positions: &'a [Vec3],
    indices: &'a [[u32; 3]],
    // At least one more `Vec3` is allocated after `positions`.
    padded: bool,
}

impl<'a> TriangleView<'a> {
    /// A view of triangles that Embree copies into its own buffers.
    pub fn new(positions: &'a [Vec3], indices: &'a [[u32; 3]]) -> Self {
        TriangleView { positions, indices, padded: false }
    }

    /// A view that Embree reads in place when `positions` has spare capacity
    /// (see [`crate::scene::Mesh::new`], which reserves it); copied otherwise.
    pub fn padded(positions: &'a Vec<Vec3>, indices: &'a [[u32; 3]]) -> Self {
        TriangleView { positions, indices, padded: positions.capacity() > positions.len() }
    }

    /// Vertex positions.
    pub fn positions(&self) -> &'a [Vec3] {
        self.positions
    }

    /// Counter-clockwise vertex indices, three per triangle.
    pub fn indices(&self) -> &'a [[u32; 3]] {
        self.indices
    }

    /// Whether Embree can read these buffers in place.
    pub fn shareable(&self) -> bool {
        self.padded
    }
}

/// Checks that every index names a vertex of its mesh: out-of-range indices
/// would make Embree (or the native BVH) read out of bounds.
pub fn check_indices(meshes: &[TriangleView<'_>]) -> Result<()> {
    for (id, mesh) in meshes.iter().enumerate() {
        let vertex_count = mesh.positions.len();
        if let Some(bad) = mesh.indices.iter().flatten().find(|&&i| i as usize >= vertex_count) {
            return Err(Error::Embree {
                code: "RTC_ERROR_INVALID_ARGUMENT",
                message: format!("mesh {id}: vertex index {bad} out of range ({vertex_count} vertices)"),
            });
        }
    }
    Ok(())
}

/// Where Embree's error callback leaves the first error it reports.
#[derive(Default)]
struct ErrorSink {
    first: Mutex<Option<Error>>,
}

/// The callback Embree calls on any device error. It must not unwind into C.
extern "C" fn record_error(user: *mut c_void, code: ffi::RTCError, message: *const c_char) {
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: `user` is the `ErrorSink` boxed inside the `Device` that
        // registered this callback; the box outlives the device handle.
        let sink = unsafe { &*(user as *const ErrorSink) };
        let message = if message.is_null() {
            String::new()
        } else {
            // SAFETY: Embree passes a NUL-terminated string valid for this call.
            unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
        };
        if let Ok(mut first) = sink.first.lock() {
            first.get_or_insert(Error::Embree { code: error_name(code), message });
        }
    });
}

fn error_name(code: ffi::RTCError) -> &'static str {
    match code {
        ffi::RTC_ERROR_NONE => "RTC_ERROR_NONE",
        ffi::RTC_ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT",
        ffi::RTC_ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION",
        ffi::RTC_ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY",
        ffi::RTC_ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU",
        ffi::RTC_ERROR_CANCELLED => "RTC_ERROR_CANCELLED",
        _ => "RTC_ERROR_UNKNOWN",
    }
}

/// An Embree device: Embree's global state (thread pool, CPU dispatch).
pub struct Device {
    raw: ffi::RTCDevice,
    // Boxed so its address stays fixed while Embree holds a pointer to it.
    errors: Box<ErrorSink>,
}

impl Device {
    /// Creates a device with as many build threads as the current rayon
    /// pool has (so `--threads` limits Embree too), Embree's defaults otherwise.
    pub fn new() -> Result<Self> {
        let config = CString::new(format!("threads={}", rayon::current_num_threads()))
            .expect("no NUL in a formatted number");
        // SAFETY: `config` is a NUL-terminated string that outlives the call.
        let raw = unsafe { ffi::rtcNewDevice(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: with a null device this reads the thread's creation error.
            let code = unsafe { ffi::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(Error::Embree {
                code: error_name(code),
                message: "rtcNewDevice failed (is this CPU supported by Embree?)".into(),
            });
        }
        let errors = Box::<ErrorSink>::default();
        let user = &*errors as *const ErrorSink as *mut c_void;
        // SAFETY: `raw` is a live device; `user` points into `errors`, which is
        // owned by the returned `Device` and so outlives every callback.
        unsafe { ffi::rtcSetDeviceErrorFunction(raw, Some(record_error), user) };
        Ok(Device { raw, errors })
    }

    /// Embree's version, e.g. `"3.13.5"`.
    pub fn version(&self) -> String {
        // SAFETY: `raw` is a live device and the property is read-only.
        let v = unsafe { ffi::rtcGetDeviceProperty(self.raw, ffi::RTC_DEVICE_PROPERTY_VERSION) };
        format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
    }

    /// Returns the first error Embree reported since the last check, if any.
    fn check(&self) -> Result<()> {
        let mut first = self.errors.first.lock().unwrap_or_else(|e| e.into_inner());
        match first.take() {
            Some(err) => Err(err),
            None => Ok(()),
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `raw` came from `rtcNewDevice` and is released only here.
        unsafe { ffi::rtcReleaseDevice(self.raw) };
    }
}

/// A committed Embree scene of triangle meshes, ready for queries.
///
/// Geometry ids equal the meshes' positions in the slice given to [`build`].
/// Embree reads padded meshes' vertex and index arrays in place, so the
/// intersector borrows them for `'a`.
///
/// [`build`]: EmbreeIntersector::build
pub struct EmbreeIntersector<'a> {
    scene: ffi::RTCScene,
    // Declared after `scene`; released after it in `Drop` order.
    device: Device,
    // Triangles (of all meshes) Embree reads from our memory, not its own copy.
    shared_triangles: usize,
    // Built with `RTC_SCENE_FLAG_COMPACT`.
    compact: bool,
    // Power of two the ray directions are scaled by (see `direction_scale`).
    dir_scale: f32,
    meshes: PhantomData<&'a [Vec3]>,
}

/// The power of two that ray directions are multiplied by for Embree in a
/// scene whose largest coordinate is `extent`. Embree treats a triangle as
/// parallel to a ray when `|(e1 x e2) . dir|` falls below about 1e-18, which
/// every triangle of a scene 1e-8 across does with unit directions; scaling
/// the directions by about `1 / extent^2` (and `t` back) keeps the test in
/// range. 1 for scenes of size 1 and more, so their hits are unchanged. At
/// most 2^59: Embree asserts that no direction component exceeds 1.8e18.
fn direction_scale(extent: f32) -> f32 {
    if !(extent > 0.0 && extent < 1.0) {
        return 1.0;
    }
    let exponent = (-2.0 * extent.log2()).round().clamp(0.0, 59.0) as i32;
    2f32.powi(exponent)
}

// SAFETY: the scene is committed in `build` and never modified afterwards.
// Embree documents `rtcIntersect1`/`rtcOccluded1` on a committed scene as safe
// to call from any number of threads at once, and releasing happens only in
// `Drop`, which has exclusive access. The error sink is behind a `Mutex`.
unsafe impl Send for EmbreeIntersector<'_> {}
// SAFETY: see `Send` above: all `&self` methods are Embree's thread-safe queries.
unsafe impl Sync for EmbreeIntersector<'_> {}

impl<'a> EmbreeIntersector<'a> {
    /// How [`Intersector::intersect_batch`] hands rays to Embree: one call
    /// into the ray-stream API (Embree 3), or ray by ray (Embree 4 has no streams).
    pub const BATCH_CALL: &'static str = ffi::BATCH_CALL;

    /// Builds and commits a scene holding `meshes`, one Embree geometry each.
    ///
    /// Returns an error (never undefined behaviour) if an index is out of range.
    pub fn build(meshes: &[TriangleView<'a>]) -> Result<Self> {
        Self::build_with_layout(meshes, BvhLayout::Fast)
    }

    /// [`build`](Self::build) with the BVH in `layout` (`Auto` decided by
    /// the triangle count and the memory available).
    pub fn build_with_layout(meshes: &[TriangleView<'a>], layout: BvhLayout) -> Result<Self> {
        check_indices(meshes)?;
        let triangles = meshes.iter().map(|m| m.indices.len()).sum();
        let compact = layout.resolve(triangles) == BvhLayout::Compact;
        let device = Device::new()?;
        // SAFETY: `device.raw` is a live device.
        let scene = unsafe { ffi::rtcNewScene(device.raw) };
        device.check()?;
        let extent = meshes
            .iter()
            .flat_map(|m| m.positions().iter())
            .fold(0.0f32, |e, p| e.max(p.abs().max_element()));
        let dir_scale = direction_scale(extent);
        let mut this =
            EmbreeIntersector { scene, device, shared_triangles: 0, compact, dir_scale, meshes: PhantomData };
        let flags = ffi::RTC_SCENE_FLAG_ROBUST
            | if compact { ffi::RTC_SCENE_FLAG_COMPACT } else { ffi::RTC_SCENE_FLAG_NONE };
        // SAFETY: `scene` is live and not yet committed.
        unsafe { ffi::rtcSetSceneFlags(scene, flags) };
        for (id, mesh) in meshes.iter().enumerate() {
            if this.attach(id as u32, mesh)? {
                this.shared_triangles += mesh.indices.len();
            }
        }
        // SAFETY: all geometries are attached; committing builds the BVH.
        unsafe { ffi::rtcCommitScene(scene) };
        this.device.check()?;
        Ok(this)
    }

    /// Adds `mesh` as geometry `id`; says whether Embree reads it in place.
    fn attach(&self, id: u32, mesh: &TriangleView<'a>) -> Result<bool> {
        // SAFETY: `device.raw` is live; the geometry is released below after attaching.
        let geom = unsafe { ffi::rtcNewGeometry(self.device.raw, ffi::RTC_GEOMETRY_TYPE_TRIANGLE) };
        self.device.check()?;
        let shared = mesh.shareable() && !mesh.indices.is_empty();
        let filled = if shared {
            Self::share_buffers(geom, mesh);
            self.device.check()
        } else {
            self.copy_buffers(geom, mesh)
        };
        if let Err(err) = filled {
            // SAFETY: `geom` is live and owned here.
            unsafe { ffi::rtcReleaseGeometry(geom) };
            return Err(err);
        }
        // SAFETY: `geom` is complete; attaching takes a reference, so releasing
        // ours afterwards leaves the scene as the sole owner.
        unsafe {
            ffi::rtcCommitGeometry(geom);
            ffi::rtcAttachGeometryByID(self.scene, geom, id);
            ffi::rtcReleaseGeometry(geom);
        }
        self.device.check().map(|()| shared)
    }

    /// Points Embree at the mesh's own arrays: no copy.
    fn share_buffers(geom: ffi::RTCGeometry, mesh: &TriangleView<'a>) {
        const _: () = assert!(std::mem::size_of::<Vec3>() == 12 && std::mem::align_of::<Vec3>() == 4);
        // SAFETY: `Vec3` is three packed `f32`s (checked above), 4-byte
        // aligned as Embree requires; `shareable()` guarantees the one more
        // `Vec3` allocated after the last vertex that Embree's 16-byte loads
        // read. The arrays are borrowed for `'a`, the intersector's lifetime,
        // so they outlive every use Embree makes of them, and nothing can
        // write to them while borrowed.
        unsafe {
            ffi::rtcSetSharedGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_VERTEX,
                0,
                ffi::RTC_FORMAT_FLOAT3,
                mesh.positions.as_ptr().cast(),
                0,
                std::mem::size_of::<Vec3>(),
                mesh.positions.len(),
            )
        };
        // SAFETY: `[u32; 3]` is 12 bytes, 4-byte aligned; borrowed for `'a` as above.
        unsafe {
            ffi::rtcSetSharedGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_INDEX,
                0,
                ffi::RTC_FORMAT_UINT3,
                mesh.indices.as_ptr().cast(),
                0,
                std::mem::size_of::<[u32; 3]>(),
                mesh.indices.len(),
            )
        };
    }

    /// Copies the mesh into buffers Embree allocates (and pads).
    fn copy_buffers(&self, geom: ffi::RTCGeometry, mesh: &TriangleView<'_>) -> Result<()> {
        let vertex_count = mesh.positions.len();
        // SAFETY: `geom` is a new triangle geometry; Embree allocates (and pads
        // to a 16-byte readable tail) buffers of exactly the requested sizes.
        let vertices = unsafe {
            ffi::rtcSetNewGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_VERTEX,
                0,
                ffi::RTC_FORMAT_FLOAT3,
                std::mem::size_of::<[f32; 3]>(),
                vertex_count,
            )
        } as *mut [f32; 3];
        // SAFETY: as above, for the index buffer.
        let indices = unsafe {
            ffi::rtcSetNewGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_INDEX,
                0,
                ffi::RTC_FORMAT_UINT3,
                std::mem::size_of::<[u32; 3]>(),
                mesh.indices.len(),
            )
        } as *mut [u32; 3];
        self.device.check()?;
        if vertex_count > 0 {
            // SAFETY: Embree returned a buffer of `vertex_count` float triples.
            let dst = unsafe { std::slice::from_raw_parts_mut(vertices, vertex_count) };
            for (d, p) in dst.iter_mut().zip(mesh.positions) {
                *d = p.to_array();
            }
        }
        if !mesh.indices.is_empty() {
            // SAFETY: Embree returned a buffer of `indices.len()` u32 triples.
            let dst = unsafe { std::slice::from_raw_parts_mut(indices, mesh.indices.len()) };
            dst.copy_from_slice(mesh.indices);
        }
        Ok(())
    }

    /// Triangles Embree reads in place from the meshes (the rest it copied).
    pub fn shared_triangles(&self) -> usize {
        self.shared_triangles
    }

    /// Embree's record of `ray`, its direction multiplied by `scale` (a power
    /// of two) and its far end divided by it, so it stands for the same segment.
    fn ray(ray: &Ray, scale: f32) -> ffi::RTCRay {
        ffi::RTCRay {
            org_x: ray.origin.x,
            org_y: ray.origin.y,
            org_z: ray.origin.z,
            // Embree accepts t >= tnear; the smallest positive tnear makes that t > 0.
            tnear: f32::MIN_POSITIVE,
            dir_x: ray.dir.x * scale,
            dir_y: ray.dir.y * scale,
            dir_z: ray.dir.z * scale,
            time: 0.0,
            tfar: ray.t_max / scale,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }
}

impl Drop for EmbreeIntersector<'_> {
    fn drop(&mut self) {
        // SAFETY: `scene` came from `rtcNewScene` and is released only here.
        unsafe { ffi::rtcReleaseScene(self.scene) };
    }
}

/// Batches of fewer rays than this are traced ray by ray: a stream of 4
/// final-gathering rays made the photon-mapped Cornell box 4-6% slower
/// (BENCHMARKS.md, "Rays in batches").
const MIN_STREAM: usize = 8;

/// Batches of at most this many rays are converted into Embree's records on
/// the stack: the integrators hand over a few rays at a time, for which a
/// heap allocation per call would cost about as much as the stream saves.
const STACK_BATCH: usize = 16;

/// Converts `rays` into Embree's records with `record`, hands them to
/// `trace` in one call, and reads each back with `read(index, record)`: on
/// the stack for batches of up to [`STACK_BATCH`], else in one allocation
/// (a longer stream lets Embree reorder more).
fn in_records<R: Copy>(
    rays: &[Ray],
    record: impl Fn(&Ray) -> R,
    trace: impl FnOnce(&mut [R]),
    mut read: impl FnMut(usize, &R),
) {
    let Some(first) = rays.first() else { return };
    let mut on_stack;
    let mut on_heap;
    let records: &mut [R] = if rays.len() <= STACK_BATCH {
        on_stack = [record(first); STACK_BATCH];
        for (r, ray) in on_stack.iter_mut().zip(rays) {
            *r = record(ray);
        }
        &mut on_stack[..rays.len()]
    } else {
        on_heap = rays.iter().map(&record).collect::<Vec<R>>();
        &mut on_heap
    };
    trace(records);
    for (i, r) in records.iter().enumerate() {
        read(i, r);
    }
}

/// Embree's ray-and-hit record for `ray`, with the hit marked empty.
fn new_rayhit(ray: &Ray, scale: f32) -> ffi::RTCRayHit {
    ffi::RTCRayHit { ray: EmbreeIntersector::ray(ray, scale), hit: ffi::empty_hit() }
}

/// Our hit from Embree's record, if it hit anything.
fn hit_of(rayhit: &ffi::RTCRayHit, scale: f32) -> Option<Hit> {
    let h = &rayhit.hit;
    (h.geomID != ffi::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
        t: rayhit.ray.tfar * scale,
        u: h.u,
        v: h.v,
        geom_id: h.geomID,
        prim_id: h.primID,
        ng: Vec3::new(h.Ng_x, h.Ng_y, h.Ng_z),
    })
}

/// Rays already in Embree's own record format, for measuring what calling
/// Embree directly costs without our conversions (see [`EmbreeIntersector::intersect_raw`]).
pub struct RawRays(Vec<ffi::RTCRayHit>);

impl RawRays {
    /// Converts rays once, up front, as a C program would hold them.
    pub fn new(rays: &[Ray]) -> RawRays {
        RawRays(rays.iter().map(|r| new_rayhit(r, 1.0)).collect())
    }

    /// Resets the hit records so the same rays can be traced again.
    pub fn reset(&mut self, rays: &[Ray]) {
        for (record, ray) in self.0.iter_mut().zip(rays) {
            *record = new_rayhit(ray, 1.0);
        }
    }

    /// How many rays have recorded a hit.
    pub fn hits(&self) -> usize {
        self.0.iter().filter(|r| r.hit.geomID != ffi::RTC_INVALID_GEOMETRY_ID).count()
    }
}

impl EmbreeIntersector<'_> {
    /// Traces `rays` with `rtcIntersect1` straight on Embree's records, in
    /// parallel chunks, with no conversion to or from our types: the baseline
    /// for the cost of the wrapper.
    pub fn intersect_raw(&self, rays: &mut RawRays) {
        use rayon::prelude::*;
        let scene = SceneHandle(self.scene);
        rays.0.par_chunks_mut(1024).for_each(|chunk| {
            let scene = &scene;
            for record in chunk {
                // SAFETY: the scene is committed and outlives this call; each
                // record is a valid, 16-byte aligned `RTCRayHit`.
                unsafe { ffi::intersect1(scene.0, record) };
            }
        });
    }
}

/// A committed scene handle that may cross threads (see the `Sync` impl of
/// [`EmbreeIntersector`]: queries on a committed scene are thread-safe).
struct SceneHandle(ffi::RTCScene);
// SAFETY: only used for `rtcIntersect1` on a committed scene, which Embree
// allows from any number of threads at once.
unsafe impl Sync for SceneHandle {}

impl Intersector for EmbreeIntersector<'_> {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut rayhit = new_rayhit(ray, self.dir_scale);
        // SAFETY: the scene is committed; `rayhit` is a valid record, 16-byte
        // aligned by its `repr(align(16))`.
        unsafe { ffi::intersect1(self.scene, &mut rayhit) };
        hit_of(&rayhit, self.dir_scale)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let mut r = Self::ray(ray, self.dir_scale);
        // SAFETY: as in `intersect`; `RTCRay` is 16-byte aligned.
        unsafe { ffi::occluded1(self.scene, &mut r) };
        // Embree marks an occluded ray by setting tfar to -infinity.
        r.tfar == f32::NEG_INFINITY
    }

    /// The batch through Embree's ray-stream API (`rtcIntersect1M`) with
    /// Embree 3 (ray by ray with Embree 4, which has no streams).
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        if !self.batches_pay(rays.len()) {
            for (ray, hit) in rays.iter().zip(hits) {
                *hit = self.intersect(ray);
            }
            return;
        }
        let scale = self.dir_scale;
        in_records(
            rays,
            |ray| new_rayhit(ray, scale),
            // SAFETY: the scene is committed; `records` is a live array of
            // valid records, 16-byte aligned by the type's `repr(align(16))`.
            |records| unsafe { ffi::intersect_many(self.scene, records) },
            |i, record| hits[i] = hit_of(record, scale),
        );
    }

    /// As [`Intersector::intersect_batch`], for shadow rays (`rtcOccluded1M`).
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one result slot per ray");
        if !self.batches_pay(rays.len()) {
            for (ray, o) in rays.iter().zip(occluded) {
                *o = self.occluded(ray);
            }
            return;
        }
        let scale = self.dir_scale;
        in_records(
            rays,
            |ray| Self::ray(ray, scale),
            // SAFETY: as in `intersect_batch`, for an array of `RTCRay`.
            |records| unsafe { ffi::occluded_many(self.scene, records) },
            // Embree marks an occluded ray by setting tfar to -infinity.
            |i, record| occluded[i] = record.tfar == f32::NEG_INFINITY,
        );
    }

    /// With Embree 3, from 8 rays on; never with Embree 4.
    fn batches_pay(&self, rays: usize) -> bool {
        ffi::STREAMS && rays >= MIN_STREAM
    }

    fn name(&self) -> String {
        let layout = if self.compact { " (compact BVH)" } else { "" };
        format!("embree {}{layout}", self.device.version())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_triangle() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        (vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])
    }

    #[test]
    fn hits_report_embree_barycentrics_and_ccw_normal() {
        let (p, i) = unit_triangle();
        let accel = EmbreeIntersector::build(&[TriangleView::new(&p, &i)]).unwrap();
        let hit = accel.intersect(&Ray::new(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z)).unwrap();
        assert!((hit.t - 2.0).abs() < 1e-6);
        assert!((hit.u - 0.25).abs() < 1e-6 && (hit.v - 0.5).abs() < 1e-6);
        assert_eq!((hit.geom_id, hit.prim_id), (0, 0));
        // (v1 - v0) x (v2 - v0) = X x Y = +Z.
        assert!(hit.ng.normalize().abs_diff_eq(Vec3::Z, 1e-6), "ng = {}", hit.ng);
        assert!(accel.occluded(&Ray::new(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z)));
    }

    #[test]
    fn a_hit_at_the_origin_does_not_count() {
        // The ray starts exactly in the triangle's plane, inside it.
        let (p, i) = unit_triangle();
        let accel = EmbreeIntersector::build(&[TriangleView::new(&p, &i)]).unwrap();
        let native = crate::accel::bvh::Bvh::build(&[TriangleView::new(&p, &i)]);
        let ray = Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::new(0.1, 0.2, -1.0));
        for backend in [&accel as &dyn Intersector, &native] {
            assert_eq!(backend.intersect(&ray), None, "{}", backend.name());
            assert!(!backend.occluded(&ray), "{}", backend.name());
        }
    }

    #[test]
    fn misses_and_t_max_are_respected() {
        let (p, i) = unit_triangle();
        let accel = EmbreeIntersector::build(&[TriangleView::new(&p, &i)]).unwrap();
        assert!(accel.intersect(&Ray::new(Vec3::new(0.8, 0.8, 1.0), -Vec3::Z)).is_none());
        let short = Ray { t_max: 0.5, ..Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z) };
        assert!(accel.intersect(&short).is_none());
        assert!(!accel.occluded(&short));
    }

    #[test]
    fn meshes_are_read_in_place_and_answer_as_copies_do() {
        let sphere = crate::scene::shapes::sphere("s", Vec3::ZERO, 1.0, 3, 0);
        let shared_view = sphere.view();
        assert!(shared_view.shareable(), "Mesh::new should leave room for Embree's padding");
        let shared = EmbreeIntersector::build(&[shared_view]).unwrap();
        let copied =
            EmbreeIntersector::build(&[TriangleView::new(&sphere.positions, &sphere.indices)]).unwrap();
        assert_eq!(shared.shared_triangles(), sphere.indices.len());
        assert_eq!(copied.shared_triangles(), 0);
        let mut rng = crate::sampling::Rng::new(7, 0);
        for _ in 0..2000 {
            let origin = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
            let ray = Ray::new(origin, Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5);
            assert_eq!(shared.intersect(&ray), copied.intersect(&ray));
            assert_eq!(shared.occluded(&ray), copied.occluded(&ray));
        }
    }

    #[test]
    fn out_of_range_indices_are_an_error_not_a_crash() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let bad = [[0u32, 1, 7]];
        let err = EmbreeIntersector::build(&[TriangleView::new(&p, &bad)]);
        assert!(matches!(err, Err(Error::Embree { .. })));
    }

    #[test]
    fn embree_errors_come_back_through_the_callback() {
        let device = Device::new().unwrap();
        assert!(device.check().is_ok());
        // SAFETY: a new triangle geometry on a live device, released below.
        let geom = unsafe { ffi::rtcNewGeometry(device.raw, ffi::RTC_GEOMETRY_TYPE_TRIANGLE) };
        assert!(!geom.is_null());
        // SAFETY: a deliberately invalid stride (not a multiple of 4) on a live
        // geometry; Embree rejects it, returns null and reports through the
        // error callback.
        let buffer = unsafe {
            ffi::rtcSetNewGeometryBuffer(geom, ffi::RTC_BUFFER_TYPE_VERTEX, 0, ffi::RTC_FORMAT_FLOAT3, 13, 3)
        };
        assert!(buffer.is_null());
        match device.check() {
            Err(Error::Embree { code, message }) => {
                eprintln!("{code}: {message}");
                // Embree 3 and 4 name this error differently; both explain it.
                assert!(
                    ["RTC_ERROR_INVALID_ARGUMENT", "RTC_ERROR_INVALID_OPERATION"].contains(&code),
                    "{code}"
                );
                assert!(message.contains("stride") || message.contains("aligned"), "{message}");
            }
            other => panic!("expected an Embree error, got {other:?}"),
        }
        // Reported once, then cleared.
        assert!(device.check().is_ok());
        // SAFETY: `geom` is live and owned here.
        unsafe { ffi::rtcReleaseGeometry(geom) };
    }

    #[test]
    fn queries_from_many_threads_agree() {
        use rayon::prelude::*;
        let (p, i) = unit_triangle();
        let accel = EmbreeIntersector::build(&[TriangleView::new(&p, &i)]).unwrap();
        let hits: usize = (0..10_000)
            .into_par_iter()
            .filter(|k| {
                // Offsets keep every point off the diagonal edge x + y = 1.
                let x = (k % 100) as f32 / 100.0 + 0.0025;
                let y = (k / 100) as f32 / 100.0 + 0.0025;
                accel.intersect(&Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z)).is_some()
            })
            .count();
        // Points of a 100 x 100 grid with x + y < 1, i.e. i + j <= 99.
        let expected = (0..10_000).filter(|k| (k % 100) + (k / 100) <= 99).count();
        assert_eq!(hits, expected);
    }

    #[test]
    fn batches_agree_with_single_rays() {
        let (p, i) = unit_triangle();
        let accel = EmbreeIntersector::build(&[TriangleView::new(&p, &i)]).unwrap();
        let rays: Vec<Ray> = (0..1000)
            .map(|k| {
                let (x, y) = ((k % 40) as f32 / 30.0 - 0.1, (k / 40) as f32 / 20.0 - 0.1);
                Ray {
                    t_max: if k % 7 == 0 { 0.5 } else { f32::INFINITY },
                    ..Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z)
                }
            })
            .collect();
        let mut hits = vec![None; rays.len()];
        accel.intersect_batch(&rays, &mut hits);
        let mut occluded = vec![false; rays.len()];
        accel.occluded_batch(&rays, &mut occluded);
        for ((ray, hit), o) in rays.iter().zip(&hits).zip(&occluded) {
            assert_eq!(*hit, accel.intersect(ray));
            assert_eq!(*o, accel.occluded(ray));
            assert_eq!(*o, hit.is_some());
        }
        assert!(hits.iter().any(Option::is_some) && hits.iter().any(Option::is_none));
    }

    #[test]
    fn device_reports_the_major_version_it_was_built_for() {
        let version = Device::new().unwrap().version();
        assert!(version.starts_with(&format!("{}.", ffi::MAJOR)), "{version}");
    }
}
