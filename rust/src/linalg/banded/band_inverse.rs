//! The band of the inverse of a banded SPD matrix from its Cholesky factor (selected
//! inversion, Takahashi's recurrence): the entries of Z = A⁻¹ within A's band, without
//! forming the dense inverse. The quasi-optimal row filter's per-pixel error variances read
//! the n_y × n_y diagonal blocks of A_t⁻¹ (SPEC §2.3; `ScalarRowFilter::error_variance`).
//!
//! With A = L Lᵀ (L lower, bandwidth b), Z = L⁻ᵀ L⁻¹ satisfies Lᵀ Z = L⁻¹, whose upper
//! triangle is diag(1/L_ii). Column i of that identity, for rows j ≥ i, gives, from the last
//! row up:
//!
//!   Z_ji = −(1/L_ii) Σ_{k=i+1}^{i+b} L_ki Z_kj   (j = i+1..i+b),
//!   Z_ii = (1/L_ii) (1/L_ii − Σ_{k=i+1}^{i+b} L_ki Z_ki),
//!
//! every Z_kj on the right lying within the band (|k − j| < b) and already known. O(n b²).

use super::band::band_index;

/// The lower band (same storage as the factor: rows of b + 1 entries, the diagonal last) of
/// A⁻¹, A = L Lᵀ of order n and bandwidth b, `l` the factor's band.
pub(crate) fn selected_inverse(l: &[f64], n: usize, b: usize) -> Vec<f64> {
    debug_assert_eq!(l.len(), n * (b + 1));
    let mut z = vec![0.0; n * (b + 1)];
    // column i of L below the pivot, L_{i+1..=last, i}, gathered once per i
    let mut column = vec![0.0; b];
    for i in (0..n).rev() {
        let last = (i + b).min(n - 1);
        let below = last - i;
        let inverse_pivot = 1.0 / l[band_index(b, i, i)];
        for (d, c) in column[..below].iter_mut().enumerate() {
            *c = l[band_index(b, i + 1 + d, i)];
        }
        for j in (i + 1..=last).rev() {
            // Σ_k L_ki Z_kj: k ≤ j from row j of the band (contiguous), k > j down column j
            let row_j = &z[band_index(b, j, i + 1)..=band_index(b, j, j)];
            let near: f64 = column[..j - i].iter().zip(row_j).map(|(c, v)| c * v).sum();
            // Z_kj for k = j + 1..=last: b apart in the band storage
            let far: f64 = if j < last {
                let down = z[band_index(b, j + 1, j)..].iter().step_by(b);
                column[j - i..below]
                    .iter()
                    .zip(down)
                    .map(|(c, v)| c * v)
                    .sum()
            } else {
                0.0
            };
            z[band_index(b, j, i)] = -(near + far) * inverse_pivot;
        }
        let sum: f64 = (0..below)
            .map(|d| column[d] * z[band_index(b, i + 1 + d, i)])
            .sum();
        z[band_index(b, i, i)] = (inverse_pivot - sum) * inverse_pivot;
    }
    z
}

#[cfg(test)]
mod tests {
    use crate::linalg::banded::band::SymmetricBand;
    use nalgebra::DMatrix;
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    #[test]
    fn the_band_of_the_inverse_equals_the_dense_inverse() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        for (n, b) in [
            (1usize, 0usize),
            (7, 1),
            (30, 2),
            (40, 5),
            (25, 11),
            (12, 19),
        ] {
            let mut a = SymmetricBand::zeros(n, b);
            for i in 0..n {
                // diagonally dominant: SPD
                a.add(i, i, 0.5 * (2 * b + 1) as f64 + rng.random::<f64>());
                for k in i.saturating_sub(b)..i {
                    a.add(i, k, rng.random::<f64>() - 0.5);
                }
            }
            let dense = DMatrix::from_fn(n, n, |i, k| a.get(i, k));
            let inverse = dense.try_inverse().unwrap();
            let scale = inverse.amax();
            // from the solver's factor and from a plain factorisation
            for z in [
                a.cholesky().unwrap().inverse_band(),
                a.inverse_band().unwrap(),
            ] {
                for i in 0..n {
                    for k in i.saturating_sub(b)..=i {
                        let (got, want) = (z.get(i, k), inverse[(i, k)]);
                        assert!((got - want).abs() < 1e-13 * scale, "n {n} b {b} ({i},{k})");
                    }
                }
            }
        }
    }
}
