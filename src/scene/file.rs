//! The scene file: TOML, read with serde. Unknown keys are errors (a typo
//! never silently falls back to a default), and every number is checked as
//! it is read; see `values.rs`. The README documents the format with a full
//! example.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use super::values::{whole_number, Finite, Point, Position, Positive, Power, Reflectance, Scale, Size};

use crate::config::limits::*;
use crate::config::PhotonConfig;

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub camera: CameraSection,
    #[serde(default)]
    pub image: ImageSection,
    #[serde(default)]
    pub render: RenderSection,
    #[serde(default)]
    pub photons: PhotonSection,
    #[serde(default)]
    pub materials: BTreeMap<String, Spanned<MaterialSection>>,
    #[serde(default)]
    pub point_light: Vec<PointLightSection>,
    #[serde(default)]
    pub area_light: Vec<AreaLightSection>,
    #[serde(default)]
    pub spot_light: Vec<SpotLightSection>,
    #[serde(default)]
    pub sphere: Vec<SphereSection>,
    #[serde(default)]
    pub quad: Vec<QuadSection>,
    #[serde(default, rename = "box")]
    pub cuboid: Vec<BoxSection>,
    #[serde(default)]
    pub ring: Vec<RingSection>,
    #[serde(default)]
    pub teapot: Vec<TeapotSection>,
    #[serde(default)]
    pub mesh: Vec<MeshSection>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    pub eye: Position,
    pub look_at: Position,
    #[serde(default = "default_up")]
    pub up: Point,
    /// Full vertical field of view in degrees.
    #[serde(default = "default_fov")]
    pub fov: Finite,
}

fn default_up() -> Point {
    Point(glam::Vec3::Y)
}

fn default_fov() -> Finite {
    Finite(40.0)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageSection {
    #[serde(deserialize_with = "image_side")]
    pub width: u32,
    #[serde(deserialize_with = "image_side")]
    pub height: u32,
    #[serde(default = "default_samples", deserialize_with = "samples")]
    pub samples: u32,
}

impl Default for ImageSection {
    fn default() -> Self {
        let config = crate::config::RenderConfig::default();
        ImageSection { width: config.width, height: config.height, samples: config.samples }
    }
}

fn default_samples() -> u32 {
    crate::config::RenderConfig::default().samples
}

fn image_side<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 1, MAX_IMAGE_SIDE)
}

fn samples<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 1, MAX_SAMPLES)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSection {
    #[serde(default = "default_integrator")]
    pub integrator: crate::config::IntegratorKind,
    #[serde(default = "default_backend")]
    pub backend: crate::accel::Backend,
    #[serde(default)]
    pub bvh: crate::accel::BvhLayout,
    #[serde(default = "default_max_depth", deserialize_with = "max_depth")]
    pub max_depth: u32,
    #[serde(default, deserialize_with = "light_samples")]
    pub light_samples: Option<u32>,
    #[serde(default)]
    pub ambient: Option<Power>,
    #[serde(default)]
    pub denoise: bool,
    #[serde(default)]
    pub sampler: crate::sampling::SamplerKind,
    #[serde(default)]
    pub time: Option<f32>,
}

impl Default for RenderSection {
    fn default() -> Self {
        RenderSection {
            integrator: default_integrator(),
            backend: default_backend(),
            bvh: Default::default(),
            max_depth: default_max_depth(),
            light_samples: None,
            ambient: None,
            denoise: false,
            sampler: Default::default(),
            time: None,
        }
    }
}

fn default_integrator() -> crate::config::IntegratorKind {
    crate::config::IntegratorKind::default()
}

fn default_backend() -> crate::accel::Backend {
    crate::accel::Backend::Embree
}

fn default_max_depth() -> u32 {
    crate::config::RenderConfig::default().max_depth
}

fn max_depth<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 1, MAX_DEPTH)
}

