//! A ray's hit turned into what shading needs: position, normals on the
//! ray's side, material, and robust ray spawning.

use glam::Vec3;

use crate::accel::{Hit, Ray};
use crate::material::Material;
use crate::optics;
use crate::sampling::Rng;
use crate::scene::Scene;

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
    /// Bound on the floating-point error of `p`, per axis.
    error: Vec3,
}

impl SurfacePoint {
    /// The point `hit` of `ray` in `scene`.
    pub fn new(scene: &Scene, ray: &Ray, hit: &Hit) -> SurfacePoint {
        let mesh = &scene.meshes[hit.geom_id as usize];
        let [i0, i1, i2] = mesh.indices[hit.prim_id as usize];
        let (b0, b1, b2) = (1.0 - hit.u - hit.v, hit.u, hit.v);
        let [p0, p1, p2] = [i0, i1, i2].map(|i| mesh.positions[i as usize]);
        let (w0, w1, w2) = (b0 * p0, b1 * p1, b2 * p2);
        // The barycentric blend is accurate to a few ulps of its terms (pbrt's
        // bound is 7 ulps); 32 ulps leaves a margin for Embree's own rounding of (u, v).
        let error = 32.0 * f32::EPSILON * (w0.abs() + w1.abs() + w2.abs());
        let face = mesh.face_normal(hit.prim_id);
        let front = face.dot(ray.dir) < 0.0;
        let ng = if front { face } else { -face };
        let ns = mesh.shading_normal(hit.prim_id, hit.u, hit.v);
        let ns = if ns.dot(ng) < 0.0 { -ns } else { ns };
        SurfacePoint { p: w0 + w1 + w2, ng, ns, front, material: mesh.material, error }
    }

    /// The ray origin for leaving in direction `dir`: `p` pushed along the
    /// geometric normal, to the side `dir` goes, by just more than the error
    /// of `p`. Scale-aware: no fixed epsilon.
    fn offset_origin(&self, dir: Vec3) -> Vec3 {
        let distance = self.ng.abs().dot(self.error) + f32::MIN_POSITIVE;
        let offset = distance * self.ng;
        if dir.dot(self.ng) >= 0.0 {
            self.p + offset
        } else {
            self.p - offset
        }
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

    /// At a smooth dielectric of index `ior` (inside), the Fresnel reflectance
    /// for `dir` and the refracted direction (`None` on total internal
    /// reflection). Which side is inside follows the geometric normal.
    pub fn refract(&self, dir: Vec3, ior: f32) -> (f32, Option<Vec3>) {
        let (n1, n2) = if self.front { (1.0, ior) } else { (ior, 1.0) };
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

    /// One direction out of a smooth dielectric of index `ior` for `dir`:
    /// refracted with probability `1 - kr`, else reflected (always on total
    /// internal reflection). Fresnel chooses with exactly its own weights, so
    /// whatever follows needs no rescaling. Draws a number only when there is
    /// a choice.
    pub fn dielectric_direction(&self, dir: Vec3, ior: f32, rng: &mut Rng) -> Vec3 {
        let (kr, refracted) = self.refract(dir, ior);
        match refracted {
            Some(t) if rng.uniform() >= kr => t,
            _ => self.reflect(dir),
        }
    }

    /// One of `m`'s mirror and glass parts for `dir`, chosen in proportion to
    /// its weight summed over channels: the part's weight over the chance of
    /// choosing it, and the direction out. `None` if `m` has neither part.
    pub fn specular_bounce(&self, m: &Material, dir: Vec3, rng: &mut Rng) -> Option<(Vec3, Vec3)> {
        let (mirror, glass) = (m.mirror.element_sum(), m.transmittance.element_sum());
        if mirror + glass <= 0.0 {
            return None;
        }
        Some(if rng.uniform() * (mirror + glass) < mirror {
            (m.mirror * ((mirror + glass) / mirror), self.reflect(dir))
        } else {
            (m.transmittance * ((mirror + glass) / glass), self.dielectric_direction(dir, m.ior, rng))
        })
    }

    /// A shadow ray from the surface to `target`, stopping just short of it
    /// (`t` runs from 0 at the surface to 1 at the target).
    pub fn spawn_to(&self, target: Vec3) -> Ray {
        let origin = self.offset_origin(target - self.p);
        Ray { origin, dir: target - origin, t_max: 1.0 - 1e-4 }
    }
}
