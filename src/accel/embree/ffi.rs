//! Raw bindings to Embree, one major version per build: Embree 3 by default
//! (bindgen in `build.rs` over `vendor-headers/embree3_wrapper.h`), Embree 4
//! with the `embree4` feature (the `embree4-sys` crate). Both present the same
//! names to `accel::embree`, Embree 3's, plus a few functions where the APIs
//! differ (Embree 4 dropped the intersect context and the ray streams). Only
//! `accel::embree` uses them.

#![allow(non_upper_case_globals, non_camel_case_types, non_snake_case, dead_code)]
#![allow(clippy::all)]
// bindgen emits `unsafe extern` declarations whose bodies have no SAFETY lines.
#![allow(clippy::undocumented_unsafe_blocks, unsafe_op_in_unsafe_fn)]

#[cfg(not(feature = "embree4"))]
pub use embree3::*;
#[cfg(feature = "embree4")]
pub use embree4::*;

#[cfg(not(feature = "embree4"))]
mod embree3 {
    include!(concat!(env!("OUT_DIR"), "/embree3_bindings.rs"));

    /// The Embree major version these bindings are for.
    pub const MAJOR: u32 = 3;

    /// How [`intersect_many`] and [`occluded_many`] hand rays to Embree.
    pub const BATCH_CALL: &str = "ray streams (rtcIntersect1M)";

    /// Whether [`intersect_many`] and [`occluded_many`] trace streams.
    pub const STREAMS: bool = true;

    /// `#define RTC_INVALID_GEOMETRY_ID ((unsigned int)-1)`: a cast bindgen cannot evaluate.
    pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;

