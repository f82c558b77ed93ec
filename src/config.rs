//! What a render is asked to do, besides the scene: [`RenderConfig`].
//!
//! A scene file's `[image]`, `[render]` and `[photons]` tables fill one in
//! (see [`crate::scene::Scene::config`]); the command line and library
//! callers change fields and call [`RenderConfig::validate`], which checks
//! every limit in one place, so a library caller gets the same clear error
//! as a user of the command line instead of a panic.

use glam::Vec3;

use crate::accel::{Backend, BvhLayout};
use crate::error::{Error, Result};

/// Bounds on the numbers a scene file, the command line or a library caller may set.
pub mod limits {
    /// Largest image side we accept (a typo like 100000 would exhaust memory).
    pub const MAX_IMAGE_SIDE: u32 = 16384;
    /// Most samples per pixel (and light samples, gather rays) we accept.
    pub const MAX_SAMPLES: u32 = 1 << 16;
    /// Longest ray chain (and most photon bounces) we accept.
    pub const MAX_DEPTH: u32 = 64;
    /// Finest tessellation we accept (sphere: 20 * 4^9 = 5.2M triangles).
    pub const MAX_SPHERE_SUBDIVISIONS: u32 = 9;
    /// Finest teapot tessellation (32 * 2 * 1024^2 = 67M triangles).
    pub const MAX_TEAPOT_LEVEL: u32 = 1024;
    /// Most photons a map (or a pass) may be asked for.
    pub const MAX_PHOTONS: u32 = 100_000_000;
    /// Most passes progressive photon mapping may be asked for.
    pub const MAX_PASSES: u32 = 1_000_000;
    /// Longest time budget, in seconds (a month).
    pub const MAX_TIME: f32 = 2_592_000.0;
    /// Most photons one radiance estimate may use.
    pub const MAX_NEIGHBOURS: u32 = 100_000;
    /// Farthest a vertex may lie from the camera: triangle tests multiply
    /// three coordinates, which must stay inside `f32`'s range of 3.4e38.
    pub const MAX_DISTANCE: f32 = 1e12;
    /// The smallest extent a scene may have (its farthest vertex from the
    /// camera): below it, triangle tests run out of `f32` precision.
    pub const MIN_EXTENT: f32 = 1e-12;
}

/// Defines [`IntegratorKind`] from one list of variants and names, so a
/// new integrator is one line here (and one in [`crate::integrator::create`]).
macro_rules! integrator_kinds {
    ($($(#[$meta:meta])* $variant:ident = $name:literal,)*) => {
        /// Which integrator computes the pixels. Each has its own file under
        /// [`crate::integrator`]; [`crate::integrator::create`] makes one from its kind.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
        #[serde(rename_all = "lowercase")]
        pub enum IntegratorKind {
            $($(#[$meta])* $variant,)*
        }

        impl IntegratorKind {
            /// Every kind, in the order the command line lists them.
            pub const ALL: &'static [IntegratorKind] = &[$(IntegratorKind::$variant),*];

            /// The lower-case name used in scene files and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $(IntegratorKind::$variant => $name,)*
                }
            }
        }
    };
}

impl IntegratorKind {
    /// Whether it draws geometry into the image rather than light (the
    /// normals and depth previews): no light or albedo components.
    pub fn is_preview(self) -> bool {
        matches!(self, IntegratorKind::Normals | IntegratorKind::Depth)
    }
}

integrator_kinds! {
    /// Photon mapping: Whitted ray tracing plus caustics from the caustic
    /// map and indirect light from the global map (by final gathering, or
    /// shown directly when there are no gather rays). The default.
    #[default]
    Photon = "photon",
    /// Stochastic progressive photon mapping: passes of camera paths and
    /// photons with a shrinking radius, converging to the exact image.
    Sppm = "sppm",
    /// Vertex connection and merging: bidirectional path tracing and photon
    /// merging weighted against each other, with a shrinking radius.
    Vcm = "vcm",
    /// Bidirectional path tracing: every connection of a camera and a light
    /// subpath, weighted by multiple importance sampling. Unbiased.
    Bdpt = "bdpt",
    /// Light tracing: light subpaths connected to the camera (and the lights
    /// the camera sees directly). Unbiased, but blind to lights seen in
    /// mirrors or through glass.
    Light = "light",
    /// Whitted ray tracing: direct light, mirrors, refraction with Fresnel.
    Whitted = "whitted",
    /// The unbiased reference: path tracing with next-event estimation and
    /// multiple importance sampling for area lights.
    Path = "path",
    /// Geometry preview: smooth normals as colours, `0.5 * (n + 1)`, dimmed by
    /// the angle to the viewer so shapes read clearly.
    Normals = "normals",
    /// Geometry preview: distance to the first hit, near bright, far dark.
    Depth = "depth",
}

impl std::str::FromStr for IntegratorKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        IntegratorKind::ALL.iter().copied().find(|k| k.name() == s).ok_or_else(|| {
            let names: Vec<&str> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
            format!("unknown integrator `{s}`; choose from {}", names.join(", "))
        })
    }
}

