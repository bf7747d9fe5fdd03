"""Byte-level and field-level corruption of pickled streaming objects (issue 49, "Done when").

Each case pickles an object mid-stream, corrupts the bytes (bit flips, overwritten bytes, special
float/int words in either byte order, truncation, cut or doubled ranges; seeded) or the fields of
its state, loads it and steps it. The only acceptable outcomes:

- a clear exception at load: one the pickle machinery raises on bytes it cannot parse
  (UnpicklingError, EOFError, KeyError, …), or, from kalmanfield's own code (a loader, a
  constructor called by a reducer), ValueError/TypeError/MemoryError;
- an object of the same type whose continuation is finite and correct: a FieldStream's next
  frames equal the NumPy twin's on the loaded history (given noise), a filter's output on an
  image of its width is finite, a tracker's tracks are finite.

Never a pyo3 PanicException, another exception from kalmanfield's code, NaN/inf output or a hang.

The loads use an Unpickler that resolves only numpy, builtins, copyreg and kalmanfield names
(the harness must not let a flipped byte name some other callable), and that declines — as
valid but too costly to run here — row filters rebuilt at widths above MAX_WIDTH (their build is
O(W³)). Each suite runs in a fresh interpreter under an address-space limit (RLIMIT_AS, 6 GiB)
and a timeout, printing each case before it runs: a corrupt state that aborts the
interpreter, exhausts memory or hangs is reported with its case number. Quick mode: 150 cases
per suite; KALMANFIELD_FUZZ=long: 3000.
"""

from __future__ import annotations

import io
import json
import pickle
import struct
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fuzz_support import CLEAR, LONG, bad_leaves, report, rng, run_script

import kalmanfield as kf
from kalmanfield import reference as ref

CASES = 3000 if LONG else 150
ADDRESS_SPACE = 6 * 2**30
TIMEOUT = 1800 if LONG else 120
MAX_WIDTH = 4096
PACKAGE = str(Path(kf.__file__).parent)
#: what the pickle machinery itself raises on bytes it cannot parse
MACHINERY = (
    pickle.UnpicklingError,
    EOFError,
    ValueError,
    TypeError,
    KeyError,
    IndexError,
    AttributeError,
    ImportError,
    OverflowError,
    MemoryError,
    UnicodeDecodeError,
    RecursionError,
    struct.error,
    SystemError,  # (NumPy's dtype __setstate__ on some corrupt bytes: "returned NULL")
)


class TooCostly(Exception):
    """A valid state the harness declines to run (a row filter of width > MAX_WIDTH)."""


def _capped_rebuild(rebuild: Callable) -> Callable:
    def rebuild_checked(*args):
        widths = [a for a in _flat(args) if isinstance(a, int) and not isinstance(a, bool)]
        if any(w > MAX_WIDTH for w in widths):
            raise TooCostly
        return rebuild(*args)

    return rebuild_checked


def _flat(args):
    for a in args:
        if isinstance(a, (tuple, list)):
            yield from _flat(a)
        elif isinstance(a, dict):
            yield from _flat(list(a.values()))
        else:
            yield a


def _dtype_without_datetimes(code: Any, *args: Any) -> np.dtype:
    """numpy.dtype for the unpickler, refusing datetime codes: NumPy 2.4 segfaults when the
    state of a float64 dtype is set on a datetime one (a pickled array whose 'f8' became
    'M8'), whatever object holds the array — a NumPy defect, not one of kalmanfield's."""
    if isinstance(code, str) and code.lstrip("<>=|")[:1] in ("M", "m"):
        raise pickle.UnpicklingError(f"the harness does not rebuild the dtype {code!r}")
    return np.dtype(code, *args)


class RestrictedUnpickler(pickle.Unpickler):
    ALLOWED = ("numpy", "builtins", "copyreg", "_codecs", "kalmanfield")

    def find_class(self, module: str, name: str) -> Any:
        if module.split(".")[0] not in self.ALLOWED:
            raise pickle.UnpicklingError(f"the harness does not resolve {module}.{name}")
        if module.split(".")[0] == "numpy" and name == "dtype":
            return _dtype_without_datetimes
        found = super().find_class(module, name)
        if module in ("kalmanfield.rowfilter.scalar", "kalmanfield.rowfilter.vector"):
            if name == "_rebuild":
                return _capped_rebuild(found)
        return found


