//! The bank against the plain Kalman recursion, batches against single trajectories (bit for
//! bit), the pickled state against an uninterrupted run, the IMM against a single filter.

use super::*;
use crate::kalman::{self, Gaussian, LinearGaussian};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn bank_model(model: LinearGaussian) -> BankModel {
    let n = model.state_dim();
    let prior = Gaussian::new(DVector::zeros(n), DMatrix::identity(n, n) * 100.0).unwrap();
    BankModel::new(model, prior).unwrap()
}

fn bank() -> Vec<BankModel> {
    vec![
        bank_model(kalman::markov_velocity(1.0, 0.95, 1.0, 2, 0.5).unwrap()),
        bank_model(kalman::singer(1.0, 0.8, 0.3, 2, 0.5).unwrap()),
        bank_model(kalman::constant_velocity(1.0, 0.2, 2, 0.5).unwrap()),
    ]
}

/// n_traj × n_frames × 2 random-walk positions, some rows missed.
fn measurements(n_traj: usize, n_frames: usize, missed: f64, seed: u64) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut z = Vec::new();
    for _ in 0..n_traj {
        let (mut p, mut v) = ([0.0f64; 2], [0.0f64; 2]);
        for _ in 0..n_frames {
            for a in 0..2 {
                v[a] += rng.random_range(-0.5..0.5);
                p[a] += v[a];
            }
            if rng.random::<f64>() < missed {
                z.extend([f64::NAN; 2]);
            } else {
                z.extend(p.iter().map(|x| x + rng.random_range(-0.5..0.5)));
            }
        }
    }
    z
}

#[test]
fn bank_log_likelihoods_are_those_of_the_kalman_recursion() {
    let models = bank();
    let (n_traj, n_frames) = (11, 15);
    let z = measurements(n_traj, n_frames, 0.2, 1);
    let mut id = TypeIdentifier::new(models.clone(), &[0.2, 0.3, 0.5], None).unwrap();
    let out = id.run(&z, n_traj, n_frames, true).unwrap();
    let ll = out.log_likelihoods.unwrap();
    for t in 0..n_traj {
        for (i, b) in models.iter().enumerate() {
            let mut state = b.prior.clone();
            let mut total = 0.0;
            for f in 0..n_frames {
                let row = &z[(t * n_frames + f) * 2..][..2];
                state = kalman::predict(&b.dynamics, &state);
                if !row[0].is_nan() {
                    let up = kalman::update(&b.dynamics, &state, &DVector::from_row_slice(row));
                    let up = up.unwrap();
                    total += up.log_likelihood;
                    state = up.posterior;
                }
                let got = ll[(t * n_frames + f) * 3 + i];
                assert!(
                    (got - total).abs() < 1e-9 * (1.0 + total.abs()),
                    "{got} {total}"
                );
            }
        }
    }
}

#[test]
fn a_batch_gives_the_bits_of_single_trajectories() {
    let (n_traj, n_frames) = (150, 12);
    let z = measurements(n_traj, n_frames, 0.05, 2);
    let mut batch = TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], None).unwrap();
    let all = batch.run(&z, n_traj, n_frames, true).unwrap();
    let ll = all.log_likelihoods.unwrap();
    for t in [0, 7, 8, 63, 64, 149] {
        let mut one = TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], None).unwrap();
        let zt = &z[t * n_frames * 2..(t + 1) * n_frames * 2];
        let single = one.run(zt, 1, n_frames, true).unwrap();
        assert_eq!(single.decisions, all.decisions[t * n_frames..][..n_frames]);
        let llt = &ll[t * n_frames * 3..(t + 1) * n_frames * 3];
        assert_eq!(single.log_likelihoods.unwrap(), llt);
        assert_eq!(one.trajectories[0], batch.trajectories[t]);
    }
}

#[test]
fn frame_by_frame_and_a_restored_state_continue_exactly() {
    let (n_traj, n_frames) = (20, 10);
    let z = measurements(n_traj, n_frames, 0.1, 3);
    let mut whole = TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], None).unwrap();
    whole.run(&z, n_traj, n_frames, false).unwrap();
    let mut stepped = TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], None).unwrap();
    for f in 0..n_frames {
        let frame: Vec<f64> = (0..n_traj)
            .flat_map(|t| z[(t * n_frames + f) * 2..][..2].to_vec())
            .collect();
        stepped.run(&frame, n_traj, 1, false).unwrap();
        if f == 4 {
            let mut restored = TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], None).unwrap();
            restored.load_state(&stepped.state_bytes()).unwrap();
            stepped = restored;
        }
    }
    assert_eq!(stepped.log_likelihoods(), whole.log_likelihoods());
    assert_eq!(stepped.trajectories, whole.trajectories);
    let mut other = TypeIdentifier::new(bank()[..2].to_vec(), &[0.5, 0.5], None).unwrap();
    assert!(other.load_state(&whole.state_bytes()).is_err());
    assert!(whole.load_state(&whole.state_bytes()[..40]).is_err());
}

/// `bytes` with word `word` (8 bytes) replaced by `v`.
fn altered(bytes: &[u8], word: usize, v: f64) -> Vec<u8> {
    let mut out = bytes.to_vec();
    out[word * 8..][..8].copy_from_slice(&v.to_le_bytes());
    out
}

