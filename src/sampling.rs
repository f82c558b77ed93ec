//! Random numbers and sample placement.
//!
//! Every pixel and every photon gets its own [`Rng`] stream derived from its
//! index, so results never depend on which thread did the work or in which
//! order: an image is bit-identical whatever the thread count.

use glam::Vec2;

/// PCG32 (O'Neill 2014): small, fast, statistically good, and cheap to seed
/// into independent streams.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

    /// The generator for `stream` (e.g. a pixel or photon index) under `seed`.
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut rng = Rng { state: 0, inc: (stream << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Two uniforms in `[0, 1)`.
    pub fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
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
    let (columns, rows) = strata(count);
    let cell = Vec2::new((index % columns) as f32, (index / columns % rows) as f32);
    (cell + rng.uniform2()) / Vec2::new(columns as f32, rows as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

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
