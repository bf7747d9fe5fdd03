//! The row model: the block AR(m) fit along the row to the band of P_e
//! ([P 3.11, 3.12, 3.34–3.36]), its banded precision Λ = Lᵀ D⁻¹ L (directly, or in
//! square-root form with a jitter where float64 fails) and the factors of the row systems
//! A = Λ + Hᵀ H/σ_θ².

use super::ScalarRowFilter;
use crate::error::{FieldError, Result};
use crate::linalg::{BandCholesky, SymmetricBand};
use faer::Mat;
use nalgebra::DMatrix;

/// Largest entry difference, relative to the largest entry, within which a column's term of
/// Λ is replaced by the middle column's (see `ScalarRowFilter::precision`): above the
/// rounding scatter of the interior columns' fits (~1e-10 for n_y = 3; ~5e-8 for n_y = 4 at
/// ρ = 0.9, ~6e-6 at ρ = 0.95), below the edge effects that matter.
pub(super) const INTERIOR_TOLERANCE: f64 = 1e-5;

/// Jitters ε (relative to the largest variance of a column's joint covariance with its
/// past), smallest first, of the square-root fit that replaces a row model whose systems
/// cannot be factored in float64 (`ScalarRowFilter::sound_systems`): near ρ = 1 the
/// innovation variance D of an AR(n_x) fit along the row falls to the rounding of the band
/// (~6e-15 of the variance for n_x = 3 at ρ = 0.999), and D⁻¹ is then rounding noise.
pub(super) const JITTERS: [f64; 8] = [0.0, 1e-15, 1e-14, 1e-13, 1e-12, 1e-11, 1e-10, 1e-9];

/// Whether a column's term of Λ lies within [`INTERIOR_TOLERANCE`] of the middle column's
/// (largest entry difference relative to the middle one's largest entry).
pub(super) fn is_settled(own: &DMatrix<f64>, central: &DMatrix<f64>) -> bool {
    (own - central).amax() <= INTERIOR_TOLERANCE * central.amax()
}

pub(super) fn singular_model() -> FieldError {
    FieldError::InvalidParameter(
        "the row model's covariance is singular (ill-conditioned model)".into(),
    )
}

impl ScalarRowFilter {
    pub(super) fn block(&self, band: &[Mat<f64>], i: usize, j: usize) -> DMatrix<f64> {
        let n = self.dynamics.order;
        let (d, at, transpose) = if i <= j {
            (j - i, i, false)
        } else {
            (i - j, j, true)
        };
        DMatrix::from_fn(n, n, |a, b| {
            let (a, b) = if transpose { (b, a) } else { (a, b) };
            band[d][(at, a * n + b)]
        })
    }

    /// Λ = Lᵀ D⁻¹ L of the block AR(m) model fitted to the band (interleaved (ℓ, i) ↦ ℓn+i).
    /// Where the band is Toeplitz (`RowModes::toeplitz_columns`), every column with a full
    /// past gives the same contribution, so it is computed once (the middle column's). Other
    /// columns: a column with a full past
    /// whose contribution lies within [`INTERIOR_TOLERANCE`] of the middle column's takes
    /// the middle one's: the interior columns' fits differ by rounding only (scattered up
    /// to ~6e-6 for n_y = 4, through the ill-conditioned whitened basis), and an exactly
    /// periodic interior of Λ gives factors that `steady_band` solves fastest. Each term
    /// stays a whole fit (Bᵀ D⁻¹ B, positive semi-definite): moving the entries of Γ or D
    /// separately by such amounts wrecks the n_y = 4 models.
    /// `jitter`: None for the direct fit (`column_contribution`), Some(ε) for the square-root
    /// one (`root_contribution`).
    pub(super) fn precision(
        &self,
        band: &[Mat<f64>],
        jitter: Option<f64>,
    ) -> Result<SymmetricBand> {
        let (w, n, m) = (self.width(), self.dynamics.order, self.ar_order);
        let mut out = SymmetricBand::zeros(w * n, self.bandwidth());
        // columns with a full past that reaches a Toeplitz row (`Ends`: also those whose past
        // straddles the splice) take the Toeplitz fit, the middle column's term: a fit mixing
        // the two sources, which differ by their rounding (~1e-9 for n_y = 4), can be
        // indefinite
        let toeplitz = self.modes.toeplitz_columns();
        let steady = |ell: usize| ell >= m.max(toeplitz.start) && ell < toeplitz.end + m;
        let central = if w / 2 < m {
            None
        } else {
            Some(self.contribution(band, w / 2, jitter)?)
        };
        for ell in 0..w {
            let k = ell.min(m);
            let computed;
            let q = match &central {
                Some(c) if steady(ell) => c,
                _ => {
                    computed = self.contribution(band, ell, jitter)?;
                    match &central {
                        Some(c) if k == m && is_settled(&computed, c) => c,
                        _ => &computed,
                    }
                }
            };
            // columns ℓ, ℓ − 1, …, ℓ − k of the contribution, each n wide
            let column = |p: usize, r: usize| (ell - p) * n + r;
            for p in 0..=k {
                for q_col in 0..=k {
                    for r in 0..n {
                        for c in 0..n {
                            let (gi, gk) = (column(p, r), column(q_col, c));
                            if gi >= gk {
                                out.add(gi, gk, q[(p * n + r, q_col * n + c)]);
                            }
                        }
                    }
                }
            }
        }
        Ok(out)
    }

