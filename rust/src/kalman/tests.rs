//! The recursions against independent computations: the update against the information form
//! of Gaussian conditioning, the summed log-likelihoods against the dense Gaussian density of
//! the whole measurement sequence, the motion models' Q against the integral defining it.

use super::*;
use crate::FieldError;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn random_matrix(rng: &mut Xoshiro256PlusPlus, rows: usize, cols: usize) -> DMatrix<f64> {
    DMatrix::from_fn(rows, cols, |_, _| rng.random_range(-1.0..1.0))
}

/// A random positive definite matrix A Aᵀ + εI.
fn random_spd(rng: &mut Xoshiro256PlusPlus, n: usize) -> DMatrix<f64> {
    let a = random_matrix(rng, n, n);
    &a * a.transpose() + DMatrix::identity(n, n) * 0.1
}

fn random_model(rng: &mut Xoshiro256PlusPlus, n: usize, m: usize) -> LinearGaussian {
    let f = random_matrix(rng, n, n) * 0.9;
    LinearGaussian::new(
        f,
        random_spd(rng, n),
        random_matrix(rng, m, n),
        random_spd(rng, m),
    )
    .unwrap()
}

fn max_abs_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax()
}

#[test]
fn update_is_gaussian_conditioning_in_information_form() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    for (n, m) in [(1, 1), (2, 1), (4, 2), (6, 3)] {
        let model = random_model(&mut rng, n, m);
        let predicted = Gaussian::new(
            DVector::from_fn(n, |_, _| rng.random_range(-2.0..2.0)),
            random_spd(&mut rng, n),
        )
        .unwrap();
        let z = DVector::from_fn(m, |_, _| rng.random_range(-2.0..2.0));
        let up = update(&model, &predicted, &z).unwrap();
        // P = (P⁻⁻¹ + Hᵀ R⁻¹ H)⁻¹, x = P (P⁻⁻¹ x⁻ + Hᵀ R⁻¹ z)
        let p_inv = predicted.cov.clone().try_inverse().unwrap();
        let r_inv = model.r.clone().try_inverse().unwrap();
        let cov = (&p_inv + model.h.transpose() * &r_inv * &model.h)
            .try_inverse()
            .unwrap();
        let mean = &cov * (&p_inv * &predicted.mean + model.h.transpose() * &r_inv * &z);
        assert!(max_abs_diff(&up.posterior.cov, &cov) < 1e-10 * cov.amax());
        assert!((&up.posterior.mean - &mean).amax() < 1e-10 * (1.0 + mean.amax()));
        // the likelihood: N(z; H x⁻, H P⁻ Hᵀ + R) by its own determinant and inverse
        let s = &model.h * &predicted.cov * model.h.transpose() + &model.r;
        let nu = &z - &model.h * &predicted.mean;
        let quad = (nu.transpose() * s.clone().try_inverse().unwrap() * &nu)[0];
        let expected =
            -0.5 * (quad + s.determinant().ln() + m as f64 * (2.0 * std::f64::consts::PI).ln());
        assert!((up.log_likelihood - expected).abs() < 1e-10 * (1.0 + expected.abs()));
    }
}

/// ln N(z_1..z_N) of the stacked measurements with their dense covariance.
fn dense_log_density(model: &LinearGaussian, prior: &Gaussian, zs: &[DVector<f64>]) -> f64 {
    let (n, m, frames) = (model.state_dim(), model.measurement_dim(), zs.len());
    // state means, covariances C_k = Cov(x_k) and powers F^j
    let mut means = vec![prior.mean.clone()];
    let mut covs = vec![prior.cov.clone()];
    let mut powers = vec![DMatrix::<f64>::identity(n, n)];
    for k in 1..=frames {
        means.push(&model.f * &means[k - 1]);
        covs.push(&model.f * &covs[k - 1] * model.f.transpose() + &model.q);
        powers.push(&model.f * &powers[k - 1]);
    }
    let mut sigma = DMatrix::<f64>::zeros(frames * m, frames * m);
    let mut residual = DVector::<f64>::zeros(frames * m);
    for i in 1..=frames {
        residual
            .rows_mut((i - 1) * m, m)
            .copy_from(&(&zs[i - 1] - &model.h * &means[i]));
        for j in 1..=i {
            // Cov(x_i, x_j) = F^(i−j) C_j for i ≥ j
            let mut block = &model.h * &powers[i - j] * &covs[j] * model.h.transpose();
            if i == j {
                block += &model.r;
            }
            sigma
                .view_mut(((i - 1) * m, (j - 1) * m), (m, m))
                .copy_from(&block);
            sigma
                .view_mut(((j - 1) * m, (i - 1) * m), (m, m))
                .copy_from(&block.transpose());
        }
    }
    let chol = sigma.cholesky().unwrap();
    let white = chol.l().solve_lower_triangular(&residual).unwrap();
    let log_det = 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let dim = (frames * m) as f64;
    -0.5 * (white.norm_squared() + log_det + dim * (2.0 * std::f64::consts::PI).ln())
}

fn filter_log_likelihood(model: &LinearGaussian, prior: &Gaussian, zs: &[DVector<f64>]) -> f64 {
    let mut state = prior.clone();
    let mut total = 0.0;
    for z in zs {
        let up = update(model, &predict(model, &state), z).unwrap();
        total += up.log_likelihood;
        state = up.posterior;
    }
    total
}

