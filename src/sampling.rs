//! Random numbers and sample placement.
//!
//! Every pixel and every photon gets its own [`Rng`] stream derived from its
//! index, so results never depend on which thread did the work or in which
//! order: an image is bit-identical whatever the thread count.

use glam::{Vec2, Vec3};

/// Where a pixel's camera samples get their random numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SamplerKind {
    /// One PCG32 stream per pixel, its samples stratified over the pixel
    /// and independent otherwise.
    Independent,
    /// Padded Owen-scrambled Sobol points per sample ([`Rng::sobol`]):
    /// every dimension pair (pixel position, light sample, bounce) is
    /// stratified over the pixel's samples. The default: 6-30% lower RMSE
    /// at equal samples (BENCHMARKS.md). Photons too: a light's photons
    /// leave it stratified in position and direction together ([`Sobol4`]).
    #[default]
    Sobol,
}

impl SamplerKind {
    /// Every sampler, by its name in scene files and on the command line.
    pub const NAMES: [(&'static str, SamplerKind); 2] =
        [("independent", SamplerKind::Independent), ("sobol", SamplerKind::Sobol)];

    /// Its name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(_, kind)| *kind == self)
            .map(|(name, _)| *name)
            .expect("every sampler is named")
    }

    /// The stream of its own that sample `index` of `stream` (a pixel)
    /// draws from under `seed`, if this sampler gives each sample one
    /// (Sobol: [`Rng::sobol`]); `None` when the samples share the pixel's
    /// stream (independent).
    pub fn sample_stream(self, seed: u64, stream: u64, index: u32) -> Option<Rng> {
        (self == SamplerKind::Sobol).then(|| Rng::sobol(seed, stream, index))
    }
}

impl std::str::FromStr for SamplerKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        crate::accel::named(&Self::NAMES, s)
    }
}

/// A pixel sample's (or a photon's) random numbers: PCG32 (O'Neill 2014),
/// small, fast, statistically good and cheap to seed into independent
/// streams; or, made by [`Rng::sobol`], a low-discrepancy stream whose every
/// 2D draw is the next dimension pair of an Owen-scrambled Sobol sequence.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    inc: u64,
    sobol: Option<Sobol>,
}

/// Padded Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based
/// Owen Scrambling"; pbrt-v4's `PaddedSobolSampler`): each dimension pair
/// is the 2D Sobol (0,2)-sequence at this sample's index, the index shuffled
/// and both coordinates scrambled with seeds hashed from the stream and the
/// pair's number. Any prefix of 2^k samples of a pixel is stratified in
/// every pair, whatever the other pairs; every value is uniform, so the
/// estimates stay unbiased.
#[derive(Debug, Clone)]
struct Sobol {
    /// The sample's index within its pixel, its bits reversed (the form
    /// Owen scrambling works on).
    index_reversed: u32,
    /// Hash of the seed and the stream (pixel).
    seed: u32,
    /// The next dimension pair to hand out.
    pair: u32,
    /// The seeds of the pairs drawn so far by this stream's samples, if it
    /// keeps them ([`Rng::sobol_kept`]): the same for every sample of a
    /// pixel, so a stream restarted at its next sample ([`Rng::restart`])
    /// hashes them once (four hashes a pair, a third of the Sobol points'
    /// cost in the path tracer: BENCHMARKS.md). A stream drawn for one
    /// sample keeps none, and allocates nothing.
    seeds: Option<Vec<PairSeeds>>,
    /// The PCG32 state the stream starts from (its [`Rng::next_u32`]).
    start_state: u64,
}

/// A dimension pair's seeds: for its index shuffle, and for its two
/// coordinates' scrambles.
#[derive(Debug, Clone, Copy)]
struct PairSeeds {
    index: u32,
    x: u32,
    y: u32,
}

impl PairSeeds {
    /// The seeds of pair `pair` of the stream hashed to `seed`.
    fn of(seed: u32, pair: u32) -> PairSeeds {
        let seed = mix(seed, pair);
        PairSeeds { index: mix(seed, 1), x: mix(seed, 2), y: mix(seed, 3) }
    }
}