/// How a radiance estimate gathers photons.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Photons used at most (the k nearest).
    pub k: usize,
    /// Largest search radius.
    pub max_radius: f32,
    /// Cone filter constant `k_c >= 1` (Jensen): photons are weighted by
    /// `1 - d / (k_c r)`, sharpening caustics. `None`: no filter.
    pub cone_filter: Option<f32>,
}

/// How progressive photon mapping runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SppmConfig {
    /// Passes (each one camera sample per pixel and one batch of photons).
    pub passes: u32,
    /// Photons emitted per pass.
    pub photons_per_pass: u32,
    /// Every pixel's gathering radius before the first pass; `None`: each
    /// pixel's own, from the density of a first batch of photons around its
    /// first visible point (SPPM; VCM's default is its own).
    pub initial_radius: Option<f32>,
    /// The fraction of new photons kept per pass, in (0, 1): smaller shrinks
    /// the radius faster (less bias, more noise). `None`: each integrator's
    /// own ([`SppmConfig::SPPM_ALPHA`], [`SppmConfig::VCM_ALPHA`]).
    pub alpha: Option<f32>,
}

impl SppmConfig {
    /// SPPM's alpha unless the scene says: 0.8, measured against 0.7
    /// (Hachisuka and Jensen's) and 0.75-0.9 on the Cornell boxes and the
    /// teapot from 57 to 3,000 passes once caustics seen directly stopped
    /// depending on the discs' shrinking (BENCHMARKS.md, issue 16).
    pub const SPPM_ALPHA: f32 = 0.8;
    /// VCM's alpha unless the scene says (its merging radius shrinks as
    /// `pass^((alpha - 1) / 2)`): 0.7; 0.8 was 10% worse on the point-lit
    /// Cornell box at 5 s.
    pub const VCM_ALPHA: f32 = 0.7;

    /// The alpha SPPM uses.
    pub fn sppm_alpha(&self) -> f32 {
        self.alpha.unwrap_or(Self::SPPM_ALPHA)
    }

    /// The alpha VCM's merging radius uses.
    pub fn vcm_alpha(&self) -> f32 {
        self.alpha.unwrap_or(Self::VCM_ALPHA)
    }
}

/// Photon counts and how the maps are read.
#[derive(Debug, Clone, PartialEq)]
pub struct PhotonConfig {
    /// Photons emitted for the global map.
    pub global_photons: u32,
    /// Photons emitted for the caustic map.
    pub caustic_photons: u32,
    /// Nearest photons per global estimate (at least 2: the farthest only
    /// marks the radius).
    pub global_k: u32,
    /// Nearest photons per caustic estimate (at least 2).
    pub caustic_k: u32,
    /// Largest global search radius; `None`: 1/25 of the scene's diagonal.
    pub global_radius: Option<f32>,
    /// Largest caustic search radius; `None`: 1/100 of the scene's diagonal.
    pub caustic_radius: Option<f32>,
    /// Cone filter constant for caustic estimates (at least 1); `None`: no filter.
    pub cone_filter: Option<f32>,
    /// Final-gathering rays per camera sample (so the gathering grows with
    /// the samples); 0 shows the global map directly. With a time budget
    /// of 1 s or more (and a count above 0) photon mapping chooses the
    /// count for itself by a pilot.
    pub gather_rays: u32,
    /// Whether gather rays favour the directions the global map's photons
    /// came from (Jensen 1995), rather than follow the cosine alone.
    pub guided_gathering: bool,
    /// Most bounces a photon makes (fewer where more would make paths
    /// longer than `max_depth` allows the camera's: [`crate::photon::map_bounces`]).
    pub max_bounces: u32,
    /// Progressive photon mapping (for [`IntegratorKind::Sppm`]).
    pub sppm: SppmConfig,
}

