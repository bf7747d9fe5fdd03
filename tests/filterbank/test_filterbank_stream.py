"""Streams: a batch gives the bits of its trajectories run one at a time, frame-by-frame
updates give the bits of one run, thread counts do not matter, and a pickled identifier or
IMM resumes exactly where it stopped."""

import pickle

import numpy as np
import pytest
from filterbank_cases import four_types, simulate_batch, with_missed

import kalmanfield as kf

bank = pytest.fixture(four_types, name="bank")

TRANSITION = [[0.9, 0.1], [0.2, 0.8]]


def imm_models():
    return [
        kf.LinearGaussianModel.singer(1.0, 0.0, 0.0, 2, 0.5, name="straight"),
        kf.LinearGaussianModel.singer(1.0, 0.8, 0.7, 2, 0.5, name="turning"),
    ]


def test_a_batch_is_its_trajectories_one_at_a_time(bank):
    z = with_missed(simulate_batch(bank, 70, 20, seed=1), 0.05, seed=2)
    decisions, ll = kf.TypeIdentifier(bank).run(z, return_log_likelihoods=True, threads=2)
    for t in [0, 8, 33, 69]:
        one = kf.TypeIdentifier(bank)
        d, l1 = one.run(z[t], return_log_likelihoods=True)
        np.testing.assert_array_equal(d, decisions[t])
        np.testing.assert_array_equal(l1, ll[t])
    one_thread = kf.TypeIdentifier(bank).run(z, return_log_likelihoods=True, threads=1)
    np.testing.assert_array_equal(one_thread[1], ll)


def test_updates_are_one_run(bank):
    z = with_missed(simulate_batch(bank, 9, 12, seed=3), 0.1, seed=4)
    whole = kf.TypeIdentifier(bank, alpha=None)
    decisions = whole.run(z)
    stepped = kf.TypeIdentifier(bank)
    for f in range(12):
        np.testing.assert_array_equal(stepped.update(z[:, f]), decisions[:, f])
    np.testing.assert_array_equal(stepped.log_likelihoods, whole.log_likelihoods)
    single = kf.TypeIdentifier(bank)
    for row in z[4]:
        single.update(row)
    np.testing.assert_array_equal(single.log_likelihoods, whole.log_likelihoods[4])
    assert single.decision == whole.decision[4]


def test_a_pickled_identifier_resumes_exactly(bank):
    z = with_missed(simulate_batch(bank[:2], 20, 30, seed=5), 0.1, seed=6)
    whole = kf.TypeIdentifier(bank[:2], priors=[0.3, 0.7], alpha=0.01, beta=0.02)
    expected = whole.run(z)
    first = kf.TypeIdentifier(bank[:2], priors=[0.3, 0.7], alpha=0.01, beta=0.02)
    head = first.run(z[:, :13])
    resumed = pickle.loads(pickle.dumps(first))
    tail = resumed.run(z[:, 13:])
    np.testing.assert_array_equal(np.concatenate([head, tail], axis=1), expected)
    np.testing.assert_array_equal(resumed.log_likelihoods, whole.log_likelihoods)
    assert resumed.frame == 30 and resumed.thresholds == whole.thresholds
    fresh = pickle.loads(pickle.dumps(kf.TypeIdentifier(bank)))
    assert fresh.decision == 0 and fresh.log_likelihoods.shape == (4,)


def test_a_pickled_imm_resumes_exactly():
    models = imm_models()
    z = with_missed(simulate_batch(models, 5, 24, seed=7), 0.1, seed=8)
    whole = kf.IMMEstimator(models, TRANSITION).run(z)
    first = kf.IMMEstimator(models, TRANSITION)
    head = first.run(z[:, :10])
    resumed = pickle.loads(pickle.dumps(first))
    tail = resumed.run(z[:, 10:])
    for a, b, c in zip(head, tail, whole):
        np.testing.assert_array_equal(np.concatenate([a, b], axis=1), c)
    single = kf.IMMEstimator(models, TRANSITION)
    for row in z[2]:
        single.update(row)
    np.testing.assert_array_equal(single.x, whole.state[2, -1])
    np.testing.assert_array_equal(single.mu, whole.mode_probabilities[2, -1])


def switching(first, second, switch, n_frames, runs, seed):
    """Measurements of objects moving by `first` up to frame `switch`, then by `second`."""
    rng = np.random.default_rng(seed)

    def root(cov):
        values, vectors = np.linalg.eigh(cov)
        return vectors * np.sqrt(np.clip(values, 0, None))

    x = first.x0 + rng.standard_normal((runs, first.state_dim)) @ root(first.P0).T
    z = np.empty((runs, n_frames, first.measurement_dim))
    for t in range(n_frames):
        model = first if t < switch else second
        x = x @ model.F.T + rng.standard_normal(x.shape) @ root(model.Q).T
        z[:, t] = x @ model.H.T + rng.standard_normal(z[:, t].shape) @ root(model.R).T
    return z


def test_the_imm_follows_a_switch_of_type():
    x0, p0 = np.zeros(6), np.diag([1.0, 1.0, 0.1] * 2)
    straight, turning = (m.with_prior(x0, p0) for m in imm_models())
    z = switching(straight, turning, 40, 80, 200, seed=9)
    imm = kf.IMMEstimator([straight, turning], [[0.95, 0.05], [0.05, 0.95]])
    turning_probability = imm.run(z).mode_probabilities[:, :, 1].mean(0)
    assert turning_probability[30:40].mean() < 0.3
    assert turning_probability[70:80].mean() > 0.7