def load(blob: bytes) -> Any:
    return RestrictedUnpickler(io.BytesIO(blob)).load()


# ------------------------------------------------------------------------------ corruptions
SPECIAL_FLOATS = [np.nan, np.inf, -np.inf, 1e308, -1e308, 5e-324, 1e154, -0.0, 2.0**63]
SPECIAL_INTS = [2**63 - 1, -(2**63), -1, 0, 2**31, 2**32 - 1, 10**12]


def _words() -> list[bytes]:
    words = []
    for v in SPECIAL_FLOATS:
        words += [struct.pack("<d", v), struct.pack(">d", v)]
    for v in SPECIAL_INTS:
        words += [struct.pack("<q", v), struct.pack(">q", v)]
    return words


WORDS = _words()


def corrupt(blob: bytes, g: np.random.Generator, lo: int = 0, hi: int | None = None) -> bytes:
    """One random corruption of blob[lo:hi] (the rest kept)."""
    data = bytearray(blob)
    hi = len(data) if hi is None else hi
    at = int(g.integers(lo, hi))
    kind = int(g.integers(6))
    if kind == 0:  # a bit flip
        data[at] ^= 1 << int(g.integers(8))
    elif kind == 1:  # a random byte
        data[at] = int(g.integers(256))
    elif kind == 2:  # a special 8-byte word
        word = WORDS[int(g.integers(len(WORDS)))]
        at = min(at, max(lo, hi - 8))
        data[at : at + 8] = word[: len(data) - at]
    elif kind == 3:  # truncation
        del data[at:]
    elif kind == 4:  # a range cut out
        del data[at : at + int(g.integers(1, 16))]
    else:  # a range doubled
        piece = data[at : at + int(g.integers(1, 16))]
        data[at:at] = piece
    return bytes(data)


def in_package(err: BaseException) -> bool:
    """Whether kalmanfield's own code raised (or passed on) `err`."""
    return any(f.filename.startswith(PACKAGE) for f in traceback.extract_tb(err.__traceback__))


def outcome(blob: bytes, step: Callable[[Any], list[str]], kind: type) -> str | None:
    """None when loading `blob` and stepping the object behaved (module docstring)."""
    try:
        obj = load(blob)
    except TooCostly:
        return None
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as err:  # noqa: BLE001 - the point of the probe
        if in_package(err):
            ok = isinstance(err, CLEAR) and str(err).strip()
        else:
            ok = isinstance(err, MACHINERY)
        return None if ok else f"load: {type(err).__module__}.{type(err).__name__}: {err}"[:300]
    if not isinstance(obj, kind):
        return None  # the bytes decoded to another object: the pickle's business, not ours
    try:
        problems = step(obj)
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as err:  # noqa: BLE001
        return f"step: {type(err).__module__}.{type(err).__name__}: {err}"[:300]
    return f"step: {problems[:3]}" if problems else None


def run_cases(blob: bytes, step, kind: type, salt: int, lo: int = 0, hi: int | None = None):
    g = rng(salt)
    failures = []
    for case in range(CASES):
        bad = corrupt(blob, g, lo, hi)
        print(f"CASE {case}", flush=True)  # (the last one printed names a case that killed us)
        problem = outcome(bad, step, kind)
        if problem:
            failures.append(f"case {case} (seed {salt}): {problem}")
    return failures


#: every suite of this module and its arguments, for the one interpreter of quick mode
SUITES: list[tuple] = []
_RESULTS: dict[str, list[str]] = {}


def isolated(suite: str, *args) -> list[str]:
    """The failures of `suite(*args)` (a function of this module returning them), run in a
    fresh interpreter under RLIMIT_AS and a timeout; its death is a failure too. Quick mode
    runs every suite of SUITES in one interpreter (start-up dominates), long mode one each."""
    key = repr((suite, *args))
    if key not in _RESULTS:
        _RESULTS.update(_run_suites(SUITES if not LONG else [(suite, *args)]))
    return _RESULTS[key]


