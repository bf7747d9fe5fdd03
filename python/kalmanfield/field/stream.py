"""Endless space–time field sequences, frame by frame (method page *Random fields*, §1.4)."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import numpy.typing as npt

from .._validation import (
    SeedLike,
    ShapeLike,
    allocate,
    check_given_noise_output,
    check_memory,
    finite_noise,
    float_dtype,
    grid_shape,
    positive_int,
    resolve_seed,
    thread_count,
)
from .model import ARFieldModel
from .stream_state import check_recursions, checked_state, history_limit


class FieldStream:
    """Endless, stationary sequence of frames of a model whose axis 0 is time.

    Frame t is x_t = Σ_j α_{t,j} x_{t−j} + β_t η_t with η_t a spatial field of the remaining
    axes, stationary from frame 0. The stream is its own iterator (``next(stream)``) and
    keeps only the last n_t frames.

    Parameters
    ----------
    model : ARFieldModel
        A model of at least two axes; axis 0 is time.
    frame_shape : int or tuple of int
        Shape of a frame (the model's axes after the first).
    seed : int, numpy.random.Generator or None, default None
        Seed (None: OS entropy). Frame t draws the same noise as slice t of
        ``model.sample((T, *frame_shape), seed)``, so the two agree.
    dtype : {numpy.float64, numpy.float32}, default numpy.float64
        Dtype of the frames.
    threads : int, optional
        Number of threads per frame (None: all cores).

    Attributes
    ----------
    model : ARFieldModel
        The model.
    frame_shape : tuple of int
        Shape of a frame.
    dtype : numpy.dtype
        Dtype of the frames.
    seed : int
        The resolved seed.
    threads : int or None
        Threads per frame.
    time : int
        Number of frames drawn so far.

    Raises
    ------
    TypeError
        `model` is not an ARFieldModel.
    ValueError
        A model of one axis, a frame shape that does not match it, a float32 stream of a
        model whose single-precision recursion would drift (use float64), a model whose
        exact start is beyond float64.
    MemoryError
        Frames larger than the machine's memory.

    Notes
    -----
    Frames are returned read-only: the stream keeps the same arrays as its state (no copy
    per frame); ``frame.copy()`` gives a writable one. A stream pickles at any point and the
    copy continues bit-identically; a pickled state is checked at load, and a corrupt one is
    a ValueError or TypeError there. One stream serves one thread at a time: a call while
    another thread draws from it raises RuntimeError. Method: §1.4 of
    :doc:`/methods/random_fields`.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel([0.95, 0.9, 0.9], [1, 2, 2])
    >>> video = kf.FieldStream(model, (64, 64), seed=7)
    >>> frame0, frame1 = next(video), next(video)
    >>> video.take(3).shape, video.time
    ((3, 64, 64), 5)
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
        # the history and the frame being made
        check_memory(self.frame_shape, self.dtype, copies=model.order[0] + 1)
        check_recursions(model, self.dtype)
        self.seed = resolve_seed(seed)
        self.threads = thread_count(threads)
        self.time = 0
        self._history: list[np.ndarray] = []  # most recent first, at most n_t frames
        self._lock = threading.Lock()

    def __iter__(self) -> FieldStream:
        return self

    def __next__(self) -> np.ndarray:
        return self.next_frame()

    def _acquire(self) -> None:
        """The stream for this call alone: RuntimeError while another call holds it."""
        if not self._lock.acquire(blocking=False):
            raise RuntimeError(
                "FieldStream is already in use by another thread (a stream's frames follow "
                "one another: draw from it in one thread, or give each thread its own stream)"
            )

    def next_frame(self, noise: npt.ArrayLike | None = None) -> np.ndarray:
        """The next frame.

        Parameters
        ----------
        noise : array_like, optional
            The frame's driving noise η_t (standard normal, shape `frame_shape`) instead of
            the seeded stream.

        Returns
        -------
        numpy.ndarray
            The frame, read-only.

        Raises
        ------
        ValueError
            Given noise of the wrong shape or not finite, or whose frame would leave what the
            stream can carry (about a quarter of the dtype's largest number, less for a
            slowly decaying time recursion); the stream is then unchanged.
        RuntimeError
            Another thread is drawing from the stream.
        """
        given = None if noise is None else finite_noise(noise, self.frame_shape)
        self._acquire()
        try:
            return self._step(given)
        finally:
            self._lock.release()

    def _step(self, given: np.ndarray | None) -> np.ndarray:
        frame = allocate(self.frame_shape, self.dtype)
        self.model._core.stream_into(
            frame, self._history, self.time, self.seed, given, self.threads
        )
        if given is not None:
            check_given_noise_output(frame, history_limit(self.model, self.dtype, self.time + 1))
        frame.flags.writeable = False
        self._history = [frame, *self._history][: self.model.order[0]]
        self.time += 1
        return frame

    def take(self, count: int) -> np.ndarray:
        """The next frames, stacked.

        Parameters
        ----------
        count : int
            Number of frames.

        Returns
        -------
        numpy.ndarray
            Shape ``(count, *frame_shape)``, writable.

        Raises
        ------
        MemoryError
            The stack would not fit in memory (raised before any frame is drawn).
        RuntimeError
            Another thread is drawing from the stream.

        Notes
        -----
        On any error the stream is left where it was (no frame lost).
        """
        count = positive_int(count, "count")
        shape = (count, *self.frame_shape)
        check_memory(shape, self.dtype)
        self._acquire()
        try:
            time, history = self.time, self._history
            out = np.empty(shape, dtype=self.dtype)
            try:
                for frame in out:
                    frame[...] = self._step(None)
            except BaseException:
                self.time, self._history = time, history
                raise
            return out
        finally:
            self._lock.release()

    def __getstate__(self) -> dict[str, Any]:
        self._acquire()
        try:
            return {
                "model": self.model,
                "frame_shape": self.frame_shape,
                "dtype": self.dtype.str,
                "seed": self.seed,
                "threads": self.threads,
                "time": self.time,
                "history": list(self._history),
            }
        finally:
            self._lock.release()

    def __setstate__(self, state: dict[str, Any]) -> None:
        checked = checked_state(state)
        self.model = checked["model"]
        self.frame_shape = checked["frame_shape"]
        self.dtype = checked["dtype"]
        self.seed = checked["seed"]
        self.threads = checked["threads"]
        self.time = checked["time"]
        self._history = checked["history"]
        self._lock = threading.Lock()

    def __repr__(self) -> str:
        return f"FieldStream({self.model!r}, frame_shape={self.frame_shape}, time={self.time})"
