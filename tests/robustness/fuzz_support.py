"""What the robustness harnesses share: the run mode, the verdict on one call, and the check
that a returned value holds no NaN or inf.

Quick mode (default, CI): a curated set of cases, a few seconds per harness. Long mode
(``KALMANFIELD_FUZZ=long``): every case of the pools plus seeded random ones, minutes
(``KALMANFIELD_FUZZ_SEED`` picks another seed for the random cases).
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import textwrap
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

LONG = os.environ.get("KALMANFIELD_FUZZ", "").lower() == "long"
SEED = int(os.environ.get("KALMANFIELD_FUZZ_SEED", "49"))

#: the exceptions a public call may raise on bad input (each with a message)
CLEAR = (ValueError, TypeError, MemoryError)


def rng(salt: int = 0) -> np.random.Generator:
    """The harnesses' seeded generator (a failure names the seed: reproducible)."""
    return np.random.default_rng([SEED, salt])


def bad_leaves(value: Any, allow_nan: bool = False, depth: int = 0) -> list[str]:
    """Where `value` (an array, a DataFrame, a float, a tuple/list/dict/dataclass of them)
    holds NaN or ±inf (NaN tolerated with `allow_nan`, inf never)."""
    if depth > 4:
        return []
    if isinstance(value, np.ndarray) and value.dtype.kind in "fc":
        bad = np.isinf(value) if allow_nan else ~np.isfinite(value)
        return [f"array {value.shape}: {int(bad.sum())} non-finite"] if bad.any() else []
    if isinstance(value, pd.DataFrame):
        return bad_leaves(value.select_dtypes("number").to_numpy(float), allow_nan, depth + 1)
    if isinstance(value, (float, np.floating)):
        ok = not np.isinf(value) if allow_nan else np.isfinite(value)
        return [] if ok else [f"scalar {value}"]
    if isinstance(value, dict):
        value = list(value.values())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = [getattr(value, f.name) for f in dataclasses.fields(value)]
    if isinstance(value, (tuple, list)):
        return [b for item in value for b in bad_leaves(item, allow_nan, depth + 1)]
    for name in ("rho", "sigma"):  # an ARFieldModel
        if hasattr(value, "_core") and hasattr(value, name):
            return bad_leaves(np.asarray(getattr(value, name), float), allow_nan, depth + 1)
    return []


def verdict(
    call: Callable[[], Any], must_raise: bool, allow_nan: bool = False, accept: tuple = CLEAR
) -> str | None:
    """None when `call` behaved: it raised one of `accept` with a message, or (unless
    `must_raise`) returned a value without NaN/inf. Otherwise what went wrong: another
    exception type (a pyo3 PanicException too: it derives from BaseException), an empty
    message, a return where an exception was due, a non-finite result."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = call()
    except (KeyboardInterrupt, SystemExit):
        raise
    except accept as err:
        return None if str(err).strip() else f"{type(err).__name__} without a message"
    except BaseException as err:  # noqa: BLE001 - the point of the probe
        return f"{type(err).__module__}.{type(err).__name__}: {str(err)[:160]}"
    if must_raise:
        return f"returned {type(result).__name__} instead of raising"
    bad = bad_leaves(result, allow_nan)
    return f"non-finite result: {bad[:3]}" if bad else None


def report(failures: list[str], limit: int = 40) -> str:
    shown = "\n  ".join(failures[:limit])
    more = f"\n  … and {len(failures) - limit} more" if len(failures) > limit else ""
    return f"{len(failures)} probe(s) misbehaved:\n  {shown}{more}"


def run_script(
    body: str,
    timeout: float,
    env: dict[str, str] | None = None,
    address_space: int | None = None,
) -> subprocess.CompletedProcess:
    """Runs `body` in a fresh interpreter (this one's sys.path), optionally under
    RLIMIT_AS = `address_space` bytes; TimeoutExpired past `timeout` seconds."""
    limit = ""
    if address_space is not None:
        limit = (
            "import resource\n"
            f"resource.setrlimit(resource.RLIMIT_AS, ({address_space}, {address_space}))\n"
        )
    script = limit + textwrap.dedent(body)
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    environment.update(env or {})
    return subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=environment,
    )
