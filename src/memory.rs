//! Memory: what the machine can give, and what a render will take, checked
//! before anything big is allocated, so that an absurd request is refused
//! with figures instead of ending in an out-of-memory abort.

use crate::config::{IntegratorKind, RenderConfig};
use crate::error::{Error, Result};
use crate::scene::Scene;

/// Memory the kernel could give this process now (Linux's `MemAvailable`).
pub fn available() -> Option<usize> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Bytes per pixel while rendering: the per-tile samples and the film they
/// are copied into (two `Sample`s), then the image and its encoding (24 B);
/// and the first look for the lights' edges (`integrator/emission.rs`: the
/// least and most it saw and its rays, 24 B).
const FILM_BYTES_PER_PIXEL: u64 = 2 * std::mem::size_of::<crate::film::Sample>() as u64 + 24 + 24;

/// Extra bytes per pixel for progressive photon mapping: each pixel's state,
/// its visible point and its places in the hash grid.
const SPPM_BYTES_PER_PIXEL: u64 = 256;

/// Bytes per stored photon: the record, twice while the traced chunks are
/// joined (and again while the map sorts them along its Morton curve, with
/// 16 B of sort keys, before the tree and the records exist), and the
/// kd-tree (BENCHMARKS.md: 48 B and about 17 B), with the
/// precomputed irradiance of at most every fourth photon (every twelfth at
/// the default `global_k`).
const PHOTON_BYTES: u64 =
    2 * std::mem::size_of::<crate::photon::Photon>() as u64 + 17 + IRRADIANCE_RECORD_BYTES.div_ceil(4);

/// Bytes per precomputed irradiance record: about 45 B in its nearest-point
/// tree, its gather guide, and about 60 B in the grid cells that list it
/// (`photon/cells.rs`: 52 B of candidates and the table, measured on the
/// teapot, with a margin).
const IRRADIANCE_RECORD_BYTES: u64 =
    45 + 64 + std::mem::size_of::<Option<crate::photon::guide::GatherGuide>>() as u64;

/// Bytes per caustic photon in the caustic map's grid (`photon/grid.rs`):
/// its position and index, and while it is built 16 B of cell keys; the
/// table's share; and the finer grids where photons are dense, of at most
/// `FINER_PHOTONS` times the photons, each 16 B and the table's share.
const CAUSTIC_GRID_BYTES: u64 = 16 + 16 + 8 + crate::photon::grid::FINER_PHOTONS as u64 * 20;

/// Bytes per photon an SPPM pass gathers (`integrator/sppm`): the photon
/// (its traced chunk is freed as it is copied into the pass's array), its
/// 8-byte key along the Morton curve, its position in the runs and its
/// index (`photon/ranges.rs`).
const PASS_PHOTON_BYTES: u64 = std::mem::size_of::<crate::photon::Photon>() as u64 + 8 + 12 + 4;

/// Bytes per photon of SPPM's density batch (for the starting radii): its
/// position, twice while the chunks are joined, and its place in the tree.
const DENSITY_POINT_BYTES: u64 = 2 * 12 + 8;

/// Bytes per triangle of a mesh being built: positions, normals and indices
/// (24 B, `caustix info`), with room for the tessellation's own arrays.
pub const MESH_BYTES_PER_TRIANGLE: u64 = 72;

/// What a render of `scene` with `config` will take, in parts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Estimate {
    /// The film and its images.
    pub film: u64,
    /// The photon maps (or one progressive pass's photons and grid, or
    /// one VCM pass's light vertices).
    pub photons: u64,
    /// The setting that sizes `photons`, and what they are, for the error.
    photons_setting: (&'static str, &'static str),
}

