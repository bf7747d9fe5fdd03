//! The driving white noise ξ, one independent seeded stream per line of the grid.
//!
//! A "line" is a run of the last (contiguous) axis. Line `i` of the grid draws from a
//! xoshiro256++ generator keyed by (seed, i) with SplitMix64 mixing, so every line's numbers
//! depend on the seed and the line index only: the same seed gives the same field whatever the
//! number of threads or the order lines are produced in, and frame `t` of a stream draws the
//! same numbers as slice `t` of a one-shot sample of the same space–time model.

use super::real::Real;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Where the standard-normal driving noise of a grid comes from.
#[derive(Debug, Clone, Copy)]
pub enum DrivingNoise<'a> {
    /// Seeded streams, one per line (see the module docs).
    Seeded(u64),
    /// Caller-supplied noise in C order, covering the lines from `first_line` on.
    Given { values: &'a [f64], first_line: u64 },
}

impl DrivingNoise<'_> {
    /// Writes the noise of line `line` (of length `out.len()`) into `out`.
    pub fn fill<T: Real>(&self, out: &mut [T], line: u64) {
        match *self {
            DrivingNoise::Seeded(seed) => {
                let mut rng = line_rng(seed, line);
                for v in out.iter_mut() {
                    *v = T::from_f64(rng.sample::<f64, _>(StandardNormal));
                }
            }
            DrivingNoise::Given { values, first_line } => {
                let len = out.len();
                let start = (line - first_line) as usize * len;
                for (v, &g) in out.iter_mut().zip(&values[start..start + len]) {
                    *v = T::from_f64(g);
                }
            }
        }
    }
}

fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The generator of line `line` under `seed`.
pub(crate) fn line_rng(seed: u64, line: u64) -> Xoshiro256PlusPlus {
    Xoshiro256PlusPlus::seed_from_u64(splitmix64(splitmix64(seed) ^ line))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_reproducible_and_distinct() {
        let mut a = vec![0.0f64; 64];
        let mut b = vec![0.0f64; 64];
        DrivingNoise::Seeded(7).fill(&mut a, 3);
        DrivingNoise::Seeded(7).fill(&mut b, 3);
        assert_eq!(a, b);
        DrivingNoise::Seeded(7).fill(&mut b, 4);
        assert_ne!(a, b);
    }

    #[test]
    fn standard_normal_moments() {
        let n = 200_000;
        let mut v = vec![0.0f64; n];
        DrivingNoise::Seeded(1).fill(&mut v, 0);
        let mean = v.iter().sum::<f64>() / n as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        // 5 standard errors
        assert!(mean.abs() < 5.0 / (n as f64).sqrt());
        assert!((var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt());
        // the shape: E x⁴ = 3 (SE √(96/n)) and P(|x| > 2) = 2Φ(−2) (binomial SE)
        let fourth = v.iter().map(|x| x.powi(4)).sum::<f64>() / n as f64;
        assert!(
            (fourth - 3.0).abs() < 5.0 * (96.0 / n as f64).sqrt(),
            "{fourth}"
        );
        let tail = v.iter().filter(|x| x.abs() > 2.0).count() as f64 / n as f64;
        let p = 0.045_500_263_896_358;
        assert!(
            (tail - p).abs() < 5.0 * (p * (1.0 - p) / n as f64).sqrt(),
            "{tail}"
        );
    }
}
