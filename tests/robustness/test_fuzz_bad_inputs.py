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
from kalmanfield import experiments, trajectory

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
    masked.mask.flat[min(3, z.size - 1)] = True
    strings = z.astype(object)
    strings.flat[min(5, z.size - 1)] = "1.5"
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
        Bad("float16", _float16(z), invalid=False),
        Bad("masked", masked, invalid=False),
        Bad("fortran order", np.asfortranarray(z), invalid=False),
        Bad("strided", np.repeat(z, 2, axis=-1)[..., ::2], invalid=False),
        Bad("object floats", z.astype(object), invalid=False),
        Bad("10**400 object", _big_object(z)),
    ]
    pools += _random_images(shape, z) if LONG else []
    return [Bad(prefix + b.label, b.value, b.invalid) for b in pools]


def _float16(z: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):  # (values beyond 65504 become inf: a probe as good)
        return z.astype(np.float16)


def _big_object(z: np.ndarray) -> np.ndarray:
    out = z.astype(object)
    out.flat[min(2, z.size - 1)] = 10**400
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


def _column_pool(column: str, table: pd.DataFrame | None = None) -> list[Bad]:
    n = 12
    base = (_df() if table is None else table)[column].to_numpy()
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
        valid={"measurement_std=list", "measurement_std=None", "x=2**63 uint64"},  # None: estimated
    ),
]


# ------------------------------------------------------------------------------ filterbank
CV = kf.LinearGaussianModel.constant_velocity(1.0, 0.5, 2, 0.5, name="cv")
STRAIGHT = kf.LinearGaussianModel.singer(1.0, 0.0, 0.0, 2, 0.5, name="straight")
TURNING = kf.LinearGaussianModel.singer(1.0, 0.8, 0.7, 2, 0.5, name="turning")
ONE_AXIS = kf.LinearGaussianModel.singer(1.0, 0.8, 0.7, 1, 0.5, name="one axis")
FRAMES = TURNING.simulate(20, seed=1)[1]  # (20, 2)
BATCH = TURNING.simulate(20, 3, seed=2)[1]  # (3, 20, 2)
SWITCH = [[0.95, 0.05], [0.05, 0.95]]
CV_ARRAYS = dict(zip(("F", "Q", "H", "R", "x0", "P0"), CV.arrays()))
BANK_MODELS = [
    Bad("None", None),
    Bad("'model'", "model"),
    Bad("one model", CV),
    Bad("[]", []),
    Bad("[model]", [CV]),
    Bad("[model, 'x']", [CV, "x"]),
    Bad("[model, None]", [CV, None]),
    Bad("measurement lengths 2 and 1", [CV, ONE_AXIS]),
    Bad("a generator", (m for m in [CV, TURNING])),
]


def _matrices(name: str) -> list[Bad]:
    """The pool of one matrix (or vector) argument of LinearGaussianModel."""
    base = CV_ARRAYS[name]
    return _images(base.shape, base)


def _tracks(**columns) -> pd.DataFrame:
    return _df(**{"particle": np.tile([0, 1], 6), **columns})  # two particles, six frames


def _run_tracks(frame=None, x=None, particle=None, **kwargs):
    columns = {
        k: v for k, v in (("frame", frame), ("x", x), ("particle", particle)) if v is not None
    }
    return kf.TypeIdentifier.run_tracks(_tracks(**columns), **{"models": [CV, TURNING], **kwargs})


def _imm_update(measurement):
    imm = kf.IMMEstimator([STRAIGHT, TURNING], SWITCH)
    imm.update(FRAMES[0])
    return imm.update(measurement), imm.mu


def _identifier_update(measurement):
    ident = kf.TypeIdentifier([CV, TURNING])
    ident.update(FRAMES[0])
    return ident.update(measurement), ident.posterior


