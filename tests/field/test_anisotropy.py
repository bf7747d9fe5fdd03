"""A_τ of method page *Random fields*, §1.5."""

import numpy as np
import pytest

import kalmanfield as kf
from kalmanfield import reference as ref


@pytest.mark.parametrize("rho", [0.3, 0.72, 0.9, 0.99])
def test_habibi_model_closed_form(rho):
    m = 2 * np.sqrt(2) / np.pi * np.log(1 + np.sqrt(2))  # mean of 1/(|cos φ| + |sin φ|)
    want = np.sqrt((2 / np.pi) / m**2 - 1)
    assert kf.ARFieldModel([rho, rho], [1, 1]).anisotropy() == pytest.approx(want, abs=1e-9)
    assert want == pytest.approx(0.10509, abs=1e-5)


@pytest.mark.parametrize(
    "rho,order",
    [
        ([0.8, 0.8], [2, 2]),
        ([0.9, 0.7], [1, 3]),
        ([0.75, 0.75], [4, 4]),
        ([0.9, 0.8, 0.7], [1, 2, 2]),
    ],
)
def test_matches_independent_quadrature(rho, order):
    got = kf.ARFieldModel(rho, order).anisotropy()
    assert got == pytest.approx(ref.anisotropy(rho, order), abs=1e-4)


def test_higher_multiplicity_is_more_isotropic():
    values = [kf.ARFieldModel([0.8, 0.8], [n, n]).anisotropy() for n in (1, 2, 3, 4)]
    assert values[1] < values[0]
    assert values[3] < values[1]


def test_four_axes_runs_and_is_scale_free():
    a = kf.ARFieldModel([0.6] * 4, [1] * 4).anisotropy()
    b = kf.ARFieldModel([0.9] * 4, [1] * 4).anisotropy()
    assert a == pytest.approx(b, abs=1e-4)
    # multiplicity 1 on every axis: τ(u) ∝ 1/‖u‖₁, so A_τ = std/mean of 1/‖u‖₁ over the unit
    # sphere S³; Monte Carlo (u = g/‖g‖₂, g normal), SE from 20 batch means
    g = np.random.default_rng(4).standard_normal((20, 100_000, 4))
    tau = np.linalg.norm(g, axis=2) / np.abs(g).sum(axis=2)
    batches = tau.std(axis=1) / tau.mean(axis=1)
    se = batches.std(ddof=1) / np.sqrt(len(batches))
    assert a == pytest.approx(tau.std() / tau.mean(), abs=5 * se)
    assert se < 1e-4


def test_one_axis_is_refused():
    with pytest.raises(ValueError, match="two axes"):
        kf.ARFieldModel(0.5, 1).anisotropy()