def _run_suites(suites: list[tuple]) -> dict[str, list[str]]:
    body = f"""
        import json, test_fuzz_pickles as t
        for suite, *args in {suites!r}:
            print("SUITE " + repr((suite, *args)), flush=True)
            failures = getattr(t, suite)(*args)
            print("FAILURES " + json.dumps(failures), flush=True)
    """
    try:
        done = run_script(body, TIMEOUT * len(suites), address_space=ADDRESS_SPACE)
        out, death = done.stdout, None
        if done.returncode != 0:
            death = f"the interpreter died (exit {done.returncode}): {done.stderr[-600:]}"
    except Exception as err:  # subprocess.TimeoutExpired
        out = err.stdout.decode() if isinstance(getattr(err, "stdout", None), bytes) else ""
        death = f"timed out after {TIMEOUT * len(suites)} s"
    results, current, cases = {}, None, []
    for line in out.splitlines():
        if line.startswith("SUITE "):
            current, cases = line[len("SUITE ") :], []
        elif line.startswith("CASE "):
            cases.append(line)
        elif line.startswith("FAILURES ") and current is not None:
            results[current] = json.loads(line[len("FAILURES ") :])
            current = None
    for suite in suites:
        key = repr(tuple(suite))
        if key not in results:
            where = f" at {_last_case(cases)}" if key == current else " (not reached)"
            results[key] = [f"{key}: {death or 'no result'}{where}"]
    return results


def _last_case(cases: list[str]) -> str:
    return cases[-1].lower() if cases else "start-up"


# ------------------------------------------------------------------------------ streams
def _stream(time: int, dtype=np.float64) -> kf.FieldStream:
    orders = [3, 1, 2] if dtype == np.float64 else [2, 1, 1]  # (float32: 1/β̃ ≤ 84)
    stream = kf.ARFieldModel([0.9, 0.8, 0.7], orders, 1.5).stream((3, 4), seed=7, dtype=dtype)
    for _ in range(time):
        next(stream)
    return stream


def step_stream(stream: kf.FieldStream) -> list[str]:
    """Two frames from given noise against the NumPy twin, then one seeded frame."""
    model, g = stream.model, np.random.default_rng(0)
    problems = []
    history = list(stream._history)
    tolerance = 1e-9 if stream.dtype == np.float64 else 1e-4
    for _ in range(2):
        noise = g.standard_normal(stream.frame_shape)
        try:
            frame = stream.next_frame(noise=noise)
        except ValueError as err:  # a valid history near its limit (module docstring)
            return [] if "can carry" in str(err) else [f"ValueError: {err}"]
        want = ref.stream_frame(
            model.rho, model.order, model.sigma, history, stream.time - 1, noise
        )
        scale = max(1.0, float(np.abs(want).max()))
        if not np.allclose(frame, want, rtol=tolerance, atol=tolerance * scale):
            problems.append(f"frame {stream.time - 1} differs from the twin's")
        history = [frame.astype(np.float64), *history][: model.order[0]]
    return problems + bad_leaves(next(stream))


def suite_stream(time: int, dtype: str) -> list[str]:
    stream = _stream(time, np.dtype(dtype))
    problems = step_stream(pickle.loads(pickle.dumps(stream)))  # the harness's own baseline
    assert not problems, problems
    return run_cases(pickle.dumps(stream), step_stream, kf.FieldStream, 10 * time + len(dtype))


SUITES += [("suite_stream", t, d) for d in ("float64", "float32") for t in (0, 2, 5)]


@pytest.mark.parametrize("time", [0, 2, 5])
@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_corrupt_field_stream_pickles(time, dtype):
    failures = isolated("suite_stream", time, dtype)
    assert not failures, report(failures)


STATE_VALUES = [
    None,
    "x",
    -1,
    2**64,
    1.5,
    np.nan,
    [],
    (3, 4),
    np.zeros((3, 4)),
    np.full((3, 4), np.nan),
    np.full((3, 4), 1e300),
    np.zeros((3, 4), np.float32),
    kf.ARFieldModel([0.5, 0.5], [1, 1]),
    kf.ARFieldModel([0.5, 0.5, 0.5], [1, 1, 1], 1e150),
]


def suite_stream_states() -> list[str]:
    """Field-level: each field of the state replaced by a value of another kind or out of
    range, history frames too (their entries, their number)."""
    g = rng(99)
    failures = []
    base = _stream(5).__getstate__()
    for case in range(CASES):
        state = dict(base)
        key = list(state)[int(g.integers(len(state)))]
        if key == "history" and g.random() < 0.7:
            frames = [f.copy() for f in state["history"]]
            j = int(g.integers(len(frames)))
            frames[j].flat[int(g.integers(frames[j].size))] = g.choice(SPECIAL_FLOATS + [1e10])
            state["history"] = frames if g.random() < 0.8 else frames[: int(g.integers(4))]
        else:
            state[key] = STATE_VALUES[int(g.integers(len(STATE_VALUES)))]
        print(f"CASE {case}", flush=True)
        problem = outcome(pickle.dumps(_Rebuilt(state)), step_stream, kf.FieldStream)
        if problem:
            failures.append(f"case {case}: {key}: {problem}")
    return failures


