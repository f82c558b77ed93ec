//! caustix: a photon-mapping renderer. Embree finds ray/triangle hits; Rust
//! does the rest.
//!
//! - [`scene`]: the scene file, meshes, built-in shapes, the teapot, OBJ.
//! - [`accel`]: the [`accel::Intersector`] trait and the Embree backend (the
//!   only `unsafe` code, in `accel::embree`).
//! - [`material`], [`light`], [`optics`]: what surfaces and lights are, and
//!   the Fresnel/Snell formulas.
//! - [`photon`]: photon tracing, the global and caustic maps (kiddo kd-trees),
//!   radiance estimates.
//! - [`render`]: camera, images, integrators.

#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod accel;
pub mod bench;
pub mod bounds;
pub mod error;
pub mod light;
pub mod material;
pub mod optics;
pub mod photon;
pub mod render;
pub mod sampling;
pub mod scene;

pub use error::{Error, Result};
