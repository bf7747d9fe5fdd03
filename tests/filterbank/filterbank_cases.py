"""Shared cases of the filter-bank tests."""

import numpy as np

import kalmanfield as kf


def four_types():
    """Four 2-D types: calm and agile velocity models, calm and agile Singer models."""
    return [
        kf.LinearGaussianModel.markov_velocity(1.0, 0.98, 0.5, 2, 0.5, name="calm_v"),
        kf.LinearGaussianModel.markov_velocity(1.0, 0.7, 2.0, 2, 0.5, name="agile_v"),
        kf.LinearGaussianModel.singer(1.0, 0.95, 0.1, 2, 0.5, name="calm_a"),
        kf.LinearGaussianModel.singer(1.0, 0.6, 0.8, 2, 0.5, name="agile_a"),
    ]


def with_missed(z, fraction, seed):
    """A copy of the batch z with a random `fraction` of its rows NaN."""
    z = np.array(z, dtype=float)
    rows = np.random.default_rng(seed).random(z.shape[:-1]) < fraction
    z[rows] = np.nan
    return z


def simulate_batch(models, n_traj, n_frames, seed):
    """n_traj trajectories, drawn from the models in turn."""
    parts = [m.simulate(n_frames, n_traj, seed=seed + i)[1] for i, m in enumerate(models)]
    return np.stack(parts, axis=1).reshape(-1, n_frames, parts[0].shape[-1])[:n_traj]
