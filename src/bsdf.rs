//! Scattering at one surface point: a [`Material`] seen from an incoming
//! ray becomes a [`Bsdf`] that evaluates, samples and gives the density of
//! its lobes. Every integrator and the photon tracer scatter through it, so
//! the lobes, their choice and their weights are written once.
//!
//! The lobes: Lambertian diffuse, a normalised Phong lobe (glossy), a
//! perfect mirror, and a smooth dielectric (Fresnel reflection or
//! refraction). The first two are smooth; the last two are deltas, which
//! only [`Bsdf::sample`] and the specular helpers can produce.

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};

use crate::material::Material;
use crate::query::SurfacePoint;
use crate::sampling::{around, cosine_hemisphere, phong_lobe, phong_lobe_pdf, Rng};

/// What kind of scattering a sample made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScatterKind {
    /// Lambertian reflection.
    Diffuse,
    /// Phong-lobe reflection.
    Glossy,
    /// Mirror reflection, or Fresnel reflection off a dielectric.
    SpecularReflection,
    /// Refraction into or out of a dielectric.
    SpecularTransmission,
}

impl ScatterKind {
    /// Mirror and glass: a single direction, no density.
    pub fn is_specular(self) -> bool {
        matches!(self, ScatterKind::SpecularReflection | ScatterKind::SpecularTransmission)
    }
}

/// One sampled direction out of a surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// Unit direction the light goes on in (away from the surface).
    pub wi: Vec3,
    /// `f cos / pdf`, the lobe choice included: what the path's weight is
    /// multiplied by.
    pub weight: Vec3,
    /// Solid-angle density of the smooth lobes at `wi` (for multiple
    /// importance sampling); `None` for a specular sample.
    pub pdf: Option<f32>,
    /// Which lobe made it.
    pub kind: ScatterKind,
    /// For a refraction, the indices of refraction on the side the ray
    /// arrived from and on the side it goes on into (see [`RadianceScale`]);
    /// `None` for every other lobe.
    pub indices: Option<(f32, f32)>,
}

/// What radiance found where a camera path now is counts for at the camera,
/// across the refractions the path has made: radiance is `eta^2` times
/// denser in a medium of index `eta` (a refraction squeezes the light of a
/// solid angle into a smaller one), so light found in a medium of index
/// `eta` counts `(eta_camera / eta)^2` at a camera in a medium of index
/// `eta_camera` (Veach 1997, section 5.2; pbrt's `TransportMode::Radiance`).
/// Light paths carry power, which a refraction does not scale: they take no
/// such factor. Without it, light that a photon or light subpath brought to
/// a diffuse surface inside glass was read by the camera `eta^2` too
/// bright, and every photon and bidirectional method disagreed with the
/// path tracer on glass with a diffuse part (a furnace of such a sphere
/// came out up to 32% too bright).
///
/// The camera's medium is the one the path's first refraction left, and
/// the medium now the one its last went into: what lies between does not
/// count. In closed, well-wound glass that is the product of `(eta_i /
/// eta_t)^2` over every refraction; where shells cross or are open (the
/// teapot's spout through its body), a path that entered twice and left
/// once is still in air, not in glass. A path in air at both ends takes
/// exactly 1, so images of scenes whose camera and lights are outside
/// glass are unchanged to the bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadianceScale {
    /// The indices of the media the first refraction left and the last
    /// one went into; `None` before any.
    ends: Option<(f32, f32)>,
}

impl RadianceScale {
    /// A path that has made no refraction.
    pub const ONE: RadianceScale = RadianceScale { ends: None };

    /// The scale after the scattering `s`.
    #[inline]
    pub fn after(self, s: &BsdfSample) -> RadianceScale {
        match (s.indices, self.ends) {
            (Some((_, into)), Some((camera, _))) => RadianceScale { ends: Some((camera, into)) },
            (Some(indices), None) => RadianceScale { ends: Some(indices) },
            (None, _) => self,
        }
    }