    pub(super) fn contribution(
        &self,
        band: &[Mat<f64>],
        ell: usize,
        jitter: Option<f64>,
    ) -> Result<DMatrix<f64>> {
        match jitter {
            None => self.column_contribution(band, ell),
            Some(epsilon) => self.root_contribution(band, ell, epsilon),
        }
    }

    /// The past columns of column ℓ, newest first: ℓ − 1, …, ℓ − min(ℓ, m).
    pub(super) fn past(&self, ell: usize) -> Vec<usize> {
        (ell.saturating_sub(self.ar_order)..ell).rev().collect()
    }

    /// Column ℓ's term of Λ in square-root form: C = L Lᵀ, C the joint covariance of the
    /// past ℓ − k, …, ℓ − 1 and column ℓ (in that order) plus ε max_i C_ii I; the last n_y
    /// rows of L⁻¹ are G = L_ℓℓ⁻¹ [−Γ_ℓ, I] with D = L_ℓℓ L_ℓℓᵀ (the fit of
    /// `column_contribution` to the jittered C), so the term Bᵀ D⁻¹ B = GᵀG is positive
    /// semi-definite whatever the rounding ([P 3.34–3.36] by the inverse Cholesky factor).
    pub(super) fn root_contribution(
        &self,
        band: &[Mat<f64>],
        ell: usize,
        epsilon: f64,
    ) -> Result<DMatrix<f64>> {
        let n = self.dynamics.order;
        // joint order: past (oldest first), then ℓ; the term is returned in (ℓ, ℓ − 1, …)
        let mut columns = self.past(ell);
        columns.reverse();
        columns.push(ell);
        let size = columns.len() * n;
        let mut joint = DMatrix::from_fn(size, size, |r, c| {
            self.block(band, columns[r / n], columns[c / n])[(r % n, c % n)]
        });
        joint = (&joint + joint.transpose()) * 0.5;
        let top = joint.diagonal().max();
        for i in 0..size {
            joint[(i, i)] += epsilon * top;
        }
        let lower = joint.cholesky().ok_or_else(singular_model)?.l();
        let inverse = lower
            .solve_lower_triangular(&DMatrix::identity(size, size))
            .ok_or_else(singular_model)?;
        let rows = inverse.rows(size - n, n);
        // reorder the columns to (ℓ, ℓ − 1, …, ℓ − k)
        let k = columns.len() - 1;
        let g = DMatrix::from_fn(n, size, |r, c| {
            let (block, i) = (c / n, c % n);
            rows[(r, (k - block) * n + i)]
        });
        Ok(g.transpose() * g)
    }

