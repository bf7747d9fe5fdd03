"""Endless space–time field sequences, frame by frame (SPEC §1.4)."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ._validation import (
    SeedLike,
    ShapeLike,
    allocate,
    finite_noise,
    float_dtype,
    grid_shape,
    positive_int,
    resolve_seed,
    thread_count,
)
from .ar_field_model import ARFieldModel


class FieldStream:
    """Frames x_t of a model whose axis 0 is time: x_t = Σ_j α_{t,j} x_{t-j} + β_t η_t with
    η_t a spatial field of the remaining axes (SPEC §1.4), stationary from frame 0 (the first
    n_t frames use the boundary recursion of SPEC §1.3).

    The stream is its own iterator (``next(stream)``), unbounded, and keeps only the last n_t
    frames (memory O(n_t · frame)). Frames are returned read-only because the stream keeps
    the same arrays as its state (no copy per frame); ``frame.copy()`` gives a writable one.
    Frame t draws the same noise as slice t of ``model.sample((T, *frame_shape), seed)``, so
    the two agree. It pickles at any point; the
    unpickled copy continues bit-identically.

    A float32 stream runs its recursions in single precision, so it is refused (ValueError:
    use float64) for models whose rounding errors would pass ~1e-3 σ there (1/β̃ > 84 on an
    axis; :meth:`ARFieldModel.sample` falls back to float64 for those instead).
    """

    def __init__(
        self,
        model: ARFieldModel,
        frame_shape: ShapeLike,
        seed: SeedLike = None,
        dtype: npt.DTypeLike = np.float64,
        threads: int | None = None,
    ) -> None:
        if not isinstance(model, ARFieldModel):
            raise TypeError(f"model must be an ARFieldModel, got {type(model).__name__}")
        if model.ndim < 2:
            raise ValueError("a stream needs a model with a time axis (axis 0) and spatial axes")
        self.model = model
        self.frame_shape = grid_shape(frame_shape, model.ndim - 1, "frame_shape")
        self.dtype = float_dtype(dtype, model.sigma)
        if self.dtype == np.float32:  # the kernel's precision check: frame 0 of one element
            probe = np.empty((1,) * (model.ndim - 1), dtype=self.dtype)
            model._core.stream_into(probe, [], 0, 0, None, 1)
        self.seed = resolve_seed(seed)
        self.threads = thread_count(threads)
        self.time = 0
        self._history: list[np.ndarray] = []  # most recent first, at most n_t frames

    def __iter__(self) -> FieldStream:
        return self

    def __next__(self) -> np.ndarray:
        return self.next_frame()

    def next_frame(self, noise: npt.ArrayLike | None = None) -> np.ndarray:
        """The next frame; `noise` optionally supplies its driving noise η_t (standard
        normal, shape `frame_shape`) instead of the seeded stream."""
        given = None if noise is None else finite_noise(noise, self.frame_shape)
        frame = allocate(self.frame_shape, self.dtype)
        self.model._core.stream_into(
            frame, self._history, self.time, self.seed, given, self.threads
        )
        frame.flags.writeable = False
        self._history = [frame, *self._history][: self.model.order[0]]
        self.time += 1
        return frame

    def take(self, count: int) -> np.ndarray:
        """The next `count` frames stacked into an array of shape (count, *frame_shape)."""
        count = positive_int(count, "count")
        return np.stack([self.next_frame() for _ in range(count)])

    def __getstate__(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "frame_shape": self.frame_shape,
            "dtype": self.dtype.str,
            "seed": self.seed,
            "threads": self.threads,
            "time": self.time,
            "history": self._history,
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.model = state["model"]
        self.frame_shape = tuple(state["frame_shape"])
        self.dtype = np.dtype(state["dtype"])
        self.seed = state["seed"]
        self.threads = state["threads"]
        self.time = state["time"]
        self._history = [np.ascontiguousarray(h, dtype=self.dtype) for h in state["history"]]

    def __repr__(self) -> str:
        return f"FieldStream({self.model!r}, frame_shape={self.frame_shape}, time={self.time})"