SUITES.append(("suite_stream_states",))


def test_corrupt_field_stream_states():
    failures = isolated("suite_stream_states")
    assert not failures, report(failures)


class _Rebuilt:
    """Pickles as a FieldStream with the given state (what a corrupt file would hold)."""

    def __init__(self, state: dict) -> None:
        self.state = state

    def __reduce__(self):
        return (object.__new__, (kf.FieldStream,), self.state)


# ------------------------------------------------------------------------------ row filters
MODEL = kf.ARFieldModel([0.9, 0.8], [2, 1], 2.0)
FILTERS = {
    "scalar": lambda: kf.ScalarRowFilter(MODEL, 0.5, 24, smooth=True, mean=0.5),
    "scalar toeplitz": lambda: kf.ScalarRowFilter(MODEL, 0.5, 24, 3, modes="toeplitz"),
    "vector": lambda: kf.VectorRowFilter(MODEL, 0.5, 24, smooth=True),
}


def step_filter(filt) -> list[str]:
    z = np.random.default_rng(1).standard_normal((6, filt.width)) * 2.0
    return bad_leaves(filt.filter(z))


def suite_filter(name: str) -> list[str]:
    filt = FILTERS[name]()
    assert not step_filter(pickle.loads(pickle.dumps(filt)))
    return run_cases(pickle.dumps(filt), step_filter, type(filt), len(name))


SUITES += [("suite_filter", name) for name in FILTERS]


@pytest.mark.parametrize("name", list(FILTERS))
def test_corrupt_row_filter_pickles(name):
    failures = isolated("suite_filter", name)
    assert not failures, report(failures)


def suite_model() -> list[str]:
    def step(model):
        try:
            return bad_leaves(model.sample((5, 6), seed=1))
        except ValueError as err:  # a valid model whose start is beyond float64 (documented)
            return [] if "beyond float64" in str(err) else [f"ValueError: {err}"]

    return run_cases(pickle.dumps(MODEL), step, kf.ARFieldModel, 3)


SUITES.append(("suite_model",))


def test_corrupt_model_pickles():
    failures = isolated("suite_model")
    assert not failures, report(failures)


# ------------------------------------------------------------------------------ the tracker
def _tracker() -> kf.BranchingTracker:
    tracker = kf.BranchingTracker(2, max_misses=2)
    g = np.random.default_rng(4)
    for f in range(8):
        targets = [[10.0 + 2 * f, 20.0 + f], [40.0 - f, 5.0 + 0.5 * f]]
        clutter = g.uniform(0, 60, (3, 2))
        tracker.update(np.vstack([targets, clutter]))
    return tracker


def step_tracker(tracker) -> list[str]:
    for f in range(8, 11):
        tracker.update([[10.0 + 2 * f, 20.0 + f], [40.0 - f, 5.0 + 0.5 * f]])
    return bad_leaves(tracker.tracks()) + bad_leaves(tracker.tracks(online=True))


def _state_range(blob: bytes, state: bytes) -> tuple[int, int]:
    at = blob.find(state)
    assert at > 0
    return at, at + len(state)


def suite_tracker_outside() -> list[str]:
    tracker = _tracker()
    assert not step_tracker(pickle.loads(pickle.dumps(tracker)))
    blob = pickle.dumps(tracker)
    lo, hi = _state_range(blob, tracker._core.state_bytes())
    g = rng(7)
    failures = []
    for case in range(CASES):
        if g.random() < lo / (len(blob) - (hi - lo)):
            bad = corrupt(blob, g, 0, lo)
        else:
            bad = corrupt(blob, g, hi, len(blob))
        print(f"CASE {case}", flush=True)
        problem = outcome(bad, step_tracker, kf.BranchingTracker)
        if problem:
            failures.append(f"case {case}: {problem}")
    return failures


SUITES += [("suite_tracker_outside",), ("suite_tracker_state_bytes",)]


