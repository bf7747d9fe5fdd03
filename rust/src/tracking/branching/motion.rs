//! The per-parameter polynomial motion model and its scalar-measurement Kalman step
//! (SPEC §3.1).

/// Highest polynomial order ν of a parameter's motion model.
pub const MAX_MOTION_ORDER: usize = 4;

/// Transition F (d × d, row-major) and process-noise covariance Q of one parameter over a
/// step τ: F[i][j] = τ^(j−i)/(j−i)!, Q = σ² g gᵀ with g_i = τ^(d−i)/(d−i)!, d = ν + 1
/// (a white (ν+1)-th derivative held over the step; ν = 1 is the white-noise-acceleration
/// model).
pub(crate) fn motion_matrices(order: usize, tau: f64, process_std: f64) -> (Vec<f64>, Vec<f64>) {
    let d = order + 1;
    let mut f = vec![0.0; d * d];
    for i in 0..d {
        for j in i..d {
            f[i * d + j] = tau.powf((j - i) as f64) / factorial(j - i);
        }
    }
    let g: Vec<f64> = (0..d)
        .map(|i| tau.powf((d - i) as f64) / factorial(d - i))
        .collect();
    let s2 = process_std * process_std;
    let mut q = vec![0.0; d * d];
    for i in 0..d {
        for j in 0..d {
            q[i * d + j] = s2 * (g[i] * g[j]);
        }
    }
    (f, q)
}

fn factorial(n: usize) -> f64 {
    (1..=n).map(|v| v as f64).product()
}

/// Prediction: x⁻ = F x, P⁻ = F P Fᵀ + Q (all d × d row-major).
pub(crate) fn predict(f: &[f64], q: &[f64], x: &[f64], p: &[f64], xp: &mut [f64], pp: &mut [f64]) {
    let d = x.len();
    for i in 0..d {
        xp[i] = (0..d).fold(0.0, |acc, j| acc + f[i * d + j] * x[j]);
    }
    let mut fp = [0.0; (MAX_MOTION_ORDER + 1) * (MAX_MOTION_ORDER + 1)];
    for i in 0..d {
        for j in 0..d {
            fp[i * d + j] = (0..d).fold(0.0, |acc, l| acc + f[i * d + l] * p[l * d + j]);
        }
    }
    for i in 0..d {
        for j in 0..d {
            let fpf = (0..d).fold(0.0, |acc, l| acc + fp[i * d + l] * f[j * d + l]);
            pp[i * d + j] = fpf + q[i * d + j];
        }
    }
}

/// Update with the scalar measurement of the first state component: innovation v,
/// innovation variance s = P⁻[0][0] + R, gain K = P⁻[:,0]/s, x = x⁻ + K v, P = P⁻ − K Kᵀ s.
pub(crate) fn update(xp: &[f64], pp: &[f64], s: f64, v: f64, x: &mut [f64], p: &mut [f64]) {
    let d = xp.len();
    let mut gain = [0.0; MAX_MOTION_ORDER + 1];
    for i in 0..d {
        gain[i] = pp[i * d] / s;
        x[i] = xp[i] + gain[i] * v;
    }
    for i in 0..d {
        for j in 0..d {
            p[i * d + j] = pp[i * d + j] - gain[i] * gain[j] * s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_velocity_matrices() {
        let (f, q) = motion_matrices(1, 2.0, 0.5);
        assert_eq!(f, vec![1.0, 2.0, 0.0, 1.0]);
        // g = (τ²/2, τ) = (2, 2); Q = 0.25 g gᵀ
        assert_eq!(q, vec![1.0, 1.0, 1.0, 1.0]);
        let (f, _) = motion_matrices(2, 3.0, 1.0);
        assert_eq!(f[2], 4.5);
    }

    #[test]
    fn kalman_step_matches_the_closed_form() {
        // random walk (ν = 0): P⁻ = P + Q, gain = P⁻/(P⁻ + R)
        let (f, q) = motion_matrices(0, 1.0, 1.0);
        let (mut xp, mut pp) = ([0.0], [0.0]);
        predict(&f, &q, &[2.0], &[3.0], &mut xp, &mut pp);
        assert_eq!(pp[0], 4.0);
        let (mut x, mut p) = ([0.0], [0.0]);
        update(&xp, &pp, pp[0] + 1.0, 5.0 - xp[0], &mut x, &mut p);
        assert!((x[0] - (2.0 + 0.8 * 3.0)).abs() < 1e-15);
        assert!((p[0] - 0.8).abs() < 1e-15);
    }
}