impl Default for PhotonConfig {
    fn default() -> Self {
        PhotonConfig {
            global_photons: 100_000,
            caustic_photons: 200_000,
            global_k: 100,
            caustic_k: 60,
            global_radius: None,
            caustic_radius: None,
            cone_filter: Some(1.1),
            gather_rays: 16,
            guided_gathering: true,
            max_bounces: 16,
            sppm: SppmConfig { passes: 64, photons_per_pass: 100_000, initial_radius: None, alpha: None },
        }
    }
}

impl PhotonConfig {
    /// The global map's estimate in a scene whose bounding box has this diagonal.
    pub fn global_estimate(&self, diagonal: f32) -> Estimate {
        Estimate {
            k: self.global_k as usize,
            max_radius: self.global_radius.unwrap_or(diagonal / 25.0),
            cone_filter: None,
        }
    }

    /// The caustic map's estimate in a scene whose bounding box has this diagonal.
    pub fn caustic_estimate(&self, diagonal: f32) -> Estimate {
        Estimate {
            k: self.caustic_k as usize,
            max_radius: self.caustic_radius.unwrap_or(diagonal / 100.0),
            cone_filter: self.cone_filter,
        }
    }
}

/// Everything that controls a render besides the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderConfig {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Camera samples per pixel (stratified, jittered).
    pub samples: u32,
    /// The integrator.
    pub integrator: IntegratorKind,
    /// The intersector.
    pub backend: Backend,
    /// Embree's BVH layout.
    pub bvh: BvhLayout,
    /// Longest chain of rays from the camera (1 = camera rays only).
    pub max_depth: u32,
    /// Shadow-ray samples per area light at each shading point; `None`
    /// leaves it to the integrator ([`RenderConfig::light_samples_or`]).
    pub light_samples: Option<u32>,
    /// Constant ambient radiance times the diffuse colour: the seed report's
    /// classic look, off (zero) by default.
    pub ambient: Vec3,
    /// Specular branches carrying less than this fraction of the camera
    /// ray's weight are not followed (Whitted and photon mapping).
    pub min_throughput: f32,
    /// Seed of every random stream (pixels and photons): another seed, an
    /// independent image.
    pub seed: u64,
    /// Photon counts and estimates.
    pub photons: PhotonConfig,
    /// Where camera samples get their random numbers, and photons theirs
    /// (photon mapping and SPPM: [`crate::photon::PhotonNumbers`]; VCM's
    /// light paths draw independent numbers either way).
    pub sampler: crate::sampling::SamplerKind,
    /// Refine until this many seconds have passed instead of taking a fixed
    /// number of samples (`None`): the path tracer, Whitted and photon
    /// mapping add camera samples (and with them gather rays) in rounds,
    /// SPPM adds passes. From 10 s on, photon mapping also traces more
    /// photons than the scene asks, in step with the budget (`t^(2/3)`), so
    /// its maps' bias keeps falling too. The image is written when the next
    /// round would not fit in the budget.
    pub time: Option<f32>,
    /// Render only this part of the image (`None`: all of it). Every pixel
    /// has its own random stream, so a region's pixels are bit-identical to
    /// the same pixels of the whole image; the film holds the region alone.
    pub region: Option<Region>,
    /// Denoise the final image with Open Image Denoise when writing it
    /// ([`crate::film::Film::denoised`]; the render itself is unchanged).
    /// Needs the cargo feature `denoise`.
    pub denoise: bool,
}

impl Default for RenderConfig {
    fn default() -> Self {
        RenderConfig {
            width: 640,
            height: 480,
            samples: 4,
            integrator: IntegratorKind::default(),
            backend: Backend::Embree,
            bvh: BvhLayout::default(),
            max_depth: 10,
            light_samples: None,
            ambient: Vec3::ZERO,
            min_throughput: 1e-4,
            seed: 0,
            photons: PhotonConfig::default(),
            sampler: Default::default(),
            time: None,
            region: None,
            denoise: false,
        }
    }
}

