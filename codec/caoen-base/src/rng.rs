//! A seeded linear congruential sequence (Knuth's MMIX constants): the same numbers on
//! every platform and thread count, with no random-number crate, for the tests' inputs
//! and for samplers whose output must be repeatable.

/// The generator's state; [`Lcg::new`] seeds it.
#[derive(Debug, Clone)]
pub struct Lcg(u64);

impl Lcg {
    /// A sequence starting from `seed`.
    pub fn new(seed: u64) -> Self {
        Lcg(seed)
    }

    /// The next state, all 64 bits (the low bits are the weak ones of an LCG).
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// The top 31 bits of the next state.
    pub fn next_u31(&mut self) -> u32 {
        (self.next_u64() >> 33) as u32
    }

    /// Uniform in `[0, 1)` from the top 53 bits (every `f64` step of the interval).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[0, 1)` from the top 24 bits (every `f32` step of the interval).
    pub fn unit_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// `n` values uniform in `[-0.5, 0.5)` (24-bit steps), a noise plane.
    pub fn noise(&mut self, n: usize) -> Vec<f32> {
        (0..n).map(|_| self.unit_f32() - 0.5).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Knuth's MMIX multiplier and increment.
    const MMIX: (u64, u64) = (6364136223846793005, 1442695040888963407);

    #[test]
    fn the_sequence_is_knuths_mmix_generator() {
        let (a, c) = MMIX;
        for seed in [0u64, 1, 12345, u64::MAX] {
            let mut g = Lcg::new(seed);
            let x1 = seed.wrapping_mul(a).wrapping_add(c);
            assert_eq!(g.next_u64(), x1);
            assert_eq!(
                g.next_u31(),
                (x1.wrapping_mul(a).wrapping_add(c) >> 33) as u32
            );
        }
        assert_eq!(Lcg::new(1).next_u64(), 7806831264735756412);
    }

    #[test]
    fn units_stay_in_the_unit_interval() {
        let mut g = Lcg::new(99);
        for _ in 0..10_000 {
            let (u, v) = (g.unit(), g.unit_f32());
            assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
        }
        assert!(g.noise(1000).iter().all(|x| (-0.5..0.5).contains(x)));
    }
}
