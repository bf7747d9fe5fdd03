"""Bad input gets a clear ValueError or TypeError naming what is wrong, never a panic; a
failed call changes nothing."""

import numpy as np
import pandas as pd
import pytest
from filterbank_cases import four_types

import kalmanfield as kf
from kalmanfield import _core

bank = pytest.fixture(four_types, name="bank")

EYE2, H = np.eye(2), np.array([[1.0, 0.0]])
GOOD = dict(F=EYE2, Q=EYE2, H=H, R=np.eye(1), x0=np.zeros(2), P0=EYE2)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"Q": np.eye(3)}, "Q must be 2×2"),
        ({"H": np.ones((1, 3))}, "H must be"),
        ({"R": np.eye(2)}, "R must be 1×1"),
        ({"x0": np.zeros(3), "P0": np.eye(3)}, "x0 has 3 states"),
        ({"P0": np.eye(3)}, "P0 must be 2×2"),
        ({"Q": [[1.0, 0.3], [0.0, 1.0]]}, "Q must be symmetric"),
        ({"Q": [[1.0, 2.0], [2.0, 1.0]]}, "Q must be positive semi-definite"),
        ({"P0": -EYE2}, "P0 must be positive semi-definite"),
        ({"R": [[0.0]]}, "R must be positive definite"),
        ({"F": [[1.0, np.nan], [0.0, 1.0]]}, "finite"),
        ({"F": np.ones((2, 2, 1))}, "F must be a 2-D array"),
        ({"x0": np.zeros((2, 1))}, "x0 must be a 1-D array"),
    ],
)
def test_bad_models(change, message):
    with pytest.raises(ValueError, match=message):
        kf.LinearGaussianModel(**{**GOOD, **change})


def test_bad_model_types_and_parameters():
    with pytest.raises(TypeError):
        kf.LinearGaussianModel(**{**GOOD, "F": [["a", "b"], ["c", "d"]]})
    cv = kf.LinearGaussianModel.constant_velocity
    for args, error in [
        ((0.0, 1.0), ValueError),
        ((1.0, -1.0), ValueError),
        ((1.0, 1.0, 0), ValueError),
        ((1.0, 1.0, True), TypeError),
        ((1.0, 1.0, 2, -0.5), ValueError),
        (("1", 1.0), TypeError),
    ]:
        with pytest.raises(error):
            cv(*args)
    with pytest.raises(ValueError, match="rho"):
        kf.LinearGaussianModel.singer(1.0, 1.2, 1.0)
    with pytest.raises(ValueError, match="sigma"):
        kf.LinearGaussianModel.markov_velocity(1.0, 0.5, -1.0)


def test_bad_banks(bank):
    one_d = kf.LinearGaussianModel.constant_velocity(1.0, 1.0, ndim=1)
    cases = [
        (dict(models=bank[:1]), ValueError, "at least two"),
        (dict(models=[bank[0], one_d]), ValueError, "one length"),
        (dict(models=bank, priors=[0.5, 0.5, 0.5, 0.5]), ValueError, "sum to 1"),
        (dict(models=bank, priors=[0.5, 0.5]), ValueError, "4 entries"),
        (dict(models=bank, priors=[1.5, -0.5, 0, 0]), ValueError, r"\[0, 1\]"),
        (dict(models=bank[:2], alpha=0.0, beta=0.1), ValueError, "alpha"),
        (dict(models=bank[:2], alpha=0.1, beta=1.0), ValueError, "beta"),
        (dict(models=bank[:2], alpha=0.6, beta=0.5), ValueError, "below 1"),
        (dict(models=bank[:2], alpha=0.1), ValueError, "both"),
        (dict(models=bank, alpha=0.1, beta=0.1), ValueError, "two models"),
        (dict(models=[bank[0], "model"]), TypeError, "LinearGaussianModel"),
        (dict(models=bank[0]), TypeError, "sequence"),
    ]
    for kwargs, error, message in cases:
        with pytest.raises(error, match=message):
            kf.TypeIdentifier(**kwargs)


def test_bad_measurements_change_nothing(bank):
    ident = kf.TypeIdentifier(bank)
    z = bank[0].simulate(10, 3, seed=1)[1]
    ident.run(z)
    before = ident.log_likelihoods.copy()
    partly = z.copy()
    partly[1, 4, 0] = np.nan
    infinite = z.copy()
    infinite[0, 2, 1] = np.inf
    cases = [
        (z[..., :1], ValueError, "2 values per frame"),
        (partly, ValueError, "trajectory 1, frame 4 is partly NaN"),
        (infinite, ValueError, "infinite"),
        (z * 1e200, ValueError, "1e150"),
        (z[:2], ValueError, "follows 3 trajectories"),
        (z[0], ValueError, "follows a batch"),
        (z[None], ValueError, "must be"),
        (np.array([["a", "b"]]), TypeError, "real numbers"),
        (np.empty((0, 5, 2)), ValueError, "at least one trajectory"),
    ]
    for bad, error, message in cases:
        with pytest.raises(error, match=message):
            ident.run(bad)
    with pytest.raises(ValueError):
        ident.update(np.zeros(3))
    np.testing.assert_array_equal(ident.log_likelihoods, before)