ENTRIES += [
    Entry(
        "LinearGaussianModel",
        lambda **kw: kf.LinearGaussianModel(**kw).simulate(4, seed=1),
        dict(CV_ARRAYS),
        {name: _matrices(name) for name in CV_ARRAYS}
        | dict(name=[Bad(repr(v), v) for v in (1, b"x", ["x"])]),
        valid={"name=None", "name=1", "name=b'x'", "name=['x']"},  # (str(name), documented)
    ),
    Entry(
        "LinearGaussianModel.singer",
        lambda **kw: kf.LinearGaussianModel.singer(**kw).simulate(4, seed=1),
        dict(dt=1.0, rho=0.8, sigma_a=0.7),
        dict(
            dt=_positive_scalars(),
            rho=_scalars(),
            sigma_a=_scalars(),
            ndim=_positive_ints(),
            measurement_std=_positive_scalars(),
            x0=_images((6,), np.zeros(6)),
            P0=_images((6, 6), np.eye(6)),
        ),
        valid={"x0=None", "P0=None"},
    ),
    Entry(
        "LinearGaussianModel.constant_velocity",
        lambda **kw: kf.LinearGaussianModel.constant_velocity(**kw).simulate(4, seed=1),
        dict(dt=1.0, q=0.5),
        dict(dt=_positive_scalars(), q=_scalars(), ndim=_positive_ints()),
    ),
    Entry(
        "LinearGaussianModel.markov_velocity",
        lambda **kw: kf.LinearGaussianModel.markov_velocity(**kw).simulate(4, seed=1),
        dict(dt=1.0, rho=0.9, sigma=0.5),
        dict(rho=_scalars(), sigma=_scalars(), measurement_std=_positive_scalars()),
    ),
    Entry(
        "LinearGaussianModel.simulate",
        lambda **kw: TURNING.simulate(**kw),
        dict(n_frames=5),
        dict(
            n_frames=_positive_ints(),
            n_trajectories=_positive_ints(),
            seed=SEEDS,
            start=_images((6,), np.ones(6)),
        ),
        valid={"n_trajectories=None", "start=None", "n_frames=0"},  # (n_frames ≥ 0)
    ),
    Entry(
        "LinearGaussianModel.with_prior",
        lambda **kw: CV.with_prior(**kw).simulate(4, seed=1),
        dict(x0=np.zeros(4), P0=np.eye(4)),
        dict(x0=_images((4,), np.zeros(4)), P0=_images((4, 4), np.eye(4))),
    ),
    Entry(
        "TypeIdentifier",
        lambda **kw: kf.TypeIdentifier(**kw).run(FRAMES),
        dict(models=[CV, TURNING]),
        dict(models=BANK_MODELS, priors=_images((2,), np.array([0.3, 0.7]))),
        valid={"priors=None"},
    ),
    Entry(
        "TypeIdentifier (Wald)",
        lambda **kw: kf.TypeIdentifier([CV, TURNING], **kw).run(FRAMES),
        dict(alpha=0.01, beta=0.02),
        dict(alpha=_scalars(), beta=_scalars()),
    ),
    Entry(
        "TypeIdentifier.run",
        lambda **kw: kf.TypeIdentifier([CV, TURNING]).run(**kw),
        dict(measurements=FRAMES),
        dict(
            measurements=_images((20, 2), FRAMES) + _images((3, 20, 2), BATCH, "batch "),
            return_log_likelihoods=[Bad(repr(v), v, invalid=False) for v in (1, "yes", None)],
            threads=THREADS,
        ),
        valid={"measurements=batch one axis fewer"},
    ),
    Entry(
        "TypeIdentifier.update",
        _identifier_update,
        dict(measurement=FRAMES[1]),
        dict(measurement=_images((2,), FRAMES[1])),
    ),
    Entry(
        "TypeIdentifier.run_tracks",
        _run_tracks,
        dict(),
        dict(
            frame=_column_pool("frame", _tracks()),
            x=_column_pool("x", _tracks()),
            particle=_column_pool("particle", _tracks()),
            models=BANK_MODELS,
            columns=[Bad(repr(v), v) for v in ([], ["nope"], "x", [1], ["x", "y", "frame"])],
            threads=THREADS,
        ),
        # frame numbers near 2**63 that follow each other, coordinates near 9e18; particle ids
        # are labels, any hashable value (the table gives them back)
        valid={"frame=huge int64", "x=2**63 uint64"}
        | {
            f"particle={label}"
            for label in ("complex", "strings", "bool", "numeric str object", "datetime")
        }
        | {"particle=2**63 uint64", "particle=huge int64", "particle=fractions"},
    ),
    Entry(
        "IMMEstimator",
        lambda **kw: kf.IMMEstimator(**kw).run(FRAMES),
        dict(models=[STRAIGHT, TURNING], transition=SWITCH),
        dict(
            models=BANK_MODELS + [Bad("state lengths 4 and 6", [CV, TURNING])],
            transition=_images((2, 2), np.array(SWITCH)),
            mu=_images((2,), np.array([0.3, 0.7])),
        ),
        valid={"mu=None"},
    ),
    Entry(
        "IMMEstimator.run",
        lambda **kw: kf.IMMEstimator([STRAIGHT, TURNING], SWITCH).run(**kw),
        dict(measurements=FRAMES),
        dict(
            measurements=_images((20, 2), FRAMES) + _images((3, 20, 2), BATCH, "batch "),
            threads=THREADS,
        ),
        valid={"measurements=batch one axis fewer"},
    ),
    Entry(
        "IMMEstimator.update",
        _imm_update,
        dict(measurement=FRAMES[1]),
        dict(measurement=_images((2,), FRAMES[1])),
    ),
    Entry(
        "experiments.type_confusion",
        lambda **kw: experiments.type_confusion(progress=False, **kw).table,
        dict(n_frames=4, runs=3),
        dict(
            models=[Bad(repr(v), v) for v in ("x", [CV, TURNING], {"bank": [CV]})],
            n_frames=[b for b in _positive_ints() if b.label != "2**62"],
            runs=[b for b in _positive_ints() if b.label != "2**62"],
            seed=SEEDS,
            threads=THREADS,
        ),
        valid={"models=None"},
    ),
    Entry(
        "experiments.source_banks",
        lambda **kw: [m.arrays() for bank in experiments.source_banks(**kw).values() for m in bank],
        dict(),
        dict(
            rho=[Bad(repr(v), v) for v in ((1.0, 0.5), (0.5,), (np.nan, 0.5), "ab", 0.5)],
            driving_std=_positive_scalars(),
            measurement_std=_positive_scalars(),
            ndim=_positive_ints(),
            dt=_positive_scalars(),
        ),
    ),
]