fn light_samples<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
    whole_number(d, 1, MAX_SAMPLES).map(Some)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhotonSection {
    /// Photons emitted for the global map.
    #[serde(default = "default_global_photons", deserialize_with = "photon_count")]
    pub global: u32,
    /// Photons emitted for the caustic map.
    #[serde(default = "default_caustic_photons", deserialize_with = "photon_count")]
    pub caustic: u32,
    /// Nearest photons per global estimate.
    #[serde(default = "default_global_k", deserialize_with = "neighbours")]
    pub global_k: u32,
    /// Nearest photons per caustic estimate.
    #[serde(default = "default_caustic_k", deserialize_with = "neighbours")]
    pub caustic_k: u32,
    /// Largest global search radius (default: 1/25 of the scene's diagonal).
    #[serde(default)]
    pub global_radius: Option<Positive>,
    /// Largest caustic search radius (default: 1/100 of the scene's diagonal).
    #[serde(default)]
    pub caustic_radius: Option<Positive>,
    /// Cone filter constant for caustics (>= 1; 0 turns the filter off).
    #[serde(default = "default_cone_filter")]
    pub cone_filter: Spanned<Finite>,
    /// Final-gathering rays per shading point; 0 shows the global map directly.
    #[serde(default = "default_gather_rays", deserialize_with = "gather_rays")]
    pub gather_rays: u32,
    /// Whether gather rays favour the directions photons came from.
    #[serde(default = "default_guided_gathering")]
    pub guided_gathering: bool,
    /// Most bounces per photon.
    #[serde(default = "default_photon_bounces", deserialize_with = "max_depth")]
    pub max_bounces: u32,
    /// Progressive photon mapping: passes.
    #[serde(default = "default_passes", deserialize_with = "passes")]
    pub passes: u32,
    /// Progressive photon mapping: photons emitted per pass.
    #[serde(default = "default_pass_photons", deserialize_with = "pass_photons")]
    pub pass_photons: u32,
    /// Progressive photon mapping: starting radius (default: each pixel's
    /// own, from the density of a first batch of photons).
    #[serde(default)]
    pub sppm_radius: Option<Positive>,
    /// Progressive photon mapping and VCM's merging: fraction of new photons
    /// kept per pass, in (0, 1) (default: each integrator's own).
    #[serde(default)]
    pub sppm_alpha: Option<Spanned<Finite>>,
}

impl Default for PhotonSection {
    fn default() -> Self {
        PhotonSection {
            global: default_global_photons(),
            caustic: default_caustic_photons(),
            global_k: default_global_k(),
            caustic_k: default_caustic_k(),
            global_radius: None,
            caustic_radius: None,
            cone_filter: default_cone_filter(),
            gather_rays: default_gather_rays(),
            guided_gathering: default_guided_gathering(),
            max_bounces: default_photon_bounces(),
            passes: default_passes(),
            pass_photons: default_pass_photons(),
            sppm_radius: None,
            sppm_alpha: None,
        }
    }
}

fn default_global_photons() -> u32 {
    PhotonConfig::default().global_photons
}

fn default_caustic_photons() -> u32 {
    PhotonConfig::default().caustic_photons
}

fn default_global_k() -> u32 {
    PhotonConfig::default().global_k
}

fn default_caustic_k() -> u32 {
    PhotonConfig::default().caustic_k
}

fn default_cone_filter() -> Spanned<Finite> {
    Spanned::new(0..0, Finite(PhotonConfig::default().cone_filter.unwrap_or(0.0)))
}

fn default_guided_gathering() -> bool {
    PhotonConfig::default().guided_gathering
}

fn default_gather_rays() -> u32 {
    PhotonConfig::default().gather_rays
}

fn default_photon_bounces() -> u32 {
    PhotonConfig::default().max_bounces
}

fn default_passes() -> u32 {
    PhotonConfig::default().sppm.passes
}

fn default_pass_photons() -> u32 {
    PhotonConfig::default().sppm.photons_per_pass
}

