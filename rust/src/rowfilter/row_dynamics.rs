//! The row-state dynamics of one mode of the row filters (SPEC §2.2), in the rows' own
//! basis and in the whitened one, and its modal Riccati recursion.

use super::{StateMatrix, MAX_ROW_ORDER};
use crate::error::{FieldError, Result};
use crate::field::AxisModel;
use nalgebra::Vector4;

/// The row-state dynamics of one mode, in units of its variance (SPEC §2.2): in the rows'
/// own basis (`new`), the companion transition of the row axis, the innovation β̃_y² e₀e₀ᵀ,
/// the exact stationary prior R_y[:n,:n] of the first n rows and the identity readout (the
/// quasi-optimal filter's splice check runs there); both row filters run it in the whitened
/// basis (`whitened`).
#[derive(Debug, Clone)]
pub(crate) struct RowDynamics {
    pub(crate) order: usize,
    pub(crate) transition: StateMatrix,
    /// Covariance one row's prediction adds.
    pub(crate) innovation: StateMatrix,
    pub(crate) prior: StateMatrix,
    /// Row i: the observation vector of the image row that state component i holds.
    pub(crate) readout: StateMatrix,
    /// The readout's inverse T (v' = T v; the identity in the rows' own basis).
    pub(crate) whitening: StateMatrix,
}

/// Per-mode covariances of one step: prediction P_e, filtered P.
#[derive(Clone, Copy)]
pub(crate) struct ModeCovariance {
    pub(crate) predicted: StateMatrix,
    pub(crate) filtered: StateMatrix,
}

impl RowDynamics {
    /// The dynamics of the row axis `y`.
    pub(crate) fn new(y: &AxisModel) -> Self {
        let order = y.order();
        let mut transition = StateMatrix::zeros();
        for (i, a) in y.ar_coefficients().iter().enumerate() {
            transition[(0, i)] = *a;
        }
        for i in 1..order {
            transition[(i, i - 1)] = 1.0;
        }
        let mut prior = StateMatrix::zeros();
        for i in 0..order {
            for k in 0..order {
                prior[(i, k)] = y.correlation(i.abs_diff(k) as f64);
            }
        }
        let mut innovation = StateMatrix::zeros();
        innovation[(0, 0)] = y.beta_tilde_sq();
        Self {
            order,
            transition,
            innovation,
            prior,
            readout: StateMatrix::identity(),
            whitening: StateMatrix::identity(),
        }
    }

    /// The same dynamics in the whitened basis v' = T v of the rows (T = L⁻¹, R_y[:n,:n] =
    /// L Lᵀ): prior I, transition T S L, innovation β̃² (T e₀)(T e₀)ᵀ, readout L. Every
    /// quantity is O(1) there, so the covariances stay positive semi-definite where the rows'
    /// basis (R_y[:n,:n] of condition ~3e17 for n_y = 4 at ρ = 0.999) rounds them indefinite.
    /// Error: R_y[:n,:n] does not factor in float64 (n_y = 4 at ρ = 0.9999).
    pub(crate) fn whitened(&self) -> Result<Self> {
        let n = self.order;
        let mut prior = self.prior;
        for i in n..MAX_ROW_ORDER {
            prior[(i, i)] = 1.0;
        }
        let lower = prior.cholesky().map(|c| c.l()).ok_or_else(|| {
            FieldError::InvalidParameter("the row correlation is not positive definite".into())
        })?;
        // a triangular solve, not a general 4×4 inverse: R_y[:n,:n] is ill-conditioned
        // (condition ~5e9 for n = 4, ρ = 0.95)
        let whitening = lower
            .solve_lower_triangular(&StateMatrix::identity())
            .ok_or_else(|| {
                FieldError::InvalidParameter("the row correlation is singular".into())
            })?;
        let mut identity = StateMatrix::zeros();
        identity.view_mut((0, 0), (n, n)).fill_with_identity();
        let t0 = whitening.column(0).into_owned();
        Ok(Self {
            order: n,
            transition: whitening * self.transition * lower,
            innovation: (t0 * t0.transpose()) * self.innovation[(0, 0)],
            prior: identity,
            readout: lower,
            whitening,
        })
    }

    /// h_t: the observation vector of row t (1-based), row `observed(t)` of the readout.
    pub(crate) fn observation(&self, t: usize) -> Vector4<f64> {
        self.readout.row(self.observed(t)).transpose()
    }

    /// Index of the state component that row t (1-based) observes.
    pub(crate) fn observed(&self, t: usize) -> usize {
        self.order.saturating_sub(t)
    }