    /// Column ℓ's term Bᵀ D⁻¹ B of Λ, B = [I, −Γ_ℓ] over the columns ℓ, ℓ − 1, …, ℓ − k
    /// (k = min(ℓ, m)): Γ_ℓ = C_{ℓ,past} C_{past,past}⁻¹, D = C_ℓℓ − Γ_ℓ C_{past,ℓ}
    /// ([P 3.11, 3.12, 3.34–3.36]).
    pub(super) fn column_contribution(
        &self,
        band: &[Mat<f64>],
        ell: usize,
    ) -> Result<DMatrix<f64>> {
        let n = self.dynamics.order;
        let past = self.past(ell);
        let k = past.len();
        let mut b = DMatrix::<f64>::zeros(n, (k + 1) * n);
        b.view_mut((0, 0), (n, n)).fill_with_identity();
        let mut noise = self.block(band, ell, ell);
        if k > 0 {
            let cpp = DMatrix::from_fn(k * n, k * n, |r, c| {
                self.block(band, past[r / n], past[c / n])[(r % n, c % n)]
            });
            let clp = DMatrix::from_fn(n, k * n, |r, c| {
                self.block(band, ell, past[c / n])[(r, c % n)]
            });
            let gamma_t = cpp
                .clone()
                .cholesky()
                .map(|ch| ch.solve(&clp.transpose()))
                .or_else(|| cpp.lu().solve(&clp.transpose()))
                .ok_or_else(singular_model)?;
            let gamma = gamma_t.transpose();
            noise -= &gamma * clp.transpose();
            b.view_mut((0, n), (n, k * n)).copy_from(&(-gamma));
        }
        let noise = (&noise + noise.transpose()) * 0.5;
        // by its Cholesky factor: nalgebra's try_inverse takes the cofactor formula for
        // n ≤ 4, which loses every digit at D's condition (~1e8 for n_y = 4 at high SNR:
        // an indefinite D⁻¹, a negative diagonal of Λ and "not positive definite")
        let inverse = noise
            .clone()
            .cholesky()
            .map(|c| c.inverse())
            .or_else(|| noise.lu().try_inverse())
            .ok_or_else(singular_model)?;
        Ok(b.transpose() * inverse * b)
    }

    /// Λ fitted to a prediction row's band and the factor of its system (row 0 observed).
    pub(super) fn row_system(&self, band: &[Mat<f64>]) -> Result<(SymmetricBand, BandCholesky)> {
        let (precision, mut factors) = self.sound_systems(band, &[vec![0]])?;
        Ok((precision, factors.remove(0)))
    }

    /// The start's prior Λ (the stationary one, fitted to the first band) and the factors of
    /// the start rows' systems, row t ≤ n_y observing the state rows n_y − 1, …, n_y − t.
    pub(super) fn start_systems(
        &self,
        band: &[Mat<f64>],
    ) -> Result<(SymmetricBand, Vec<BandCholesky>)> {
        let n = self.dynamics.order;
        let observed: Vec<Vec<usize>> = (1..=n).map(|t| (1..=t).map(|i| n - i).collect()).collect();
        self.sound_systems(band, &observed)
    }

    /// Λ fitted to `band` and the factors of its systems for each set of `observed` state
    /// rows. If the direct fit or one of its systems fails in float64, the square-root fit
    /// (`root_contribution`) with the smallest jitter of [`JITTERS`] for which Λ itself and
    /// every system factor (so the weighted rows' systems, Λ plus non-negative terms, factor
    /// too); the jitter bounds D from below, i.e. adds a white component of ε times the
    /// variance along the row to the model the filter assumes. Without one that works, the
    /// direct fit's failure is returned.
    pub(super) fn sound_systems(
        &self,
        band: &[Mat<f64>],
        observed: &[Vec<usize>],
    ) -> Result<(SymmetricBand, Vec<BandCholesky>)> {
        let systems = |p: SymmetricBand| -> Result<(SymmetricBand, Vec<BandCholesky>)> {
            let factors = observed
                .iter()
                .map(|o| self.system(&p, o))
                .collect::<Result<_>>()?;
            Ok((p, factors))
        };
        let failure = match self.precision(band, None).and_then(systems) {
            Ok(found) => return Ok(found),
            Err(e) => e,
        };
        for epsilon in JITTERS {
            let root = self.precision(band, Some(epsilon));
            if let Ok(found) = root.and_then(|p| p.cholesky().and_then(|_| systems(p))) {
                return Ok(found);
            }
        }
        Err(failure)
    }

    /// A = Λ + I_W ⊗ h hᵀ/σ_θ² for each observed row h in `observed`.
    pub(super) fn system(
        &self,
        precision: &SymmetricBand,
        observed: &[usize],
    ) -> Result<BandCholesky> {
        let mut a = precision.clone();
        for &index in observed {
            self.add_observation(&mut a, index, |_| 1.0 / self.noise_var);
        }
        a.cholesky()
    }

    /// a += Σ_ℓ weight(ℓ) h hᵀ on the block of column ℓ, h = row `index` of L (the observed
    /// row of the state in the whitened basis).
    pub(super) fn add_observation(
        &self,
        a: &mut SymmetricBand,
        index: usize,
        weight: impl Fn(usize) -> f64,
    ) {
        let n = self.dynamics.order;
        let h = self.lower().row(index);
        for ell in 0..self.width() {
            let r_ell = weight(ell);
            for r in 0..n {
                for c in 0..=r {
                    a.add(ell * n + r, ell * n + c, h[r] * h[c] * r_ell);
                }
            }
        }
    }
}
