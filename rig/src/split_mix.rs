//! A small seeded generator (Steele, Lea and Flood's SplitMix64) for the random samples of the
//! robust fits — RANSAC over laser-plane points (`calib`) and over descriptor matches (`process`):
//! the same input and seed give the same result, run after run, with no dependency for it.

/// The generator's state; any seed, zero included, starts a full-period sequence.
#[derive(Debug, Clone)]
pub struct SplitMix(pub u64);

impl SplitMix {
    /// The next draw in `0..n` (`n` > 0; the modulo's bias is below 2⁻⁴⁰ for the sizes drawn here).
    pub fn below(&mut self, n: usize) -> usize {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) % n as u64) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_in_range_and_repeat_with_the_seed() {
        let (mut a, mut b) = (SplitMix(7), SplitMix(7));
        let draws: Vec<usize> = (0..1000).map(|_| a.below(13)).collect();
        assert!(draws.iter().all(|&d| d < 13));
        assert!((0..13).all(|k| draws.contains(&k)));
        assert!(draws.iter().all(|&d| d == b.below(13)));
    }
}
