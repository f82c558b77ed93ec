//! Ray/triangle intersection: the one narrow seam between the renderer and
//! whichever acceleration structure answers its queries.
//!
//! [`Intersector`] is implemented by Embree ([`embree::EmbreeIntersector`], the
//! default) and by the native BVH ([`bvh::Bvh`]). Both report hits in Embree's
//! convention so that shading code never knows which one answered.

pub mod bvh;
pub mod embree;

use glam::Vec3;

use crate::error::Result;
use embree::TriangleView;

/// Which intersector answers ray queries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// Intel Embree, as the system provides it (the default).
    Embree,
    /// The pure-Rust BVH in this crate.
    Native,
}

/// How Embree lays out its BVH: memory against speed. The native BVH has one layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BvhLayout {
    /// Leaves hold copies of their triangles' vertices: the fastest rays
    /// (Embree's default).
    Fast,
    /// Leaves index the meshes' own vertex arrays (`RTC_SCENE_FLAG_COMPACT`):
    /// about a third of the memory while building, slower rays.
    Compact,
    /// Compact only when the fast layout would not fit in the memory
    /// available now (so a huge mesh renders rather than being killed).
    #[default]
    Auto,
}

impl Backend {
    /// Every backend, by its name in scene files and on the command line.
    pub const NAMES: [(&'static str, Backend); 2] =
        [("embree", Backend::Embree), ("native", Backend::Native)];
}

impl std::str::FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        named(&Self::NAMES, s)
    }
}

impl std::str::FromStr for BvhLayout {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        named(&Self::NAMES, s)
    }
}

/// The value called `name` among `names`, or an error listing them (the
/// `FromStr` of the settings named in scene files and on the command line).
pub(crate) fn named<T: Copy>(names: &[(&'static str, T)], name: &str) -> std::result::Result<T, String> {
    names.iter().find(|(n, _)| *n == name).map(|(_, v)| *v).ok_or_else(|| {
        let all: Vec<&str> = names.iter().map(|(n, _)| *n).collect();
        format!("unknown value `{name}`; choose from {}", all.join(", "))
    })
}

impl BvhLayout {
    /// Every layout, by its name in scene files and on the command line.
    pub const NAMES: [(&'static str, BvhLayout); 3] =
        [("fast", BvhLayout::Fast), ("compact", BvhLayout::Compact), ("auto", BvhLayout::Auto)];

    /// Bytes per triangle Embree's fast layout needs at its peak while
    /// building: BVH plus build scratch, measured at 10M triangles
    /// (BENCHMARKS.md, 625 + 315 MiB), rounded up.
    pub const FAST_BYTES_PER_TRIANGLE: usize = 100;

    /// `Fast` or `Compact`: `Auto` decided for `triangles` triangles.
    pub fn resolve(self, triangles: usize) -> BvhLayout {
        match self {
            BvhLayout::Auto => match crate::memory::available() {
                Some(free) if triangles.saturating_mul(Self::FAST_BYTES_PER_TRIANGLE) > free => {
                    BvhLayout::Compact
                }
                _ => BvhLayout::Fast,
            },
            chosen => chosen,
        }
    }
}

/// Builds the chosen intersector over `meshes` (mesh `i` is geometry `i`),
/// Embree's with the fast BVH layout.
pub fn build<'a>(backend: Backend, meshes: &[TriangleView<'a>]) -> Result<Box<dyn Intersector + 'a>> {
    build_with_layout(backend, BvhLayout::Fast, meshes)
}

/// [`build`] with Embree's BVH in `layout`.
pub fn build_with_layout<'a>(
    backend: Backend,
    layout: BvhLayout,
    meshes: &[TriangleView<'a>],
) -> Result<Box<dyn Intersector + 'a>> {
    Ok(match backend {
        Backend::Embree => Box::new(embree::EmbreeIntersector::build_with_layout(meshes, layout)?),
        Backend::Native => {
            embree::check_indices(meshes)?;
            Box::new(bvh::Bvh::build(meshes))
        }
    })
}

/// A ray `origin + t * dir` for `t` in `(0, t_max]`.
///
/// `dir` need not be normalised; `t` is measured in units of `|dir|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Where the ray starts (already offset off any surface it leaves).
    pub origin: Vec3,
    /// Direction of travel.
    pub dir: Vec3,
    /// The far end of the segment to test.
    pub t_max: f32,
}

impl Ray {
    /// A ray with unbounded extent.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray { origin, dir, t_max: f32::INFINITY }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// The closest hit along a ray, in Embree's convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Barycentric weight of vertex 1; vertex weights are `(1-u-v, u, v)`.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// Index of the mesh (Embree geometry id) that was hit.
    pub geom_id: u32,
    /// Index of the triangle within that mesh.
    pub prim_id: u32,
    /// Unnormalised geometric normal `(v1 - v0) x (v2 - v0)`: it faces the side
    /// from which the triangle's vertices appear counter-clockwise.
    pub ng: Vec3,
}

/// Answers ray queries against a fixed set of triangle meshes.
///
/// Implementations must be safe to query from many threads at once.
pub trait Intersector: Send + Sync {
    /// The closest hit with `0 < t <= ray.t_max`, if any. A hit at exactly
    /// `t = 0` is the surface the ray starts on (e.g. a ray leaving a wall at
    /// its corner with the ceiling, offset along the wall's normal, starts in
    /// the ceiling's plane) and never counts, as in pbrt.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;

    /// Whether anything is hit with `0 < t <= ray.t_max` (shadow rays).
    fn occluded(&self, ray: &Ray) -> bool;

    /// [`intersect`](Intersector::intersect) for many rays at once, writing
    /// `hits[i]` for `rays[i]`. Backends override this where handing over a
    /// batch is faster (Embree's ray streams).
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        for (ray, hit) in rays.iter().zip(hits) {
            *hit = self.intersect(ray);
        }
    }

    /// [`occluded`](Intersector::occluded) for many rays at once.
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        for (ray, o) in rays.iter().zip(occluded) {
            *o = self.occluded(ray);
        }
    }

    /// Whether handing over `rays` rays as one batch is faster than one by
    /// one; callers that would gather them for a batch only to trace them
    /// singly skip the gathering (direct light's shadow rays). No by default.
    fn batches_pay(&self, rays: usize) -> bool {
        let _ = rays;
        false
    }

    /// A short name for logs and benchmarks, e.g. `"embree 3.13.5"`.
    fn name(&self) -> String;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_layout_is_compact_only_when_fast_would_not_fit() {
        assert_eq!(BvhLayout::Fast.resolve(usize::MAX), BvhLayout::Fast);
        assert_eq!(BvhLayout::Compact.resolve(1), BvhLayout::Compact);
        assert_eq!(BvhLayout::Auto.resolve(1000), BvhLayout::Fast);
        // More triangles than any machine's memory holds at 100 bytes each.
        let huge = usize::MAX / BvhLayout::FAST_BYTES_PER_TRIANGLE;
        assert_eq!(BvhLayout::Auto.resolve(huge), BvhLayout::Compact);
    }
}
