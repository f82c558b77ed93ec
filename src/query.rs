//! The one question every integrator and the photon tracer ask of a scene:
//! what does this ray meet first, a surface or the front of an area light?
//! [`SceneQuery::first`] answers it with everything shading needs; a
//! [`SurfacePoint`] spawns the next ray robustly ([`SurfacePoint::spawn`],
//! [`SurfacePoint::spawn_to`]). Rays are counted here, in one place.

use glam::Vec3;

use crate::accel::{Hit, Intersector, Ray};
use crate::light::{Light, Side};
use crate::material::Material;
use crate::optics;
use crate::scene::{Mesh, Scene};

/// Rays traced, for the summary line of a render.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct RayCount {
    /// Rays traced to their closest hit (camera, reflection, refraction,
    /// gather, photon).
    pub closest: u64,
    /// Shadow rays.
    pub shadow: u64,
}

impl std::ops::AddAssign for RayCount {
    fn add_assign(&mut self, o: RayCount) {
        self.closest += o.closest;
        self.shadow += o.shadow;
    }
}

impl std::iter::Sum for RayCount {
    fn sum<I: Iterator<Item = RayCount>>(counts: I) -> RayCount {
        counts.fold(RayCount::default(), |mut all, c| {
            all += c;
            all
        })
    }
}

/// What a ray meets first: a surface, worked out as a [`SurfacePoint`] (or,
/// from [`SceneQuery::first_meeting`], left as the intersector's [`Hit`]).
#[derive(Debug, Clone, Copy)]
pub enum Interaction<'a, S = SurfacePoint> {
    /// A surface of the scene's geometry.
    Surface(S),
    /// The emitting front of an area light (lights are not in the
    /// intersector's geometry: they are tested against the ray's segment up
    /// to the nearest surface; a light's back ends a ray with nothing).
    Emitter {
        /// The light.
        light: &'a Light,
        /// Ray parameter of the hit.
        t: f32,
        /// Radiance leaving the light towards the ray's origin.
        radiance: Vec3,
    },
}

/// A scene and the intersector that answers its ray queries.
#[derive(Clone, Copy)]
pub struct SceneQuery<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Answers ray/triangle queries (Embree or the native BVH).
    pub accel: &'a dyn Intersector,
}

impl<'a> SceneQuery<'a> {
    /// A query over `scene` answered by `accel` (built over its meshes).
    pub fn new(scene: &'a Scene, accel: &'a dyn Intersector) -> Self {
        SceneQuery { scene, accel }
    }

