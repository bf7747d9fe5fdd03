"""The parallel entry points and their inputs for the thread-count determinism harness:
`digests(threads)` runs each with `threads` (None: rayon's global pool, whose size
RAYON_NUM_THREADS sets) and returns a digest of every output's bytes. Run as a script it
prints those of threads=None as JSON (the harness calls it under RAYON_NUM_THREADS)."""

from __future__ import annotations

import hashlib
import json
import sys
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

import kalmanfield as kf

LONG = "--long" in sys.argv or __import__("fuzz_support").LONG

#: frames above the kernels' parallel thresholds (2**16 elements for the fields)
SIDE = 320 if LONG else 260
MODEL = kf.ARFieldModel([0.9, 0.85], [2, 1], 1.5)
SPACE_TIME = kf.ARFieldModel([0.8, 0.9, 0.7], [1, 2, 1])


def _stack(frames: int = 3, side: int = 96) -> np.ndarray:
    x = MODEL.sample((frames * side, side), seed=5).reshape(frames, side, side)
    return x + 0.5 * np.random.default_rng(6).standard_normal(x.shape)


def _cases(threads: int | None) -> dict[str, Callable[[], Any]]:
    z = _stack()
    t = dict(threads=threads)
    return {
        "sample": lambda: MODEL.sample((SIDE, SIDE), seed=1, **t),
        "sample float32": lambda: MODEL.sample((SIDE, SIDE), seed=2, dtype=np.float32, **t),
        "sample_product_field": lambda: kf.sample_product_field(MODEL, (SIDE, SIDE), seed=3, **t),
        "stream": lambda: SPACE_TIME.stream((SIDE, SIDE), seed=4, **t).take(3),
        "scalar filter stack": lambda: kf.ScalarRowFilter(MODEL, 0.25, 96, smooth=True, **t).filter(
            z
        ),
        "scalar filter weighted": lambda: kf.ScalarRowFilter(MODEL, 0.25, 96, **t).filter(
            np.where(z > 2.5, np.nan, z)
        ),
        "vector filter stack": lambda: kf.VectorRowFilter(MODEL, 0.25, 96, smooth=True, **t).filter(
            z
        ),
        "vector error_variance": lambda: kf.VectorRowFilter(
            MODEL, 0.25, 96, smooth=True, **t
        ).error_variance(64),
        "wiener_error_map": lambda: kf.wiener_error_map(MODEL, 0.25, (80, 96)),
        "scalar filter toeplitz": lambda: kf.ScalarRowFilter(
            MODEL, 0.25, 96, smooth=True, modes="toeplitz", **t
        ).filter(z),
        "denoise adaptive": lambda: kf.denoise(z, method="adaptive", **t),
        "denoise auto": lambda: kf.denoise(z, **t),
        "denoise stationary": lambda: kf.denoise(z, method="stationary", **t),
        "identify": lambda: _identified(kf.identify(z, max_order=3, axes=(1, 2), **t)),
        "segment stack": lambda: kf.segment(z, 1.5),
        "local_moments stack": lambda: kf.local_moments(z, 7),
        "estimate_noise_var": lambda: kf.estimate_noise_var(z),
        "link": lambda: _linked(),
    }


def _identified(fit) -> list:
    return [fit.model.rho, fit.model.order, fit.model.sigma, fit.mean, *fit.fits]


def _linked() -> pd.DataFrame:
    g = np.random.default_rng(8)
    frames = np.repeat(np.arange(30), 12)
    xy = g.uniform(0, 200, (frames.size, 2))
    xy[::12] = np.c_[np.arange(30) * 2.0 + 10, np.arange(30) * 1.0 + 20]
    det = pd.DataFrame({"frame": frames, "x": xy[:, 0], "y": xy[:, 1]})
    return kf.link(det, measurement_std=0.5, process_std=0.1)


def digest(value: Any) -> str:
    h = hashlib.sha256()
    _feed(h, value)
    return h.hexdigest()


def _feed(h, value: Any) -> None:
    if isinstance(value, np.ndarray):
        h.update(str((value.dtype, value.shape)).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, pd.DataFrame):
        h.update(str(list(value.columns)).encode())
        for name in value.columns:
            _feed(h, value[name].to_numpy())
    elif isinstance(value, (tuple, list)):
        for item in value:
            _feed(h, item)
    elif hasattr(value, "__dataclass_fields__"):
        for name in value.__dataclass_fields__:
            _feed(h, getattr(value, name))
    else:
        h.update(repr(value).encode())


def digests(threads: int | None) -> dict[str, str]:
    return {name: digest(call()) for name, call in _cases(threads).items()}


if __name__ == "__main__":
    print(json.dumps(digests(None)))
