"""Argument checks shared by the public API: every bad input becomes a clear Python exception
before any kernel runs."""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Sequence
from typing import Any, Union

import numpy as np
import numpy.typing as npt

from ._memory import memory_budget

SeedLike = Union[int, np.integer, np.random.Generator, None]
ShapeLike = Union[int, Sequence[int]]

_U64 = 1 << 64


def pickled_fields(state: Any, kind: str, *names: str) -> tuple[Any, ...]:
    """The fields `names` of the pickled state of a `kind` object (a dict); ValueError when
    the pickle was altered so that it is not a dict holding them."""
    if not isinstance(state, dict) or not set(names) <= set(state):
        raise ValueError(f"the pickled {kind} is altered: its state lacks some of {names}")
    return tuple(state[n] for n in names)


def resolve_seed(seed: SeedLike) -> int:
    """A 64-bit seed from an int, a NumPy Generator (one draw) or None (fresh OS entropy)."""
    if seed is None:
        return int(np.random.SeedSequence().generate_state(1, dtype=np.uint64)[0])
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, _U64, dtype=np.uint64))
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise TypeError(
            f"seed must be an int, a numpy Generator or None, got {type(seed).__name__}"
        )
    seed = int(seed)
    if not 0 <= seed < _U64:
        raise ValueError(f"seed must be in [0, 2**64), got {seed}")
    return seed


def positive_int(value: Any, name: str) -> int:
    """An int ≥ 1 (numpy integers accepted, bools and floats refused)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a positive integer, got {value!r}")
    if not 1 <= int(value) < 2**63:
        raise ValueError(f"{name} must be a positive integer below 2**63, got {int(value)}")
    return int(value)


#: The most threads a call may start (a pool per call; thousands of threads only queue).
MAX_THREADS = 1024


def thread_count(threads: Any) -> int | None:
    """None (all cores) or a thread count in 1..=MAX_THREADS."""
    if threads is None:
        return None
    k = positive_int(threads, "threads")
    if k > MAX_THREADS:
        raise ValueError(f"threads must lie in 1..={MAX_THREADS} (or None: all cores), got {k}")
    return k


def nonnegative_int(value: Any, name: str) -> int:
    """An int ≥ 0 (numpy integers accepted, bools and floats refused)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a non-negative integer, got {value!r}")
    if not 0 <= int(value) < 2**63:
        raise ValueError(f"{name} must be a non-negative integer below 2**63, got {int(value)}")
    return int(value)


def real_value(value: object, name: str, what: str = "be a real number") -> float:
    """`value` as a float; TypeError "<name> must <what>" unless it is a real number (bools
    refused). An integer or fraction beyond float64 becomes ±inf, for the caller's range
    check to refuse (float() raised OverflowError, NumPy's isfinite a TypeError on them)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must {what}, got {value!r}")
    try:
        return float(value)
    except OverflowError:
        return -math.inf if value < 0 else math.inf


def real_number(value: Any, name: str) -> float:
    """A finite real number (bools refused)."""
    number = real_value(value, name)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {number}")
    return number


def positive_float(value: object, name: str) -> float:
    """A positive finite real number (bools refused)."""
    number = real_value(value, name)
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"{name} must be positive and finite, got {number}")
    return number


def probability(value: Any, name: str) -> float:
    """A real number strictly between 0 and 1."""
    p = real_number(value, name)
    if not 0.0 < p < 1.0:
        raise ValueError(f"{name} must lie strictly between 0 and 1, got {p}")
    return p


def check_real_dtype(raw: np.ndarray, name: str) -> None:
    """TypeError unless `raw` holds real numbers: an integer or float dtype, or objects that
    are all real numbers (not bools, strings, None, complex…: float() would parse "1.5" and
    take True as 1)."""
    if raw.dtype.kind not in "iufO":
        raise TypeError(f"{name} must hold real numbers, got dtype {raw.dtype}")
    if raw.dtype.kind == "O":
        for item in raw.flat:
            if isinstance(item, (bool, np.bool_)) or not isinstance(item, numbers.Real):
                raise TypeError(f"{name} must hold real numbers, got {item!r}")


def real_array(value: npt.ArrayLike, name: str) -> np.ndarray:
    """`value` as a C-contiguous float64 array (at least 1-D); None, bool, complex, strings,
    datetimes, structured and other non-numeric input refused. The masked entries of a
    ``numpy.ma.MaskedArray`` become NaN (missing), as in :func:`observed`."""
    if value is None:
        raise TypeError(f"{name} must be an array, got None")
    masked = np.ma.getmaskarray(value) if isinstance(value, np.ma.MaskedArray) else None
    raw = np.asarray(np.ma.getdata(value) if masked is not None else value)
    check_real_dtype(raw, name)
    try:
        out = np.ascontiguousarray(raw, dtype=np.float64)
    except OverflowError:
        raise ValueError(f"{name} hold a number beyond float64's range") from None
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name} must be numeric arrays: {err}") from None
    if masked is not None and masked.any():
        if np.shares_memory(out, raw):  # never write into the caller's data
            out = out.copy()
        out[masked] = np.nan
    return out


def power_of_two_exponent(deviations: np.ndarray) -> int | None:
    """e with 2^e the power of two nearest max |deviations| (None when they are all 0):
    dividing by 2^e is exact (the same bits wherever the unscaled values did not overflow or
    underflow), and sums of squares of the scaled values stay inside float64 whatever the
    data's magnitude. ValueError when the deviations themselves overflow."""
    with np.errstate(over="ignore", invalid="ignore"):
        peak = float(np.max(np.abs(deviations)))
    if not np.isfinite(peak):
        raise ValueError("the data's deviations from their mean overflow float64: rescale them")
    return int(np.round(np.log2(peak))) if peak > 0 else None


