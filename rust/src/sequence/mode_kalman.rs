//! The Kalman recursion of one spatial mode in time (SPEC §2.5): a scalar AR(n_t) sequence of
//! variance λ observed in white noise, its state the last d ≥ n_t values (x_t, …, x_{t−d+1})
//! (d > n_t carries the fixed-lag smoother's older frames), started exactly from the
//! stationary covariance λ·Toeplitz(R_t) of those values.

use crate::field::AxisModel;

/// Most iterations of the Riccati recursion `steady_variance` runs.
const MAX_STEADY_ITERATIONS: usize = 1_000_000;

/// The companion dynamics every mode shares: x_t = Σ_i α_i x_{t−i} + √λ β̃_t η_t.
#[derive(Debug, Clone)]
pub(crate) struct TemporalDynamics {
    alpha: Vec<f64>,
    drive: f64,
    /// R_t(k), k = 0..d.
    correlation: Vec<f64>,
    pub dim: usize,
}

impl TemporalDynamics {
    pub fn new(axis: &AxisModel, dim: usize) -> Self {
        Self {
            alpha: axis.ar_coefficients(),
            drive: axis.beta_tilde_sq(),
            correlation: (0..dim).map(|k| axis.correlation(k as f64)).collect(),
            dim,
        }
    }

    /// The state of frame 0 before its observation: mean 0, covariance λ·Toeplitz(R_t).
    pub fn prior(&self, lambda: f64, mean: &mut [f64], cov: &mut [f64]) {
        let d = self.dim;
        mean.fill(0.0);
        for (k, c) in cov.iter_mut().enumerate() {
            *c = lambda * self.correlation[(k / d).abs_diff(k % d)];
        }
    }

    /// One step of the companion transition: mean ← F mean, cov ← F cov Fᵀ + Q.
    pub fn predict(&self, lambda: f64, mean: &mut [f64], cov: &mut [f64], work: &mut [f64]) {
        let d = self.dim;
        let newest = self.alpha.iter().zip(mean.iter()).map(|(a, m)| a * m).sum();
        mean.copy_within(0..d - 1, 1);
        mean[0] = newest;
        // work = F cov (row 0 the AR combination of the rows, the others shifted down)
        for k in 0..d {
            work[k] = self
                .alpha
                .iter()
                .enumerate()
                .map(|(i, a)| a * cov[i * d + k])
                .sum();
        }
        work[d..d * d].copy_from_slice(&cov[..d * (d - 1)]);
        // cov = work Fᵀ
        for i in 0..d {
            let row = &work[i * d..(i + 1) * d];
            cov[i * d] = self.alpha.iter().zip(row).map(|(a, w)| a * w).sum();
            for k in 1..d {
                cov[i * d + k] = row[k - 1];
            }
        }
        cov[0] += lambda * self.drive;
        mirror_lower(cov, d);
    }

    /// The update by an observation `z` of element 0 with noise variance `noise_var`.
    pub fn update(&self, z: f64, noise_var: f64, mean: &mut [f64], cov: &mut [f64]) {
        let d = self.dim;
        let innovation = z - mean[0];
        let s = cov[0] + noise_var;
        for i in 0..d {
            mean[i] += cov[i * d] / s * innovation;
        }
        // rows and columns downwards: entry (i, k) reads column 0 of rows i and k ≤ i, which
        // no earlier step has changed (row i's own column-0 entry changes last)
        for i in (0..d).rev() {
            let ci = cov[i * d];
            for k in (0..=i).rev() {
                cov[i * d + k] -= ci * cov[k * d] / s;
            }
        }
        mirror_lower(cov, d);
    }

    /// The steady-state posterior variance of state element `element` (frame t − element
    /// given frames ..t) of a mode of variance `lambda`: the Riccati recursion from the
    /// exact start, run until it stops changing.
    pub fn steady_variance(&self, lambda: f64, noise_var: f64, element: usize) -> f64 {
        let d = self.dim;
        let (mut mean, mut cov, mut work) = (vec![0.0; d], vec![0.0; d * d], vec![0.0; d * d]);
        self.prior(lambda, &mut mean, &mut cov);
        self.update(0.0, noise_var, &mut mean, &mut cov);
        let mut last = f64::INFINITY;
        for t in 1..MAX_STEADY_ITERATIONS {
            self.predict(lambda, &mut mean, &mut cov, &mut work);
            self.update(0.0, noise_var, &mut mean, &mut cov);
            let v = cov[element * d + element];
            if t >= d && (v - last).abs() <= 1e-15 * v {
                return v;
            }
            last = v;
        }
        last
    }
}

fn mirror_lower(cov: &mut [f64], d: usize) {
    for i in 0..d {
        for k in 0..i {
            cov[k * d + i] = cov[i * d + k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_steady_state_is_the_closed_form() {
        // n_t = 1: m = ρ² p + (1 − ρ²) λ, p = m s / (m + s) (SPEC §2.5)
        let (rho, lambda, s) = (0.9, 2.0, 0.7);
        let dynamics = TemporalDynamics::new(&AxisModel::new(rho, 1).unwrap(), 1);
        let p = dynamics.steady_variance(lambda, s, 0);
        let m = rho * rho * p + (1.0 - rho * rho) * lambda;
        assert!((p - m * s / (m + s)).abs() < 1e-13);
    }

    #[test]
    fn prediction_keeps_the_stationary_covariance() {
        let axis = AxisModel::new(0.8, 2).unwrap();
        let dynamics = TemporalDynamics::new(&axis, 4);
        let (mut mean, mut cov, mut work) = (vec![0.0; 4], vec![0.0; 16], vec![0.0; 16]);
        dynamics.prior(3.0, &mut mean, &mut cov);
        let prior = cov.clone();
        dynamics.predict(3.0, &mut mean, &mut cov, &mut work);
        for (a, b) in cov.iter().zip(&prior) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }
}