    /// The first surface or area-light front along `ray`; `None` if it
    /// leaves the scene. Counts one ray.
    pub fn first(&self, ray: &Ray, count: &mut RayCount) -> Option<Interaction<'a>> {
        self.first_meeting(ray, count).map(|met| self.worked_out(ray, met))
    }

    /// [`SceneQuery::first`] with a surface left as the intersector's hit,
    /// for callers that need less than its whole [`SurfacePoint`] (final
    /// gathering's rays read a record from the triangle and its barycentrics).
    /// Counts one ray.
    pub fn first_meeting(&self, ray: &Ray, count: &mut RayCount) -> Option<Interaction<'a, Hit>> {
        count.closest += 1;
        self.meeting(ray, self.accel.intersect(ray))
    }

    /// The surface point of a surface `ray` met (as [`SceneQuery::first`] gives it).
    pub fn worked_out(&self, ray: &Ray, met: Interaction<'a, Hit>) -> Interaction<'a> {
        match met {
            Interaction::Surface(hit) => Interaction::Surface(SurfacePoint::new(self.scene, ray, &hit)),
            Interaction::Emitter { light, t, radiance } => Interaction::Emitter { light, t, radiance },
        }
    }

    /// [`SceneQuery::first`] for every ray of `rays` at once, into `first`
    /// (as many): the intersector may trace them together (Embree 3's ray
    /// streams). The answers are those `first` gives. Counts one ray each.
    pub fn first_batch(&self, rays: &[Ray], first: &mut [Option<Interaction<'a>>], count: &mut RayCount) {
        self.batch(rays, first, count, |ray, met| self.worked_out(ray, met));
    }

    /// [`SceneQuery::first_meeting`] for every ray of `rays` at once, as
    /// [`SceneQuery::first_batch`] takes them.
    pub fn first_meeting_batch(
        &self,
        rays: &[Ray],
        first: &mut [Option<Interaction<'a, Hit>>],
        count: &mut RayCount,
    ) {
        self.batch(rays, first, count, |_, met| met);
    }

    /// The rays of `rays` traced together in chunks, each meeting turned
    /// into an answer by `answer`.
    fn batch<A>(
        &self,
        rays: &[Ray],
        first: &mut [Option<A>],
        count: &mut RayCount,
        answer: impl Fn(&Ray, Interaction<'a, Hit>) -> A,
    ) {
        assert_eq!(rays.len(), first.len(), "one answer per ray");
        count.closest += rays.len() as u64;
        const CHUNK: usize = 16;
        let mut hits = [None; CHUNK];
        for (rays, first) in rays.chunks(CHUNK).zip(first.chunks_mut(CHUNK)) {
            let hits = &mut hits[..rays.len()];
            self.accel.intersect_batch(rays, hits);
            for ((ray, hit), out) in rays.iter().zip(hits.iter()).zip(first) {
                *out = self.meeting(ray, *hit).map(|met| answer(ray, met));
            }
        }
    }

    /// What `ray` meets first, given the closest triangle it hits: an area
    /// light's front before it, or the surface there.
    ///
    /// A light's back is black and opaque: a ray that meets it first meets
    /// nothing more (`None`), as a ray from the other side ends at the
    /// front. Were the back transparent, camera paths would pass down
    /// through a ceiling light into the room while light paths going up end
    /// at its front: the path tracer and the light tracer would disagree on
    /// the ceiling above the light (BENCHMARKS.md, issue 16).
    ///
    /// A light laid flush on a surface (a panel in the ceiling's plane) is
    /// in front of it: the two crossings differ only by rounding, and
    /// taking the nearer of them showed the surface through the light on a
    /// tenth to a half of the rays (`tests/lights.rs`). So lights are
    /// looked for a little beyond the hit, and one found there counts if
    /// [`SceneQuery::flush`] says so.
    fn meeting(&self, ray: &Ray, hit: Option<Hit>) -> Option<Interaction<'a, Hit>> {
        let reach = hit.map_or(ray.t_max, |h| flush_reach(ray, h.t));
        match self.scene.lights.nearest_crossing(&Ray { t_max: reach, ..*ray }) {
            Some((light, t, side)) if hit.is_none_or(|h| t <= h.t || self.flush(ray, &h, light, t)) => {
                return match side {
                    Side::Front => Some(Interaction::Emitter { light, t, radiance: light.front_radiance() }),
                    Side::Back => None,
                };
            }
            _ => {}
        }
        hit.map(Interaction::Surface)
    }

    /// Whether `light`, crossed by `ray` at `t` just beyond the surface
    /// `hit`, lies in the surface's plane within the rounding of both: the
    /// two crossings' distance along the surface's normal is within what
    /// rounding puts between points of the two.
    fn flush(&self, ray: &Ray, hit: &Hit, light: &Light, t: f32) -> bool {
        let mesh = &self.scene.meshes[hit.geom_id as usize];
        let face = mesh.face_normal(hit.prim_id);
        let surface = SurfacePoint::facing(mesh, hit, face, true);
        let apart = (t - hit.t) * ray.dir.dot(face).abs();
        apart <= face.abs().dot(surface.error) + light.rounding_along(face)
    }

    /// The first triangle along `ray`, seeing through lights (geometry
    /// previews). Counts one ray.
    pub fn first_hit(&self, ray: &Ray, count: &mut RayCount) -> Option<Hit> {
        count.closest += 1;
        self.accel.intersect(ray)
    }

    /// Whether anything blocks the shadow ray `ray`: a surface, or an area
    /// light (either side; a ray towards a point on a light stops short of
    /// it). Counts one shadow ray.
    pub fn occluded(&self, ray: &Ray, count: &mut RayCount) -> bool {
        count.shadow += 1;
        self.accel.occluded(ray) || self.crosses_a_light(ray)
    }

    /// Whether `ray` crosses an area light before its end. Lights are
    /// opaque panels to shadow rays as to every other ray: a connection
    /// from a wall behind a light to the camera (the light tracer's, VCM's)
    /// once passed through it and added the wall to the light's pixels.
    fn crosses_a_light(&self, ray: &Ray) -> bool {
        self.scene.lights.any_crossing(ray)
    }

    /// [`SceneQuery::occluded`] for every ray of `rays` at once, into
    /// `occluded` (as many): the intersector may trace them together
    /// (Embree 3's ray streams). Counts one shadow ray each.
    pub fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool], count: &mut RayCount) {
        count.shadow += rays.len() as u64;
        self.accel.occluded_batch(rays, occluded);
        for (ray, occluded) in rays.iter().zip(occluded) {
            *occluded = *occluded || self.crosses_a_light(ray);
        }
    }

    /// The material of a surface point.
    pub fn material(&self, sp: &SurfacePoint) -> &'a Material {
        &self.scene.materials[sp.material]
    }

    /// The material of the triangle an intersector hit.
    pub fn hit_material(&self, hit: &Hit) -> &'a Material {
        &self.scene.materials[self.scene.meshes[hit.geom_id as usize].material]
    }
}

