"""A correct likelihood machine: the bank's accumulated log-likelihood of every model is the
exact log-density of the whole measurement sequence under that model (dense joint Gaussian
of the stacked measurements, missed frames marginalised out), and Wald's test keeps the
error rates its thresholds promise."""

import numpy as np
import pytest
from filterbank_cases import four_types, with_missed

import kalmanfield as kf
from kalmanfield.reference.kalman import sequence_log_density

bank = pytest.fixture(four_types, name="bank")


@pytest.mark.parametrize("missed", [0.0, 0.3])
def test_log_likelihoods_are_exact_log_densities(bank, missed):
    truth = bank[3].with_prior(np.ones(6), np.eye(6))
    z = with_missed(truth.simulate(12, 3, seed=1)[1], missed, seed=2)
    ident = kf.TypeIdentifier([truth, *bank[:2]])
    ident.run(z)
    for t in range(3):
        for i, model in enumerate(ident.models):
            exact = sequence_log_density(*model.arrays(), z[t])
            assert ident.log_likelihoods[t, i] == pytest.approx(exact, rel=1e-10)


def test_missed_frames_only_predict(bank):
    z = bank[0].simulate(10, seed=3)[1]
    z[[0, 4, 5]] = np.nan
    _, ll = kf.TypeIdentifier(bank).run(z, return_log_likelihoods=True)
    np.testing.assert_array_equal(ll[0], 0.0)
    np.testing.assert_array_equal(ll[5], ll[3])
    assert (ll[6] != ll[5]).all()


def test_wald_error_rates_keep_their_bounds():
    """Wald's bounds hold for any sequence of likelihood ratios: P0(decide 1) ≤ α/(1 − β),
    P1(decide 0) ≤ β/(1 − α). With 4,000 runs per type the SE of a rate near the bound b
    is √(b(1 − b)/4000) ≤ 0.005, so each rate must stay below b + 3 SE. The overshoot of
    the thresholds only lowers the rates; with these slowly separating types (per-frame
    increments of the log-ratio ~0.1) it is small, and Wald's approximation (rates ≈ α,
    β) is checked loosely from below: rate ≥ nominal / 3 (measured: 0.030 for α = 0.05,
    0.10 for β = 0.1)."""
    alpha, beta, runs = 0.05, 0.1, 4000
    m0 = kf.LinearGaussianModel.markov_velocity(
        1.0, 0.9, 1.0, 1, 1.0, x0=[0, 0], P0=np.diag([1.0, 1.0])
    )
    m1 = kf.LinearGaussianModel.markov_velocity(
        1.0, 0.9, 1.5, 1, 1.0, x0=[0, 0], P0=np.diag([1.0, 2.25])
    )
    rates = []
    for truth, model in enumerate([m0, m1]):
        z = model.simulate(300, runs, seed=10 + truth)[1]
        final = kf.TypeIdentifier([m0, m1], alpha=alpha, beta=beta).run(z)[:, -1]
        assert (final == -1).mean() < 0.01  # the test ends within 300 frames
        rates.append((final == 1 - truth).mean())
    for rate, nominal, bound in [
        (rates[0], alpha, alpha / (1 - beta)),
        (rates[1], beta, beta / (1 - alpha)),
    ]:
        se = np.sqrt(bound * (1 - bound) / runs)
        assert nominal / 3 <= rate <= bound + 3 * se, (rate, nominal, bound)
