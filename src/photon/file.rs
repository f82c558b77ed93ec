//! Photon maps saved to a file (`.cxpm`) and loaded instead of traced: on a
//! cluster one job traces them and every tile's job reads them.
//!
//! The format, all little-endian:
//!
//! ```text
//! "CXPM" u32 version
//! u64 scene fingerprint (Scene::fingerprint)
//! the settings the maps depend on: u64 seed, u8 sampler (0 Sobol, 1
//!   independent), u32 global photons, u32 caustic photons, u32 max bounces,
//!   u32 max depth, u8 for gathering, u32 global k, f32 global radius
//! stats: u64 global emitted, u64 caustic emitted, u64 notes, each u32
//!   length + UTF-8 (no times: the same maps are the same bytes, run after run)
//! global map, caustic map: u8 present; u64 photons, each 15 f32 (position,
//!   incoming, power, normal, face normal), u8 indirect and u8 from a point
//!   or spot light; u8 precomputed; u64 records,
//!   each 10 f32 (position, normal, irradiance, squared radius), u8 guided
//!   and, if guided, the gather guide's cell probabilities (guide::CELLS f32)
//! u64 checksum of everything before it (hash::checksum)
//! ```
//!
//! The kd-trees are rebuilt on load (serially, so they are the trees the
//! tracing run built). A map made for another scene or other settings, a
//! truncated or corrupted file: each is an error naming what differs.

use std::path::Path;

use glam::Vec3;

use super::guide::{GatherGuide, CELLS};
use super::map::{IrradianceRecord, Photon, PhotonMap};
use super::{PhotonMaps, PhotonStats};
use crate::config::RenderConfig;
use crate::error::{Error, Result};
use crate::query::RayCount;
use crate::sampling::SamplerKind;
use crate::scene::Scene;

const MAGIC: &[u8; 4] = b"CXPM";
const VERSION: u32 = 7;

/// What a scene's photon maps depend on besides the scene: two maps are
/// interchangeable when these and the scene's fingerprint agree.
#[derive(Debug, Clone, Copy, PartialEq)]
struct MapSettings {
    seed: u64,
    /// The photons' numbers: Sobol or independent (`PhotonNumbers`).
    sampler: SamplerKind,
    global_photons: u32,
    caustic_photons: u32,
    max_bounces: u32,
    /// The render's longest camera path, which limits the photons' paths
    /// ([`super::map_bounces`]).
    max_depth: u32,
    for_gathering: bool,
    global_k: u32,
    global_radius: f32,
}

impl MapSettings {
    fn of(config: &RenderConfig, diagonal: f32) -> MapSettings {
        let p = &config.photons;
        MapSettings {
            seed: config.seed,
            sampler: config.sampler,
            global_photons: p.global_photons,
            caustic_photons: p.caustic_photons,
            max_bounces: p.max_bounces,
            max_depth: config.max_depth,
            for_gathering: p.gather_rays > 0,
            global_k: p.global_k,
            global_radius: p.global_estimate(diagonal).max_radius,
        }
    }

    /// Each setting's name (as the command line spells it), value in the
    /// file and value asked for, where they differ.
    fn differences(&self, asked: &MapSettings) -> Vec<String> {
        let mut out = Vec::new();
        let mut differ = |name: &str, file: String, now: String| {
            if file != now {
                out.push(format!("{name} {file} in the file, {now} now"));
            }
        };
        differ("--seed", self.seed.to_string(), asked.seed.to_string());
        differ("--sampler", self.sampler.name().into(), asked.sampler.name().into());
        differ("--photons", self.global_photons.to_string(), asked.global_photons.to_string());
        differ("--caustic-photons", self.caustic_photons.to_string(), asked.caustic_photons.to_string());
        differ("max_bounces", self.max_bounces.to_string(), asked.max_bounces.to_string());
        differ("max_depth", self.max_depth.to_string(), asked.max_depth.to_string());
        let gathering = |g: bool| if g { "some" } else { "none" }.to_string();
        differ("--gather-rays", gathering(self.for_gathering), gathering(asked.for_gathering));
        differ("--global-k", self.global_k.to_string(), asked.global_k.to_string());
        differ("--global-radius", self.global_radius.to_string(), asked.global_radius.to_string());
        out
    }
}