/// `value` in `min..=max`, or the error naming `name`.
fn in_range(name: &'static str, value: u32, min: u32, max: u32) -> Result<()> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(Error::Setting { name, message: format!("must be from {min} to {max}, found {value}") })
    }
}

/// `None`, or a finite distance greater than 0 whose square is finite too.
fn distance(name: &'static str, value: Option<f32>) -> Result<()> {
    match value {
        Some(r) if !(r.is_finite() && r > 0.0) => {
            Err(Error::Setting { name, message: format!("must be a distance greater than 0, found {r}") })
        }
        Some(r) if r > 1e18 => {
            Err(Error::Setting { name, message: format!("must be at most 1e18, found {r:e}") })
        }
        _ => Ok(()),
    }
}

/// A rectangle of pixels: columns `x0..x1`, rows `y0..y1` (row 0 at the top).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Region {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// The pixel count.
    pub fn pixels(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// The `(x, y)` of the `i`-th pixel, row-major.
    pub fn pixel(&self, i: usize) -> (u32, u32) {
        let w = self.width() as usize;
        (self.x0 + (i % w) as u32, self.y0 + (i / w) as u32)
    }

    /// Tile `index` (0-based) of `count` tiles of a `width` x `height` image:
    /// bands of whole rows, as equal as rows allow, top to bottom. Bands
    /// keep each tile's photon gathering and memory proportional to its share.
    pub fn tile(index: u32, count: u32, width: u32, height: u32) -> Region {
        let row = |i: u32| (i as u64 * height as u64 / count as u64) as u32;
        Region { x0: 0, y0: row(index), x1: width, y1: row(index + 1) }
    }
}

impl std::fmt::Display for Region {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

impl RenderConfig {
    /// The pixel count of what is rendered (the region, or the image).
    pub fn pixels(&self) -> u64 {
        self.region().pixels()
    }

    /// Shadow rays per area light at each shading point: the setting, or
    /// else the integrator's `default`.
    pub fn light_samples_or(&self, default: u32) -> u32 {
        self.light_samples.unwrap_or(default)
    }

    /// The pixels rendered: the region, or the whole image.
    pub fn region(&self) -> Region {
        self.region.unwrap_or(Region { x0: 0, y0: 0, x1: self.width, y1: self.height })
    }

