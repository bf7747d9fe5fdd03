"""Bad-input probes per public entry point (issue 49, "Done when"): a table of calls × bad
values. Each call must raise ValueError/TypeError/MemoryError with a message, or — for values
that are only unusual (NaN pixels, 1e308, subnormals, empty stacks…) — return a result
without NaN/inf; never another exception type, a pyo3 PanicException or a silent NaN.

Quick mode: the curated pools below. Long mode (KALMANFIELD_FUZZ=long): the same plus seeded
random arrays with special values at random places, random shapes and dtypes."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
import pytest
from fuzz_support import LONG, bad_leaves, report, rng, verdict

import kalmanfield as kf

MODEL2 = kf.ARFieldModel([0.9, 0.8], [2, 1])
MODEL3 = kf.ARFieldModel([0.9, 0.8, 0.7], [1, 2, 1])
H, W = 12, 16
IMAGE = MODEL2.sample((H, W), seed=1) + 0.3 * np.random.default_rng(1).standard_normal((H, W))


@dataclass(frozen=True)
class Bad:
    """A probe value; `invalid` ones must be refused, the others may also give an answer."""

    label: str
    value: Any
    invalid: bool = True


# ------------------------------------------------------------------------------ value pools
def _scalars() -> list[Bad]:
    return [
        Bad("None", None),
        Bad("'1'", "1"),
        Bad("1j", 1j),
        Bad("True", True),
        Bad("nan", np.nan),
        Bad("inf", np.inf),
        Bad("-inf", -np.inf),
        Bad("10**400", 10**400),
        Bad("list", [1.0, 2.0]),
        Bad("object", object()),
        Bad("0", 0.0, invalid=False),
        Bad("-1", -1.0, invalid=False),
        Bad("1e308", 1e308, invalid=False),
        Bad("-1e308", -1e308, invalid=False),
        Bad("1e-320", 1e-320, invalid=False),
        Bad("float32 nan", np.float32("nan")),
    ] + (_random_scalars() if LONG else [])


def _random_scalars(count: int = 60) -> list[Bad]:
    """Long mode: finite numbers of every magnitude and sign (may be refused or answered)."""
    g = rng(1)
    values = np.sign(g.standard_normal(count)) * 10.0 ** g.uniform(-320, 308, count)
    return [Bad(f"random {v:.3g}", float(v), invalid=False) for v in values]


def _positive_scalars() -> list[Bad]:
    """For parameters that must be > 0: 0 and negatives are invalid there."""
    pool = _scalars()
    return [Bad(b.label, b.value, b.invalid or _not_positive(b.value)) for b in pool]


def _not_positive(value: Any) -> bool:
    return isinstance(value, float) and not np.isnan(value) and value <= 0


def _ints() -> list[Bad]:
    return [
        Bad("None", None),
        Bad("'3'", "3"),
        Bad("1.5", 1.5),
        Bad("3.0", 3.0),
        Bad("True", True),
        Bad("nan", np.nan),
        Bad("0", 0, invalid=False),
        Bad("-1", -1),
        Bad("2**62", 2**62, invalid=False),
        Bad("2**63", 2**63),
        Bad("2**64", 2**64),
        Bad("10**400", 10**400),
        Bad("uint64 max", np.uint64(2**64 - 1)),
    ]


def _positive_ints() -> list[Bad]:
    return [Bad(b.label, b.value, b.invalid or b.label == "0") for b in _ints()]


def _shapes(ndim: int) -> list[Bad]:
    return [
        Bad("None", None),
        Bad("'55'", "55"),
        Bad("5.0", 5.0),
        Bad("zero", (0,) * ndim),
        Bad("negative", (-1,) * ndim),
        Bad("too few axes", (5,) * (ndim - 1)),
        Bad("too many axes", (5,) * (ndim + 1)),
        Bad("floats", (5.0,) * ndim),
        Bad("bools", (True,) * ndim),
        Bad("1e7 per axis", (10**7,) * ndim),
        Bad("2**63", (2**63,) + (1,) * (ndim - 1)),
        Bad("2**62 total", (2**62,) + (1,) * (ndim - 1)),
    ]


def _images(
    shape: tuple[int, ...] = (H, W), base: np.ndarray | None = None, prefix: str = ""
) -> list[Bad]:
    z = IMAGE if base is None else base
    z = z.copy() if z.shape == shape else np.random.default_rng(7).standard_normal(shape)

    def at(value):
        out = z.copy()
        out.flat[0] = value
        return out

    masked = np.ma.MaskedArray(z.copy(), mask=np.zeros(shape, bool))
    masked.mask.flat[3] = True
    strings = z.astype(object)
    strings.flat[5] = "1.5"
    ragged = [np.atleast_1d(row).tolist() for row in z]
    ragged[-1] = ragged[-1][:-1] or [1.0, 2.0]
    pools = [
        Bad("None", None),
        Bad("'abc'", "abc"),
        Bad("complex", z.astype(complex)),
        Bad("bool", z > 0),
        Bad("str dtype", z.astype(str)),
        Bad("numeric str in object", strings),
        Bad("datetime", z.astype("datetime64[s]")),
        Bad("ragged", ragged),
        Bad("one axis fewer", z[0]),
        Bad("two axes more", z[None, None]),
        Bad("scalar", 5.0),
        Bad("nan pixel", at(np.nan), invalid=False),
        Bad("all nan", np.full(shape, np.nan), invalid=False),
        Bad("inf pixel", at(np.inf), invalid=False),
        Bad("-inf pixel", at(-np.inf), invalid=False),
        Bad("1e308 pixel", at(1e308), invalid=False),
        Bad("-1e308 everywhere", np.full(shape, -1e308), invalid=False),
        Bad("1e200 scale", z * 1e200, invalid=False),
        Bad("1e-320 scale", z * 1e-320, invalid=False),
        Bad("1e300 offset", z + 1e300, invalid=False),
        Bad("constant", np.ones(shape), invalid=False),
        Bad("zeros", np.zeros(shape), invalid=False),
        Bad("empty first axis", np.zeros((0, *shape[1:])), invalid=False),
        Bad("empty last axis", np.zeros((*shape[:-1], 0)), invalid=False),
        Bad("uint64 max pixel", np.full(shape, 2**64 - 1, np.uint64), invalid=False),
        Bad("int8", (z * 10).astype(np.int8), invalid=False),
        Bad("float16", z.astype(np.float16), invalid=False),
        Bad("masked", masked, invalid=False),
        Bad("fortran order", np.asfortranarray(z), invalid=False),
        Bad("strided", np.repeat(z, 2, axis=-1)[..., ::2], invalid=False),
        Bad("object floats", z.astype(object), invalid=False),
        Bad("10**400 object", _big_object(z)),
    ]
    pools += _random_images(shape, z) if LONG else []
    return [Bad(prefix + b.label, b.value, b.invalid) for b in pools]


def _big_object(z: np.ndarray) -> np.ndarray:
    out = z.astype(object)
    out.flat[2] = 10**400
    return out


SPECIALS = np.array([np.nan, np.inf, -np.inf, 1e308, -1e308, 1e-320, 0.0, 1e154, -1e-300])


def _random_images(shape: tuple[int, ...], z: np.ndarray, count: int = 150) -> list[Bad]:
    """Long mode: special values at random places, random dtypes and shapes."""
    g = rng(len(shape))
    out = []
    for k in range(count):
        x = z.copy()
        hits = g.integers(1, max(2, x.size // 4))
        x.flat[g.integers(0, x.size, hits)] = g.choice(SPECIALS, hits)
        out.append(Bad(f"random specials {k}", x, invalid=False))
        dims = tuple(int(d) for d in g.integers(0, 5, len(shape)))
        out.append(Bad(f"random shape {dims}", g.standard_normal(dims), invalid=False))
        dtype = g.choice(["int16", "uint16", "float32", "int64", "uint8"])
        out.append(Bad(f"dtype {dtype}", (z * 100).astype(dtype), invalid=False))
    return out


def _choices(valid: str) -> list[Bad]:
    return [Bad(repr(v), v) for v in ("", valid.upper(), valid + " ", None, 1, b"x", [valid])]


SEEDS = [Bad("-1", -1), Bad("2**64", 2**64), Bad("1.5", 1.5), Bad("'1'", "1"), Bad("[1]", [1])]
THREADS = [Bad(repr(v), v) for v in (0, -1, 1025, 2**70, 1.5, "2", True)]
DTYPES = [Bad(repr(v), v) for v in (np.int32, "f2", complex, "nonsense", object, np.bool_)]
MODELS = [
    Bad("'model'", "model"),
    Bad("None", None),
    Bad("1-axis", kf.ARFieldModel(0.5, 1)),
    Bad("3-axis", MODEL3),
    Bad("n_y = 5", kf.ARFieldModel([0.5, 0.5], [5, 1])),
]


# ------------------------------------------------------------------------------ the table
@dataclass
class Entry:
    """A public call, its valid arguments, and the pool to probe each argument with."""

    name: str
    call: Callable[..., Any]
    defaults: dict[str, Any]
    pools: dict[str, list[Bad]]
    allow_nan: bool = False
    #: "arg=label" (or "label", any argument) of values this entry documents as valid: they
    #: may be refused or answered (finitely)
    valid: set[str] = field(default_factory=set)

    def cases(self):
        for arg, pool in self.pools.items():
            for bad in pool:
                documented = bad.label in self.valid or f"{arg}={bad.label}" in self.valid
                yield arg, Bad(bad.label, bad.value, bad.invalid and not documented)


def _df(**columns) -> pd.DataFrame:
    f = np.repeat(np.arange(6), 2)
    base = {"frame": f, "x": 10.0 + 40 * (np.arange(12) % 2) + f, "y": 20.0 + 0.5 * f}
    base.update(columns)
    return pd.DataFrame(base)


def _column_pool(column: str) -> list[Bad]:
    n = 12
    base = _df()[column].to_numpy()
    return [
        Bad("complex", base.astype(complex)),
        Bad("strings", base.astype(str)),
        Bad("bool", base > base.mean()),
        Bad("numeric str object", np.where(np.arange(n) == 3, "1", base.astype(object))),
        Bad("nan", np.where(np.arange(n) == 3, np.nan, base), invalid=column != "x"),
        Bad("1e300", np.full(n, 1e300), invalid=False),
        Bad("uint64 max", np.full(n, 2**64 - 1, np.uint64), invalid=column == "frame"),
        Bad("2**63 uint64", np.arange(n, dtype=np.uint64) + np.uint64(2**63)),
        Bad("huge int64", np.arange(n) + (2**63 - 3), invalid=column == "frame"),
        Bad("fractions", base + 0.5, invalid=column == "frame"),
        Bad("datetime", pd.date_range("2020", periods=n).to_numpy()),
        Bad("object None", np.where(np.arange(n) == 3, None, base.astype(object))),
    ]


def _link(frame=None, x=None, **kwargs):
    columns = {k: v for k, v in (("frame", frame), ("x", x)) if v is not None}
    return kf.link(_df(**columns), **{"measurement_std": 0.5, "process_std": 0.1, **kwargs})


def _stream_take(count, frame_shape=(4, 5), **kw):
    return MODEL3.stream(frame_shape, seed=1, **kw).take(count)


def _next_frame(noise):
    stream = MODEL3.stream((4, 5), seed=1)
    next(stream)
    return stream.next_frame(noise=noise)


SRF = kf.ScalarRowFilter(MODEL2, 0.5, W)
SRF_SMOOTH = kf.ScalarRowFilter(MODEL2, 0.5, W, smooth=True)
VRF = kf.VectorRowFilter(MODEL2, 0.5, W)
YW = kf.yule_walker(IMAGE, (1, 1))
STACK = np.stack([IMAGE, IMAGE[::-1]])


def _tracker_update(measurements=None, time=None):
    tracker = kf.BranchingTracker(2)
    tracker.update([[1.0, 2.0], [30.0, 4.0]])
    tracker.update([[2.0, 2.5]] if measurements is None else measurements, time=time)
    return tracker.tracks()


STACK_POOL = _images((2, H, W), STACK, "stack ")
#: the arguments both row filters take
FILTER_POOLS = dict(
    model=MODELS,
    noise_var=_positive_scalars(),
    width=[b for b in _positive_ints() if b.label != "2**62"],
    mean=_scalars(),
    threads=THREADS,
)
NONE_DEFAULTS = {"None"}  # (None: the documented default of an optional argument)

ENTRIES = [
    Entry(
        "ARFieldModel",
        kf.ARFieldModel,
        dict(rho=0.8, order=1, sigma=1.0),
        dict(rho=_scalars(), order=_positive_ints(), sigma=_positive_scalars()),
    ),
    Entry(
        "ARFieldModel.sample",
        lambda **kw: MODEL2.sample(**kw),
        dict(shape=(6, 7), seed=1),
        dict(shape=_shapes(2), seed=SEEDS, dtype=DTYPES, threads=THREADS, noise=_images((6, 7))),
        valid={"noise=None"},
    ),
    Entry(
        "ARFieldModel.correlation",
        lambda **kw: MODEL2.correlation(**kw),
        dict(lags=[[1, 2]]),
        dict(lags=_images((3, 2), base=np.ones((3, 2)))),
        valid={"one axis fewer", "two axes more"},  # one lag (2,), lags of shape (…, 2)
    ),
    Entry(
        "sample_product_field",
        kf.sample_product_field,
        dict(model=MODEL2, shape=(6, 7), seed=1),
        dict(
            model=MODELS[:2],
            shape=_shapes(2),
            seed=SEEDS,
            dtype=DTYPES,
            threads=THREADS,
            noise=[
                Bad(b.label, [b.value, np.ones(7)], b.invalid) for b in _images((6,), np.ones(6))
            ],
        ),
    ),
    Entry(
        "FieldStream",
        lambda **kw: next(kf.FieldStream(**kw)),
        dict(model=MODEL3, frame_shape=(4, 5), seed=1),
        dict(model=MODELS[:3], frame_shape=_shapes(2), seed=SEEDS, dtype=DTYPES, threads=THREADS),
    ),
    Entry("FieldStream.take", _stream_take, dict(count=3), dict(count=_positive_ints())),
    Entry(
        "FieldStream.next_frame",
        _next_frame,
        dict(noise=None),
        dict(noise=_images((4, 5))),
        valid={"noise=None"},
    ),
    Entry(
        "ScalarRowFilter",
        lambda **kw: kf.ScalarRowFilter(**kw).filter(IMAGE),
        dict(model=MODEL2, noise_var=0.5, width=W),
        dict(
            **FILTER_POOLS,
            ar_order=_positive_ints(),
            modes=_choices("ends"),
            row_models=_choices("auto"),
        ),
        valid={"ar_order=None"},
    ),
    Entry(
        "ScalarRowFilter.filter",
        lambda **kw: SRF.filter(**kw),
        dict(z=IMAGE),
        dict(z=_images() + STACK_POOL, noise_var=_images()),
        valid={"noise_var=None", "noise_var=scalar", "z=stack one axis fewer"},
    ),
    Entry(
        "ScalarRowFilter.filter (smooth)",
        lambda **kw: SRF_SMOOTH.filter(**kw),
        dict(z=IMAGE),
        dict(z=_images() + STACK_POOL, out=_images()),
        valid={"out=None", "z=stack one axis fewer"},
    ),
    Entry(
        "ScalarRowFilter.error_variance",
        lambda **kw: SRF.error_variance(**kw),
        dict(height=H),
        dict(height=_positive_ints(), noise_var=_images()),
        valid={"noise_var=None", "noise_var=scalar"},
    ),
    Entry(
        "VectorRowFilter",
        lambda **kw: kf.VectorRowFilter(**kw).filter(IMAGE),
        dict(model=MODEL2, noise_var=0.5, width=W),
        FILTER_POOLS,
    ),
    Entry(
        "VectorRowFilter.filter",
        lambda **kw: VRF.filter(**kw),
        dict(z=IMAGE),
        dict(z=_images() + STACK_POOL),
        valid={"z=stack one axis fewer"},
    ),
    Entry(
        "VectorRowFilter.error_variance",
        lambda **kw: VRF.error_variance(**kw),
        dict(height=H),
        dict(height=_positive_ints()),
    ),
    Entry(
        "wiener_bound",
        kf.wiener_bound,
        dict(model=MODEL2, noise_var=0.5, shape=(H, W)),
        dict(model=MODELS, noise_var=_positive_scalars(), shape=_shapes(2)),
    ),
    Entry(
        "wiener_error_map",
        kf.wiener_error_map,
        dict(model=MODEL2, noise_var=0.5, shape=(H, W)),
        dict(noise_var=_positive_scalars(), shape=_shapes(2)),
    ),
    Entry(
        "denoise",
        kf.denoise,
        dict(image=IMAGE, noise_var=0.09),
        dict(
            image=_images() + STACK_POOL,
            noise_var=_positive_scalars(),
            model=MODELS[:2] + MODELS[3:],
            method=_choices("scalar"),
            window=_positive_ints(),
            mean=_scalars(),
            threads=THREADS,
            row_models=_choices("nominal"),
        ),
        valid={
            "noise_var=None",
            "model=None",
            "mean=None",
            "window=uint64 max",  # (any window ≥ 2 max(H, W) + 1: the whole frame)
            "image=stack one axis fewer",
        },
    ),
    Entry(
        "denoise (stationary)",
        lambda **kw: kf.denoise(method="stationary", **kw),
        dict(image=IMAGE, noise_var=0.09),
        dict(image=_images(), mean=_scalars(), model=MODELS[:2] + MODELS[3:]),
        valid={"mean=None", "model=None"},
    ),
    Entry(
        "denoise (vector)",
        lambda **kw: kf.denoise(method="vector", **kw),
        dict(image=IMAGE, noise_var=0.09),
        dict(image=_images()),
    ),
    Entry(
        "estimate_noise_var",
        kf.estimate_noise_var,
        dict(image=IMAGE),
        dict(image=_images()),
        valid={"two axes more"},  # (axes (…, H, W))
    ),
    Entry(
        "local_moments",
        kf.local_moments,
        dict(image=IMAGE, window=5),
        dict(image=_images() + STACK_POOL, window=_positive_ints()),
        allow_nan=True,  # a box without an observed pixel is NaN (documented)
        valid={"window=uint64 max", "image=stack one axis fewer"},
    ),
    Entry(
        "model_from_noisy",
        kf.model_from_noisy,
        dict(image=IMAGE),
        dict(image=_images() + STACK_POOL, max_order=_positive_ints()),
        valid={"image=stack one axis fewer"},
    ),
    Entry(
        "identify",
        kf.identify,
        dict(data=IMAGE, max_order=2),
        dict(
            data=_images(),
            max_order=_positive_ints(),
            axes=[Bad(repr(v), v) for v in (5, -3, [0, 0], [], 1.5, ["0"])]
            + [Bad("(1,)", (1,), invalid=False)],
            mask=_images(),
            threads=THREADS,
        ),
        allow_nan=True,  # the whiteness test of a residual of variance 0 (documented)
        valid={"data=one axis fewer", "mask=bool", "mask=None"},
    ),
    Entry(
        "sample_correlation",
        kf.sample_correlation,
        dict(data=IMAGE, max_lag=2),
        dict(
            data=_images(),
            max_lag=_ints() + [Bad("(1, 2, 3)", (1, 2, 3)), Bad("(20, 1)", (20, 1))],
            mask=_images(),
            estimator=_choices("biased"),
        ),
        allow_nan=True,  # lags without a valid pair (documented)
        valid={"data=one axis fewer", "mask=bool", "mask=None"},
    ),
    Entry(
        "yule_walker",
        kf.yule_walker,
        dict(image=IMAGE, order=(1, 1)),
        dict(
            image=_images(),
            order=[Bad(repr(v), v) for v in ((0, 0), (-1, 1), (1.5, 1), "11", 2, (1, 2, 3))],
            mask=_images(),
        ),
        valid={"mask=bool", "mask=None"},
    ),
    Entry(
        "YuleWalkerModel.predict",
        lambda **kw: YW.predict(**kw),
        dict(image=IMAGE),
        dict(image=_images()),
        allow_nan=True,  # where the template leaves the image (documented)
    ),
    Entry(
        "segment",
        kf.segment,
        dict(frame=IMAGE, threshold=0.5),
        dict(
            frame=_images() + STACK_POOL,
            threshold=_scalars(),
            min_area=_positive_ints(),
            connectivity=[Bad(repr(v), v) for v in (0, 6, 4.0, "8", None, True)],
            frame_no=_ints(),
        ),
        valid={
            "frame=bool",
            "frame=stack bool",
            "frame=stack one axis fewer",
            "frame_no=None",
            "frame_no=-1",
        },
    ),
    Entry(
        "BranchingTracker",
        lambda **kw: kf.BranchingTracker(**kw).update([[1.0, 2.0]]),
        dict(),
        dict(
            n_params=_positive_ints(),
            process_std=_scalars(),
            measurement_std=_positive_scalars(),
            confidence=_scalars(),
            memory=_positive_ints(),
            max_misses=_ints(),
            dt=_positive_scalars(),
            clutter_density=_positive_scalars(),
            max_speed=_positive_scalars(),
            merge_depth=_positive_ints(),
            selection=_choices("llr"),
            seed=SEEDS,
        ),
        valid={
            "process_std=list",  # (one std per parameter)
            "measurement_std=list",
            "clutter_density=None",  # (estimated)
        },
    ),
    Entry(
        "BranchingTracker.update",
        _tracker_update,
        dict(),
        dict(measurements=_images((3, 2), np.ones((3, 2))), time=_scalars()),
        valid={"time=None", "measurements=None"},  # (None: this probe's default frame)
    ),
    Entry(
        "link",
        _link,
        dict(),
        dict(
            frame=_column_pool("frame"),
            x=_column_pool("x"),
            measurement_std=_positive_scalars(),
            memory=_positive_ints(),
            pos_columns=[Bad(repr(v), v) for v in ([], ["nope"], "x", [1])],
        ),
        valid={"measurement_std=list", "x=2**63 uint64"},
    ),
]


@pytest.mark.parametrize("entry", ENTRIES, ids=lambda e: e.name)
def test_every_bad_argument_gets_a_clear_exception_or_a_finite_answer(entry):
    # the valid call itself answers, finitely
    assert verdict(lambda: entry.call(**entry.defaults), False, entry.allow_nan) is None
    failures = []
    for arg, bad in entry.cases():
        kwargs = {**entry.defaults, arg: bad.value}
        problem = verdict(lambda kw=kwargs: entry.call(**kw), bad.invalid, entry.allow_nan)
        if problem:
            failures.append(f"{entry.name}({arg}={bad.label}): {problem}")
    assert not failures, report(failures)


def test_bad_leaves_finds_nan_and_inf_anywhere():
    """The harness's own check can fail."""
    assert bad_leaves((np.ones(2), {"a": pd.DataFrame({"x": [1.0, np.inf]})}))
    assert bad_leaves([1.0, float("nan")]) and not bad_leaves([1.0, float("nan")], True)
    assert verdict(lambda: np.array([np.nan]), False) is not None
    assert verdict(lambda: 1 / 0, False) is not None  # ZeroDivisionError is not clear
    assert verdict(lambda: 5, True) is not None