# ------------------------------------------------------------------------------ trajectory
SERIES = np.cumsum(np.random.default_rng(3).standard_normal((2, 40)), axis=1)
TIMES = np.arange(40.0)
FUZZY = kf.FuzzyFilter(1.0, 0.5, 1.0, 0.5, 0.1)
FUZZY_VEL = kf.FuzzyFilter(1.0, 0.5, 1.0, 0.5, 0.1, R_vel=1.0)
SERIES_POOL = _images((2, 40), SERIES)
TIMES_POOL = _images((40,), TIMES, "times ") + _images((2, 40), TIMES + SERIES * 0, "per series ")
#: documented: None (t_n = n) and times shared by the series, (n,)
TIMES_VALID = {"times=times None", "times=per series None", "times=per series one axis fewer"}
SPREADS = dict(P=1.0, Q=0.5, R=1.0, P_vel=0.5, Q_vel=0.1)
#: documented: missing samples (NaN) give NaN estimates before a series' first observed one
SERIES_VALID = {"z=one axis fewer", "z=all nan", "z=nan pixel"}


def _outs() -> list[Bad]:
    def pair(make):
        return make(), make()

    buffer = np.empty(2 * 40 + 1)
    read_only = pair(lambda: np.empty((2, 40)))
    for a in read_only:
        a.flags.writeable = False
    shared = np.empty((2, 40))
    return [
        Bad("one array", np.empty((2, 40))),
        Bad("list", [np.empty((2, 40)), np.empty((2, 40))]),
        Bad("three arrays", pair(lambda: np.empty((2, 40))) + (np.empty((2, 40)),)),
        Bad("float32", pair(lambda: np.empty((2, 40), np.float32))),
        Bad("int64", pair(lambda: np.empty((2, 40), np.int64))),
        Bad("wrong shape", pair(lambda: np.empty((2, 39)))),
        Bad("transposed", pair(lambda: np.empty((40, 2)).T)),
        Bad("read-only", read_only),
        Bad("the same array twice", (shared, shared)),
        Bad("overlapping", (buffer[:80].reshape(2, 40), buffer[1:81].reshape(2, 40))),
        Bad("z itself", (SERIES, np.empty((2, 40)))),
        Bad("lists", ([[0.0] * 40] * 2, [[0.0] * 40] * 2)),
    ]


def _step(z_n=None, t_n=None, velocity=None, filt=None, detector=False):
    filt = filt or kf.FuzzyFilter(**SPREADS)
    stream = kf.ChangeDetector(filt) if detector else filt
    stream.step(SERIES[:, 0], 0.0, **({} if velocity is None else {"velocity": SERIES[:, 0]}))
    kwargs = {} if velocity is None else {"velocity": velocity}
    return stream.step(SERIES[:, 1] if z_n is None else z_n, t_n, **kwargs)


def _plot(call):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    try:
        call()
    finally:
        plt.close("all")


FOUND = kf.ChangeDetector(FUZZY).run(SERIES)