/// How far along `ray` to look for a light flush with the surface hit at
/// `t` ([`SceneQuery::flush`]): a thousandth of the size of the
/// coordinates beyond it, far more than their rounding (32 ulps is 4e-6 of
/// them), so that only rays within a few tenths of a degree of the plane
/// find the light's crossing farther off. Never beyond `ray.t_max`.
fn flush_reach(ray: &Ray, t: f32) -> f32 {
    let size = t + ray.origin.abs().max_element() / ray.dir.abs().max_element();
    (t + 1e-3 * size).min(ray.t_max)
}

/// A point on a surface, seen from an incoming ray.
#[derive(Debug, Clone, Copy)]
pub struct SurfacePoint {
    /// Position, interpolated from the triangle's vertices.
    pub p: Vec3,
    /// Unit geometric normal, flipped to the side the ray came from.
    pub ng: Vec3,
    /// Unit smooth shading normal, flipped to the same side as `ng`.
    pub ns: Vec3,
    /// Whether the ray arrived on the front (counter-clockwise, outside) side.
    pub front: bool,
    /// Index of the material.
    pub material: usize,
    /// Ray parameter of the hit.
    pub t: f32,
    /// Bound on the floating-point error of `p`, per axis.
    error: Vec3,
}

impl SurfacePoint {
    /// The point `hit` of `ray` in `scene`.
    pub fn new(scene: &Scene, ray: &Ray, hit: &Hit) -> SurfacePoint {
        let mesh = &scene.meshes[hit.geom_id as usize];
        let face = mesh.face_normal(hit.prim_id);
        SurfacePoint::facing(mesh, hit, face, face.dot(ray.dir) < 0.0)
    }

    /// The point of `hit` on `mesh` (the triangle's unit normal `face`),
    /// seen from the front (against `face`) or from the back, as
    /// [`SurfacePoint::new`] sees it from a ray.
    pub fn facing(mesh: &Mesh, hit: &Hit, face: Vec3, front: bool) -> SurfacePoint {
        let [i0, i1, i2] = mesh.indices[hit.prim_id as usize];
        let (b0, b1, b2) = (1.0 - hit.u - hit.v, hit.u, hit.v);
        let [p0, p1, p2] = [i0, i1, i2].map(|i| mesh.positions[i as usize]);
        let (w0, w1, w2) = (b0 * p0, b1 * p1, b2 * p2);
        // The barycentric blend is accurate to a few ulps of its terms (pbrt's
        // bound is 7 ulps); 32 ulps leaves a margin for Embree's own rounding of (u, v).
        let error = 32.0 * f32::EPSILON * (w0.abs() + w1.abs() + w2.abs());
        let ng = if front { face } else { -face };
        let ns = mesh.shading_normal(hit.prim_id, hit.u, hit.v);
        let ns = if ns.dot(ng) < 0.0 { -ns } else { ns };
        SurfacePoint { p: w0 + w1 + w2, ng, ns, front, material: mesh.material, t: hit.t, error }
    }