    /// The factor itself, for what the path finds.
    #[inline]
    pub fn factor(self) -> f32 {
        match self.ends {
            Some((camera, now)) if camera != now => (camera / now) * (camera / now),
            _ => 1.0,
        }
    }
}

/// A material at a surface point, seen along a ray.
#[derive(Debug, Clone, Copy)]
pub struct Bsdf<'a> {
    material: &'a Material,
    sp: &'a SurfacePoint,
    /// Unit direction of the arriving ray (towards the surface).
    dir: Vec3,
    /// Chance of choosing each lobe when sampling: in proportion to its
    /// reflectance summed over channels (diffuse, glossy, mirror, glass).
    choice: [f32; 4],
}

impl<'a> Bsdf<'a> {
    /// `material` at `sp`, for a ray arriving along the unit direction `dir`.
    pub fn new(material: &'a Material, sp: &'a SurfacePoint, dir: Vec3) -> Self {
        let m = material;
        let sums = [m.diffuse, m.specular, m.mirror, m.transmittance].map(|c| c.element_sum());
        let total: f32 = sums.iter().sum();
        let choice = sums.map(|s| if total > 0.0 { s / total } else { 0.0 });
        Bsdf { material, sp, dir, choice }
    }

    /// The material.
    pub fn material(&self) -> &'a Material {
        self.material
    }

    /// Unit direction back along the arriving ray (towards the viewer).
    pub fn wo(&self) -> Vec3 {
        -self.dir
    }

    /// Whether a smooth (diffuse or glossy) lobe is there: the part that
    /// direct light and photon estimates act on.
    pub fn has_smooth(&self) -> bool {
        self.material.is_glossy_or_diffuse()
    }

    /// Whether a specular lobe (mirror or glass) is there.
    pub fn has_specular(&self) -> bool {
        self.material.is_specular()
    }

    /// The fraction of light scattered, per channel, all lobes together
    /// (what Russian roulette for photons is decided on).
    pub fn albedo(&self) -> Vec3 {
        self.material.total_reflectance()
    }

    /// The chance that [`Bsdf::sample`] picks a smooth lobe.
    pub fn smooth_probability(&self) -> f32 {
        self.choice[0] + self.choice[1]
    }

    /// The chance that [`Bsdf::sample`] picks a specular lobe (mirror or
    /// glass): 0 exactly without one.
    pub fn specular_probability(&self) -> f32 {
        self.choice[2] + self.choice[3]
    }

    /// The smooth lobes' BRDF for light arriving from `wi` (unit, away from
    /// the surface) and leaving towards the viewer.
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        self.material.brdf(self.sp.ns, wi, self.wo())
    }

    /// The glossy lobe's part of [`Bsdf::eval`] alone.
    pub fn eval_glossy(&self, wi: Vec3) -> Vec3 {
        self.material.glossy_brdf(self.sp.ns, wi, self.wo())
    }

    /// Solid-angle density with which [`Bsdf::sample`] produces `wi` through
    /// its smooth lobes, lobe choice included.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let cos = wi.dot(self.sp.ns);
        if cos <= 0.0 {
            return 0.0;
        }
        self.mixture_pdf(wi, cos)
    }

    /// The smooth lobes' density at `wi`, lobe choice included, where the
    /// diffuse lobe draws by the cosine `cos` (positive) about its axis.
    fn mixture_pdf(&self, wi: Vec3, cos: f32) -> f32 {
        let [diffuse, glossy, ..] = self.choice;
        let mut pdf = diffuse * cos * FRAC_1_PI;
        if glossy > 0.0 {
            pdf += glossy * self.glossy_pdf(wi);
        }
        pdf
    }

    /// The glossy lobe's share of the smooth lobes' reflectance (summed
    /// over channels): the chance that [`Bsdf::sample`], having chosen a
    /// smooth lobe, chooses the glossy one. 0 without a glossy lobe.
    pub fn glossy_share(&self) -> f32 {
        let [diffuse, glossy, ..] = self.choice;
        if glossy > 0.0 {
            glossy / (diffuse + glossy)
        } else {
            0.0
        }
    }

    /// A direction from the glossy lobe alone (about the mirror direction),
    /// from a uniform point `u` of the unit square; its density is
    /// [`Bsdf::glossy_pdf`]. It may point below the surface.
    pub fn sample_glossy(&self, u: Vec2) -> Vec3 {
        around(self.sp.reflect(self.dir), phong_lobe(u, self.material.phong_exponent))
    }

    /// The solid-angle density of [`Bsdf::sample_glossy`] at `wi`: about
    /// the same axis it draws about ([`SurfacePoint::reflect`]: the mirror
    /// direction about the geometric normal where the shading normal's
    /// points below the surface). About the shading normal's there, a drawn
    /// direction's density could fall below the normal floats: an infinite
    /// weight, and the lobe's estimate off where light grazes a smooth mesh.
    pub fn glossy_pdf(&self, wi: Vec3) -> f32 {
        phong_lobe_pdf(self.sp.reflect(self.dir).dot(wi), self.material.phong_exponent)
    }

    /// The density the other way round: with which [`Bsdf::sample`], for
    /// light arriving back along `wi` (unit, away from the surface), would
    /// produce the direction towards this viewer. Bidirectional methods
    /// weigh a path by how each of its ends could have made it.
    pub fn pdf_reverse(&self, wi: Vec3) -> f32 {
        Bsdf { dir: -wi, ..*self }.pdf(self.wo())
    }

    /// [`Bsdf::sample`] for light carried from the lights (photons), which
    /// arrived along this BSDF's ray: its smooth lobes' way out is drawn
    /// over the surface's side, the diffuse lobe's by the geometric normal's
    /// cosine, and weighed by the adjoint BSDF with Veach's correction,
    /// `f |wo.ns| |wi.ng| / |wo.ng|` over the density (`wo` back where the
    /// light came from). The path tracer's camera paths see light leave
    /// towards directions below the shading normal but above the surface
    /// (the eye may lie there); drawn about the shading normal, light
    /// never left that way (under normals leaning 80 degrees, SPPM's light
    /// bounced off a floor onto the ceiling was 21% low). Exactly
    /// [`Bsdf::sample`]'s draw and weight where the normals agree. `None`
    /// also where the light arrived from below the shading normal's side,
    /// which the smooth lobes do not reflect
    /// ([`SurfacePoint::smooth_lobes_take`]). Specular lobes as
    /// [`Bsdf::sample`]'s (the caller takes their correction).
    pub fn sample_adjoint(&self, u_lobe: f32, rng: &mut Rng) -> Option<BsdfSample> {
        let [diffuse, glossy, ..] = self.choice;
        let sp = self.sp;
        if u_lobe >= diffuse + glossy {
            return self.sample(u_lobe, rng);
        }
        if !sp.smooth_lobes_take(self.wo()) {
            return None;
        }
        let (wi, kind) = self.draw_smooth(u_lobe, sp.ng, rng);
        let cos = wi.dot(sp.ng);
        if cos <= 0.0 {
            return None;
        }
        let pdf = self.mixture_pdf(wi, cos);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wi) * (cos * sp.shading_over_geometric(self.wo())) / pdf,
            pdf: Some(pdf),
            kind,
            indices: None,
        })
    }

    /// A direction from the smooth lobe `u_lobe` picks (below the diffuse
    /// lobe's chance, the diffuse one, drawn by the cosine about `axis`;
    /// else the glossy one, about its mirror direction), and which it is.
    fn draw_smooth(&self, u_lobe: f32, axis: Vec3, rng: &mut Rng) -> (Vec3, ScatterKind) {
        if u_lobe < self.choice[0] {
            (around(axis, cosine_hemisphere(rng.uniform2())), ScatterKind::Diffuse)
        } else {
            (self.sample_glossy(rng.uniform2()), ScatterKind::Glossy)
        }
    }

    /// Solid-angle density with which [`Bsdf::sample_adjoint`] produces `wi`
    /// through its smooth lobes, lobe choice included.
    pub fn pdf_adjoint(&self, wi: Vec3) -> f32 {
        let cos = wi.dot(self.sp.ng);
        if cos <= 0.0 || !self.sp.smooth_lobes_take(self.wo()) {
            return 0.0;
        }
        self.mixture_pdf(wi, cos)
    }

    /// [`Bsdf::pdf_adjoint`] the other way round: the density with which
    /// light arriving back along `wi` would leave towards this viewer.
    pub fn pdf_adjoint_reverse(&self, wi: Vec3) -> f32 {
        Bsdf { dir: -wi, ..*self }.pdf_adjoint(self.wo())
    }

    /// Picks a lobe with `u_lobe` (uniform in `[0, 1)`) in proportion to its
    /// reflectance, then a direction from it with `rng`. Smooth lobes are
    /// sampled as one mixture (their weight is `f cos / pdf` over both), so
    /// the density is the one [`Bsdf::pdf`] gives. `None` when the material
    /// scatters nothing or the direction would leave below the surface.
    pub fn sample(&self, u_lobe: f32, rng: &mut Rng) -> Option<BsdfSample> {
        let [diffuse, glossy, mirror, glass] = self.choice;
        let (sp, m) = (self.sp, self.material);
        let smooth = diffuse + glossy;
        if u_lobe < smooth {
            let (wi, kind) = self.draw_smooth(u_lobe, sp.ns, rng);
            let cos = wi.dot(sp.ns);
            let pdf = self.pdf(wi);
            if cos <= 0.0 || wi.dot(sp.ng) <= 0.0 || pdf <= 0.0 {
                return None;
            }
            return Some(BsdfSample {
                wi,
                weight: self.eval(wi) * cos / pdf,
                pdf: Some(pdf),
                kind,
                indices: None,
            });
        }
        if u_lobe < smooth + mirror {
            return Some(self.mirror(m.mirror / mirror));
        }
        if glass <= 0.0 {
            return None;
        }
        Some(self.dielectric(m.transmittance / glass, rng))
    }

    /// One of the specular lobes (mirror or glass), chosen in proportion to
    /// its reflectance with one number from `rng`. `None` if there is none.
    pub fn sample_specular(&self, rng: &mut Rng) -> Option<BsdfSample> {
        let m = self.material;
        let (mirror, glass) = (m.mirror.element_sum(), m.transmittance.element_sum());
        if mirror + glass <= 0.0 {
            return None;
        }
        Some(if rng.uniform() * (mirror + glass) < mirror {
            self.mirror(m.mirror * ((mirror + glass) / mirror))
        } else {
            self.dielectric(m.transmittance * ((mirror + glass) / glass), rng)
        })
    }

    /// Every specular direction with its weight, none chosen at random (for
    /// Whitted's recursion): the mirror, then the dielectric's Fresnel
    /// reflection and refraction. Where no refracted ray can leave (total
    /// internal reflection, or a shading normal whose refraction would keep
    /// to the near side, with none about the geometric normal either), the
    /// reflection takes all, as [`Bsdf::sample`]'s does.
    pub fn specular_branches(&self) -> impl Iterator<Item = BsdfSample> {
        let m = self.material;
        let mirror = (m.mirror.max_element() > 0.0).then(|| self.mirror(m.mirror));
        let (reflected, refracted) = if m.transmittance.max_element() > 0.0 {
            let (kr, t) = self.sp.refract(self.dir, m.ior);
            match t {
                Some(t) => (
                    Some(self.mirror(m.transmittance * kr)),
                    Some(self.refracted(t, m.transmittance * (1.0 - kr))),
                ),
                None => (Some(self.mirror(m.transmittance)), None),
            }
        } else {
            (None, None)
        };
        [mirror, reflected, refracted].into_iter().flatten()
    }

    fn mirror(&self, weight: Vec3) -> BsdfSample {
        BsdfSample {
            wi: self.sp.reflect(self.dir),
            weight,
            pdf: None,
            kind: ScatterKind::SpecularReflection,
            indices: None,
        }
    }

    fn refracted(&self, wi: Vec3, weight: Vec3) -> BsdfSample {
        let indices = Some(self.sp.indices(self.material.ior));
        BsdfSample { wi, weight, pdf: None, kind: ScatterKind::SpecularTransmission, indices }
    }

    /// The smooth dielectric: refracted with probability `1 - kr`, else
    /// reflected (always on total internal reflection). Fresnel chooses with
    /// exactly its own weights, so `weight` needs no rescaling. Draws a
    /// number only when there is a choice.
    fn dielectric(&self, weight: Vec3, rng: &mut Rng) -> BsdfSample {
        let (kr, refracted) = self.sp.refract(self.dir, self.material.ior);
        match refracted {
            Some(wi) if rng.uniform() >= kr => self.refracted(wi, weight),
            _ => self.mirror(weight),
        }
    }
}