#[test]
fn summed_log_likelihoods_are_the_dense_density() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let models = [
        random_model(&mut rng, 3, 2),
        constant_velocity(0.5, 0.3, 2, 0.7).unwrap(),
        constant_acceleration(1.0, 0.1, 1, 1.0).unwrap(),
        singer(1.0, 0.8, 0.5, 2, 1.0).unwrap(),
        markov_velocity(1.0, 0.9, 2.0, 1, 0.5).unwrap(),
    ];
    for model in &models {
        let n = model.state_dim();
        let prior = Gaussian::new(
            DVector::from_fn(n, |_, _| rng.random_range(-1.0..1.0)),
            random_spd(&mut rng, n),
        )
        .unwrap();
        let zs: Vec<_> = (0..7)
            .map(|_| DVector::from_fn(model.measurement_dim(), |_, _| rng.random_range(-3.0..3.0)))
            .collect();
        let recursive = filter_log_likelihood(model, &prior, &zs);
        let dense = dense_log_density(model, &prior, &zs);
        assert!(
            (recursive - dense).abs() < 1e-9 * dense.abs(),
            "{recursive} vs {dense}"
        );
    }
}

/// q ∫₀ᵀ e^{As} b bᵀ e^{Aᵀs} ds by composite Simpson (error ~1e-14 with 2000 intervals).
fn white_noise_integral(d: usize, dt: f64, q: f64) -> DMatrix<f64> {
    let phi = |s: f64| {
        DMatrix::from_fn(d, d, |i, j| {
            if j >= i {
                s.powi((j - i) as i32) / (1..=(j - i)).product::<usize>() as f64
            } else {
                0.0
            }
        })
    };
    let mut b = DVector::zeros(d);
    b[d - 1] = 1.0;
    let intervals = 2000;
    let h = dt / intervals as f64;
    let mut sum = DMatrix::zeros(d, d);
    for k in 0..=intervals {
        let w = if k == 0 || k == intervals {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let g = phi(k as f64 * h) * &b;
        sum += &g * g.transpose() * w;
    }
    sum * (q * h / 3.0)
}

#[test]
fn white_noise_models_integrate_their_noise() {
    let (dt, q) = (0.7, 1.3);
    let cv = constant_velocity(dt, q, 1, 1.0).unwrap();
    let ca = constant_acceleration(dt, q, 1, 1.0).unwrap();
    assert!(max_abs_diff(&cv.q, &white_noise_integral(2, dt, q)) < 1e-12);
    assert!(max_abs_diff(&ca.q, &white_noise_integral(3, dt, q)) < 1e-12);
    assert_eq!(cv.f, DMatrix::from_row_slice(2, 2, &[1.0, dt, 0.0, 1.0]));
}

#[test]
fn markov_models_keep_their_stationary_variance() {
    let (rho, sigma) = (0.6, 2.5);
    let s = singer(1.0, rho, sigma, 2, 1.0).unwrap();
    let v = markov_velocity(1.0, rho, sigma, 2, 1.0).unwrap();
    for (model, d) in [(&s, 3), (&v, 2)] {
        let n = model.state_dim();
        let mut cov = DMatrix::<f64>::zeros(n, n);
        for axis in 0..2 {
            cov[(axis * d + d - 1, axis * d + d - 1)] = sigma * sigma;
        }
        let next = predict_cov(model, &cov);
        for axis in 0..2 {
            let i = axis * d + d - 1;
            assert!((next[(i, i)] - sigma * sigma).abs() < 1e-12);
        }
        assert_eq!(model.h[(1, d)], 1.0);
        assert_eq!(model.h.sum(), 2.0);
    }
    assert_eq!(s.f[(2, 2)], rho);
    assert_eq!(s.f[(0, 2)], 0.5);
}

#[test]
fn bad_models_are_errors() {
    let eye = |n| DMatrix::<f64>::identity(n, n);
    let h = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    let mut nan = eye(2);
    nan[(0, 1)] = f64::NAN;
    let cases = [
        LinearGaussian::new(eye(2), eye(3), h.clone(), eye(1)),
        LinearGaussian::new(eye(2), eye(2), DMatrix::zeros(1, 3), eye(1)),
        LinearGaussian::new(eye(2), asym, h.clone(), eye(1)),
        LinearGaussian::new(eye(2), indefinite, h.clone(), eye(1)),
        LinearGaussian::new(eye(2), eye(2), h.clone(), DMatrix::zeros(1, 1)),
        LinearGaussian::new(nan, eye(2), h.clone(), eye(1)),
        constant_velocity(0.0, 1.0, 2, 1.0),
        constant_velocity(1.0, -1.0, 2, 1.0),
        singer(1.0, 1.5, 1.0, 2, 1.0),
        markov_velocity(1.0, 0.5, 1.0, 0, 1.0),
        markov_velocity(1.0, 0.5, 1.0, 1, 0.0),
    ];
    for case in cases {
        assert!(case.is_err());
    }
    let model = constant_velocity(1.0, 1.0, 1, 1.0).unwrap();
    let prior = Gaussian::new(DVector::zeros(2), eye(2)).unwrap();
    let wrong = update(&model, &prior, &DVector::zeros(2));
    assert!(matches!(wrong, Err(FieldError::Shape(_))));
    let missing = update(&model, &prior, &DVector::from_element(1, f64::NAN));
    assert!(matches!(missing, Err(FieldError::NonFinite(_))));
    assert!(Gaussian::new(DVector::zeros(2), -eye(2)).is_err());
}
