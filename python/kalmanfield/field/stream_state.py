"""What a :class:`~kalmanfield.FieldStream` may carry from frame to frame: the bound on its
history frames that keeps every later frame inside the float range, and the check of a
pickled state against it (a corrupt state is a ValueError/TypeError at load, never NaN
frames later)."""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import numpy as np

from .._validation import float_dtype, grid_shape, nonnegative_int, thread_count
from .model import ARFieldModel

#: the keys of a pickled FieldStream state
STATE_KEYS = ("model", "frame_shape", "dtype", "seed", "threads", "time", "history")


def history_limit(model: ARFieldModel, dtype: np.dtype, time: int) -> float:
    """The largest |value| a history frame of a stream at frame `time` may hold: the time
    recursion's response to any history within ±limit stays within a quarter of the dtype's
    largest number at every later frame (the rest is room for the innovations).

    The response to the last n frames x_{-1..-n} (stationary part, ρ and n of the time axis) solves
    (1 − ρz⁻¹)ⁿ x = 0, so x_t = ρ^t Σ_j ρ^j x_{-j} L_j(t), L_j the Lagrange basis on the nodes
    −1..−n. For t ≥ 0 the sign of L_j(t) is (−1)^{j−1}: the worst history alternates in sign and
    reaches G = sup_t ρ^t Σ_j ρ^j |L_j(t)|, a log-concave function of t (its polynomial part has its
    n − 1 roots in (−n, −1)) with its peak below t = (n − 1)/(−ln ρ): a ternary search finds it (ρ →
    1 with n = 4 gives G ~ (3/(e(1 − ρ)))³/3!). Before frame n the boundary recursion (method page
    *Random fields*, §1.3) feeds the stationary one; its gains multiply G. The limit is max / (4
    max(G, 1)), so 1e308 is never carried."""
    return _history_limit(model, np.dtype(dtype).str, min(time, model.order[0]))


@lru_cache(maxsize=64)
def _history_limit(model: ARFieldModel, dtype: str, position: int) -> float:
    n, rho = model.order[0], model.rho[0]
    gain = _boundary_gain(model, position) * max(_stationary_gain(rho, n), 1.0)
    return float(np.finfo(np.dtype(dtype)).max) / 4.0 / max(gain, 1.0)


def _stationary_gain(rho: float, n: int) -> float:
    """G = sup_{t ≥ 0} ρ^t Σ_j ρ^j |L_j(t)| (see :func:`history_limit`), or inf beyond float64."""
    log_rho = math.log(rho)
    # log((j−1)! (n−j)!) of the Lagrange denominators
    denominators = [math.lgamma(j) + math.lgamma(n - j + 1) for j in range(1, n + 1)]

    def log_gain(t: float) -> float:
        logs = np.array(
            [
                j * log_rho
                - denominators[j - 1]
                + sum(math.log(t + i) for i in range(1, n + 1) if i != j)
                for j in range(1, n + 1)
            ]
        )
        top = logs.max()
        return t * log_rho + top + math.log(np.exp(logs - top).sum())

    lo, hi = 0.0, (n - 1) / -log_rho
    for _ in range(200):  # ternary search on a concave function (hi may be ~1e17)
        if hi - lo <= 1e-9 * max(hi, 1.0):
            break
        a, b = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        if log_gain(a) < log_gain(b):
            lo = a
        else:
            hi = b
    peak = max(log_gain(0.0), log_gain(0.5 * (lo + hi)))
    # (1e-6: the search's tolerance and the rounding of the sums, with room to spare)
    return math.exp(peak) * (1 + 1e-6) if peak < 709.0 else math.inf


def _boundary_gain(model: ARFieldModel, position: int) -> float:
    """The largest row sum of |response| of the frames position..n−1 of the boundary
    recursion (and of the history itself) to the `position` frames of the history; 1 from
    frame n on (the stationary recursion's own gain is :func:`_stationary_gain`)."""
    n = model.order[0]
    if position >= n:
        return 1.0
    coefficients, _ = model._core.boundary(0)
    rows = [np.eye(position)[position - 1 - a] for a in range(position)]  # absolute time a
    for a in range(position, n):
        terms = (c * rows[a - 1 - j] for j, c in enumerate(coefficients[a]))
        rows.append(sum(terms, np.zeros(position)))
    return max(1.0, *(float(np.abs(r).sum()) for r in rows))