/// A 32-bit mix of two words (the `hash_combine` of Boost with a final
/// avalanche from MurmurHash3).
fn mix(a: u32, b: u32) -> u32 {
    let mut h = a ^ b.wrapping_add(0x9e37_79b9).wrapping_add(a << 6).wrapping_add(a >> 2);
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// Owen scrambling of the bits of `x` (most significant first) by `seed`:
/// Burley's nested uniform scramble, the Laine-Karras permutation on the
/// reversed bits.
#[cfg(test)]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    scramble_reversed(x.reverse_bits(), seed)
}

/// [`owen_scramble`] of the number whose reversed bits are `reversed`:
/// `reverse(LK(reversed + seed))`, with the Laine-Karras permutation `LK`.
/// Taking and giving the forms the Sobol code has at hand saves bit
/// reversals, which x86 has no instruction for.
fn scramble_reversed(reversed: u32, seed: u32) -> u32 {
    let mut v = reversed.wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v.reverse_bits()
}

/// The first two dimensions of the Sobol sequence at `index`, as 32-bit
/// fractions: van der Corput, and the dimension with generator polynomial
/// `x + 1` (direction numbers `v_k = v_(k-1) ^ (v_(k-1) >> 1)`). The second
/// is the XOR of the direction numbers of the index's set bits, read a byte
/// at a time from tables: shuffled indices use all 32 bits, and a loop over
/// them branched unpredictably (5% of a photon-mapped render).
#[cfg(test)]
fn sobol_pair(index: u32) -> (u32, u32) {
    (index.reverse_bits(), sobol_second_reversed(index).reverse_bits())
}

/// The second dimension of [`sobol_pair`] with its bits reversed.
fn sobol_second_reversed(index: u32) -> u32 {
    sobol_reversed(&SOBOL_BYTES, index)
}

/// A Sobol dimension at `index`, bits reversed, from its byte tables.
#[inline]
fn sobol_reversed(tables: &[[u32; 256]; 4], index: u32) -> u32 {
    (0..4).fold(0, |y, byte| y ^ tables[byte][(index >> (8 * byte)) as usize & 0xff])
}

/// The 32 direction numbers of a Sobol dimension (as 32-bit fractions,
/// most significant first) from its primitive polynomial of `degree`, its
/// inner coefficients `a` (bits, highest power first) and its initial
/// numbers `m` (Joe and Kuo 2008): `v_k = m_k / 2^k` for `k <= degree`,
/// then `v_k = a_1 v_(k-1) ^ ... ^ a_(degree-1) v_(k-degree+1) ^ v_(k-degree)
/// ^ (v_(k-degree) >> degree)`.
const fn direction_numbers(degree: usize, a: u32, m: [u32; 3]) -> [u32; 32] {
    let mut v = [0u32; 32];
    let mut k = 0;
    while k < 32 {
        if k < degree {
            v[k] = m[k] << (31 - k);
        } else {
            let mut x = v[k - degree] ^ (v[k - degree] >> degree);
            let mut j = 1;
            while j < degree {
                if (a >> (degree - 1 - j)) & 1 != 0 {
                    x ^= v[k - j];
                }
                j += 1;
            }
            v[k] = x;
        }
        k += 1;
    }
    v
}