    /// Checks every setting against its limits; the error names the setting
    /// (as [`Error::Setting`]) and says what is allowed.
    pub fn validate(&self) -> Result<()> {
        use limits::*;
        in_range("width", self.width, 1, MAX_IMAGE_SIDE)?;
        in_range("height", self.height, 1, MAX_IMAGE_SIDE)?;
        in_range("samples", self.samples, 1, MAX_SAMPLES)?;
        in_range("max_depth", self.max_depth, 1, MAX_DEPTH)?;
        if let Some(n) = self.light_samples {
            in_range("light_samples", n, 1, MAX_SAMPLES)?;
        }
        if !(self.ambient.is_finite() && self.ambient.min_element() >= 0.0) {
            return Err(Error::Setting {
                name: "ambient",
                message: format!("must be finite and not negative, found {}", self.ambient),
            });
        }
        if !(self.min_throughput.is_finite() && self.min_throughput >= 0.0) {
            return Err(Error::Setting {
                name: "min_throughput",
                message: format!("must be finite and not negative, found {}", self.min_throughput),
            });
        }
        let p = &self.photons;
        in_range("global_photons", p.global_photons, 0, MAX_PHOTONS)?;
        in_range("caustic_photons", p.caustic_photons, 0, MAX_PHOTONS)?;
        // The k-th photon only marks the estimate's radius: k = 1 would sum none.
        in_range("global_k", p.global_k, 2, MAX_NEIGHBOURS)?;
        in_range("caustic_k", p.caustic_k, 2, MAX_NEIGHBOURS)?;
        in_range("gather_rays", p.gather_rays, 0, MAX_SAMPLES)?;
        in_range("max_bounces", p.max_bounces, 1, MAX_DEPTH)?;
        in_range("passes", p.sppm.passes, 1, MAX_PASSES)?;
        in_range("pass_photons", p.sppm.photons_per_pass, 1, MAX_PHOTONS)?;
        distance("global_radius", p.global_radius)?;
        distance("caustic_radius", p.caustic_radius)?;
        distance("sppm_radius", p.sppm.initial_radius)?;
        if let Some(k) = p.cone_filter {
            if !(k.is_finite() && k >= 1.0) {
                return Err(Error::Setting {
                    name: "cone_filter",
                    message: format!("must be at least 1 (or none), found {k}"),
                });
            }
        }
        if let Some(alpha) = p.sppm.alpha.filter(|a| !(*a > 0.0 && *a < 1.0)) {
            return Err(Error::Setting {
                name: "sppm_alpha",
                message: format!("must lie between 0 and 1 (exclusive), found {alpha}"),
            });
        }
        if let Some(t) = self.time.filter(|t| !(t.is_finite() && *t > 0.0 && *t <= MAX_TIME)) {
            return Err(Error::Setting {
                name: "time",
                message: format!("must be a number of seconds above 0 and at most {MAX_TIME}, found {t}"),
            });
        }
        if let Some(r) = self.region {
            if !(r.x0 < r.x1 && r.y0 < r.y1 && r.x1 <= self.width && r.y1 <= self.height) {
                return Err(Error::Setting {
                    name: "region",
                    message: format!(
                        "{r} (x0,y0,x1,y1) must be a non-empty part of the {}x{} image",
                        self.width, self.height
                    ),
                });
            }
        }
        if self.denoise && !cfg!(feature = "denoise") {
            return Err(Error::Setting { name: "denoise", message: crate::film::denoise::NOT_BUILT.into() });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_valid_and_every_limit_is_checked() {
        assert!(RenderConfig::default().validate().is_ok());
        type Breaks = fn(&mut RenderConfig);
        let cases: [(&str, Breaks); 9] = [
            ("samples", |c| c.samples = 0),
            ("light_samples", |c| c.light_samples = Some(0)),
            ("width", |c| c.width = limits::MAX_IMAGE_SIDE + 1),
            ("max_depth", |c| c.max_depth = 0),
            ("global_k", |c| c.photons.global_k = 1),
            ("passes", |c| c.photons.sppm.passes = 0),
            ("sppm_radius", |c| c.photons.sppm.initial_radius = Some(f32::NAN)),
            ("sppm_alpha", |c| c.photons.sppm.alpha = Some(1.0)),
            ("ambient", |c| c.ambient = Vec3::splat(f32::INFINITY)),
        ];
        for (name, break_it) in cases {
            let mut config = RenderConfig::default();
            break_it(&mut config);
            match config.validate() {
                Err(Error::Setting { name: found, .. }) => assert_eq!(found, name),
                other => panic!("{name}: expected a setting error, got {other:?}"),
            }
        }
    }

    #[test]
    fn denoising_is_refused_only_by_a_build_without_the_feature() {
        let result = RenderConfig { denoise: true, ..RenderConfig::default() }.validate();
        if cfg!(feature = "denoise") {
            assert!(result.is_ok(), "{result:?}");
        } else {
            match result {
                Err(Error::Setting { name: "denoise", message }) => {
                    assert!(message.contains("--features denoise"), "{message}")
                }
                other => panic!("expected the denoise setting refused, got {other:?}"),
            }
        }
    }

    #[test]
    fn integrator_names_round_trip() {
        for &kind in IntegratorKind::ALL {
            assert_eq!(kind.name().parse::<IntegratorKind>(), Ok(kind));
            assert_eq!(
                kind.name(),
                format!("{kind:?}").to_lowercase(),
                "scene files use serde's lower-case names"
            );
        }
        let err = "whit".parse::<IntegratorKind>().unwrap_err();
        assert!(err.contains("choose from photon, sppm"), "{err}");
    }

    #[test]
    fn radii_default_to_fractions_of_the_scene() {
        let p = PhotonConfig::default();
        assert_eq!(p.global_estimate(50.0).max_radius, 2.0);
        assert_eq!(p.caustic_estimate(50.0).max_radius, 0.5);
        let given = PhotonConfig { global_radius: Some(0.3), ..p };
        assert_eq!(given.global_estimate(50.0).max_radius, 0.3);
    }
}
