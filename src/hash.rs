//! A small, stable 64-bit hash (FNV-1a, over bytes or whole 32-bit words)
//! for fingerprints that are written to files and compared across runs and
//! machines: which scene and settings a photon map or a tile was made for,
//! and checksums. `std`'s hashers promise no stability between releases.

use glam::Vec3;

/// FNV-1a, 64 bits.
#[derive(Debug, Clone, Copy)]
pub struct Fnv64(u64);

const PRIME: u64 = 0x0000_0100_0000_01B3;

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Adds bytes, one at a time.
    pub fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(PRIME);
        }
        self
    }

    /// Adds a 32-bit word in one step (four times faster than its bytes;
    /// bulk data goes through here).
    pub fn word(&mut self, w: u32) -> &mut Self {
        self.0 = (self.0 ^ w as u64).wrapping_mul(PRIME);
        self
    }

    /// Adds a 64-bit value as two words.
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.word(v as u32).word((v >> 32) as u32)
    }

    /// Adds the bits of some vectors.
    pub fn vec3s(&mut self, vs: &[Vec3]) -> &mut Self {
        for v in vs {
            self.word(v.x.to_bits()).word(v.y.to_bits()).word(v.z.to_bits());
        }
        self
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// The hash of some bytes, taken a word at a time (any tail byte-wise):
/// the checksum of files.
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut h = Fnv64::default();
    let mut words = bytes.chunks_exact(4);
    for w in &mut words {
        h.word(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
    }
    h.bytes(words.remainder());
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_of_known_strings() {
        // The published FNV-1a 64 values.
        assert_eq!(Fnv64::default().bytes(b"").finish(), 0xcbf29ce484222325);
        assert_eq!(Fnv64::default().bytes(b"a").finish(), 0xaf63dc4c8601ec8c);
        assert_eq!(Fnv64::default().bytes(b"foobar").finish(), 0x85944171f73967e8);
    }

    #[test]
    fn a_checksum_sees_every_byte() {
        let data: Vec<u8> = (0..1001u32).map(|i| (i * 7) as u8).collect();
        let sum = checksum(&data);
        for i in [0, 3, 4, 500, 1000] {
            let mut changed = data.clone();
            changed[i] ^= 1;
            assert_ne!(checksum(&changed), sum, "byte {i}");
        }
    }
}