#[test]
fn altered_numbers_in_a_saved_state_are_errors() {
    let (n_traj, n_frames) = (4, 6);
    let z = measurements(n_traj, n_frames, 0.0, 3);
    let fresh = || TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], None).unwrap();
    let mut ident = fresh();
    ident.run(&z, n_traj, n_frames, false).unwrap();
    let bytes = ident.state_bytes();
    let dims: Vec<usize> = bank().iter().map(|b| b.state_dim()).collect();
    // words: magic, K, m, the K dims, frame, n_traj; the K shared covariances; then the first
    // trajectory's means and log-likelihoods
    let shared = 5 + dims.len();
    let means = shared + dims.iter().map(|n| n * n).sum::<usize>();
    let log_lik = means + dims.iter().sum::<usize>();
    assert!(fresh().load_state(&bytes).is_ok());
    for (word, v) in [
        (means, -4e161),          // a mean beyond the measurements' range
        (means, f64::NAN),        // a NaN mean
        (shared, -1.0),           // a negative variance
        (shared + 1, 1e3),        // an asymmetric covariance
        (log_lik, f64::INFINITY), // an infinite log-likelihood
    ] {
        assert!(
            fresh().load_state(&altered(&bytes, word, v)).is_err(),
            "word {word} = {v}"
        );
    }
    let mut beyond = bytes.clone();
    beyond[(shared - 2) * 8..][..8].copy_from_slice(&u64::MAX.to_le_bytes()); // frame count
    assert!(fresh().load_state(&beyond).is_err());
}

#[test]
fn wald_thresholds_and_bad_decision_rules() {
    let two = bank()[..2].to_vec();
    let id = TypeIdentifier::new(two.clone(), &[0.5, 0.5], Some((0.05, 0.1))).unwrap();
    assert_eq!(
        id.rule,
        DecisionRule::Sprt {
            lower: (0.1f64 / 0.95).ln(),
            upper: (0.9f64 / 0.05).ln()
        }
    );
    for (priors, errors) in [
        (vec![0.5, 0.6], None),
        (vec![0.5, 0.5], Some((0.0, 0.1))),
        (vec![0.5, 0.5], Some((0.1, 1.0))),
        (vec![0.5, 0.5], Some((0.6, 0.5))),
        (vec![1.0], None),
    ] {
        assert!(TypeIdentifier::new(two.clone(), &priors, errors).is_err());
    }
    assert!(TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], Some((0.1, 0.1))).is_err());
    assert!(TypeIdentifier::new(two[..1].to_vec(), &[1.0], None).is_err());
}

#[test]
fn bad_measurements_are_errors_and_change_nothing() {
    let mut id = TypeIdentifier::new(bank(), &[0.2, 0.3, 0.5], None).unwrap();
    let z = measurements(3, 4, 0.0, 4);
    id.run(&z, 3, 4, false).unwrap();
    let before = id.state_bytes();
    let mut partly = z.clone();
    partly[5] = f64::NAN;
    let mut infinite = z.clone();
    infinite[2] = f64::INFINITY;
    assert!(id.run(&partly, 3, 4, false).is_err());
    assert!(id.run(&infinite, 3, 4, false).is_err());
    assert!(id.run(&z[..11], 3, 2, false).is_err()); // wrong length
    assert!(id.run(&z[..16], 2, 4, false).is_err()); // another batch size
    assert_eq!(id.state_bytes(), before);
}

#[test]
fn an_imm_of_identical_models_is_the_kalman_filter() {
    let model = kalman::constant_velocity(1.0, 0.3, 2, 0.5).unwrap();
    let b = bank_model(model.clone());
    let transition = [0.9, 0.1, 0.2, 0.8];
    let mut imm = ImmEstimator::new(vec![b.clone(), b.clone()], &transition, &[0.3, 0.7]).unwrap();
    let (n_frames, z) = (9, measurements(1, 9, 0.2, 5));
    let out = imm.run(&z, 1, n_frames).unwrap();
    let mut state = b.prior.clone();
    let mut mu = [0.3, 0.7];
    for f in 0..n_frames {
        state = kalman::predict(&model, &state);
        let row = &z[f * 2..f * 2 + 2];
        let mut ll = 0.0;
        if !row[0].is_nan() {
            let up = kalman::update(&model, &state, &DVector::from_row_slice(row)).unwrap();
            ll = up.log_likelihood;
            state = up.posterior;
        }
        mu = [0.9 * mu[0] + 0.2 * mu[1], 0.1 * mu[0] + 0.8 * mu[1]];
        for i in 0..4 {
            assert!((out.state[f * 4 + i] - state.mean[i]).abs() < 1e-9);
        }
        assert!((out.mode_probabilities[f * 2] - mu[0]).abs() < 1e-12);
        assert!((out.log_likelihood[f] - ll).abs() < 1e-9);
    }
    let mut restored = ImmEstimator::new(vec![b.clone(), b.clone()], &transition, &[0.3, 0.7]);
    let restored = restored.as_mut().unwrap();
    restored.load_state(&imm.state_bytes()).unwrap();
    assert_eq!(restored.trajectories, imm.trajectories);
    // words: magic, K, n, m, frame, n_traj, then the first trajectory's mode probabilities
    assert!(restored
        .load_state(&altered(&imm.state_bytes(), 6, 0.95))
        .is_err());
    assert!(restored
        .load_state(&altered(&imm.state_bytes(), 6, -0.1))
        .is_err());
    let singer = bank_model(kalman::singer(1.0, 0.5, 1.0, 2, 0.5).unwrap());
    assert!(ImmEstimator::new(vec![b.clone(), singer], &transition, &[0.5, 0.5]).is_err());
    assert!(ImmEstimator::new(
        vec![b.clone(), b.clone()],
        &[0.9, 0.2, 0.2, 0.8],
        &[0.5, 0.5]
    )
    .is_err());
}