    /// Embree 3's `rtcInitIntersectContext` is a `static inline` function in
    /// `rtcore_common.h`, so bindgen cannot bind it: this is the same code.
    fn new_intersect_context() -> RTCIntersectContext {
        RTCIntersectContext {
            flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: None,
            instID: [RTC_INVALID_GEOMETRY_ID; RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
        }
    }

    /// A hit record marked empty.
    pub fn empty_hit() -> RTCHit {
        RTCHit {
            geomID: RTC_INVALID_GEOMETRY_ID,
            primID: RTC_INVALID_GEOMETRY_ID,
            instID: [RTC_INVALID_GEOMETRY_ID; RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
            ..Default::default()
        }
    }

    /// `rtcIntersect1` with a fresh incoherent context.
    /// Safety: `scene` is committed; `rayhit` points to a live record.
    pub unsafe fn intersect1(scene: RTCScene, rayhit: *mut RTCRayHit) {
        let mut context = new_intersect_context();
        rtcIntersect1(scene, &mut context, rayhit)
    }

    /// `rtcOccluded1` with a fresh incoherent context.
    /// Safety: `scene` is committed; `ray` points to a live record.
    pub unsafe fn occluded1(scene: RTCScene, ray: *mut RTCRay) {
        let mut context = new_intersect_context();
        rtcOccluded1(scene, &mut context, ray)
    }

    /// Every record through Embree's ray-stream API, one call per 2^32 - 1.
    /// Safety: `scene` is committed.
    pub unsafe fn intersect_many(scene: RTCScene, records: &mut [RTCRayHit]) {
        let mut context = new_intersect_context();
        for chunk in records.chunks_mut(u32::MAX as usize) {
            let stride = std::mem::size_of::<RTCRayHit>();
            rtcIntersect1M(scene, &mut context, chunk.as_mut_ptr(), chunk.len() as u32, stride)
        }
    }

    /// Every record through Embree's ray-stream API, one call per 2^32 - 1.
    /// Safety: `scene` is committed.
    pub unsafe fn occluded_many(scene: RTCScene, records: &mut [RTCRay]) {
        let mut context = new_intersect_context();
        for chunk in records.chunks_mut(u32::MAX as usize) {
            let stride = std::mem::size_of::<RTCRay>();
            rtcOccluded1M(scene, &mut context, chunk.as_mut_ptr(), chunk.len() as u32, stride)
        }
    }
}

#[cfg(feature = "embree4")]
mod embree4 {
    use embree4_sys as sys;
    pub use sys::{
        rtcAttachGeometryByID, rtcCommitGeometry, rtcCommitScene, rtcGetDeviceError, rtcGetDeviceProperty,
        rtcNewDevice, rtcNewGeometry, rtcNewScene, rtcReleaseDevice, rtcReleaseGeometry, rtcReleaseScene,
        rtcSetDeviceErrorFunction, rtcSetNewGeometryBuffer, rtcSetSceneFlags, rtcSetSharedGeometryBuffer,
        RTCDevice, RTCError, RTCGeometry, RTCRay, RTCScene, RTC_INVALID_GEOMETRY_ID,
        RTC_MAX_INSTANCE_LEVEL_COUNT,
    };

    /// The Embree major version these bindings are for.
    pub const MAJOR: u32 = 4;

    /// How [`intersect_many`] and [`occluded_many`] hand rays to Embree:
    /// Embree 4 has no ray streams.
    pub const BATCH_CALL: &str = "single rays (Embree 4 has no ray streams)";

    /// Whether [`intersect_many`] and [`occluded_many`] trace streams.
    pub const STREAMS: bool = false;

    pub const RTC_ERROR_NONE: RTCError = RTCError::NONE;
    pub const RTC_ERROR_UNKNOWN: RTCError = RTCError::UNKNOWN;
    pub const RTC_ERROR_INVALID_ARGUMENT: RTCError = RTCError::INVALID_ARGUMENT;
    pub const RTC_ERROR_INVALID_OPERATION: RTCError = RTCError::INVALID_OPERATION;
    pub const RTC_ERROR_OUT_OF_MEMORY: RTCError = RTCError::OUT_OF_MEMORY;
    pub const RTC_ERROR_UNSUPPORTED_CPU: RTCError = RTCError::UNSUPPORTED_CPU;
    pub const RTC_ERROR_CANCELLED: RTCError = RTCError::CANCELLED;
    pub const RTC_DEVICE_PROPERTY_VERSION: sys::RTCDeviceProperty = sys::RTCDeviceProperty::VERSION;
    pub const RTC_SCENE_FLAG_NONE: sys::RTCSceneFlags = sys::RTCSceneFlags::NONE;
    pub const RTC_SCENE_FLAG_ROBUST: sys::RTCSceneFlags = sys::RTCSceneFlags::ROBUST;
    pub const RTC_SCENE_FLAG_COMPACT: sys::RTCSceneFlags = sys::RTCSceneFlags::COMPACT;
    pub const RTC_GEOMETRY_TYPE_TRIANGLE: sys::RTCGeometryType = sys::RTCGeometryType::TRIANGLE;
    pub const RTC_BUFFER_TYPE_VERTEX: sys::RTCBufferType = sys::RTCBufferType::VERTEX;
    pub const RTC_BUFFER_TYPE_INDEX: sys::RTCBufferType = sys::RTCBufferType::INDEX;
    pub const RTC_FORMAT_FLOAT3: sys::RTCFormat = sys::RTCFormat::FLOAT3;
    pub const RTC_FORMAT_UINT3: sys::RTCFormat = sys::RTCFormat::UINT3;

    /// Embree 4's hit record as a library built with instance arrays (the
    /// default since 4.3) writes it: `embree4-sys` carries the 4.2 headers,
    /// whose record ends before `instPrimID`, and a 4.3+ library writes that
    /// field too. With this layout whatever a 4.x library (one instance
    /// level, the default) writes lands inside the record.
    #[repr(C, align(16))]
    #[derive(Debug, Clone, Copy)]
    pub struct RTCHit {
        pub Ng_x: f32,
        pub Ng_y: f32,
        pub Ng_z: f32,
        pub u: f32,
        pub v: f32,
        pub primID: u32,
        pub geomID: u32,
        pub instID: [u32; RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
        pub instPrimID: [u32; RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
    }

    /// A ray and its hit, as `rtcIntersect1` reads and writes them (see [`RTCHit`]).
    #[repr(C, align(16))]
    #[derive(Debug, Clone, Copy)]
    pub struct RTCRayHit {
        pub ray: RTCRay,
        pub hit: RTCHit,
    }

    /// A hit record marked empty.
    pub fn empty_hit() -> RTCHit {
        RTCHit {
            Ng_x: 0.0,
            Ng_y: 0.0,
            Ng_z: 0.0,
            u: 0.0,
            v: 0.0,
            primID: RTC_INVALID_GEOMETRY_ID,
            geomID: RTC_INVALID_GEOMETRY_ID,
            instID: [RTC_INVALID_GEOMETRY_ID; RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
            instPrimID: [RTC_INVALID_GEOMETRY_ID; RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
        }
    }

    /// `rtcIntersect1` with the default arguments (incoherent rays).
    /// Safety: `scene` is committed; `rayhit` points to a live record.
    pub unsafe fn intersect1(scene: RTCScene, rayhit: *mut RTCRayHit) {
        // Our record starts with the same fields as the crate's and is longer.
        sys::rtcIntersect1(scene, rayhit.cast::<sys::RTCRayHit>(), std::ptr::null_mut())
    }

    /// `rtcOccluded1` with the default arguments.
    /// Safety: `scene` is committed; `ray` points to a live record.
    pub unsafe fn occluded1(scene: RTCScene, ray: *mut RTCRay) {
        sys::rtcOccluded1(scene, ray, std::ptr::null_mut())
    }

    /// Every record by `rtcIntersect1`. Safety: `scene` is committed.
    pub unsafe fn intersect_many(scene: RTCScene, records: &mut [RTCRayHit]) {
        for record in records {
            intersect1(scene, record)
        }
    }

    /// Every record by `rtcOccluded1`. Safety: `scene` is committed.
    pub unsafe fn occluded_many(scene: RTCScene, records: &mut [RTCRay]) {
        for record in records {
            occluded1(scene, record)
        }
    }
}