/// Russian roulette (Arvo and Kirk 1990), decided here for every path and
/// photon: with the uniform `u`, a path goes on with probability `q`, and a
/// survivor's weight must then be divided by the returned `q`, which keeps
/// the estimate unbiased. `None`: the path ends.
pub fn russian_roulette(q: f32, u: f32) -> Option<f32> {
    (u < q).then_some(q)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::accel::{Hit, Ray};

    /// A surface point on the plane y = 0 (normal +y), hit from above.
    pub(crate) fn point() -> SurfacePoint {
        let scene = crate::scene::Scene::from_toml(
            r#"
            [camera]
            eye = [0, 1, 0]
            look_at = [0, 0, 0]
            up = [0, 0, 1]
            [materials.m]
            diffuse = 0.5
            [[quad]]
            center = [0, 0, 0]
            u = [0, 0, 2]
            v = [2, 0, 0]
            material = "m"
        "#,
            std::path::Path::new("plane.toml"),
        )
        .unwrap();
        let ray = Ray::new(Vec3::new(0.1, 1.0, 0.2), -Vec3::Y);
        let mesh = &scene.meshes[0];
        let hit = Hit { t: 1.0, u: 0.3, v: 0.3, geom_id: 0, prim_id: 0, ng: mesh.face_normal(0) };
        SurfacePoint::new(&scene, &ray, &hit)
    }

    /// `glossy_pdf` is the density `sample_glossy` draws with, also where
    /// the smooth normal's mirror direction points below the surface (it
    /// then draws about the geometric normal's): over a density `p`'s draws,
    /// the mean of `h / p` is the integral of `h`, here a Phong density of
    /// half the exponent about that axis (its integral 1; `h^2 / p` is
    /// bounded, so the mean settles).
    #[test]
    fn the_glossy_density_is_that_of_the_glossy_draws_at_grazing_light() {
        let m = Material {
            diffuse: Vec3::splat(0.2),
            specular: Vec3::splat(0.5),
            phong_exponent: 20.0,
            ..Material::default()
        };
        let mut sp = point();
        sp.ns = Vec3::new(0.3, 1.0, 0.0).normalize();
        let dir = Vec3::new(1.0, -0.6, 0.0).normalize();
        assert!(
            crate::optics::reflect(dir, sp.ns).dot(sp.ng) < 0.0,
            "the smooth normal's mirror direction is below"
        );
        let axis = sp.reflect(dir);
        let bsdf = Bsdf::new(&m, &sp, dir);
        let mut rng = Rng::new(5, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let wi = bsdf.sample_glossy(rng.uniform2());
            sum += (phong_lobe_pdf(axis.dot(wi), 10.0) / bsdf.glossy_pdf(wi)) as f64;
        }
        let mean = sum / n as f64;
        assert!((mean - 1.0).abs() < 0.03, "mean h / pdf {mean}");
    }

    /// The mean of `weight` over many samples is the albedo seen from `dir`:
    /// what an unbiased sampler must give, lobe choice included.
    fn mean_weight(m: &Material, dir: Vec3) -> Vec3 {
        let sp = point();
        let bsdf = Bsdf::new(m, &sp, dir);
        let mut rng = Rng::new(1, 2);
        let n = 200_000;
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            let u = rng.uniform();
            if let Some(s) = bsdf.sample(u, &mut rng) {
                assert!((s.wi.length() - 1.0).abs() < 1e-4);
                sum += s.weight;
            }
        }
        sum / n as f32
    }

    #[test]
    fn sampling_returns_the_albedo_of_every_lobe_mix() {
        let straight_down = -Vec3::Y;
        let diffuse = Material { diffuse: Vec3::new(0.2, 0.5, 0.8), ..Material::default() };
        let w = mean_weight(&diffuse, straight_down);
        assert!((w - diffuse.diffuse).abs().max_element() < 0.01, "{w}");
        // Diffuse and glossy as one mixture; at normal view the whole lobe
        // is above the surface, so its albedo is exactly `specular`.
        let mixed = Material {
            diffuse: Vec3::splat(0.3),
            specular: Vec3::splat(0.4),
            phong_exponent: 20.0,
            mirror: Vec3::splat(0.2),
            ..Material::default()
        };
        let w = mean_weight(&mixed, straight_down);
        assert!((w - Vec3::splat(0.9)).abs().max_element() < 0.01, "{w}");
    }

    /// Diffuse, glossy and mirror in equal parts.
    fn thirds() -> Material {
        Material {
            diffuse: Vec3::splat(0.3),
            specular: Vec3::splat(0.3),
            phong_exponent: 10.0,
            mirror: Vec3::splat(0.3),
            ..Material::default()
        }
    }

    #[test]
    fn pdf_integrates_to_the_smooth_choice() {
        let m = thirds();
        let sp = point();
        let bsdf = Bsdf::new(&m, &sp, -Vec3::Y);
        // Midpoint rule over the upper hemisphere in (cos theta, phi).
        let (nt, np) = (800, 200);
        let mut integral = 0.0;
        for i in 0..nt {
            let cos = (i as f32 + 0.5) / nt as f32;
            let sin = (1.0 - cos * cos).sqrt();
            for j in 0..np {
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
                integral += bsdf.pdf(Vec3::new(sin * phi.cos(), cos, sin * phi.sin()));
            }
        }
        integral *= std::f32::consts::TAU / (nt * np) as f32;
        assert!((integral - bsdf.smooth_probability()).abs() < 2e-3, "{integral}");
        assert!((bsdf.smooth_probability() - 2.0 / 3.0).abs() < 1e-6);
    }

    #[test]
    fn reverse_pdf_swaps_the_directions() {
        let m = thirds();
        let sp = point();
        let wo = Vec3::new(0.3, 0.8, -0.2).normalize();
        let wi = Vec3::new(-0.5, 0.6, 0.4).normalize();
        let seen = Bsdf::new(&m, &sp, -wo);
        let other_way = Bsdf::new(&m, &sp, -wi);
        assert!((seen.pdf_reverse(wi) - other_way.pdf(wo)).abs() < 1e-6);
        // Diffuse alone: the cosine of the direction produced, over pi,
        // times the chance of the diffuse lobe.
        let diffuse = Material { diffuse: Vec3::splat(0.5), mirror: Vec3::splat(0.5), ..Material::default() };
        let expected = 0.5 * wo.dot(sp.ns) * std::f32::consts::FRAC_1_PI;
        assert!((Bsdf::new(&diffuse, &sp, -wo).pdf_reverse(wi) - expected).abs() < 1e-6);
        assert!((Bsdf::new(&diffuse, &sp, -wo).pdf(wi) - expected).abs() > 1e-3, "asymmetric case");
    }

    #[test]
    fn specular_branches_split_by_fresnel() {
        let glass = Material { transmittance: Vec3::ONE, ior: 1.5, ..Material::default() };
        let sp = point();
        let bsdf = Bsdf::new(&glass, &sp, -Vec3::Y);
        let branches: Vec<BsdfSample> = bsdf.specular_branches().collect();
        assert_eq!(branches.len(), 2);
        // Normal incidence at n = 1.5: 4% reflected straight back, 96% straight through.
        assert!((branches[0].weight.x - 0.04).abs() < 1e-6 && branches[0].wi.abs_diff_eq(Vec3::Y, 1e-6));
        assert!((branches[1].weight.x - 0.96).abs() < 1e-6 && branches[1].wi.abs_diff_eq(-Vec3::Y, 1e-6));
        // Only the refraction changes the medium: from air into the glass.
        assert_eq!((branches[0].indices, branches[1].indices), (None, Some((1.0, 1.5))));
        let kinds: Vec<ScatterKind> = {
            let mut rng = Rng::new(0, 0);
            (0..200).filter_map(|_| bsdf.sample_specular(&mut rng)).map(|s| s.kind).collect()
        };
        let through = kinds.iter().filter(|k| **k == ScatterKind::SpecularTransmission).count();
        assert!((180..200).contains(&through), "about 96% refract: {through} of 200");
    }

    /// Whitted's branches carry all of the glass's light, as a sampled
    /// lobe does on average, also where a leaning shading normal leaves no
    /// refracted ray that can go on (Fresnel from the shading normal below
    /// 1, while the refraction about it keeps to the near side and the one
    /// about the geometric normal is totally reflected). There the
    /// refraction's share was dropped: a 20-triangle glass sphere showed the
    /// light through it a quarter dark, and the path tracer, whose own
    /// samples keep it, got brighter with its samples as the lights' edge
    /// refinement (Whitted's recursion) weighed less.
    #[test]
    fn specular_branches_keep_all_of_the_glass_light() {
        let glass = Material { transmittance: Vec3::splat(0.9), ior: 1.5, ..Material::default() };
        let mut rng = Rng::new(3, 1);
        let mut refraction_fails = 0;
        for i in 0..20_000 {
            let mut sp = point();
            // Mostly from inside the glass, where total reflection is.
            sp.front = i % 4 == 0;
            // Shading normals leaning up to 45 degrees, any way.
            let (way, lean) =
                (rng.uniform() * std::f32::consts::TAU, rng.uniform() * std::f32::consts::FRAC_PI_4);
            sp.ns = around(Vec3::Y, Vec3::new(lean.sin() * way.cos(), lean.sin() * way.sin(), lean.cos()));
            let dir = -around(Vec3::Y, cosine_hemisphere(rng.uniform2()));
            let (kr, t) = sp.refract(dir, glass.ior);
            refraction_fails += usize::from(kr < 1.0 && t.is_none());
            let bsdf = Bsdf::new(&glass, &sp, dir);
            let carried: Vec3 = bsdf.specular_branches().map(|b| b.weight).sum();
            assert!(
                (carried - glass.transmittance).abs().max_element() < 1e-6,
                "{carried} at {dir}, ns {}",
                sp.ns
            );
        }
        // 141 of the 20,000.
        assert!(refraction_fails > 50, "the case is met: {refraction_fails}");
    }

    /// Light's way out of a diffuse surface (`sample_adjoint`): over the
    /// surface's side, its weights average the adjoint BSDF's integral,
    /// `albedo |wo.ns| / |wo.ng|`, under a shading normal leaning 60 degrees;
    /// where the normals agree it is `sample`'s draw and weight, bit for bit;
    /// and light from below the shading normal's side goes on by no smooth lobe.
    #[test]
    fn light_leaves_a_diffuse_surface_by_the_adjoint_bsdf() {
        let matte = Material { diffuse: Vec3::splat(0.5), ..Material::default() };
        let mut sp = point();
        sp.ns = Vec3::new(0.866, 0.5, 0.0);
        let dir = -Vec3::new(-0.2, 1.0, 0.3).normalize();
        let bsdf = Bsdf::new(&matte, &sp, dir);
        let mut rng = Rng::new(9, 2);
        let n = 200_000;
        let (mut sum, mut below) = (0.0f64, 0);
        for _ in 0..n {
            if let Some(s) = bsdf.sample_adjoint(0.0, &mut rng) {
                sum += s.weight.x as f64;
                below += usize::from(s.wi.dot(sp.ns) < 0.0);
            }
        }
        let expected = 0.5 * sp.shading_over_geometric(-dir) as f64;
        assert!((sum / n as f64 / expected - 1.0).abs() < 0.01, "{} against {expected}", sum / n as f64);
        assert!(below > n / 20, "light leaves below the shading normal too: {below}");
        let flat = point();
        let (a, b) = (Bsdf::new(&matte, &flat, dir), Bsdf::new(&matte, &flat, dir));
        let (mut ra, mut rb) = (Rng::new(1, 1), Rng::new(1, 1));
        for _ in 0..100 {
            let (x, y) = (a.sample(0.2, &mut ra).unwrap(), b.sample_adjoint(0.2, &mut rb).unwrap());
            assert_eq!((x.wi, x.weight, x.pdf), (y.wi, y.weight, y.pdf));
        }
        let from_below = Bsdf::new(&matte, &sp, -Vec3::new(-0.8, 0.3, 0.0).normalize());
        assert!(from_below.sample_adjoint(0.0, &mut rng).is_none());
    }

    /// The factor follows the media at the path's two ends: 1 / 1.5^2 in
    /// glass entered from the air, exactly 1 out again, 1.5^2 for a camera
    /// in glass looking out, and 1 again for a path that entered two
    /// crossing shells and left one (it is in the air).
    #[test]
    fn the_radiance_scale_follows_the_media_at_the_ends() {
        let sp = point();
        let glass = Material { transmittance: Vec3::ONE, ior: 1.5, ..Material::default() };
        let branches = |front: bool| {
            let mut sp = sp;
            sp.front = front;
            let refracted = Bsdf::new(&glass, &sp, -Vec3::Y).specular_branches().last().unwrap();
            assert_eq!(refracted.kind, ScatterKind::SpecularTransmission);
            refracted
        };
        let (enter, leave) = (branches(true), branches(false));
        assert_eq!((enter.indices, leave.indices), (Some((1.0, 1.5)), Some((1.5, 1.0))));
        let reflected = Bsdf::new(&glass, &sp, -Vec3::Y).specular_branches().next().unwrap();
        let one = RadianceScale::ONE;
        assert_eq!(one.factor(), 1.0);
        assert_eq!(one.after(&reflected), one);
        assert!((one.after(&enter).factor() - 1.0 / 2.25).abs() < 1e-7);
        assert_eq!(one.after(&enter).after(&reflected).after(&leave).factor(), 1.0);
        assert!((one.after(&leave).factor() - 2.25).abs() < 1e-6);
        assert_eq!(one.after(&enter).after(&enter).after(&leave).factor(), 1.0);
        assert_eq!(one.after(&leave).after(&enter).factor(), 1.0);
    }

    #[test]
    fn roulette_keeps_the_expected_weight() {
        let mut rng = Rng::new(5, 5);
        let n = 100_000;
        let q = 0.3;
        let mean: f32 =
            (0..n).filter_map(|_| russian_roulette(q, rng.uniform())).map(|q| 1.0 / q).sum::<f32>()
                / n as f32;
        assert!((mean - 1.0).abs() < 0.02, "{mean}");
        assert_eq!(russian_roulette(0.0, 0.0), None);
    }
}