def test_corrupt_tracker_pickles_outside_its_state_bytes():
    """The pickle's opcodes, the configuration and the names (the Rust state bytes intact).
    The long mode found: KeyError from BranchingTracker.__setstate__ for a missing key, and
    configurations inconsistent with the names and the state (a corrupt `order` list: k = 3
    with 2 names) loaded, then refused by update."""
    failures = isolated("suite_tracker_outside")
    assert not failures, report(failures)


#: the words written over the state's 8-byte items: NaN, inf (floats), 2**63 − 1 and −1
#: (counts and indexes, little-endian as the state's codec)
STATE_WORDS = [struct.pack("<d", np.nan), struct.pack("<d", np.inf)] + [
    struct.pack("<q", v) for v in (2**63 - 1, -1)
]


def suite_tracker_state_bytes() -> list[str]:
    """Random corruptions inside the state bytes, then special words over its items: a
    seeded sample of 8-byte positions (all of them in long mode), each of STATE_WORDS."""
    tracker = _tracker()
    blob = pickle.dumps(tracker)
    lo, hi = _state_range(blob, tracker._core.state_bytes())
    failures = run_cases(blob, step_tracker, kf.BranchingTracker, 11, lo + 8, hi)
    positions = np.arange(lo + 8, hi - 7, 8)
    if not LONG:
        positions = np.sort(rng(12).choice(positions, min(300, positions.size), replace=False))
    for at in positions:
        for w, word in enumerate(STATE_WORDS):
            bad = blob[:at] + word + blob[at + 8 :]
            print(f"CASE word {w} at {at - lo}", flush=True)
            problem = outcome(bad, step_tracker, kf.BranchingTracker)
            if problem:
                failures.append(f"word {word.hex()} at state byte {at - lo}: {problem}")
    return failures


def test_corrupt_numbers_inside_the_tracker_state_bytes():
    """Special words (NaN, inf, 2**63 − 1, −1, …) and flips inside the Rust state bytes: the
    loader must refuse every one it cannot continue from (issue 49 item 2)."""
    failures = isolated("suite_tracker_state_bytes")
    assert not failures, report(failures)


# ------------------------------------------------------------------------------ filter banks
CV = kf.LinearGaussianModel.constant_velocity(1.0, 0.5, 2, 0.5, name="cv")
STRAIGHT = kf.LinearGaussianModel.singer(1.0, 0.0, 0.0, 2, 0.5, name="straight")
TURNING = kf.LinearGaussianModel.singer(1.0, 0.8, 0.7, 2, 0.5, name="turning")
BANK_FRAMES = TURNING.simulate(12, 3, seed=5, start=[0, 1, 0, 0, 0.5, 0])[1]  # (3, 12, 2)
BANKS = {
    "identifier": lambda: kf.TypeIdentifier([CV, TURNING], priors=[0.4, 0.6]),
    "identifier wald": lambda: kf.TypeIdentifier([CV, TURNING], alpha=0.01, beta=0.02),
    "imm": lambda: kf.IMMEstimator([STRAIGHT, TURNING], [[0.9, 0.1], [0.2, 0.8]]),
}


def step_bank(bank) -> list[str]:
    """Four more frames of the three trajectories; the outputs finite, the probabilities
    probabilities."""
    out = bank.run(BANK_FRAMES[:, 8:])
    probabilities = bank.mu if isinstance(bank, kf.IMMEstimator) else bank.posterior
    problems = bad_leaves(out) + bad_leaves(probabilities)
    if isinstance(bank, kf.TypeIdentifier):
        problems += bad_leaves(bank.log_likelihoods)
    if not np.allclose(np.sum(probabilities, axis=-1), 1.0) or (probabilities < 0).any():
        problems.append(f"probabilities {probabilities} do not sum to 1")
    return problems


def suite_bank(name: str, inside: bool) -> list[str]:
    """Corruptions outside the Rust state bytes (`inside` False: the pickle's opcodes, the
    models, priors and settings) or inside them."""
    bank = BANKS[name]()
    bank.run(BANK_FRAMES[:, :8])
    assert not step_bank(pickle.loads(pickle.dumps(bank)))
    blob = pickle.dumps(bank)
    return corrupt_around(blob, bank._core.state_bytes(), step_bank, 20 + len(name), inside)