def test_bad_imms(bank):
    singer, velocity = bank[3], bank[0]
    with pytest.raises(ValueError, match="one state length"):
        kf.IMMEstimator([singer, velocity], [[0.9, 0.1], [0.1, 0.9]])
    for transition, message in [
        ([[0.9, 0.1]], "2×2"),
        ([[0.9, 0.2], [0.1, 0.9]], "sum to 1"),
        ([[1.1, -0.1], [0.1, 0.9]], r"\[0, 1\]"),
    ]:
        with pytest.raises(ValueError, match=message):
            kf.IMMEstimator([singer, bank[2]], transition)
    with pytest.raises(ValueError, match="sum to 1"):
        kf.IMMEstimator([singer, bank[2]], np.eye(2), mu=[0.2, 0.2])


def test_corrupt_states_are_refused(bank):
    ident = kf.TypeIdentifier(bank)
    ident.run(bank[0].simulate(5, 2, seed=2)[1])
    state = ident._core.state_bytes()
    other = _core.TypeIdentifier([m.arrays() for m in bank[:2]], [0.5, 0.5])
    for bad in [state[:-8], state + b"\0" * 8, b"", b"KFBANK01" + state[8:16]]:
        with pytest.raises(ValueError, match="saved state"):
            ident._core.load_state(bad)
    with pytest.raises(ValueError, match="saved state"):
        other.load_state(state)


def test_bad_tracks(bank):
    tracks = pd.DataFrame({"frame": [0, 1, 1], "particle": [0, 0, 0], "x": 1.0, "y": 2.0})
    with pytest.raises(ValueError, match="two rows for one frame"):
        kf.TypeIdentifier.run_tracks(tracks, bank)
    with pytest.raises(ValueError, match="lack the columns"):
        kf.TypeIdentifier.run_tracks(tracks.drop(columns="y"), bank)
    with pytest.raises(TypeError, match="DataFrame"):
        kf.TypeIdentifier.run_tracks(tracks.to_numpy(), bank)
    with pytest.raises(ValueError, match="integers"):
        kf.TypeIdentifier.run_tracks(tracks.assign(frame=[0.5, 1, 2]), bank)


def test_motion_models_beyond_memory_are_memory_errors():
    """The Rust builders abort (or panic on a capacity overflow) when the dense state
    matrices cannot be allocated; the Python layer refuses such an ndim first."""
    from kalmanfield.experiments import source_banks

    for build in (
        kf.LinearGaussianModel.constant_velocity,
        kf.LinearGaussianModel.constant_acceleration,
    ):
        with pytest.raises(MemoryError, match="GiB"):
            build(1.0, 1.0, ndim=2**40)
    with pytest.raises(MemoryError, match="GiB"):
        kf.LinearGaussianModel.singer(1.0, 0.5, 1.0, ndim=2**31)
    with pytest.raises(MemoryError, match="GiB"):
        kf.LinearGaussianModel.markov_velocity(1.0, 0.5, 1.0, ndim=2**62)
    with pytest.raises(MemoryError, match="GiB"):
        source_banks(ndim=2**40)
    with pytest.raises(ValueError, match="at least two"):
        source_banks(rho=(0.5,))
    with pytest.raises(TypeError, match="ndim"):
        source_banks(ndim=2.0)


def test_a_simulation_beyond_float64_is_an_error():
    big = kf.LinearGaussianModel(**{**GOOD, "F": [[1e308, 0.0], [0.0, 1.0]]})
    with pytest.raises(ValueError, match="overflows float64"):
        big.simulate(3, seed=1, start=[1.0, 0.0])
    wide = kf.LinearGaussianModel(**{**GOOD, "P0": np.diag([1e308, 1.0])})
    with pytest.raises(ValueError, match="overflows float64"):
        wide.simulate(3, 2, seed=1)


def test_runs_of_no_frame_are_errors(bank):
    """The Rust core returns wrongly shaped outputs for zero frames, and panics when asked
    for the log-likelihoods: refused before it is called."""
    empty = np.zeros((3, 0, 2))
    with pytest.raises(ValueError, match="at least one frame"):
        kf.TypeIdentifier(bank).run(empty, return_log_likelihoods=True)
    with pytest.raises(ValueError, match="at least one frame"):
        kf.TypeIdentifier(bank).run(empty[0])
    with pytest.raises(ValueError, match="at least one frame"):
        kf.IMMEstimator([bank[3], bank[2]], [[0.9, 0.1], [0.1, 0.9]]).run(empty)


def test_tracks_with_values_that_are_not_numbers_or_frames_beyond_int64(bank):
    tracks = pd.DataFrame({"frame": np.arange(4), "particle": 0, "x": 1.0, "y": 2.0})
    with pytest.raises(TypeError, match=r"tracks\['x'\]"):
        kf.TypeIdentifier.run_tracks(tracks.assign(x=["1", "2", "3", "4"]), bank)
    with pytest.raises(TypeError, match=r"tracks\['y'\]"):
        kf.TypeIdentifier.run_tracks(tracks.assign(y=np.ones(4, complex)), bank)
    frames = np.arange(4, dtype=np.uint64) + np.uint64(2**63)
    with pytest.raises(ValueError, match="int64"):
        kf.TypeIdentifier.run_tracks(tracks.assign(frame=frames), bank)
    near = tracks.assign(frame=np.arange(4) + (2**63 - 5))  # int64 frames that follow
    table = kf.TypeIdentifier.run_tracks(near, bank)
    assert table.loc[0, "first_frame"] == 2**63 - 5 and table.loc[0, "n_observed"] == 4
