//! The anisotropy coefficient A_τ of a separable field (SPEC §1.5, [P 2.22]).
//!
//! τ(u) = ∫_0^∞ R(t u) dt along a unit direction u; A_τ = std_u τ / mean_u τ, u uniform on
//! the unit sphere. Along u the correlation is e^{-λt}·Q(t) with λ = Σ_k |u_k| ln(1/ρ_k) and Q
//! a polynomial, so τ(u) = Σ_m q_m m! / λ^{m+1} exactly. The sphere average runs over the
//! positive orthant (τ depends on |u_k| only) in hyperspherical angles with a Gauss–Legendre
//! product rule, which converges fast because τ is smooth inside the orthant.

use super::field_model::FieldModel;

/// A_τ of the model (needs at least two axes; for one axis it is 0 by definition).
pub fn anisotropy(model: &FieldModel) -> f64 {
    let dims = model.ndim();
    if dims < 2 {
        return 0.0;
    }
    let nodes_per_angle = match dims {
        2 => 96,
        3 => 64,
        4 => 32,
        5 => 16,
        _ => 8,
    };
    let (x, w) = gauss_legendre(nodes_per_angle, 0.0, std::f64::consts::FRAC_PI_2);
    let angles = dims - 1;
    let mut index = vec![0usize; angles];
    let (mut sum_w, mut sum_t, mut sum_t2) = (0.0, 0.0, 0.0);
    let mut u = vec![0.0; dims];
    loop {
        // u from the angles, with the surface element Π_i sin^{dims-2-i} θ_i
        let mut weight = 1.0;
        let mut sin_prod = 1.0;
        for (i, &k) in index.iter().enumerate() {
            let theta = x[k];
            weight *= w[k] * theta.sin().powi((dims - 2 - i) as i32);
            u[i] = sin_prod * theta.cos();
            sin_prod *= theta.sin();
        }
        u[dims - 1] = sin_prod;
        let tau = integral_along(model, &u);
        sum_w += weight;
        sum_t += weight * tau;
        sum_t2 += weight * tau * tau;
        if !advance(&mut index, nodes_per_angle) {
            break;
        }
    }
    let mean = sum_t / sum_w;
    let var = (sum_t2 / sum_w - mean * mean).max(0.0);
    var.sqrt() / mean
}

/// τ(u) = ∫_0^∞ Π_k R_k(t u_k) dt in closed form.
pub(crate) fn integral_along(model: &FieldModel, u: &[f64]) -> f64 {
    let mut lambda = 0.0;
    let mut q = vec![1.0];
    for (axis, &uk) in model.axes().iter().zip(u) {
        let a = uk.abs();
        lambda += a * (1.0 / axis.rho()).ln();
        // p_k(t a) as a polynomial in t, multiplied into q
        let p: Vec<f64> = axis
            .polynomial()
            .iter()
            .enumerate()
            .map(|(m, c)| c * a.powi(m as i32))
            .collect();
        let mut next = vec![0.0; q.len() + p.len() - 1];
        for (i, qi) in q.iter().enumerate() {
            for (j, pj) in p.iter().enumerate() {
                next[i + j] += qi * pj;
            }
        }
        q = next;
    }
    let mut factorial = 1.0;
    let mut power = lambda;
    let mut tau = 0.0;
    for (m, qm) in q.iter().enumerate() {
        if m > 0 {
            factorial *= m as f64;
            power *= lambda;
        }
        tau += qm * factorial / power;
    }
    tau
}

fn advance(index: &mut [usize], n: usize) -> bool {
    for k in index.iter_mut().rev() {
        *k += 1;
        if *k < n {
            return true;
        }
        *k = 0;
    }
    false
}

/// Gauss–Legendre nodes and weights on [a, b] (Newton iteration on P_n).
fn gauss_legendre(n: usize, a: f64, b: f64) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = 0.5 * (b - a) * z + 0.5 * (b + a);
        weights[i] = (b - a) / ((1.0 - z * z) * dp * dp);
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn habibi_model_value_is_independent_of_rho() {
        // SPEC §1.5: sqrt((2/π)/m² - 1), m = (2√2/π) ln(1+√2) the mean of 1/(|cos|+|sin|)
        let m = 2.0 * 2f64.sqrt() / std::f64::consts::PI * (1.0 + 2f64.sqrt()).ln();
        let want = ((2.0 / std::f64::consts::PI) / (m * m) - 1.0).sqrt();
        for rho in [0.3, 0.72, 0.95] {
            let model = FieldModel::new(&[rho, rho], &[1, 1], 1.0).unwrap();
            assert!((anisotropy(&model) - want).abs() < 1e-9);
        }
    }

    #[test]
    fn integral_of_exponential() {
        let model = FieldModel::new(&[0.5], &[1], 1.0).unwrap();
        assert!((integral_along(&model, &[1.0]) - 1.0 / 2f64.ln()).abs() < 1e-14);
    }

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre(8, 0.0, 2.0);
        let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(9)).sum();
        assert!((s - 2f64.powi(10) / 10.0).abs() < 1e-10);
    }
}
