//! caustix: a photon-mapping renderer. Embree finds ray/triangle hits; Rust
//! does the rest. ARCHITECTURE.md draws the layers; in order, each using
//! only those before it:
//!
//! - [`accel`]: rays, hits and the [`accel::Intersector`] trait; Embree (the
//!   only `unsafe` code, in `accel::embree`) and the native BVH.
//! - [`config`]: [`RenderConfig`], every setting and its limits.
//! - [`material`], [`light`], [`optics`], [`sampling`]: what surfaces and
//!   lights are, the Fresnel/Snell formulas, random numbers;
//!   [`light_tree`]: which area lights a ray crosses, among many;
//!   [`light_choice_tree`]: which to draw at a point, among very many.
//! - [`scene`]: the scene file, camera, meshes, built-in shapes, the teapot, OBJ, PLY.
//! - [`query`]: the first interaction along a ray (surface or light) and ray spawning.
//! - [`bsdf`]: a material at a surface point: evaluate, sample, pdf; Russian roulette.
//! - [`photon`]: photon tracing, the global and caustic maps (kiddo kd-trees),
//!   radiance estimates.
//! - [`integrator`]: the [`integrator::Integrator`] trait, one file per integrator.
//! - [`film`]: pixels, components (AOVs) and image files.
//!
//! Rendering a scene file takes a few calls (see `examples/render.rs`):
//!
//! ```no_run
//! let scene = caustix::Scene::load(std::path::Path::new("scenes/cornell.toml"))?;
//! let accel = caustix::accel::build(scene.config.backend, &scene.triangle_views())?;
//! let rendered = caustix::render(&scene, accel.as_ref(), &scene.config, &|_| {})?;
//! rendered.film.beauty().save(std::path::Path::new("cornell.exr"), 0.0)?;
//! # Ok::<(), caustix::Error>(())
//! ```

#![warn(missing_docs)]
#![deny(unsafe_code)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod accel;
#[cfg(feature = "bench")]
pub mod bench;
pub mod bounds;
pub mod bsdf;
pub mod config;
pub mod error;
pub mod files;
pub mod film;
pub mod hash;
pub mod integrator;
pub mod light;
pub mod light_choice_tree;
pub mod light_tree;
pub mod material;
pub mod memory;
pub mod numeric;
pub mod optics;
pub mod photon;
pub mod query;
pub mod sampling;
pub mod scene;

pub use config::RenderConfig;
pub use error::{Error, Result};
pub use film::{Film, Image};
pub use integrator::{render, Rendered};
pub use scene::Scene;