fn passes<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 1, MAX_PASSES)
}

fn pass_photons<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 1, MAX_PHOTONS)
}

fn photon_count<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 0, MAX_PHOTONS)
}

fn neighbours<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 2, MAX_NEIGHBOURS)
}

fn gather_rays<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 0, MAX_SAMPLES)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSection {
    #[serde(default)]
    pub diffuse: Option<Reflectance>,
    #[serde(default)]
    pub specular: Option<Reflectance>,
    #[serde(default)]
    pub phong_exponent: Option<Positive>,
    #[serde(default)]
    pub mirror: Option<Reflectance>,
    #[serde(default)]
    pub transmittance: Option<Reflectance>,
    #[serde(default)]
    pub ior: Option<Positive>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightSection {
    pub position: Position,
    pub power: Power,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AreaLightSection {
    pub center: Position,
    /// Full edge vectors; light leaves from the side `u x v` faces.
    pub u: Spanned<Point>,
    pub v: Point,
    pub power: Power,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightSection {
    pub position: Position,
    pub direction: Spanned<Point>,
    /// Half-angle of the cone, degrees.
    pub cone_angle: Spanned<Positive>,
    /// Half-angle where the fall-off starts, degrees (default: 80% of the cone).
    #[serde(default)]
    pub falloff_start: Option<Spanned<Finite>>,
    pub power: Power,
}

/// Placement of an object: scale, then rotate, then translate.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformSection {
    #[serde(default)]
    pub scale: Option<Scale>,
    /// Degrees about x, then y, then z.
    #[serde(default)]
    pub rotate: Option<Point>,
    #[serde(default)]
    pub translate: Option<Position>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSection {
    pub center: Position,
    pub radius: Positive,
    #[serde(default = "default_subdivisions", deserialize_with = "sphere_level")]
    pub subdivisions: u32,
    pub material: Spanned<String>,
    #[serde(default)]
    pub transform: TransformSection,
}

fn default_subdivisions() -> u32 {
    4
}

fn sphere_level<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 0, MAX_SPHERE_SUBDIVISIONS)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadSection {
    pub center: Position,
    /// Full edge vectors; the front faces `u x v`.
    pub u: Spanned<Point>,
    pub v: Point,
    pub material: Spanned<String>,
    #[serde(default)]
    pub transform: TransformSection,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSection {
    pub center: Position,
    pub size: Size,
    pub material: Spanned<String>,
    #[serde(default)]
    pub transform: TransformSection,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RingSection {
    /// Centre of the ring's bottom face.
    pub base: Position,
    pub inner_radius: Positive,
    pub outer_radius: Spanned<Positive>,
    pub height: Positive,
    #[serde(default = "default_ring_segments", deserialize_with = "ring_segments")]
    pub segments: u32,
    pub material: Spanned<String>,
    #[serde(default)]
    pub transform: TransformSection,
}

fn default_ring_segments() -> u32 {
    128
}

fn ring_segments<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 3, 1 << 20)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeapotSection {
    /// Quads per patch edge.
    #[serde(default = "default_teapot_level", deserialize_with = "teapot_level")]
    pub subdivisions: u32,
    /// A `.bpt` file to use instead of the built-in teapot.
    #[serde(default)]
    pub file: Option<String>,
    pub material: Spanned<String>,
    #[serde(default)]
    pub transform: TransformSection,
}

fn default_teapot_level() -> u32 {
    8
}

fn teapot_level<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    whole_number(d, 1, MAX_TEAPOT_LEVEL)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSection {
    /// OBJ file, relative to the scene file.
    pub file: Spanned<String>,
    /// Overrides the file's MTL materials for every face.
    #[serde(default)]
    pub material: Option<Spanned<String>>,
    /// The material of faces the file gives none (and so of every face of
    /// a PLY or STL file).
    #[serde(default)]
    pub default_material: Option<Spanned<String>>,
    #[serde(default)]
    pub transform: TransformSection,
}