/// For each byte of an index and each value of that byte, the XOR of the
/// direction numbers of its set bits, bits reversed: a dimension's value
/// at any index in four lookups (a loop over the bits of a shuffled index
/// branched unpredictably: 5% of a photon-mapped render).
const fn byte_tables(directions: [u32; 32]) -> [[u32; 256]; 4] {
    let mut tables = [[0u32; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut value = 0;
        while value < 256 {
            let mut y = 0;
            let mut bit = 0;
            while bit < 8 {
                if value & (1 << bit) != 0 {
                    y ^= directions[8 * byte + bit];
                }
                bit += 1;
            }
            tables[byte][value] = y.reverse_bits();
            value += 1;
        }
        byte += 1;
    }
    tables
}

/// The second Sobol dimension (polynomial `x + 1`): `v_k = v_(k-1) ^ (v_(k-1) >> 1)`.
const SOBOL_BYTES: [[u32; 256]; 4] = byte_tables(direction_numbers(1, 0, [1, 0, 0]));

/// The third and fourth (Joe and Kuo's dimensions 3 and 4: `x^2 + x + 1`
/// with `m = 1, 3`, and `x^3 + x + 1` with `m = 1, 3, 1`).
const SOBOL_BYTES_3RD: [[u32; 256]; 4] = byte_tables(direction_numbers(2, 1, [1, 3, 0]));
const SOBOL_BYTES_4TH: [[u32; 256]; 4] = byte_tables(direction_numbers(3, 1, [1, 3, 1]));

/// A 32-bit fraction as a float in `[0, 1)`.
fn fraction(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

impl Sobol {
    /// Sample `index` of the stream hashed to `seed`, whose PCG32 words
    /// start from `start_state`.
    fn new(seed: u32, index: u32, start_state: u64, keep: bool) -> Sobol {
        let seeds = keep.then(Vec::new);
        Sobol { index_reversed: index.reverse_bits(), seed, pair: 0, seeds, start_state }
    }

    /// The pair: `index = owen_scramble(sample index)`, then the Sobol
    /// point at `index` with each coordinate Owen-scrambled, each with its
    /// own seed. The x coordinate is `index` reversed, so scrambling it
    /// starts from `index` itself.
    #[inline]
    fn next_pair(&mut self) -> Vec2 {
        let (seeds, index) = self.next_index();
        let x = scramble_reversed(index, seeds.x);
        let y = scramble_reversed(sobol_second_reversed(index), seeds.y);
        Vec2::new(fraction(x), fraction(y))
    }

    /// The x coordinate of [`Sobol::next_pair`] alone (a pair used for one
    /// number): the y coordinate's scramble and table lookups skipped.
    #[inline]
    fn next_one(&mut self) -> f32 {
        let (seeds, index) = self.next_index();
        fraction(scramble_reversed(index, seeds.x))
    }

    /// The next pair's seeds and its scrambled index.
    #[inline]
    fn next_index(&mut self) -> (PairSeeds, u32) {
        let pair = self.pair;
        self.pair += 1;
        // Pairs are drawn in order: one not kept yet is the next to keep.
        let seeds = match &mut self.seeds {
            None => PairSeeds::of(self.seed, pair),
            Some(kept) => match kept.get(pair as usize) {
                Some(&seeds) => seeds,
                None => {
                    let seeds = PairSeeds::of(self.seed, pair);
                    kept.push(seeds);
                    seeds
                }
            },
        };
        (seeds, scramble_reversed(self.index_reversed, seeds.index))
    }
}

/// A 4D Owen-scrambled Sobol sequence: dimensions 0 to 3 of the Sobol
/// sequence at one shuffled index, each coordinate scrambled on its own
/// (Burley 2020), for a light sample's position and direction together.
/// Padded pairs stratify each of the two alone, which for a photon aimed
/// past an object, say, is no better than independent numbers (the test
/// `sobol_photons_leave_a_light_stratified_in_position_and_direction`);
/// these points are a (3, m, 4)-net in every block of 2^m. The scrambles
/// are hashed once per sequence, so a point costs five scrambles and
/// twelve table lookups.
#[derive(Debug, Clone, Copy)]
pub struct Sobol4 {
    /// The index shuffle's seed, and each coordinate's.
    index_seed: u32,
    seeds: [u32; 4],
}

impl Sobol4 {
    /// The sequence of `stream` (a light) under `seed`.
    pub fn new(seed: u64, stream: u64) -> Sobol4 {
        let words = [seed as u32, (seed >> 32) as u32, stream as u32, (stream >> 32) as u32];
        let hashed = words.into_iter().fold(0x5_0B04, mix);
        Sobol4 { index_seed: mix(hashed, 1), seeds: [2, 3, 4, 5].map(|d| mix(hashed, d)) }
    }

    /// Point `index` of the sequence, as two pairs of uniforms in `[0, 1)`.
    pub fn point(&self, index: u32) -> (Vec2, Vec2) {
        let i = scramble_reversed(index.reverse_bits(), self.index_seed);
        let [s0, s1, s2, s3] = self.seeds;
        let x0 = scramble_reversed(i, s0);
        let x1 = scramble_reversed(sobol_second_reversed(i), s1);
        let x2 = scramble_reversed(sobol_reversed(&SOBOL_BYTES_3RD, i), s2);
        let x3 = scramble_reversed(sobol_reversed(&SOBOL_BYTES_4TH, i), s3);
        (Vec2::new(fraction(x0), fraction(x1)), Vec2::new(fraction(x2), fraction(x3)))
    }
}

impl Rng {
    const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

    /// The generator for `stream` (e.g. a pixel or photon index) under `seed`.
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut rng = Rng { state: 0, inc: (stream << 1) | 1, sobol: None };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The low-discrepancy stream of sample `index` of `stream` (a pixel)
    /// under `seed`: [`Rng::uniform2`] and [`Rng::uniform`] hand out
    /// successive dimensions of padded Owen-scrambled Sobol points (see
    /// `Sobol`); [`Rng::next_u32`] stays PCG32.
    pub fn sobol(seed: u64, stream: u64, index: u32) -> Rng {
        Rng::sobol_keeping(seed, stream, index, false)
    }

    /// [`Rng::sobol`], number for number, for a pixel's samples to share:
    /// [`Rng::restart`] it at each next sample, and it hashes the seeds of
    /// the dimension pairs, the same for every sample, only once.
    pub fn sobol_kept(seed: u64, stream: u64, index: u32) -> Rng {
        Rng::sobol_keeping(seed, stream, index, true)
    }

    fn sobol_keeping(seed: u64, stream: u64, index: u32, keep: bool) -> Rng {
        let words = [seed as u32, (seed >> 32) as u32, stream as u32, (stream >> 32) as u32];
        let hashed = words.into_iter().fold(0x5eed_u32, mix);
        let pcg = Rng::new(seed, stream);
        Rng { sobol: Some(Sobol::new(hashed, index, pcg.state, keep)), ..pcg }
    }

    /// This stream at another sample `index` of its stream: what
    /// [`Rng::sobol`] with the same seed and stream makes, number for
    /// number (without hashing again the pair seeds its samples share, if
    /// made by [`Rng::sobol_kept`]). A stream of independent numbers is
    /// left as it is.
    pub fn restart(&mut self, index: u32) {
        if let Some(sobol) = &mut self.sobol {
            sobol.index_reversed = index.reverse_bits();
            sobol.pair = 0;
            self.state = sobol.start_state;
        }
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in `[0, 1)` (from a Sobol stream: the first coordinate of
    /// the next dimension pair).
    pub fn uniform(&mut self) -> f32 {
        match &mut self.sobol {
            Some(sobol) => sobol.next_one(),
            None => fraction(self.next_u32()),
        }
    }

    /// Two uniforms in `[0, 1)` (from a Sobol stream: the next dimension pair).
    pub fn uniform2(&mut self) -> Vec2 {
        match &mut self.sobol {
            Some(sobol) => sobol.next_pair(),
            None => Vec2::new(self.uniform(), self.uniform()),
        }
    }
}

/// The grid `(columns, rows)` for stratifying `count` samples over a square:
/// the most nearly square factorisation of `count`.
pub fn strata(count: u32) -> (u32, u32) {
    let count = count.max(1);
    let mut columns = (count as f32).sqrt() as u32;
    while !count.is_multiple_of(columns) {
        columns -= 1;
    }
    (columns, count / columns)
}

/// Sample `index` of `count` stratified (jittered) samples over the unit square:
/// uniform within its own cell of the [`strata`] grid.
pub fn stratified(index: u32, count: u32, rng: &mut Rng) -> Vec2 {
    Strata::of(count).sample(index, rng)
}

/// The [`strata`] grid of a count, worked out once for a loop over its
/// samples (the factorisation's square root and divisions were, per gather
/// ray, a share of final gathering's own work).
#[derive(Debug, Clone, Copy)]
pub struct Strata {
    columns: u32,
    rows: u32,
}

impl Strata {
    /// The grid for `count` samples.
    pub fn of(count: u32) -> Strata {
        let (columns, rows) = strata(count);
        Strata { columns, rows }
    }

    /// Sample `index`, as [`stratified`] draws it.
    #[inline]
    pub fn sample(&self, index: u32, rng: &mut Rng) -> Vec2 {
        let Strata { columns, rows } = *self;
        let cell = Vec2::new((index % columns) as f32, (index / columns % rows) as f32);
        (cell + rng.uniform2()) / Vec2::new(columns as f32, rows as f32)
    }
}

/// A cosine-weighted direction about +z from two uniforms (Malley's method:
/// a uniform point on the disk lifted to the hemisphere); pdf `cos / pi`.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

/// A direction about +z distributed as the normalised Phong lobe `cos^e`
/// (pdf `(e + 1) / (2 pi) cos^e` of the angle to +z).
pub fn phong_lobe(u: Vec2, exponent: f32) -> Vec3 {
    let cos = u.x.powf(1.0 / (exponent + 1.0));
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// The density of [`phong_lobe`] at a direction whose angle to the lobe's
/// axis has cosine `cos`: `(e + 1) / (2 pi) cos^e` (0 behind the axis).
pub fn phong_lobe_pdf(cos: f32, exponent: f32) -> f32 {
    (exponent + 1.0) / std::f32::consts::TAU * cos.max(0.0).powf(exponent)
}

/// A direction about +z uniform in solid angle within the cone whose
/// half-angle has `1 - cos` equal to `one_minus_cos_max` (given so, a cone
/// of a hundredth of a degree keeps its width); pdf `1 / (2 pi (1 - cos_max))`.
pub fn uniform_cone(u: Vec2, one_minus_cos_max: f32) -> Vec3 {
    let one_minus_cos = u.x * one_minus_cos_max;
    let cos = 1.0 - one_minus_cos;
    let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// A uniformly distributed unit vector; pdf `1 / (4 pi)`.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// `local` (with +z as the axis) turned so that +z becomes the unit vector `n`
/// (orthonormal basis of Duff et al. 2017, no branches on `n` near the poles).
pub fn around(n: Vec3, local: Vec3) -> Vec3 {
    Frame::new(n).to_world(local)
}

/// The orthonormal frame [`around`] turns to: two unit tangents and the unit
/// normal `n` (Duff et al. 2017). Worked out once, for many directions.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    t: Vec3,
    s: Vec3,
    n: Vec3,
}

impl Frame {
    /// The frame about the unit vector `n`.
    pub fn new(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let s = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { t, s, n }
    }

    /// `local` (+z the normal) in world coordinates.
    pub fn to_world(&self, local: Vec3) -> Vec3 {
        local.x * self.t + local.y * self.s + local.z * self.n
    }

    /// The world direction `d` in this frame: the inverse of [`Frame::to_world`].
    pub fn to_local(&self, d: Vec3) -> Vec3 {
        Vec3::new(d.dot(self.t), d.dot(self.s), d.dot(self.n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_tables_match_the_direction_numbers_bit_by_bit() {
        // The definition: XOR of v_k over the set bits k of the index.
        let by_bits = |index: u32| {
            let (mut y, mut v) = (0u32, 1u32 << 31);
            for k in 0..32 {
                if index >> k & 1 != 0 {
                    y ^= v;
                }
                v ^= v >> 1;
            }
            y
        };
        let mut rng = Rng::new(4, 4);
        for index in (0..4096).chain((0..4096).map(|_| rng.next_u32())).chain([u32::MAX, 1 << 31]) {
            assert_eq!(sobol_pair(index).1, by_bits(index), "index {index:#x}");
        }
    }

    #[test]
    fn the_third_and_fourth_dimensions_are_joe_and_kuos() {
        // Sobol points 0..63 of dimensions 3 and 4 in 64ths, from SciPy's
        // `qmc.Sobol(d=4, scramble=False)` (Joe and Kuo's numbers; SciPy
        // lists them in Gray-code order, here by index).
        let third = [
            0, 32, 48, 16, 24, 56, 40, 8, 36, 4, 20, 52, 60, 28, 12, 44, 58, 26, 10, 42, 34, 2, 18, 50, 30,
            62, 46, 14, 6, 38, 54, 22, 23, 55, 39, 7, 15, 47, 63, 31, 51, 19, 3, 35, 43, 11, 27, 59, 45, 13,
            29, 61, 53, 21, 5, 37, 9, 41, 57, 25, 17, 49, 33, 1,
        ];
        let fourth = [
            0, 32, 48, 16, 8, 40, 56, 24, 20, 52, 36, 4, 28, 60, 44, 12, 62, 30, 14, 46, 54, 22, 6, 38, 42,
            10, 26, 58, 34, 2, 18, 50, 29, 61, 45, 13, 21, 53, 37, 5, 9, 41, 57, 25, 1, 33, 49, 17, 35, 3,
            19, 51, 43, 11, 27, 59, 55, 23, 7, 39, 63, 31, 15, 47,
        ];
        for index in 0..64u32 {
            let at = |tables| sobol_reversed(tables, index).reverse_bits() >> 26;
            assert_eq!(at(&SOBOL_BYTES_3RD), third[index as usize], "index {index}");
            assert_eq!(at(&SOBOL_BYTES_4TH), fourth[index as usize], "index {index}");
        }
    }

    /// Whether 256 4D points (two pairs each) are a
    /// (3, 8, 4)-net in base 2, as the first four Sobol dimensions are:
    /// every box of volume 2^-5 whose sides are halvings of the axes (2^k_d
    /// parts on axis d, the k_d summing to 5) holds 8 samples.
    fn is_a_3_8_4_net(point: impl Fn(u32) -> (Vec2, Vec2)) -> bool {
        let points: Vec<[f32; 4]> = (0..256)
            .map(|i| {
                let (a, b) = point(i);
                [a.x, a.y, b.x, b.y]
            })
            .collect();
        let splits = (0..6usize.pow(4)).map(|n| [n % 6, n / 6 % 6, n / 36 % 6, n / 216]);
        splits.filter(|k| k.iter().sum::<usize>() == 5).all(|k| {
            let mut boxes = [0u32; 32];
            for p in &points {
                let cell = (0..4).fold(0, |cell, d| (cell << k[d]) | (p[d] * (1 << k[d]) as f32) as usize);
                boxes[cell] += 1;
            }
            boxes.iter().all(|&n| n == 8)
        })
    }

    #[test]
    fn a_4d_stream_is_stratified_in_its_first_four_dimensions() {
        for seed in [1, 2, 3] {
            let sequence = Sobol4::new(seed, 9);
            assert!(is_a_3_8_4_net(|i| sequence.point(i)), "seed {seed}");
        }
        // Padded pairs are not, across pairs.
        assert!(!is_a_3_8_4_net(|i| {
            let mut rng = Rng::sobol(1, 9, i);
            (rng.uniform2(), rng.uniform2())
        }));
    }

    #[test]
    fn pairs_are_the_scrambled_sobol_points_of_the_scrambled_index() {
        // The definition, with every bit reversal spelled out.
        let by_definition = |seed: u32, index: u32, pair: u32| {
            let seed = mix(seed, pair);
            let index = owen_scramble(index, mix(seed, 1));
            let (x, y) = sobol_pair(index);
            Vec2::new(fraction(owen_scramble(x, mix(seed, 2))), fraction(owen_scramble(y, mix(seed, 3))))
        };
        let mut rng = Rng::new(8, 8);
        for _ in 0..2000 {
            let (seed, index) = (rng.next_u32(), rng.next_u32() % 1024);
            let mut sobol = Sobol::new(seed, index, 0, index % 2 == 0);
            for pair in 0..4 {
                assert_eq!(sobol.next_pair(), by_definition(seed, index, pair));
            }
            // One number alone is its pair's x coordinate, and uses up the pair.
            let mut sobol = Sobol::new(seed, index, 0, index % 2 == 0);
            for pair in 0..4 {
                assert_eq!(sobol.next_one(), by_definition(seed, index, pair).x);
            }
        }
    }

    #[test]
    fn a_restarted_stream_draws_what_a_new_one_does() {
        // Samples of one pixel drawing different numbers of pairs, single
        // numbers and PCG words, through one stream restarted at each.
        let draw = |rng: &mut Rng, sample: u32| -> Vec<u32> {
            (0..(sample * 7 % 13) + 1)
                .flat_map(|k| match k % 3 {
                    0 => {
                        let p = rng.uniform2();
                        vec![p.x.to_bits(), p.y.to_bits()]
                    }
                    1 => vec![rng.uniform().to_bits()],
                    _ => vec![rng.next_u32()],
                })
                .collect()
        };
        // Kept seeds or not, a restarted stream is a new one.
        for mut restarted in [Rng::sobol_kept(4, 77, 0), Rng::sobol(4, 77, 0)] {
            for sample in 0..40 {
                restarted.restart(sample);
                assert_eq!(
                    draw(&mut restarted, sample),
                    draw(&mut Rng::sobol(4, 77, sample), sample),
                    "sample {sample}"
                );
            }
        }
        // An independent stream goes on.
        let (mut a, mut b) = (Rng::new(1, 2), Rng::new(1, 2));
        a.next_u32();
        a.restart(5);
        b.next_u32();
        assert_eq!(a.next_u32(), b.next_u32());
    }

    #[test]
    fn the_unscrambled_sobol_pair_is_the_textbook_one() {
        let first: Vec<(f32, f32)> =
            (0..8).map(sobol_pair).map(|(x, y)| (fraction(x), fraction(y))).collect();
        // y: the XOR of the direction numbers 0.1, 0.11, 0.101 (binary) of
        // the index's set bits.
        let expected = [
            (0.0, 0.0),
            (0.5, 0.5),
            (0.25, 0.75),
            (0.75, 0.25),
            (0.125, 0.625),
            (0.625, 0.125),
            (0.375, 0.375),
            (0.875, 0.875),
        ];
        assert_eq!(first, expected);
    }

    /// Every dimension pair of the first 2^k samples of a pixel is a
    /// (0, 2)-net: each elementary box of area 1 / 2^k (1 x 2^k, 2 x 2^(k-1),
    /// ... cells) holds exactly one point, also after the scrambling.
    #[test]
    fn scrambled_sobol_pairs_stay_stratified() {
        let n = 64u32;
        for (seed, pixel) in [(0, 0), (7, 1234), (u64::MAX, 99)] {
            // Dimension pairs 0 (camera jitter) and 5 (some bounce later).
            for pair in [0, 5] {
                let points: Vec<Vec2> = (0..n)
                    .map(|i| {
                        let mut rng = Rng::sobol(seed, pixel, i);
                        for _ in 0..pair {
                            rng.uniform2();
                        }
                        rng.uniform2()
                    })
                    .collect();
                for k in 0..=6 {
                    let (cols, rows) = (1u32 << k, n >> k);
                    let mut seen = vec![false; n as usize];
                    for p in &points {
                        let cell = (p.x * cols as f32) as u32 + cols * (p.y * rows as f32) as u32;
                        assert!(!seen[cell as usize], "pair {pair}: two points in a {cols}x{rows} cell");
                        seen[cell as usize] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn sobol_values_are_uniform_across_pixels() {
        // The first sample of many pixels: uniform, so the mean is 1/2 and
        // the mean square 1/3 (within 1%).
        let n = 100_000;
        let (mut sum, mut squares) = (0.0f64, 0.0f64);
        for pixel in 0..n {
            let mut rng = Rng::sobol(3, pixel, 0);
            for v in rng.uniform2().to_array().into_iter().chain([rng.uniform()]) {
                sum += v as f64;
                squares += (v * v) as f64;
            }
        }
        let count = 3.0 * n as f64;
        assert!((sum / count - 0.5).abs() < 0.005, "mean {}", sum / count);
        assert!((squares / count - 1.0 / 3.0).abs() < 0.0033, "mean square {}", squares / count);
    }

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::new(7, 3);
                move |_| r.next_u32()
            })
            .collect();
        let again: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::new(7, 3);
                move |_| r.next_u32()
            })
            .collect();
        let other: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::new(7, 4);
                move |_| r.next_u32()
            })
            .collect();
        assert_eq!(a, again);
        assert_ne!(a, other);
    }

    #[test]
    fn uniforms_lie_in_the_unit_interval_with_mean_one_half() {
        let mut r = Rng::new(1, 1);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.uniform();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.005);
    }

    #[test]
    fn cosine_hemisphere_has_the_cosine_distribution() {
        // E[cos] under pdf cos/pi is 2/3; every sample is a unit vector up.
        let mut r = Rng::new(2, 2);
        let n = 100_000;
        let mut mean_cos = 0.0f64;
        for _ in 0..n {
            let d = cosine_hemisphere(r.uniform2());
            assert!((d.length() - 1.0).abs() < 1e-5 && d.z >= 0.0);
            mean_cos += d.z as f64 / n as f64;
        }
        assert!((mean_cos - 2.0 / 3.0).abs() < 0.005, "{mean_cos}");
    }

    #[test]
    fn phong_lobe_pdf_integrates_to_one_and_matches_the_sampler() {
        for e in [1.0f32, 20.0] {
            // Midpoint rule in cos over the hemisphere: integral of pdf d omega = 1.
            let steps = 100_000;
            let integral: f64 =
                (0..steps).map(|i| phong_lobe_pdf((i as f32 + 0.5) / steps as f32, e) as f64).sum::<f64>()
                    * std::f64::consts::TAU
                    / steps as f64;
            assert!((integral - 1.0).abs() < 1e-3, "e = {e}: {integral}");
            // Under that pdf E[cos] = (e + 1) / (e + 2); the sampler must agree.
            let mut r = Rng::new(6, 6);
            let n = 100_000;
            let mean: f32 = (0..n).map(|_| phong_lobe(r.uniform2(), e).z).sum::<f32>() / n as f32;
            assert!((mean - (e + 1.0) / (e + 2.0)).abs() < 0.005, "e = {e}: {mean}");
        }
    }

    #[test]
    fn uniform_sphere_is_centred() {
        let mut r = Rng::new(4, 4);
        let n = 100_000;
        let mean: Vec3 = (0..n).map(|_| uniform_sphere(r.uniform2())).sum::<Vec3>() / n as f32;
        assert!(mean.length() < 0.01, "{mean}");
    }

    #[test]
    fn to_local_undoes_to_world() {
        let mut rng = Rng::new(2, 9);
        for _ in 0..100 {
            let frame = Frame::new(uniform_sphere(rng.uniform2()));
            let d = uniform_sphere(rng.uniform2());
            assert!(frame.to_world(frame.to_local(d)).abs_diff_eq(d, 1e-5));
            assert!(frame.to_local(frame.to_world(d)).abs_diff_eq(d, 1e-5));
        }
    }

    #[test]
    fn around_maps_z_to_the_normal_orthonormally() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.81).normalize(),
            Vec3::new(0.0, 1e-7, -1.0).normalize(),
        ] {
            assert!(around(n, Vec3::Z).abs_diff_eq(n, 1e-6));
            let (x, y) = (around(n, Vec3::X), around(n, Vec3::Y));
            assert!(x.dot(y).abs() < 1e-6 && x.dot(n).abs() < 1e-6 && y.dot(n).abs() < 1e-6);
            assert!((x.length() - 1.0).abs() < 1e-6 && (y.length() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn stratified_samples_fill_every_cell_once() {
        assert_eq!(strata(16), (4, 4));
        assert_eq!(strata(8), (2, 4));
        assert_eq!(strata(7), (1, 7));
        let mut r = Rng::new(0, 0);
        let (c, rows) = strata(12);
        let mut seen = [false; 12];
        for i in 0..12 {
            let s = stratified(i, 12, &mut r);
            let cell = (s.x * c as f32) as usize + (s.y * rows as f32) as usize * c as usize;
            assert!(!seen[cell]);
            seen[cell] = true;
        }
    }
}