/// Writes `maps`, traced for `scene` with `config`, to `path` (whole or not
/// at all: see [`crate::files::write_whole`]).
pub fn save(
    path: &Path,
    maps: &PhotonMaps,
    scene: &Scene,
    config: &RenderConfig,
    diagonal: f32,
) -> Result<()> {
    let mut w = Writer(Vec::new());
    w.0.extend_from_slice(MAGIC);
    w.u32(VERSION);
    w.u64(scene.fingerprint());
    let s = MapSettings::of(config, diagonal);
    w.u64(s.seed);
    w.0.push(match s.sampler {
        SamplerKind::Sobol => 0,
        SamplerKind::Independent => 1,
    });
    w.u32(s.global_photons);
    w.u32(s.caustic_photons);
    w.u32(s.max_bounces);
    w.u32(s.max_depth);
    w.0.push(s.for_gathering as u8);
    w.u32(s.global_k);
    w.f32(s.global_radius);
    w.maps(maps);
    let sum = crate::hash::checksum(&w.0);
    w.u64(sum);
    crate::files::write_whole(path, &w.0)
}

/// Reads the maps at `path`, checking that they were made for `scene` and
/// the photon settings of `config`.
pub fn load(path: &Path, scene: &Scene, config: &RenderConfig, diagonal: f32) -> Result<PhotonMaps> {
    crate::files::check_regular(path)?;
    let size = std::fs::metadata(path).map_err(|e| Error::io(path, e))?.len();
    if let Some(available) = crate::memory::available().filter(|&a| size > a as u64) {
        return Err(Error::input(
            path,
            format!("{} MiB, more than the {} MiB of memory available", size >> 20, available >> 20),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let bad = |message: String| Error::input(path, message);
    if bytes.len() < 8 || &bytes[..4] != MAGIC {
        return Err(bad("not a caustix photon map (it does not start with CXPM)".into()));
    }
    let version = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
    if version != VERSION {
        return Err(bad(format!(
            "a photon map of format version {version}; this caustix reads version {VERSION}: trace the maps again \
             with `caustix photons`"
        )));
    }
    if bytes.len() < 16 {
        return Err(bad("truncated: the file ends inside its header".into()));
    }
    let (body, tail) = bytes.split_at(bytes.len() - 8);
    if crate::hash::checksum(body) != u64::from_le_bytes(tail.try_into().expect("8 bytes")) {
        return Err(bad(
            "its checksum does not match: the file is truncated or corrupted; trace the maps again with \
             `caustix photons`"
                .into(),
        ));
    }
    let mut r = Reader { bytes: body, at: 8 };
    let failed = |f: Failure| bad(f.unwrap_or_else(|| "truncated or corrupted: it ends early".into()));
    if r.u64().map_err(failed)? != scene.fingerprint() {
        return Err(bad(format!(
            "made for another scene (or another version of {}): its geometry, materials, lights or camera \
             position differ; trace the maps for this scene with `caustix photons`",
            scene.path.display()
        )));
    }
    let differences = r.settings().map_err(failed)?.differences(&MapSettings::of(config, diagonal));
    if !differences.is_empty() {
        return Err(bad(format!(
            "made with other photon settings ({}); trace them again with the same settings as the render",
            differences.join(", ")
        )));
    }
    let mut maps = r.maps().map_err(failed)?;
    maps.caustic = maps.caustic.map(|map| super::with_caustic_cells(map, &config.photons, diagonal));
    Ok(maps)
}

/// Little-endian output.
struct Writer(Vec<u8>);

impl Writer {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn vec3(&mut self, v: Vec3) {
        for c in v.to_array() {
            self.f32(c);
        }
    }
    /// The maps' counts, then the maps (read by [`Reader::maps`]). Not how
    /// long they took: a job run again writes the same file.
    fn maps(&mut self, maps: &PhotonMaps) {
        let st = &maps.stats;
        self.u64(st.global_emitted);
        self.u64(st.caustic_emitted);
        self.u64(st.skipped.len() as u64);
        for note in &st.skipped {
            self.u32(note.len() as u32);
            self.0.extend_from_slice(note.as_bytes());
        }
        for map in [&maps.global, &maps.caustic] {
            self.map(map.as_ref());
        }
    }

    fn map(&mut self, map: Option<&PhotonMap>) {
        let Some(map) = map else { return self.0.push(0) };
        self.0.push(1);
        self.u64(map.photons().len() as u64);
        for p in map.photons() {
            for v in [p.position, p.incoming, p.power, p.normal, p.face_normal] {
                self.vec3(v);
            }
            self.0.push(u8::from(p.indirect));
            self.0.push(u8::from(p.from_delta_light));
        }
        match map.precomputed_records() {
            None => self.0.push(0),
            Some(records) => {
                self.0.push(1);
                self.u64(records.len() as u64);
                for record in records {
                    for v in [record.position, record.normal, record.irradiance] {
                        self.vec3(v);
                    }
                    self.f32(record.radius2);
                    match &record.guide {
                        None => self.0.push(0),
                        Some(guide) => {
                            self.0.push(1);
                            for &p in guide.cells() {
                                self.f32(p);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Reading failed: `None` where the bytes ran out, else what is wrong.
type Failure = Option<String>;

/// Little-endian input.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> std::result::Result<[u8; N], Failure> {
        let end = self.at.checked_add(N).ok_or(None)?;
        let bytes = self.bytes.get(self.at..end).ok_or(None)?;
        self.at = end;
        Ok(bytes.try_into().expect("N bytes"))
    }
    fn u8(&mut self) -> std::result::Result<u8, Failure> {
        Ok(self.take::<1>()?[0])
    }
    fn u32(&mut self) -> std::result::Result<u32, Failure> {
        self.take().map(u32::from_le_bytes)
    }
    fn u64(&mut self) -> std::result::Result<u64, Failure> {
        self.take().map(u64::from_le_bytes)
    }
    fn f32(&mut self) -> std::result::Result<f32, Failure> {
        self.take().map(f32::from_le_bytes)
    }
    fn vec3(&mut self) -> std::result::Result<Vec3, Failure> {
        Ok(Vec3::new(self.f32()?, self.f32()?, self.f32()?))
    }

    /// A count of records of `size` bytes each, checked against what is left.
    fn count(&mut self, size: usize) -> std::result::Result<usize, Failure> {
        let n = self.u64()?;
        let left = (self.bytes.len() - self.at) / size;
        if n > left as u64 {
            return Err(Some(format!("it claims {n} records where {left} fit: corrupted")));
        }
        Ok(n as usize)
    }

    fn settings(&mut self) -> std::result::Result<MapSettings, Failure> {
        Ok(MapSettings {
            seed: self.u64()?,
            sampler: match self.u8()? {
                0 => SamplerKind::Sobol,
                1 => SamplerKind::Independent,
                n => return Err(Some(format!("sampler {n} is none known: corrupted"))),
            },
            global_photons: self.u32()?,
            caustic_photons: self.u32()?,
            max_bounces: self.u32()?,
            max_depth: self.u32()?,
            for_gathering: self.u8()? != 0,
            global_k: self.u32()?,
            global_radius: self.f32()?,
        })
    }

    fn maps(&mut self) -> std::result::Result<PhotonMaps, Failure> {
        let stats = PhotonStats {
            global_emitted: self.u64()?,
            caustic_emitted: self.u64()?,
            // Not saved (they took no time in this run).
            trace_seconds: 0.0,
            build_seconds: 0.0,
            // Rays traced now: none (`loaded`).
            rays: RayCount::default(),
            skipped: {
                let n = self.count(4)?;
                let mut notes = Vec::with_capacity(n);
                for _ in 0..n {
                    let len = self.u32()? as usize;
                    let end = self.at.checked_add(len).filter(|&e| e <= self.bytes.len()).ok_or(None)?;
                    let text = std::str::from_utf8(&self.bytes[self.at..end])
                        .map_err(|_| Some("a note is not UTF-8: corrupted".to_string()))?;
                    notes.push(text.to_string());
                    self.at = end;
                }
                notes
            },
            loaded: true,
        };
        let global = self.map(PhotonMap::searched_by_runs)?;
        let caustic = self.map(PhotonMap::new)?;
        if self.at != self.bytes.len() {
            return Err(Some(format!("{} bytes follow the maps: corrupted", self.bytes.len() - self.at)));
        }
        let for_gathering = global.as_ref().is_some_and(PhotonMap::has_precomputed);
        Ok(PhotonMaps { global, caustic, for_gathering, stats })
    }

    /// A map as saved: with its irradiance records if it has them, else
    /// as `new` makes it from its photons (the global map and the caustic
    /// map are searched each their own way, as `build_maps` makes them).
    fn map(&mut self, new: fn(Vec<Photon>) -> PhotonMap) -> std::result::Result<Option<PhotonMap>, Failure> {
        if self.u8()? == 0 {
            return Ok(None);
        }
        let n = self.count(62)?;
        let mut photons = Vec::with_capacity(n);
        for _ in 0..n {
            photons.push(Photon {
                position: self.vec3()?,
                incoming: self.vec3()?,
                power: self.vec3()?,
                normal: self.vec3()?,
                face_normal: self.vec3()?,
                indirect: self.u8()? != 0,
                from_delta_light: self.u8()? != 0,
            });
        }
        let precomputed = match self.u8()? {
            0 => None,
            _ => {
                let n = self.count(41)?;
                let mut records = Vec::with_capacity(n);
                for _ in 0..n {
                    let (position, normal, irradiance, radius2) =
                        (self.vec3()?, self.vec3()?, self.vec3()?, self.f32()?);
                    let guide = match self.u8()? {
                        0 => None,
                        _ => Some(self.guide()?),
                    };
                    records.push(IrradianceRecord { position, normal, irradiance, radius2, guide });
                }
                Some(records)
            }
        };
        Ok(Some(match precomputed {
            Some(records) => PhotonMap::with_records(photons, records),
            None => new(photons),
        }))
    }

    fn guide(&mut self) -> std::result::Result<GatherGuide, Failure> {
        let mut cells = [0.0; CELLS];
        for p in &mut cells {
            *p = self.f32()?;
        }
        GatherGuide::from_cells(cells)
            .ok_or_else(|| Some("a gather guide's probabilities are not one: corrupted".into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::Estimate;
    use crate::sampling::Rng;

    /// Maps of `global` and `caustic` with no stats, as the reader takes them back.
    fn written_and_read(global: PhotonMap, caustic: PhotonMap) -> (PhotonMaps, PhotonMaps) {
        let maps = PhotonMaps {
            global: Some(global),
            caustic: Some(caustic),
            for_gathering: false,
            stats: PhotonStats::default(),
        };
        let mut w = Writer(Vec::new());
        w.maps(&maps);
        let read = Reader { bytes: &w.0, at: 0 }.maps().expect("the bytes just written");
        (maps, read)
    }

    #[test]
    fn a_map_read_back_finds_the_photons_it_found_when_built() {
        // Photons on a lattice (many at exactly equal distances, where a
        // kd-tree and the runs may keep different ones at the k-th place),
        // and maps built as `build_maps` builds them without gathering: a
        // map read back from a file must be searched as it was built, or a
        // render from saved maps is not the render that traced them.
        let mut rng = Rng::new(3, 8);
        let photons = Photon::on_lattice_and_scattered(6000, 50, &mut rng);
        let built = (PhotonMap::searched_by_runs(photons.clone()), PhotonMap::new(photons));
        let (maps, read) = written_and_read(built.0, built.1);
        assert!(!read.for_gathering);
        for (before, after) in [(&maps.global, &read.global), (&maps.caustic, &read.caustic)] {
            let (before, after) = (before.as_ref().unwrap(), after.as_ref().unwrap());
            assert_eq!(before.photons(), after.photons());
            for j in 0..300 {
                let q = match j % 3 {
                    0 => before.photons()[j * 11].position,
                    _ => Vec3::new(rng.uniform(), 0.0, rng.uniform()),
                };
                for k in [4, 7, 20, 50] {
                    assert_eq!(before.nearest(q, k, 0.3), after.nearest(q, k, 0.3), "{q} k {k}");
                }
            }
        }
        // What the test is for: the two searches part on this lattice.
        let estimate = Estimate { k: 20, max_radius: 0.3, cone_filter: None };
        let (global, caustic) = (read.global.as_ref().unwrap(), read.caustic.as_ref().unwrap());
        let parted = (0..300).any(|j| {
            let q = global.photons()[j * 11].position;
            global.nearest(q, estimate.k, estimate.max_radius)
                != caustic.nearest(q, estimate.k, estimate.max_radius)
        });
        assert!(parted, "no query tells a kd-tree from the runs: the test proves nothing");
    }
}