def grid_shape(shape: ShapeLike, ndim: int, name: str = "shape") -> tuple[int, ...]:
    """A shape of `ndim` positive ints."""
    if isinstance(shape, numbers.Integral):
        items: tuple = (shape,)
    elif isinstance(shape, (str, bytes)) or not isinstance(shape, Iterable):
        raise TypeError(f"{name} must be an int or a sequence of ints, got {shape!r}")
    else:
        items = tuple(shape)
    dims = tuple(positive_int(s, f"every entry of {name}") for s in items)
    if len(dims) != ndim:
        raise ValueError(f"{name} {dims} has {len(dims)} axes but the model has {ndim}")
    return dims


#: σ a float32 field may have: its largest values (tens of σ for product fields) and its
#: smallest ones stay far inside float32's range (σ = 1e39 gave inf)
FLOAT32_SIGMA = (2.0**-100, 2.0**100)


def float_dtype(dtype: npt.DTypeLike, sigma: float | None = None) -> np.dtype:
    """float32 or float64; ValueError for float32 when `sigma` (the field's σ, if given) lies
    outside :data:`FLOAT32_SIGMA`."""
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise TypeError(f"dtype must be float32 or float64, got {dt}")
    low, high = FLOAT32_SIGMA
    if dt == np.float32 and sigma is not None and not low <= sigma <= high:
        raise ValueError(
            f"a float32 field needs sigma within [2**-100, 2**100], got {sigma:g}: use float64"
        )
    return dt


def check_memory(shape: tuple[int, ...], dtype: np.dtype, copies: int = 1) -> None:
    """MemoryError when `copies` arrays of `shape` and `dtype` exceed the memory this process
    may take (the machine's physical memory, or less under an address-space or cgroup limit),
    before a kernel would try to allocate them and abort."""
    nbytes = copies * int(np.prod(shape, dtype=object)) * dtype.itemsize
    budget = memory_budget()
    if budget is not None and nbytes > budget[0]:
        what = f"a {shape} {dtype} array" if copies == 1 else f"{copies} {shape} {dtype} arrays"
        raise MemoryError(
            f"{what} need{'s' if copies == 1 else ''} {nbytes / 2**30:.1f} GiB, more than "
            f"the {budget[0] / 2**30:.1f} GiB {budget[1]}"
        )


