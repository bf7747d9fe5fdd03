"""The Rust bank and IMM against their NumPy twins (kalmanfield.reference.filterbank) and the
IMM against FilterPy's: same inputs, agreement to 1e-10 (FilterPy: 1e-9, its likelihood goes
through exp/log)."""

import numpy as np
import pytest
from filterbank_cases import four_types, simulate_batch, with_missed

import kalmanfield as kf
from kalmanfield.reference import filterbank as ref

bank = pytest.fixture(four_types, name="bank")


@pytest.mark.parametrize("missed", [0.0, 0.15])
def test_bank_matches_the_twin(bank, missed):
    z = with_missed(simulate_batch(bank, 40, 25, seed=3), missed, seed=4)
    priors = [0.1, 0.2, 0.3, 0.4]
    ident = kf.TypeIdentifier(bank, priors)
    decisions, ll = ident.run(z, return_log_likelihoods=True)
    twin_decisions, twin_ll = ref.bank_run(z, [m.arrays() for m in bank], priors)
    np.testing.assert_allclose(ll, twin_ll, rtol=1e-10, atol=1e-9)
    np.testing.assert_array_equal(decisions, twin_decisions)
    np.testing.assert_allclose(ident.posterior, ref.posterior(twin_ll[:, -1], priors), atol=1e-12)


def test_sequential_test_matches_the_twin(bank):
    two = bank[:2]
    z = with_missed(simulate_batch(two, 60, 30, seed=5), 0.1, seed=6)
    ident = kf.TypeIdentifier(two, alpha=0.05, beta=0.1)
    decisions = ident.run(z)
    twin = ref.bank_run(z, [m.arrays() for m in two], alpha=0.05, beta=0.1)[0]
    np.testing.assert_array_equal(decisions, twin)
    assert (decisions == -1).any() and (decisions >= 0).any()


def same_space_bank():
    """Three Singer-space models (the IMM mixes states)."""
    return [
        kf.LinearGaussianModel.singer(1.0, 0.0, 0.0, 2, 0.5, name="straight"),
        kf.LinearGaussianModel.singer(1.0, 0.8, 0.5, 2, 0.5, name="turning"),
        kf.LinearGaussianModel.singer(1.0, 0.5, 2.0, 2, 0.5, name="jinking"),
    ]


TRANSITION = np.array([[0.9, 0.05, 0.05], [0.1, 0.85, 0.05], [0.1, 0.1, 0.8]])


@pytest.mark.parametrize("missed", [0.0, 0.2])
def test_imm_matches_the_twin(missed):
    models = [
        m.with_prior(np.arange(6.0) / 3, np.eye(6) * (i + 1))
        for i, m in enumerate(same_space_bank())
    ]
    z = with_missed(simulate_batch(models, 12, 30, seed=7), missed, seed=8)
    imm = kf.IMMEstimator(models, TRANSITION, [0.5, 0.3, 0.2])
    out = imm.run(z)
    twin = ref.imm_run(z, [m.arrays() for m in models], TRANSITION, [0.5, 0.3, 0.2])
    for a, b in zip(out, twin):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)


def test_imm_matches_filterpy():
    filterpy = pytest.importorskip("filterpy.kalman")
    models = same_space_bank()
    x0, p0 = np.array([1.0, 0.5, 0.0, -2.0, 0.3, 0.1]), np.diag([4.0, 1.0, 0.5] * 2)
    models = [m.with_prior(x0, p0) for m in models]
    z = models[1].simulate(40, seed=9)[1]
    filters = []
    for m in models:
        f = filterpy.KalmanFilter(dim_x=6, dim_z=2)
        f.F, f.Q, f.H, f.R = m.F.copy(), m.Q.copy(), m.H.copy(), m.R.copy()
        f.x, f.P = x0.copy(), p0.copy()
        filters.append(f)
    mu = np.array([0.5, 0.3, 0.2])
    anchor = filterpy.IMMEstimator(filters, mu, TRANSITION)
    ours = kf.IMMEstimator(models, TRANSITION, mu)
    for row in z:
        anchor.predict()
        anchor.update(row)
        ours.update(row)
        np.testing.assert_allclose(ours.x, anchor.x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(ours.P, anchor.P, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(ours.mu, anchor.mu, rtol=1e-9, atol=1e-12)