    /// One Riccati step of mode j in units of its variance v_j (so every mode is O(1)): row t
    /// observes h_t = row `observed(t)` of the readout with noise `ratio` = σ_θ² / v_j.
    pub(crate) fn riccati_step(
        &self,
        t: usize,
        previous: &StateMatrix,
        ratio: f64,
    ) -> ModeCovariance {
        if self.order == 1 {
            return self.scalar_riccati_step(t, previous[(0, 0)], ratio);
        }
        self.matrix_riccati_step(t, previous, ratio)
    }

    /// [`Self::riccati_step`] on the 4 × 4 matrices, for any state order.
    fn matrix_riccati_step(&self, t: usize, previous: &StateMatrix, ratio: f64) -> ModeCovariance {
        let predicted = if t == 1 {
            self.prior
        } else if t <= self.order {
            *previous
        } else {
            let p = self.transition * previous * self.transition.transpose() + self.innovation;
            (p + p.transpose()) * 0.5
        };
        let h = self.observation(t);
        // P − c cᵀ / s (c = P h) keeps P exactly symmetric; the row-times-column form drifted
        // apart by rounding and made P_e indefinite for ill-conditioned modes (ρ ≥ 0.99).
        let c = predicted * h;
        let filtered = predicted - (c * c.transpose()) / (h.dot(&c) + ratio);
        ModeCovariance {
            predicted,
            filtered,
        }
    }

    /// [`Self::riccati_step`] of a one-row state (n_y = 1) on the (0, 0) entries, the only
    /// non-zero ones (a plan walks thousands of modes per row); the update as p r / (h² p + r),
    /// which keeps its digits where p − (hp)²/(h² p + r) cancels (r ≪ p: σ_θ² ≲ 1e-16 σ_x²).
    fn scalar_riccati_step(&self, t: usize, previous: f64, ratio: f64) -> ModeCovariance {
        let (a, h) = (self.transition[(0, 0)], self.readout[(0, 0)]);
        let p = if t == 1 {
            self.prior[(0, 0)]
        } else {
            a * previous * a + self.innovation[(0, 0)]
        };
        let c = p * h;
        let mut predicted = StateMatrix::zeros();
        let mut filtered = StateMatrix::zeros();
        predicted[(0, 0)] = p;
        filtered[(0, 0)] = p * ratio / (h * c + ratio);
        ModeCovariance {
            predicted,
            filtered,
        }
    }

    /// (t, P_e,t per mode) of the modal Riccati for the mode variances `var` and noise
    /// variance `noise_var` (SPEC §2.2 [P 3.29, 3.30]), rows t = 1, 2, ….
    pub(crate) fn prediction_errors<'a>(
        &'a self,
        noise_var: f64,
        var: &'a [f64],
    ) -> impl Iterator<Item = (usize, Vec<StateMatrix>)> + 'a {
        let ratios: Vec<f64> = var.iter().map(|v| noise_var / v).collect();
        let start = ModeCovariance {
            predicted: self.prior,
            filtered: self.prior,
        };
        let mut current = vec![start; var.len()];
        (1..).map(move |t| {
            for (mode, ratio) in current.iter_mut().zip(&ratios) {
                *mode = self.riccati_step(t, &mode.filtered, *ratio);
            }
            let modal = current.iter().zip(var).map(|(c, v)| c.predicted * *v);
            (t, modal.collect())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_one_row_riccati_step_is_the_matrix_one_and_keeps_its_digits_at_high_snr() {
        let axis = AxisModel::new(0.95, 1).unwrap();
        for dynamics in [
            RowDynamics::new(&axis),
            RowDynamics::new(&axis).whitened().unwrap(),
        ] {
            let (mut scalar, mut matrix) = (dynamics.prior, dynamics.prior);
            for t in 1..=6 {
                let s = dynamics.riccati_step(t, &scalar, 0.3);
                let m = dynamics.matrix_riccati_step(t, &matrix, 0.3);
                assert!((s.predicted - m.predicted).abs().max() < 1e-15);
                assert!((s.filtered - m.filtered).abs().max() < 1e-15);
                assert_eq!(s.filtered.abs().sum(), s.filtered[(0, 0)].abs());
                (scalar, matrix) = (s.filtered, m.filtered);
            }
            // r ≪ p: the filtered variance is r (1 − r/p + …), where p − p²/(p + r) is 0
            let step = dynamics.riccati_step(3, &scalar, 1e-30);
            let want = 1e-30 / (1.0 + 1e-30 / step.predicted[(0, 0)]);
            assert!((step.filtered[(0, 0)] / want - 1.0).abs() < 1e-14);
        }
    }
}