def check_recursions(model: ARFieldModel, dtype: np.dtype) -> None:
    """ValueError unless the kernel can run the model's recursions in `dtype` (a stationary
    start beyond float64, a float32 recursion whose rounding would pass ~1e-3 σ): frame 0 of
    one element, at the stream's construction rather than at its first frame."""
    probe = np.empty((1,) * (model.ndim - 1), dtype=dtype)
    model._core.stream_into(probe, [], 0, 0, None, 1)


def checked_state(state: Any) -> dict[str, Any]:
    """The fields of a pickled FieldStream state, each checked as the constructor checks it,
    and its history (a list of at most n_t frames, most recent first, exactly min(time, n_t)
    of them, each an ndarray of the stream's dtype and frame_shape, finite and within
    :func:`history_limit`). TypeError/ValueError naming the field otherwise."""
    if not isinstance(state, dict):
        raise TypeError(f"a FieldStream state must be a dict, got {type(state).__name__}")
    missing = [k for k in STATE_KEYS if k not in state]
    if missing:
        raise ValueError(f"the FieldStream state lacks {missing}")
    model = state["model"]
    if not isinstance(model, ARFieldModel):
        raise TypeError(f"the state's model must be an ARFieldModel, got {type(model).__name__}")
    if model.ndim < 2:
        raise ValueError("the state's model has no time axis (axis 0) and spatial axes")
    frame_shape = grid_shape(state["frame_shape"], model.ndim - 1, "the state's frame_shape")
    if not isinstance(state["dtype"], str):
        raise TypeError(f"the state's dtype must be a dtype string, got {state['dtype']!r}")
    try:
        dtype = float_dtype(np.dtype(state["dtype"]), model.sigma)
    except (TypeError, ValueError) as err:
        raise type(err)(f"the state's dtype: {err}") from None
    seed = state["seed"]
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"the state's seed must be an int, got {seed!r}")
    if not 0 <= int(seed) < 2**64:
        raise ValueError(f"the state's seed must lie in [0, 2**64), got {seed}")
    check_recursions(model, dtype)
    time = nonnegative_int(state["time"], "the state's time")
    history = _checked_history(state["history"], model, frame_shape, dtype, time)
    return {
        "model": model,
        "frame_shape": frame_shape,
        "dtype": dtype,
        "seed": int(seed),
        "threads": thread_count(state["threads"]),
        "time": time,
        "history": history,
    }


def _checked_history(
    history: Any, model: ARFieldModel, frame_shape: tuple[int, ...], dtype: np.dtype, time: int
) -> list[np.ndarray]:
    if not isinstance(history, (list, tuple)):
        raise TypeError(
            f"the state's history must be a list of frames, got {type(history).__name__}"
        )
    needed = min(time, model.order[0])
    if len(history) != needed:
        raise ValueError(
            f"the state's history holds {len(history)} frames; a stream at frame {time} of "
            f"time order {model.order[0]} keeps {needed}"
        )
    limit = history_limit(model, dtype, time) if history else math.inf
    frames = []
    for j, frame in enumerate(history):
        if not isinstance(frame, np.ndarray):
            raise TypeError(f"history frame {j} must be an ndarray, got {type(frame).__name__}")
        if frame.dtype != dtype:
            raise TypeError(f"history frame {j} has dtype {frame.dtype}, the stream {dtype}")
        if frame.shape != frame_shape:
            raise ValueError(f"history frame {j} has shape {frame.shape}, the stream {frame_shape}")
        frame = np.ascontiguousarray(frame)
        if not np.isfinite(frame).all():
            raise ValueError(f"history frame {j} holds NaN or infinite values")
        peak = float(np.max(np.abs(frame)))
        if peak > limit:
            raise ValueError(
                f"history frame {j} holds |x| = {peak:g}, beyond the {limit:g} the stream's "
                "time recursion can carry without overflow"
            )
        frame.flags.writeable = False
        frames.append(frame)
    return frames