def allocate(shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """An empty C-ordered array, refusing sizes beyond the machine's physical memory."""
    check_memory(shape, dtype)
    return np.empty(shape, dtype=dtype)


def finite_noise(noise: npt.ArrayLike, shape: tuple[int, ...], name: str = "noise") -> np.ndarray:
    """Caller-supplied white noise as a C-contiguous float64 array of exactly `shape`."""
    arr = real_array(noise, name)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def peak_magnitude(values: np.ndarray) -> float:
    """max |values| without a temporary array (NaN if any is NaN; empty: 0)."""
    if values.size == 0:
        return 0.0
    with np.errstate(invalid="ignore"):
        return max(float(values.max()), -float(values.min()))


def check_given_noise_output(out: np.ndarray, limit: float | None = None) -> None:
    """ValueError when a field made from finite caller-given noise left the float range
    (or, if given, exceeds `limit`): the noise, documented as standard normal, was too large.
    (Seeded noise cannot get there: σ is bounded.)"""
    peak = peak_magnitude(out)
    bound = np.finfo(out.dtype).max if limit is None else limit
    if not peak <= bound:  # NaN too
        reach = "overflows " + str(out.dtype) if not np.isfinite(peak) else f"reaches {peak:g}"
        raise ValueError(
            f"the field made from the given noise {reach}, beyond the {bound:g} it may hold: "
            "the noise is standard normal (rescale it)"
        )


def boolean_mask(mask: npt.ArrayLike, shape: tuple[int, ...], name: str) -> np.ndarray:
    """`mask` checked as a boolean array of `shape` (True = leave the pixel out)."""
    m = np.asarray(mask)
    if m.shape != shape:
        raise ValueError(f"mask must have the shape {shape} of {name}, got {m.shape}")
    if m.dtype != np.bool_:
        raise TypeError(f"mask must be a boolean array, got dtype {m.dtype}")
    return m


def observed(data: npt.ArrayLike, mask: npt.ArrayLike | None = None, name: str = "data"):
    """Data as a fresh C-ordered float64 array with NaN at every missing pixel, plus the
    boolean array of valid pixels.

    Missing: NaN or infinite values, pixels masked by a ``numpy.ma.MaskedArray`` and pixels
    where ``mask`` is True (the ``numpy.ma`` convention: True marks a pixel to leave out).
    Integer (uint8, uint16, …) and float inputs are accepted; bool, complex, strings and
    other non-numbers are refused (TypeError, :func:`check_real_dtype`).
    """
    missing = np.ma.getmaskarray(data) if isinstance(data, np.ma.MaskedArray) else None
    raw = np.ma.getdata(data) if isinstance(data, np.ma.MaskedArray) else np.asarray(data)
    check_real_dtype(raw, name)
    try:
        values = np.array(raw, dtype=np.float64, order="C")
    except OverflowError:
        raise ValueError(f"{name} hold a number beyond float64's range") from None
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name} must be a numeric array: {err}") from None
    if mask is not None:
        m = boolean_mask(mask, values.shape, name)
        missing = m if missing is None else (missing | m)
    valid = np.isfinite(values)
    if missing is not None:
        valid &= ~missing
    values[~valid] = np.nan
    return values, valid


def images(
    z: npt.ArrayLike, width: int | None = None, missing: bool = False, finite: bool = True
) -> np.ndarray:
    """z as a C-contiguous float64 (H, W) image or (F, H, W) stack of `width` columns (None:
    any width). uint8/uint16/int/float32 inputs are converted; None, bool and complex are
    refused; infinite pixels are refused, and NaN pixels too unless `missing` (NaN = missing
    observation).
    finite=False skips the pixel check (for callers whose kernel checks every pixel)."""
    arr = real_array(z, "images")
    if arr.ndim not in (2, 3):
        raise ValueError(f"z must be an image (H, W) or a stack (F, H, W), got {arr.ndim}-D")
    if width is not None and arr.shape[-1] != width:
        raise ValueError(f"the filter was built for width {width}, the images have {arr.shape[-1]}")
    if arr.shape[-2] == 0 or arr.shape[-1] == 0:
        raise ValueError(f"the images have no {'rows' if arr.shape[-2] == 0 else 'columns'}")
    with np.errstate(over="ignore"):  # (finite pixels whose sum overflows: checked below)
        total = arr.sum() if finite else 0.0
    if np.isfinite(total):  # the fast path
        return arr
    if missing and not np.isinf(arr).any():
        return arr
    if not np.isfinite(arr).all():
        raise ValueError(
            "the images hold infinite pixels"
            if missing
            else "the images hold NaN or infinite pixels: this filter needs every pixel "
            "(ScalarRowFilter treats NaN pixels as missing observations)"
        )
    return arr