ENTRIES += [
    Entry(
        "FuzzyFilter",
        lambda **kw: kf.FuzzyFilter(**kw).filter(SERIES),
        dict(SPREADS),
        dict(
            P=_positive_scalars(),
            Q=_positive_scalars(),
            R=_positive_scalars(),
            P_vel=_scalars(),
            Q_vel=_scalars(),
        ),
    ),
    Entry(
        "KalmanFilterCV (velocity measured)",
        lambda **kw: kf.KalmanFilterCV(**kw).filter(SERIES, velocity=SERIES),
        dict(SPREADS, R_vel=1.0),
        dict(P_vel=_scalars(), R_vel=_positive_scalars()),
    ),
    Entry(
        "FuzzyFilter.filter",
        lambda **kw: FUZZY.filter(**kw),
        dict(z=SERIES),
        dict(z=SERIES_POOL, times=TIMES_POOL, out=_outs(), threads=THREADS),
        allow_nan=True,  # (SERIES_VALID)
        valid=SERIES_VALID | TIMES_VALID | {"out=None"},
    ),
    Entry(
        "FuzzyFilter.filter (velocity measured)",
        lambda **kw: FUZZY_VEL.filter(**kw),
        dict(z=SERIES, velocity=SERIES),
        dict(velocity=_images((2, 40), SERIES)),
        allow_nan=True,
        valid={"velocity=nan pixel", "velocity=all nan"},
    ),
    Entry(
        "FuzzyFilter.gains",
        lambda **kw: FUZZY.gains(**kw),
        dict(n=40),
        dict(n=_positive_ints(), times=_images((40,), TIMES)),
        valid={"times=None"},
    ),
    Entry(
        "FuzzyFilter.step",
        _step,
        dict(),
        dict(z_n=_images((2,), SERIES[:, 1]), t_n=_scalars()),
        allow_nan=True,  # (a missing sample at a series' start: NaN, documented)
        valid={"z_n=None", "t_n=None", "z_n=nan pixel", "z_n=all nan"},
    ),
    Entry(
        "FuzzyFilter.step (velocity measured)",
        lambda **kw: _step(filt=kf.FuzzyFilter(**SPREADS, R_vel=1.0), **kw),
        dict(velocity=SERIES[:, 1]),
        dict(velocity=_images((2,), SERIES[:, 1])),
        allow_nan=True,
        valid={"velocity=nan pixel", "velocity=all nan"},
    ),
    Entry(
        "ChangeDetector",
        lambda **kw: kf.ChangeDetector(**kw).run(SERIES),
        dict(filter=FUZZY),
        dict(
            filter=[
                Bad("None", None),
                Bad("the class", kf.FuzzyFilter),
                Bad("a model", CV),
                Bad("'fuzzy'", "fuzzy"),
            ],
            method=_choices("cusum"),
            confidence=_scalars(),
            window=_positive_ints(),
            drift=_positive_scalars(),
        ),
        allow_nan=True,  # (the statistic is NaN where no test was made: documented)
        valid={"method=None", "confidence=None"},
    ),
    Entry(
        "ChangeDetector.run",
        lambda **kw: kf.ChangeDetector(FUZZY, "chi2").run(**kw),
        dict(z=SERIES),
        dict(z=SERIES_POOL, times=TIMES_POOL, threads=THREADS),
        allow_nan=True,
        valid=SERIES_VALID | TIMES_VALID,
    ),
    Entry(
        "ChangeDetector.step",
        lambda **kw: _step(detector=True, **kw),
        dict(),
        dict(z_n=_images((2,), SERIES[:, 1]), t_n=_scalars()),
        allow_nan=True,
        valid={"z_n=None", "t_n=None", "z_n=nan pixel", "z_n=all nan"},
    ),
    Entry(
        "effective_memory",
        kf.effective_memory,
        dict(gains=FUZZY.gains(30)),
        dict(
            gains=_images((30, 2), FUZZY.gains(30)),
            level=_positive_scalars(),
            tau=_positive_scalars(),
        ),
        valid={"gains=one axis fewer", "gains=scalar"},  # (a pair (α, β), a number α)
    ),
    Entry(
        "trajectory.plot_gain_comparison",
        lambda **kw: _plot(lambda: trajectory.plot_gain_comparison(**kw)),
        dict(figure=1, n=5),
        dict(figure=_ints(), n=[b for b in _positive_ints() if b.label != "2**62"]),
    ),
    Entry(
        "trajectory.plot_change_points",
        lambda **kw: _plot(lambda: trajectory.plot_change_points(**kw)),
        dict(z=SERIES, found=FOUND),
        dict(
            z=SERIES_POOL,
            found=[
                Bad("None", None),
                Bad("'found'", "found"),
                Bad("estimates", FUZZY.filter(SERIES)),
            ],
            series=_ints(),
            times=_images((40,), TIMES),
        ),
        valid=SERIES_VALID | {"times=None", "series=0"},
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