def corrupt_around(blob: bytes, state: bytes, step, salt: int, inside: bool) -> list[str]:
    """run_cases on the bytes of `state` within `blob` (`inside`), or on the rest of it."""
    lo, hi = _state_range(blob, state)
    kind = type(load(blob))
    if inside:
        return run_cases(blob, step, kind, salt + 100, lo, hi)
    g = rng(salt)
    failures = []
    for case in range(CASES):
        if g.random() < lo / (len(blob) - (hi - lo)):
            bad = corrupt(blob, g, 0, lo)
        else:
            bad = corrupt(blob, g, hi, len(blob))
        print(f"CASE {case}", flush=True)
        problem = outcome(bad, step, kind)
        if problem:
            failures.append(f"case {case} (seed {salt}): {problem}")
    return failures


SUITES += [("suite_bank", name, inside) for name in BANKS for inside in (False, True)]


# ------------------------------------------------------------------------------ trajectories
SAMPLES = np.cumsum(np.random.default_rng(6).standard_normal((3, 20)), axis=1)
TRAJECTORY_STREAMS = {
    "fuzzy": lambda: kf.FuzzyFilter(1.0, 0.5, 1.0, 0.5, 0.1),
    "fuzzy one series": lambda: kf.FuzzyFilter(2.0, 0.5, 1.0),
    "kalman velocity measured": lambda: kf.KalmanFilterCV(1.0, 0.5, 1.0, 0.5, 0.1, R_vel=1.0),
    "detector cusum": lambda: kf.ChangeDetector(kf.FuzzyFilter(1.0, 0.5, 1.0, 0.5, 0.1)),
    "detector chi2": lambda: kf.ChangeDetector(kf.KalmanFilterCV(1.0, 0.5, 1.0), "chi2"),
    "detector fuzzy": lambda: kf.ChangeDetector(kf.FuzzyFilter(1.0, 0.5, 1.0, 0.5), "fuzzy"),
}


def _trajectory_step(stream, k: int, series: int):
    """One step of `stream` (a filter or a detector) at sample k of the first `series` rows
    of SAMPLES (a number when `series` is 0: a one-series stream)."""
    rows = slice(0, max(series, 1))
    z, velocity = SAMPLES[rows, k], SAMPLES[rows, k] - SAMPLES[rows, k - 1]
    if series == 0:
        z, velocity = z[0], velocity[0]
    filt = stream.filter if isinstance(stream, kf.ChangeDetector) else stream
    return stream.step(z, **({"velocity": velocity} if filt.measures_velocity else {}))


def step_trajectory(stream) -> list[str]:
    """Five more samples of as many series as the stream follows (times continue from its
    last one); the estimates finite."""
    series = 0 if stream._scalar else stream._bank.series
    problems = []
    for k in range(12, 17):
        out = _trajectory_step(stream, k, series)
        problems += bad_leaves([np.asarray(v, float) for v in out])
    return problems


def suite_trajectory(name: str, inside: bool) -> list[str]:
    """Corruptions of the stream's state values (`inside`: the float64 array the Rust bank
    saves) or of the rest of the pickle (opcodes, spreads, settings, flags, last time)."""
    stream = TRAJECTORY_STREAMS[name]()
    for k in range(1, 12):
        _trajectory_step(stream, k, 0 if name == "fuzzy one series" else 3)
    assert not step_trajectory(pickle.loads(pickle.dumps(stream)))
    blob, state = pickle.dumps(stream), stream._bank.state().tobytes()
    return corrupt_around(blob, state, step_trajectory, 60 + len(name), inside)


SUITES += [
    ("suite_trajectory", name, inside) for name in TRAJECTORY_STREAMS for inside in (False, True)
]


STREAM_SUITES = [("suite_bank", n) for n in BANKS] + [
    ("suite_trajectory", n) for n in TRAJECTORY_STREAMS
]


@pytest.mark.parametrize("inside", [False, True], ids=["around the state", "inside the state"])
@pytest.mark.parametrize(("suite", "name"), STREAM_SUITES)
def test_corrupt_bank_and_trajectory_pickles(suite, name, inside):
    """TypeIdentifier, IMMEstimator (pickled Rust state bytes), FuzzyFilter, KalmanFilterCV
    and ChangeDetector (pickled state values; k series or one) mid-stream: corruptions of the
    Rust state (`inside`) or of the rest of the pickle (opcodes, models, priors, settings,
    flags, last time)."""
    failures = isolated(suite, name, inside)
    assert not failures, report(failures)
