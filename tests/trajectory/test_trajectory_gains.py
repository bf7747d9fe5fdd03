"""Gains of the fuzzy filter == §4.1's recursion computed by hand and == the NumPy twin;
gains of KalmanFilterCV == a textbook Kalman filter with the same matrices."""

import math

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st
from trajectory_cases import CLASSES, SETTINGS, make

from kalmanfield import FuzzyFilter, KalmanFilterCV
from kalmanfield.reference import trajectory as ref


def spec_gains(P, Q, R, P_vel, Q_vel, times):
    """§4.1 [K95 5–6] line by line: (α_n, β_n)."""
    P0_sq = R**2 * P**2 / (R**2 + P**2)
    out = [(P0_sq / R**2, 0.0)]
    Pn, Pvn = math.sqrt(P0_sq), P_vel
    for n in range(1, len(times)):
        tau = times[n] - times[n - 1]
        Qn = Pn + Pvn * tau + Q
        Pn_sq = R**2 * Qn**2 / (R**2 + Qn**2)
        Hn = Pn + Q + R + Q_vel * tau
        Qvn = Pvn + Q_vel
        Pvn_sq = Hn**2 * Qvn**2 / (Hn**2 + Qvn**2 * tau**2)
        out.append((Pn_sq / R**2, Pvn_sq * tau**2 / Hn**2))
        Pn, Pvn = math.sqrt(Pn_sq), math.sqrt(Pvn_sq)
    return np.array(out)


def test_first_gains_by_hand():
    # P = P' = Q = Q' = R = 1, τ = 1: α_0 = 1/2; Q_1 = √½ + 2, α_1 = Q_1²/(1 + Q_1²);
    # H_1 = √½ + 3, Q'_1 = 2, β_1 = 4/(H_1² + 4)
    g = FuzzyFilter(1, 1, 1, 1, 1).gains(2)
    q1, h1 = math.sqrt(0.5) + 2, math.sqrt(0.5) + 3
    assert g[0] == pytest.approx([0.5, 0.0], abs=1e-15)
    assert g[1] == pytest.approx([q1**2 / (1 + q1**2), 4 / (h1**2 + 4)], rel=1e-14)
    assert g[1] == pytest.approx([0.8799, 0.2254], abs=5e-5)  # the values read off by hand


@pytest.mark.parametrize("irregular", [False, True])
def test_gains_follow_the_spec_recursion(irregular):
    times = np.cumsum(np.r_[0, np.random.default_rng(1).uniform(0.2, 3, 29)]) if irregular else None
    for P, Q, R, P_vel, Q_vel, _ in SETTINGS[:4]:
        t = np.arange(30.0) if times is None else times
        got = FuzzyFilter(P, Q, R, P_vel, Q_vel).gains(30, times)
        np.testing.assert_allclose(got, spec_gains(P, Q, R, P_vel, Q_vel, t), rtol=1e-13, atol=0)


@st.composite
def models(draw):
    spread = st.floats(0.05, 20.0)
    vel = st.one_of(st.just(0.0), spread)
    r_vel = st.one_of(st.none(), spread)
    return (draw(spread), draw(spread), draw(spread), draw(vel), draw(vel), draw(r_vel))


@given(
    setting=models(),
    steps=st.lists(st.floats(0.01, 10.0), min_size=1, max_size=25),
    rule=st.sampled_from(["fuzzy", "kalman"]),
)
@example(setting=(18.0, 0.0625, 0.0625, 0.0, 0.0, None), steps=[1.0], rule="kalman")
def test_gains_equal_the_twin(setting, steps, rule):
    f, spreads = make(rule, setting)
    times = np.cumsum(np.r_[0.0, steps])
    raw = f._model.gains(times)
    # the covariance update P − K P cancels: the two summation orders differ by up to ~1e-12
    # relative (found: spreads 18 / 0.0625 / 0.0625, one step); the project's bar is 1e-10
    np.testing.assert_allclose(raw, ref.gain_sequence(spreads, times), rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("setting", SETTINGS)
def test_kalman_gains_equal_a_textbook_filter(setting):
    P, Q, R, P_vel, Q_vel, R_vel = setting
    times = np.cumsum(np.r_[0.0, np.random.default_rng(2).uniform(0.5, 2, 19)])
    h = np.eye(2) if R_vel is not None else np.array([[1.0, 0.0]])
    noise = np.diag([R**2, (R_vel or 0) ** 2])[: len(h), : len(h)]
    cov = np.diag([P**2, P_vel**2])
    gains = KalmanFilterCV(*setting).gains(20, times)
    for n in range(20):
        if n:
            tau = times[n] - times[n - 1]
            f = np.array([[1.0, tau], [0.0, 1.0]])
            cov = f @ cov @ f.T + np.diag([Q**2, Q_vel**2])
        k = cov @ h.T @ np.linalg.inv(h @ cov @ h.T + noise)
        cov = (np.eye(2) - k @ h) @ cov
        if R_vel is None:
            tau = times[n] - times[n - 1] if n else 0.0
            np.testing.assert_allclose(gains[n], [k[0, 0], k[1, 0] * tau], rtol=1e-12, atol=1e-15)
        else:
            np.testing.assert_allclose(gains[n], k, rtol=1e-12, atol=1e-15)


def test_velocity_variant_gains_by_hand():
    # [K95 end]: P'_0² = P'²R'²/(P'² + R'²); Q'_n = P'_{n-1} + Q', P'_n² = R'²Q'_n²/(R'² + Q'_n²)
    g = FuzzyFilter(1.0, 0.5, 1.0, P_vel=2.0, Q_vel=0.3, R_vel=0.7).gains(3)
    pv0 = math.sqrt(4 * 0.49 / 4.49)
    qv1 = pv0 + 0.3
    assert g[0, 1] == pytest.approx(pv0**2 / 0.49, rel=1e-14)
    assert g[1, 1] == pytest.approx(qv1**2 / (0.49 + qv1**2), rel=1e-14)


@pytest.mark.parametrize("cls", list(CLASSES.values()))
def test_gains_shape_and_times(cls):
    f = cls(1.0, 1.0, 1.0, 1.0, 1.0)
    assert f.gains(7).shape == (7, 2)
    # gains depend on the steps only: shifting the times changes nothing
    np.testing.assert_array_equal(f.gains(5, [0, 1, 3, 4, 7]), f.gains(5, [10, 11, 13, 14, 17]))
    with pytest.raises(ValueError, match="increase"):
        f.gains(3, [0, 1, 1])
    with pytest.raises(ValueError, match="shape"):
        f.gains(3, [0, 1])
