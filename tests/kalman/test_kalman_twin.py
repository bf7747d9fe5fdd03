"""The Rust Kalman domain against its NumPy twin (kalmanfield.reference.kalman): the motion
models' matrices, and a predict-then-update run with missed frames, agree to 1e-10."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kalmanfield import _core
from kalmanfield.reference import kalman as ref

MODELS = [
    ("constant_velocity", (0.5, 0.3)),
    ("constant_acceleration", (1.0, 0.2)),
    ("singer", (1.0, 0.8, 0.5)),
    ("markov_velocity", (2.0, 0.9, 1.5)),
]


@pytest.mark.parametrize(("name", "params"), MODELS)
@pytest.mark.parametrize("ndim", [1, 2, 3])
def test_motion_models_match_the_twin(name, params, ndim):
    rust = getattr(_core, f"kalman_{name}")(*params, ndim, 0.7)
    twin = getattr(ref, name)(*params, ndim, 0.7)
    for a, b in zip(rust, twin):
        np.testing.assert_allclose(a, b, rtol=1e-15, atol=0)


def random_spd(rng, n):
    a = rng.standard_normal((n, n))
    return a @ a.T + 0.1 * np.eye(n)


@given(
    n=st.integers(1, 6),
    m=st.integers(1, 3),
    frames=st.integers(1, 12),
    seed=st.integers(0, 2**32 - 1),
)
def test_filter_matches_the_twin(n, m, frames, seed):
    rng = np.random.default_rng(seed)
    f = 0.9 * rng.standard_normal((n, n)) / np.sqrt(n)
    q, r = random_spd(rng, n), random_spd(rng, m)
    h = rng.standard_normal((m, n))
    mean, cov = rng.standard_normal(n), random_spd(rng, n)
    z = rng.standard_normal((frames, m))
    z[rng.random(frames) < 0.3] = np.nan  # missed frames: predict only
    rust = _core.kalman_filter(f, q, h, r, mean, cov, z)
    q, r = (q + q.T) / 2, (r + r.T) / 2
    twin = ref.filter_sequence(f, q, h, r, mean, (cov + cov.T) / 2, z)
    for a, b in zip(rust, twin):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)


def test_bad_models_raise_value_errors():
    eye2, h = np.eye(2), np.array([[1.0, 0.0]])
    z, mean = np.zeros((3, 1)), np.zeros(2)
    cases = {
        "Q must be 2×2": (eye2, np.eye(3), h, np.eye(1), mean, eye2),
        "H must be": (eye2, eye2, np.ones((1, 3)), np.eye(1), mean, eye2),
        "symmetric": (eye2, np.array([[1.0, 0.5], [0.0, 1.0]]), h, np.eye(1), mean, eye2),
        "semi-definite": (eye2, np.array([[1.0, 2.0], [2.0, 1.0]]), h, np.eye(1), mean, eye2),
        "positive definite": (eye2, eye2, h, np.zeros((1, 1)), mean, eye2),
        "P0 must be": (eye2, eye2, h, np.eye(1), mean, np.eye(3)),
    }
    for message, args in cases.items():
        with pytest.raises(ValueError, match=message):
            _core.kalman_filter(*args, z)
    with pytest.raises(ValueError, match="measurement must have 1"):
        _core.kalman_filter(eye2, eye2, h, np.eye(1), mean, eye2, np.zeros((3, 2)))
    for bad in [(0.0, 1.0, 2, 1.0), (1.0, -1.0, 2, 1.0), (1.0, 1.0, 0, 1.0), (1.0, 1.0, 2, 0.0)]:
        with pytest.raises(ValueError):
            _core.kalman_constant_velocity(*bad)
    with pytest.raises(ValueError, match="rho"):
        _core.kalman_singer(1.0, 1.5, 1.0, 2, 1.0)