    /// The ray origin for leaving in direction `dir`: `p` pushed along the
    /// geometric normal, to the side `dir` goes, by just more than the error
    /// of `p`. Scale-aware: no fixed epsilon.
    fn offset_origin(&self, dir: Vec3) -> Vec3 {
        let side = if dir.dot(self.ng) >= 0.0 { self.ng } else { -self.ng };
        crate::numeric::push_off(self.p, side, self.error)
    }

    /// A ray leaving the surface in direction `dir`.
    pub fn spawn(&self, dir: Vec3) -> Ray {
        Ray::new(self.offset_origin(dir), dir)
    }

    /// The mirror direction of `dir` (travelling towards the surface) about
    /// the shading normal; if the smooth normal would send it below the
    /// actual surface, about the geometric normal instead.
    pub fn reflect(&self, dir: Vec3) -> Vec3 {
        let r = optics::reflect(dir, self.ns);
        if r.dot(self.ng) > 0.0 {
            r
        } else {
            optics::reflect(dir, self.ng)
        }
    }

    /// At a dielectric of index `ior` (inside), the indices of refraction on
    /// the side the ray arrived from and on the other side: the outside is
    /// air, and which side is inside follows the geometric normal.
    pub fn indices(&self, ior: f32) -> (f32, f32) {
        if self.front {
            (1.0, ior)
        } else {
            (ior, 1.0)
        }
    }

    /// At a smooth dielectric of index `ior` (inside), the Fresnel reflectance
    /// for `dir` and the refracted direction (`None` on total internal
    /// reflection). Which side is inside follows the geometric normal.
    pub fn refract(&self, dir: Vec3, ior: f32) -> (f32, Option<Vec3>) {
        let (n1, n2) = self.indices(ior);
        let kr = optics::fresnel_dielectric((-dir.dot(self.ns)).clamp(0.0, 1.0), n1, n2);
        if kr >= 1.0 {
            return (1.0, None);
        }
        // Through the shading normal; through the geometric one when the
        // smooth normal would keep the ray on the near side.
        let eta = n1 / n2;
        let t = match optics::refract(dir, self.ns, eta) {
            Some(t) if t.dot(self.ng) < 0.0 => Some(t),
            _ => optics::refract(dir, self.ng, eta).filter(|t| t.dot(self.ng) < 0.0),
        };
        (kr, t)
    }

    /// What light carried from the lights (photons, light subpaths) takes
    /// past this point beyond the BSDF, where the shading normal is not the
    /// geometric one (Veach 1997, section 5.3; pbrt's
    /// `CorrectShadingNormal`): with `from` the unit direction back to where
    /// the light came from and `to` the one it goes on in,
    /// `|from.ns| |to.ng| / (|from.ng| |to.ns|)`. A BSDF on shading normals
    /// is not symmetric, and light carried from the lights runs the other way
    /// to the camera's: without it, the light tracer showed a smooth sphere
    /// of few triangles with its facets' pattern (the middle of a furnace's
    /// sphere of 80 triangles 9% too bright, pixels 0.4 to 1.5 of the path
    /// tracer's), and bidirectional path tracing its blocks 2% dark. Exactly
    /// 1 where the normals agree.
    pub fn adjoint_shading(&self, from: Vec3, to: Vec3) -> f32 {
        let num = from.dot(self.ns).abs() * to.dot(self.ng).abs();
        let den = from.dot(self.ng).abs() * to.dot(self.ns).abs();
        if num == den {
            1.0
        } else if den > 0.0 {
            num / den
        } else {
            0.0
        }
    }