impl Estimate {
    /// The estimate for rendering `scene` with `config`.
    pub fn of(scene: &Scene, config: &RenderConfig) -> Estimate {
        let pixels = config.pixels();
        let p = &config.photons;
        let mut photons_setting = ("global_photons", "the photons");
        let (film, photons) = match config.integrator {
            IntegratorKind::Photon => {
                let stored = p.global_photons as f64 * stores_per_photon(scene, p.max_bounces)
                    + p.caustic_photons as f64;
                let grid = p.caustic_photons as u64 * CAUSTIC_GRID_BYTES;
                (pixels * FILM_BYTES_PER_PIXEL, (stored * PHOTON_BYTES as f64) as u64 + grid)
            }
            // One pass's photons where they land, not a map; and, without
            // a starting radius, where a pass's photons landed, kept for the
            // pixels' own.
            IntegratorKind::Sppm => {
                photons_setting = ("pass_photons", "the photons of a pass");
                let stored = p.sppm.photons_per_pass as f64 * stores_per_photon(scene, p.max_bounces);
                // A pass gathers none of the photons that come straight from a light.
                let gathered = (stored - p.sppm.photons_per_pass as f64).max(0.0);
                let density = match p.sppm.initial_radius {
                    None => stored,
                    Some(_) => 0.0,
                };
                (
                    pixels * (FILM_BYTES_PER_PIXEL + SPPM_BYTES_PER_PIXEL),
                    (gathered * PASS_PHOTON_BYTES as f64 + density * DENSITY_POINT_BYTES as f64) as u64,
                )
            }
            // One pass's light vertices (one light subpath per pixel of
            // the whole image), and the film's sums.
            IntegratorKind::Vcm | IntegratorKind::Bdpt => {
                photons_setting = ("width", "the light vertices of a pass (a light subpath per pixel)");
                let light_paths = config.width as u64 * config.height as u64;
                let vertices = light_paths * crate::integrator::vcm::VERTICES_PER_LIGHT_PATH;
                (pixels * 2 * FILM_BYTES_PER_PIXEL, vertices * crate::integrator::vcm::LIGHT_VERTEX_BYTES)
            }
            _ => (pixels * FILM_BYTES_PER_PIXEL, 0),
        };
        Estimate { film, photons, photons_setting }
    }

    /// Refuses the render if it would not fit in `available` bytes (when known).
    pub fn check(&self, available: Option<usize>) -> Result<()> {
        let Some(available) = available.map(|a| a as u64) else { return Ok(()) };
        let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
        if self.film + self.photons <= available {
            return Ok(());
        }
        let (name, what) = if self.film >= self.photons {
            ("width", format!("the image needs about {:.1} GiB for its film", gib(self.film)))
        } else {
            let (name, what) = self.photons_setting;
            (name, format!("{what} need about {:.1} GiB", gib(self.photons)))
        };
        Err(Error::Setting {
            name,
            message: format!(
                "is too large: {what} ({:.1} GiB in all), and {:.1} GiB of memory are available; \
                 ask for less, or free memory",
                gib(self.film + self.photons),
                gib(available)
            ),
        })
    }
}

/// About how many times a global photon is stored: once per diffuse or
/// glossy surface it reaches, and it goes on from each with probability
/// about the scene's area-weighted albedo `a`, so `1 / (1 - a)` times, at
/// most `max_bounces`.
fn stores_per_photon(scene: &Scene, max_bounces: u32) -> f64 {
    let (mut weighted, mut area) = (0.0f64, 0.0f64);
    for mesh in &scene.meshes {
        let albedo = scene.materials[mesh.material].total_reflectance().max_element().min(1.0) as f64;
        let a = mesh.area();
        weighted += albedo * a;
        area += a;
    }
    let albedo = if area > 0.0 { weighted / area } else { 0.0 };
    (1.0 / (1.0 - albedo).max(1e-3)).min(max_bounces.max(1) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        Scene::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml")).unwrap()
    }

    #[test]
    fn absurd_requests_are_refused_with_figures() {
        let scene = scene();
        let huge_image = RenderConfig { width: 16384, height: 16384, ..scene.config.clone() };
        let err = Estimate::of(&scene, &huge_image).check(Some(24 << 30)).unwrap_err().to_string();
        assert!(
            err.starts_with("width is too large: the image needs about") && err.contains("24.0 GiB"),
            "{err}"
        );
        let mut photons = scene.config.clone();
        photons.photons.global_photons = 100_000_000;
        let err = Estimate::of(&scene, &photons).check(Some(8 << 30)).unwrap_err().to_string();
        assert!(err.starts_with("global_photons is too large: the photons need about"), "{err}");
        // What the scene files ask for fits easily.
        Estimate::of(&scene, &scene.config).check(Some(1 << 30)).unwrap();
        let vcm = RenderConfig {
            integrator: IntegratorKind::Vcm,
            width: 8000,
            height: 8000,
            ..scene.config.clone()
        };
        let err = Estimate::of(&scene, &vcm).check(Some(8 << 30)).unwrap_err().to_string();
        assert!(err.starts_with("width is too large: the light vertices of a pass"), "{err}");
    }

    #[test]
    fn stores_follow_the_albedo() {
        // The Cornell box's walls reflect about 60%: a photon is stored about
        // 2.5 times (measured: 1.67, some leave through the open front).
        let stores = stores_per_photon(&scene(), 16);
        assert!((1.5..3.5).contains(&stores), "{stores}");
    }
}
