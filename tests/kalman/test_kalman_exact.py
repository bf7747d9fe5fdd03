"""The recursion against exact Gaussian computations: one update is the conditioning of the
joint Gaussian of (state, measurement); the summed log-likelihoods of a sequence are the
log-density of all its measurements under their dense joint covariance."""

import numpy as np
import pytest

from kalmanfield import _core
from kalmanfield.reference import kalman as ref

stats = pytest.importorskip("scipy.stats")


@pytest.mark.parametrize("seed", range(5))
def test_summed_log_likelihood_is_the_dense_log_density(seed):
    rng = np.random.default_rng(seed)
    f, q, h, r = _core.kalman_singer(1.0, 0.7, 0.8, 2, 0.5)
    mean, cov = rng.standard_normal(6), np.diag(rng.uniform(0.5, 2.0, 6))
    z = 3 * rng.standard_normal((6, 2))
    loglik = _core.kalman_filter(f, q, h, r, mean, cov, z)[2].sum()
    assert loglik == pytest.approx(ref.sequence_log_density(f, q, h, r, mean, cov, z), rel=1e-10)


def test_missed_frames_are_marginalised():
    rng = np.random.default_rng(11)
    f, q, h, r = _core.kalman_constant_velocity(1.0, 0.5, 2, 0.8)
    mean, cov = rng.standard_normal(4), np.eye(4)
    z = 2 * rng.standard_normal((8, 2))
    z[[2, 3, 6]] = np.nan
    loglik = _core.kalman_filter(f, q, h, r, mean, cov, z)[2]
    assert (loglik[[2, 3, 6]] == 0).all()
    assert loglik.sum() == pytest.approx(ref.sequence_log_density(f, q, h, r, mean, cov, z))


def test_update_is_the_conditional_gaussian():
    rng = np.random.default_rng(7)
    f, q, h, r = _core.kalman_markov_velocity(1.0, 0.9, 2.0, 2, 0.7)
    mean, cov = rng.standard_normal(4), np.eye(4) + 0.2
    z = rng.standard_normal((1, 2))
    post_mean, post_cov, loglik = _core.kalman_filter(f, q, h, r, mean, cov, z)
    # joint of (x, z) after the prediction; condition on z
    xm, p = f @ mean, f @ cov @ f.T + q
    s = h @ p @ h.T + r
    cross = p @ h.T
    np.testing.assert_allclose(post_mean[0], xm + cross @ np.linalg.solve(s, z[0] - h @ xm))
    np.testing.assert_allclose(post_cov[0], p - cross @ np.linalg.solve(s, cross.T), atol=1e-12)
    assert loglik[0] == pytest.approx(stats.multivariate_normal(h @ xm, s).logpdf(z[0]))