    /// Whether light arriving from the unit direction `from` (back towards
    /// where it came from) is light the smooth (diffuse and glossy) lobes
    /// here reflect: it must come from the shading normal's side, as the
    /// path tracer weighs it by that cosine and takes none from below. Camera
    /// paths ask it of their light samples; light carried from the lights
    /// (photons, light subpaths), which arrives first, must ask it itself.
    /// At a floor whose normals lean 80 degrees, the light tracer's image
    /// of a point light's direct light was 46% too bright without it.
    pub fn smooth_lobes_take(&self, from: Vec3) -> bool {
        from.dot(self.ns) > 0.0
    }

    /// `|w.ns| / |w.ng|` for a unit direction `w`: how much more of the
    /// light arriving along `w` the surface takes in by its shading normal
    /// than the light's density on the surface measures (the path tracer
    /// weighs it by the shading normal's cosine; a photon's power lands by
    /// the geometric one's). Exactly 1 where the normals agree; 0 for `w`
    /// in the surface's plane. [`SurfacePoint::adjoint_shading`] is this
    /// for `from` over this for `to`.
    pub fn shading_over_geometric(&self, w: Vec3) -> f32 {
        let (shading, geometric) = (w.dot(self.ns).abs(), w.dot(self.ng).abs());
        if shading == geometric {
            1.0
        } else if geometric > 0.0 {
            shading / geometric
        } else {
            0.0
        }
    }

    /// A shadow ray from the surface to `target`, stopping just short of it
    /// (`t` runs from 0 at the surface to 1 at the target).
    pub fn spawn_to(&self, target: Vec3) -> Ray {
        let origin = self.offset_origin(target - self.p);
        Ray { origin, dir: target - origin, t_max: 1.0 - 1e-4 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point on a floor (geometric normal up) whose shading normal leans
    /// 45 degrees towards +x.
    fn on_leaning_floor() -> SurfacePoint {
        SurfacePoint {
            p: Vec3::ZERO,
            ng: Vec3::Y,
            ns: Vec3::new(1.0, 1.0, 0.0).normalize(),
            front: true,
            material: 0,
            t: 1.0,
            error: Vec3::ZERO,
        }
    }

    /// The cosines' ratio by hand, exactly 1 where the normals agree, and
    /// Veach's correction as the ratio for the light's way in over the one
    /// for its way out.
    #[test]
    fn shading_normal_corrections_weigh_the_two_cosines() {
        let sp = on_leaning_floor();
        let half = std::f32::consts::FRAC_1_SQRT_2;
        // Straight down onto the floor: the shading normal's cosine is 1/sqrt 2.
        assert!((sp.shading_over_geometric(Vec3::Y) - half).abs() < 1e-6);
        // Along the shading normal: 1 over its cosine with the floor's.
        let along = sp.ns;
        assert!((sp.shading_over_geometric(along) - 1.0 / half).abs() < 1e-5);
        // Across the shading normal, on the floor's side: none of it.
        let across = Vec3::new(-1.0, 1.0, 0.0).normalize();
        assert!(sp.shading_over_geometric(across).abs() < 1e-6);
        // In the floor's plane: 0, not infinite.
        assert_eq!(sp.shading_over_geometric(Vec3::X), 0.0);
        for (from, to) in [(Vec3::Y, along), (along, Vec3::new(0.3, 0.8, 0.52).normalize())] {
            let expected = sp.shading_over_geometric(from) / sp.shading_over_geometric(to);
            assert!((sp.adjoint_shading(from, to) / expected - 1.0).abs() < 1e-5, "{from} {to}");
        }
        let flat = SurfacePoint { ns: Vec3::Y, ..sp };
        for w in [Vec3::Y, along, Vec3::new(0.6, 0.1, -0.3).normalize()] {
            assert_eq!(flat.shading_over_geometric(w), 1.0);
            assert_eq!(flat.adjoint_shading(w, Vec3::Y), 1.0);
        }
    }
}
