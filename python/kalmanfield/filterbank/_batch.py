"""Measurements in, as the (n_trajectories, n_frames, m) float64 batch the Rust core takes."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from .._validation import real_array
from .model import LinearGaussianModel


def bank_models(models: Sequence[LinearGaussianModel]) -> list[LinearGaussianModel]:
    """The models as a list of at least two LinearGaussianModel with one measurement length."""
    if isinstance(models, LinearGaussianModel) or not isinstance(models, Sequence):
        raise TypeError("models must be a sequence of LinearGaussianModel")
    models = list(models)
    for m in models:
        if not isinstance(m, LinearGaussianModel):
            raise TypeError(f"models must be LinearGaussianModel instances, got {type(m).__name__}")
    if len(models) < 2:
        raise ValueError(f"a bank needs at least two models, got {len(models)}")
    dims = {m.measurement_dim for m in models}
    if len(dims) > 1:
        raise ValueError(f"all models must observe measurements of one length, got {sorted(dims)}")
    return models


def run_batch(measurements: npt.ArrayLike, m: int) -> tuple[np.ndarray, bool]:
    """(batch (B, N, m), batched): (N, m) — or (N,) when m = 1 — is one trajectory,
    (B, N, m) a batch. NaN rows are missed frames; masked entries become NaN. The values
    (partly NaN rows, inf, beyond ±1e150) are checked by the Rust core, which names the
    trajectory and frame."""
    z = real_array(measurements, "measurements")
    if z.ndim == 1 and m == 1:
        z = z[:, None]
    if z.ndim == 2:
        return _checked(z[None], m), False
    if z.ndim == 3:
        return _checked(z, m), True
    raise ValueError(
        f"measurements must be (n_frames, {m}) or (n_trajectories, n_frames, {m}), "
        f"got shape {z.shape}"
    )


def frame_batch(measurement: npt.ArrayLike, m: int) -> tuple[np.ndarray, bool]:
    """One frame: (m,) for one trajectory, (B, m) for a batch; as (B, 1, m)."""
    z = real_array(measurement, "measurement")
    if z.ndim == 0 and m == 1:
        z = z.reshape(1)
    if z.ndim == 1:
        return _checked(z[None, None], m), False
    if z.ndim == 2:
        return _checked(z[:, None], m), True
    raise ValueError(f"a frame must be ({m},) or (n_trajectories, {m}), got shape {z.shape}")


def _checked(z: np.ndarray, m: int) -> np.ndarray:
    if z.shape[-1] != m:
        raise ValueError(
            f"the models observe {m} values per frame, the measurements have {z.shape[-1]}"
        )
    if z.shape[0] == 0:
        raise ValueError("measurements need at least one trajectory")
    if z.shape[1] == 0:
        raise ValueError("measurements need at least one frame")
    return np.ascontiguousarray(z)


def restored_batched(batched: Any, n_traj: int) -> bool | None:
    """The pickled batch flag of a stream following `n_traj` trajectories (None: not started,
    False: one trajectory, True: a batch); ValueError when it does not fit the state."""
    fits = {None: n_traj == 0, False: n_traj == 1, True: n_traj >= 1}
    if not (batched is None or isinstance(batched, bool)) or not fits[batched]:
        raise ValueError(
            f"the pickled stream is altered: batch flag {batched!r} for {n_traj} trajectories"
        )
    return batched


def stream_shape(batched: bool, current: bool | None, b: int, n_traj: int) -> None:
    """ValueError when a stream started as one trajectory gets a batch or vice versa."""
    if current is None:
        return
    if batched != current:
        kinds = {False: "one trajectory", True: "a batch"}
        raise ValueError(f"this stream follows {kinds[current]}; got {kinds[batched]}")
    if b != n_traj:
        raise ValueError(f"this stream follows {n_traj} trajectories, got {b}")
