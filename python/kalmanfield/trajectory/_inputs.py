"""Checks of the series, times and velocity samples the trajectory filters take."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from .._validation import real_array, real_number


def series_array(z: npt.ArrayLike, name: str = "z") -> np.ndarray:
    """`z` as a float64 C-contiguous 1-D (one series) or 2-D (series × samples) array holding
    at least one sample; NaN marks a missing sample (masked entries become NaN)."""
    ragged = ValueError(
        f"{name} is ragged: every series needs the same number of samples "
        "(pad the shorter ones with NaN)"
    )
    try:
        ndim = np.ndim(z)
    except ValueError:
        raise ragged from None
    if ndim == 0 and not isinstance(z, (str, bytes)):
        raise ValueError(f"{name} must be 1-D (one series) or 2-D (series × samples), got a number")
    if isinstance(z, np.ndarray) and z.dtype == object:
        if any(np.ndim(item) > 0 for item in z.ravel()):
            raise ragged
    arr = real_array(z, name)
    if arr.ndim not in (1, 2):
        raise ValueError(
            f"{name} must be 1-D (one series) or 2-D (series × samples), got {arr.ndim} dimensions"
        )
    if arr.size == 0:
        raise ValueError(f"{name} holds no sample (shape {arr.shape})")
    return arr


def times_array(times: npt.ArrayLike | None, shape: tuple[int, ...]) -> np.ndarray | None:
    """None (t_n = n), times shared by every series (one per sample) or, for 2-D samples, one
    time per series and sample. Finiteness and the strict increase are checked by the kernel."""
    if times is None:
        return None
    t = real_array(times, "times")
    n = shape[-1]
    if t.shape == (n,) or (len(shape) == 2 and t.shape == shape):
        return t
    allowed = f"({n},)" + (f" or {shape}" if len(shape) == 2 else "")
    raise ValueError(f"times must have shape {allowed}, got {t.shape}")


def velocity_array(velocity: npt.ArrayLike | None, shape: tuple[int, ...], measured: bool):
    """The velocity samples (NaN = missing), required exactly when R_vel was given."""
    if velocity is None:
        if measured:
            raise ValueError("this filter measures velocities (R_vel given): pass velocity=")
        return None
    if not measured:
        raise ValueError("velocity= needs a filter with velocity measurements (R_vel)")
    zv = real_array(velocity, "velocity")
    if zv.shape != shape:
        raise ValueError(f"velocity must have the shape {shape} of z, got {zv.shape}")
    return zv


def step_samples(z_n: Any, name: str = "z_n") -> tuple[np.ndarray, bool]:
    """(samples of one step as a 1-D array, whether a scalar was given)."""
    if np.ndim(z_n) == 0:
        value = z_n if isinstance(z_n, np.ndarray) else z_n
        arr = real_array(np.asarray(value).reshape(1), name)
        return arr, True
    arr = real_array(z_n, name)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a number or a non-empty 1-D array, got {arr.shape}")
    return arr, False


def next_time(t_n: Any, t_last: float | None) -> float:
    """The step's time: given, or the last time + 1 (0 at the first step)."""
    if t_n is None:
        return 0.0 if t_last is None else t_last + 1.0
    t = real_number(t_n, "t_n")
    if t_last is not None and not t > t_last:
        raise ValueError(f"t_n must increase strictly: {t} follows {t_last}")
    if not math.isfinite(t):  # pragma: no cover - real_number refuses it
        raise ValueError("t_n must be finite")
    return t


def as_batch(values: np.ndarray, two_d: bool) -> np.ndarray:
    """A (series, samples) view of one series (1-D) or of a batch."""
    return values if two_d else values[None, :]


def output_pair(out: Any, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`out` checked as the (position, velocity) destination of a filter of `z`: two
    writeable, C-contiguous float64 arrays of z's shape sharing memory with nothing else."""
    if not isinstance(out, tuple) or len(out) != 2:
        raise TypeError("out must be a pair (position, velocity) of NumPy arrays")
    for a in out:
        if not isinstance(a, np.ndarray):
            raise TypeError(f"out must hold NumPy arrays, got {type(a).__name__}")
        if a.dtype != np.float64:
            raise TypeError(f"out must hold float64 arrays, got {a.dtype}")
        if a.shape != z.shape:
            raise ValueError(f"out arrays must have the shape {z.shape} of z, got {a.shape}")
        if not (a.flags.c_contiguous and a.flags.writeable):
            raise ValueError("out arrays must be C-contiguous and writeable")
        if np.may_share_memory(a, z):
            raise ValueError("out shares memory with z: the filter reads z after writing")
    if np.may_share_memory(out[0], out[1]):
        raise ValueError("the two out arrays share memory")
    return out[0], out[1]


def restored_stream(bank: Any, stream: Any) -> tuple[Any, bool, float]:
    """(bank, one-series flag, last time) of a pickled stream (state values, flag, last
    time), its state loaded into `bank` (a new ``_core`` FilterBank or DetectorBank, whose
    loader checks the numbers); ValueError when the parts of the pickle disagree."""
    values, scalar, t_last = stream
    bank.load_state(np.asarray(values, dtype=np.float64))
    if not isinstance(scalar, bool) or (scalar and bank.series != 1):
        raise ValueError("the pickled stream is altered: a one-series flag of another stream")
    if bank.last_time is None or t_last != bank.last_time:
        raise ValueError("the pickled stream is altered: its last time is not its state's")
    return bank, scalar, float(t_last)
