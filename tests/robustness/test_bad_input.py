"""Bad input gives a clear ValueError/TypeError/MemoryError, never a panic or silent NaN."""

import numpy as np
import pytest
from scipy.special import gammaln

import kalmanfield as kf
import kalmanfield.reference as ref


@pytest.mark.parametrize(
    "rho,order,match",
    [
        (1.0, 1, "between 0 and 1"),
        (0.0, 1, "between 0 and 1"),
        (-0.5, 1, "between 0 and 1"),
        (float("nan"), 1, "between 0 and 1"),
        (0.5, 0, "positive integer"),
        (0.5, -2, "positive integer"),
        ([0.5, 0.6], [1, 2, 3], "axes"),
        ([], [], "at least one axis"),
        (0.5, 99, "not supported"),
    ],
)
def test_bad_model_parameters(rho, order, match):
    with pytest.raises(ValueError, match=match):
        kf.ARFieldModel(rho, order)


@pytest.mark.parametrize("order", [1.5, "2", True, None])
def test_non_integer_orders(order):
    with pytest.raises(TypeError, match="order"):
        kf.ARFieldModel(0.5, [order, 1])


@pytest.mark.parametrize(
    "sigma,exc", [(0.0, ValueError), (-1.0, ValueError), (np.inf, ValueError), ("1", TypeError)]
)
def test_bad_sigma(sigma, exc):
    with pytest.raises(exc, match="sigma"):
        kf.ARFieldModel(0.5, 1, sigma)


def test_bad_rho_type():
    with pytest.raises(TypeError, match="rho"):
        kf.ARFieldModel(["a"], [1])
    for rho in (None, 1j):
        with pytest.raises(TypeError, match="rho must be a real number or a sequence"):
            kf.ARFieldModel(rho, 1)
    with pytest.raises(TypeError, match="order must be a positive integer or a sequence"):
        kf.ARFieldModel(0.5, 2.0)
    assert kf.ARFieldModel(np.array(0.5), np.array(2)).order == (2,)  # 0-d arrays: scalars


def test_templates_and_anisotropy_beyond_their_limits_are_refused():
    """(2**30 coefficients, 9^8 directions of the sphere: they ran for minutes)"""
    with pytest.raises(ValueError, match="template of orders"):
        kf.ARFieldModel([0.5] * 30, 1).coefficients()
    assert kf.ARFieldModel([0.5] * 3, 2).coefficients().shape == (3, 3, 3)
    with pytest.raises(ValueError, match="at most 8 axes"):
        kf.ARFieldModel([0.5] * 9, 1).anisotropy()


MODEL = kf.ARFieldModel([0.8, 0.7], [2, 1])


@pytest.mark.parametrize(
    "shape,exc,match",
    [
        ((0, 5), ValueError, "positive"),
        ((-3, 5), ValueError, "positive"),
        ((5,), ValueError, "axes"),
        ((5, 5, 5), ValueError, "axes"),
        ((5.0, 5), TypeError, "integer"),
        (None, TypeError, "sequence of ints"),
        (5.0, TypeError, "sequence of ints"),
        ("55", TypeError, "sequence of ints"),
        ((10**7, 10**7), MemoryError, "GiB"),
    ],
)
def test_bad_shapes(shape, exc, match):
    with pytest.raises(exc, match=match):
        MODEL.sample(shape, seed=0)


def test_starts_and_recursions_float64_cannot_resolve_are_refused():
    """Positive but wrong: the start's prediction errors of (4, 0.995) were off by 23 % (60-
    digit Levinson), of (4, 0.999) ×7700 (samples reached 15 σ), of (3, 0.99999) ×2.5e4
    (56 σ). Both twins refuse them; (4, 0.99) (its start off by 0.25 %) is kept. (The
    rounding-gain check of float64, 1/β̃ ≤ 4.5e10, binds after the start's in every case
    seen: Rust unit test.)"""
    for rho, n, match in [
        (0.995, 4, "4 ulps"),
        (0.999, 4, "4 ulps"),
        (0.98, 7, "4 ulps"),
        (0.99999, 3, "4 ulps"),
    ]:
        with pytest.raises(ValueError, match=match):
            kf.ARFieldModel(rho, n).sample(64, seed=0)
        with pytest.raises(ValueError, match="beyond float64|rounding of float64"):
            ref.stationary_start(rho, n)
    assert np.isfinite(kf.ARFieldModel(0.99, 4).sample(64, seed=0)).all()


def test_float32_fields_of_smooth_models_are_made_in_float64():
    """(0.99, 4) in single-precision recursions drifted to inf (1/β̃ = 4e6 amplifies float32
    rounding); such fields are now made in float64 and rounded once, streams refused."""
    model = kf.ARFieldModel([0.99, 0.9], [4, 2])
    x64 = model.sample((64, 48), seed=3)
    x32 = model.sample((64, 48), seed=3, dtype=np.float32)
    assert x32.dtype == np.float32
    np.testing.assert_array_equal(x32, x64.astype(np.float32))
    with pytest.raises(ValueError, match="float32.*use float64"):
        kf.FieldStream(model, (8,), seed=0, dtype=np.float32)
    assert kf.FieldStream(model, (8,), seed=0).next_frame().dtype == np.float64


def test_sigma_and_rho_at_float64s_edges_are_refused():
    for sigma in (1e154, 1.7e308, 1e-154):  # σ² overflowed (correlation inf / NaN) or underflowed
        with pytest.raises(ValueError, match=r"sigma must lie within \[2\^-510, 2\^510\]"):
            kf.ARFieldModel(0.5, 1, sigma)
    model = kf.ARFieldModel(0.5, 1, 3e153)
    assert np.isfinite(model.correlation([[0.0], [1e10]])).all()
    with pytest.raises(ValueError, match="rho must be at least"):  # anisotropy was NaN
        kf.ARFieldModel([1e-310, 0.5], [1, 1])
    assert np.isfinite(kf.ARFieldModel([1e-300, 0.5], [1, 1]).anisotropy())


def test_a_stationary_start_beyond_float64_is_refused_not_nan():
    # ρ = 0.99 with multiplicity 8: a prediction error of the start rounds to < 0 (every
    # sample was NaN); the model itself stays usable (correlation, identification results)
    model = kf.ARFieldModel([0.99, 0.5], [8, 1])
    assert np.isfinite(model.correlation([[0, 0], [5, 0]])).all()
    with pytest.raises(ValueError, match="beyond float64"):
        model.sample((16, 16), seed=0)
    with pytest.raises(ValueError, match="beyond float64"):
        kf.sample_product_field(model, (16, 16), seed=0)
    with pytest.raises(ValueError, match="beyond float64"):
        kf.FieldStream(kf.ARFieldModel([0.5, 0.99, 0.5], [1, 8, 1]), (8, 8), seed=0).next_frame()
    # multiplicity 4 is still within float64: the sample is the twin's on the same noise (to
    # the conditioning of its start, R_y[:4,:4] ~ 1e13)
    noise = np.random.default_rng(0).standard_normal((16, 16))
    sample = kf.ARFieldModel([0.99, 0.5], [4, 1]).sample((16, 16), noise=noise)
    np.testing.assert_allclose(sample, ref.sample([0.99, 0.5], [4, 1], 1.0, noise), atol=1e-6)
    # the NumPy twin refuses the same starts (it returned NaN)
    with pytest.raises(ValueError, match="beyond float64"):
        ref.sample([0.99, 0.5], [8, 1], 1.0, np.zeros((16, 16)))
    with pytest.raises(ValueError, match="beyond float64"):
        ref.stream_frame([0.99, 0.5], [8, 1], 1.0, [], 0, np.zeros(16))
    coeffs, gains = ref.stationary_start(0.99, 4)
    assert np.isfinite(gains).all() and (np.diff(gains) < 0).all()
    # β̃² of the last order is 1 / Σ h_i², h_i = C(n + i − 1, i) ρ^i the impulse response
    i = np.arange(20000)
    log_h = gammaln(i + 4) - gammaln(i + 1) - gammaln(4) + i * np.log(0.99)
    assert gains[4] ** 2 == pytest.approx(1 / np.exp(2 * log_h).sum(), rel=1e-10)


def test_bad_noise():
    with pytest.raises(ValueError, match="shape"):
        MODEL.sample((4, 5), noise=np.zeros((5, 4)))
    with pytest.raises(ValueError, match="NaN"):
        MODEL.sample((2, 2), noise=[[0.0, np.nan], [0.0, 0.0]])
    with pytest.raises(ValueError, match="NaN"):
        MODEL.sample((2, 2), noise=[[0.0, np.inf], [0.0, 0.0]])


def test_bad_seed_dtype_threads():
    with pytest.raises(ValueError, match="seed"):
        MODEL.sample((3, 3), seed=-1)
    with pytest.raises(ValueError, match="seed"):
        MODEL.sample((3, 3), seed=2**64)
    with pytest.raises(TypeError, match="seed"):
        MODEL.sample((3, 3), seed=1.5)
    with pytest.raises(TypeError, match="dtype"):
        MODEL.sample((3, 3), dtype=np.int32)
    with pytest.raises(ValueError, match="threads"):
        MODEL.sample((3, 3), threads=0)


@pytest.mark.parametrize("threads", [0, -1, 1025, 10**6, 2**70])
def test_thread_counts_out_of_range_are_refused(threads):
    """(a pool per call: 20,000 threads ran for minutes, 2**70 overflowed unclearly)"""
    z = np.zeros((4, 8))
    row = kf.ARFieldModel([0.8, 0.7], [1, 1])
    calls = [
        lambda: MODEL.sample((3, 3), threads=threads),
        lambda: kf.ScalarRowFilter(row, 1.0, 8, threads=threads),
        lambda: kf.VectorRowFilter(row, 1.0, 8, threads=threads),
        lambda: kf.denoise(z + 1.0, noise_var=0.1, threads=threads),
        lambda: kf.identify(MODEL.sample((16, 16), seed=1), threads=threads),
    ]
    for call in calls:
        with pytest.raises(ValueError, match="threads"):
            call()
    with pytest.raises(TypeError, match="threads"):
        kf.denoise(z, noise_var=0.1, threads=1.5)


def test_far_lags_correlate_by_zero_not_nan():
    """(the polynomial of order 16 overflowed at 1e25: 0 · inf)"""
    assert kf.ARFieldModel(0.5, 16).correlation([1e25, 1e300]).tolist() == [0.0, 0.0]
    with np.errstate(over="ignore"):
        assert ref.axis_correlation(0.5, 16, np.array([1e25, 1e300])).tolist() == [0.0, 0.0]


def test_bad_counts_and_frame_numbers():
    with pytest.raises(ValueError, match="below 2\\*\\*63"):
        kf.segment(np.zeros((4, 4)), 0.5, min_area=2**64)
    with pytest.raises(ValueError, match="overflow int64"):
        kf.segment(np.zeros((2, 4, 4)), 0.5, frame_no=2**63 - 1)
    assert kf.segment(np.zeros((4, 4)), 0.5, frame_no=2**63 - 1).empty
    with pytest.raises(TypeError, match="noise"):
        MODEL.sample((3, 3), noise=np.zeros((3, 3), complex))
    with pytest.raises(TypeError, match="noise"):
        MODEL.sample((3, 3), noise=np.zeros((3, 3), bool))


def test_bad_lags():
    with pytest.raises(ValueError, match="lags"):
        MODEL.correlation([1, 2, 3])
    with pytest.raises(ValueError, match="NaN"):
        MODEL.correlation([np.nan, 1])


def test_product_field_bad_input():
    with pytest.raises(ValueError, match="2 1-D arrays"):
        kf.sample_product_field(MODEL, (3, 3), noise=[np.zeros(3)])
    with pytest.raises(ValueError, match="noise\\[1\\]"):
        kf.sample_product_field(MODEL, (3, 3), noise=[np.zeros(3), np.zeros(4)])
    with pytest.raises(TypeError, match="ARFieldModel"):
        kf.sample_product_field("model", (3, 3))
    for noise in (5, "ab"):  # (an int had raised "object of type 'int' has no len()")
        with pytest.raises(TypeError, match="noise must be a sequence of 2 1-D arrays"):
            kf.sample_product_field(MODEL, (3, 3), noise=noise)


def test_core_rejects_mismatched_output_without_panicking():
    """The binding layer checks too (defence in depth)."""
    with pytest.raises(ValueError, match="3 axes"):
        MODEL._core.sample_into(np.empty((3, 4, 5)), 0, None, None)
    with pytest.raises(TypeError, match="float64 or float32"):
        MODEL._core.sample_into(np.empty((3, 4), dtype=np.int64), 0, None, None)
    with pytest.raises(ValueError, match="noise has 4 elements"):
        MODEL._core.sample_into(np.empty((3, 4)), 0, np.zeros((2, 2)), None)
    with pytest.raises(ValueError, match="previous frames"):
        MODEL._core.stream_into(np.empty(4), [], 3, 0, None, None)


# ------------------------------------------------------- values at the edges of float64's range
# (a fuzz sweep found NaN/inf outputs for finite inputs here; each is now a clear ValueError
# or a finite answer)
MAX_PIXEL = 2.0**1000
ROW_FILTERS = [
    lambda m: kf.ScalarRowFilter(m, 0.5, 16),
    lambda m: kf.ScalarRowFilter(m, 0.5, 16, smooth=True),
    lambda m: kf.VectorRowFilter(m, 0.5, 16),
    lambda m: kf.VectorRowFilter(m, 0.5, 16, smooth=True),
]


@pytest.mark.parametrize("make", ROW_FILTERS)
def test_row_filters_take_pixels_up_to_2_to_the_1000_and_refuse_larger_ones(make):
    row_filter = make(kf.ARFieldModel([0.9, 0.8], [2, 2]))
    z = np.random.default_rng(3).standard_normal((12, 16))
    # at the limit: finite, and (the filter is linear, 2^k scales exactly) the scaled estimate
    top = z / np.abs(z).max() * MAX_PIXEL
    np.testing.assert_array_equal(
        row_filter.filter(top), row_filter.filter(z / np.abs(z).max()) * MAX_PIXEL
    )
    for at, value in [((0, 3), 2.0**1001), ((9, 5), -1.7e308)]:
        bad = z.copy()
        bad[at] = value
        with pytest.raises(ValueError, match="out-of-range"):
            row_filter.filter(bad)


def test_out_of_range_pixels_are_refused_with_missing_pixels_and_by_the_mean():
    model = kf.ARFieldModel([0.9, 0.8], [1, 2])
    z = np.random.default_rng(4).standard_normal((10, 16))
    z[2, 3] = np.nan
    z[6, 7] = 1e302
    with pytest.raises(ValueError, match="beyond"):
        kf.ScalarRowFilter(model, 0.5, 16).filter(z)
    z = np.random.default_rng(4).standard_normal((10, 16)) + 1.5e308
    with np.errstate(over="ignore"), pytest.raises(ValueError, match="out-of-range"):
        kf.ScalarRowFilter(model, 0.5, 16, mean=-1.5e308).filter(z)


def test_noise_ratios_outside_float64s_normal_range_are_refused():
    model = kf.ARFieldModel([0.9, 0.8], [1, 1])
    tiny = np.finfo(float).tiny
    z = np.random.default_rng(5).standard_normal((6, 8))
    for cls in (kf.ScalarRowFilter, kf.VectorRowFilter):
        # (a subnormal ratio gave a NaN image)
        with pytest.raises(ValueError, match="normal range"):
            cls(model, 1e-320, 8)
        with pytest.raises(ValueError, match="normal range"):
            cls(kf.ARFieldModel([0.9, 0.8], [1, 1], sigma=1e-153), 1e300, 8)
        # at σ_θ² = tiny the estimate is the image (to rounding: gains of 1 − O(tiny))
        np.testing.assert_allclose(cls(model, tiny, 8).filter(z), z, rtol=0, atol=1e-14)
    # per-pixel: (it was refused as "weights must be finite", weights the user never gave)
    with pytest.raises(ValueError, match="at least"):
        kf.ScalarRowFilter(model, 1.0, 8).filter(z, noise_var=np.full(z.shape, 1e-320))


def test_scalar_filter_estimates_that_overflow_are_refused_not_nan():
    """|z − mean|·σ_x²/σ_θ² beyond float64 (1e10 at a noise ratio of 1e-300, 1e300 at 1e-12):
    the estimate was all NaN, silently (the vector filter copes). Images, stacks, per-pixel
    maps, causal and smoothed."""
    model = kf.ARFieldModel(0.9, [1, 1])
    for noise_var, value in ((1e-300, 1e10), (1e-12, 1e300)):
        for smooth in (False, True):
            srf = kf.ScalarRowFilter(model, noise_var, 3, smooth=smooth)
            for z in (np.full((3, 3), value), np.full((2, 3, 3), value)):
                with pytest.raises(ValueError, match="estimate overflowed float64"):
                    srf.filter(z)
    srf = kf.ScalarRowFilter(model, 1.0, 3)
    with pytest.raises(ValueError, match="estimate overflowed float64"):
        srf.filter(np.full((3, 3), 1e10), noise_var=np.full((3, 3), 1e-300))
    # the same pixels at an ordinary noise ratio are fine
    assert np.isfinite(kf.ScalarRowFilter(model, 1e-6, 3).filter(np.full((3, 3), 1e10))).all()


def test_overflowing_estimates_are_refused_not_inf():
    z = np.random.default_rng(6).standard_normal((40, 32))
    with pytest.raises(ValueError, match="overflows"):
        kf.estimate_noise_var(z * 1e300)
    blob = np.zeros((40, 32))
    blob[5:25, 5:25] = 1e306
    with pytest.raises(ValueError, match="moments overflow"):
        kf.segment(blob, 1.0)
    with pytest.raises(ValueError, match="moments overflow"):
        kf.segment(np.stack([blob, blob]), 1.0)
    # a threshold far below ordinary pixels: the message names it
    with pytest.raises(ValueError, match="moments overflow.*threshold"):
        kf.segment(np.full((2, 2), 255, np.uint8), -1e308)
    # 1e296 is within range: the 20 × 20 block's centroid, area and mean amplitude
    found = kf.segment(blob * 1e-10, 1.0)
    assert len(found) == 1 and found.area[0] == 400
    assert found.x[0] == pytest.approx(14.5, rel=1e-12) and found.y[0] == found.x[0]
    assert found.amplitude[0] == pytest.approx(1e296, rel=1e-12)


def test_float32_fields_refuse_a_sigma_beyond_float32():
    # (σ = 1e39 gave inf samples)
    model = kf.ARFieldModel([0.9, 0.8], [1, 1], sigma=1e39)
    with pytest.raises(ValueError, match="float32"):
        model.sample((4, 4), seed=1, dtype=np.float32)
    with pytest.raises(ValueError, match="float32"):
        kf.sample_product_field(model, (4, 4), seed=1, dtype=np.float32)
    with pytest.raises(ValueError, match="float32"):
        kf.FieldStream(model, (4,), seed=1, dtype=np.float32)
    with pytest.raises(ValueError, match="float32"):
        kf.ARFieldModel(0.5, 1, sigma=1e-35).sample((4,), seed=1, dtype=np.float32)
    # float64 holds it: σ scales the unit field of the same seed
    unit = kf.ARFieldModel([0.9, 0.8], [1, 1]).sample((4, 4), seed=1)
    np.testing.assert_allclose(model.sample((4, 4), seed=1), 1e39 * unit, rtol=1e-14)


def test_tracker_measurements_beyond_1e150_are_refused():
    # (1e200 gave NaN tracks)
    tracker = kf.BranchingTracker(2)
    with pytest.raises(ValueError, match="within"):
        tracker.update([[1e200, 0.0]])
    assert tracker.frame == 0  # nothing changed
    # 1e150 is within: the same hypotheses as the same scene translated to x = 100
    near = kf.BranchingTracker(2)
    for f in range(6):
        tracker.update([[1e150, 0.0], [1e150, 30.0 + f]])
        near.update([[100.0, 0.0], [100.0, 30.0 + f]])
    assert tracker.frame == 6 and tracker.n_hypotheses == near.n_hypotheses > 0
    np.testing.assert_array_equal(tracker.stats(), near.stats())


def test_link_with_frame_numbers_spanning_int64():
    # (the int64 span wrapped round to 0: ZeroDivisionError)
    import pandas as pd

    det = pd.DataFrame({"frame": [-(2**63), 2**63 - 1], "x": [0.0, 1.0], "y": [0.0, 1.0]})
    with pytest.raises(ValueError, match="renumber"):
        kf.link(det, measurement_std=0.5, process_std=0.1)
    wide = pd.DataFrame({"frame": [0, 0, 1], "x": [-1e150, 1e150, 0.0], "y": [-1e150, 1e150, 0.0]})
    assert (kf.link(wide, measurement_std=0.5, process_std=0.1).particle == -1).all()


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: kf.ARFieldModel(10**400, [1, 1]), "between 0 and 1, got inf"),
        (lambda: kf.ARFieldModel(0.5, [1, 1], sigma=-(10**400)), "sigma must be positive"),
        (lambda: kf.ScalarRowFilter(MODEL, 10**400, 8), "noise_var must be positive and finite"),
        (lambda: kf.VectorRowFilter(MODEL, 1.0, 8, mean=-(10**400)), "mean must be finite"),
        (lambda: kf.segment(np.zeros((4, 4)), 10**400), "threshold must be finite"),
        (lambda: kf.BranchingTracker(2, process_std=10**400), "process_std must be finite"),
    ],
)
def test_integers_beyond_float64_are_refused_by_name(call, match):
    # (float() raised OverflowError and NumPy's isfinite a TypeError about ufunc casting)
    with pytest.raises(ValueError, match=match):
        call()


def test_row_filter_inputs_of_every_kind():
    """Masked entries are missing pixels (the mask was ignored, the masked data used);
    strings, datetimes and numbers beyond float64 are refused by name (strings had been
    parsed, datetimes cast, 10**400 raised numpy's OverflowError); an empty stack with a
    noise map is an empty answer (it raised numpy's zero-size reduction error)."""
    model = kf.ARFieldModel(0.9, [1, 1])
    srf = kf.ScalarRowFilter(model, 0.5, 5)
    z = np.random.default_rng(0).standard_normal((4, 5))
    masked = np.ma.MaskedArray(z.copy(), mask=np.zeros(z.shape, bool))
    masked.mask[1, 2] = True
    holes = z.copy()
    holes[1, 2] = np.nan
    np.testing.assert_array_equal(srf.filter(masked), srf.filter(holes))
    assert np.isfinite(masked.data).all()  # the caller's data untouched
    with pytest.raises(ValueError, match="needs every pixel"):
        kf.VectorRowFilter(model, 0.5, 5).filter(masked)
    with pytest.raises(ValueError, match="beyond float64's range"):
        srf.filter(np.full((4, 5), 10**400, dtype=object))
    for bad in (np.full((4, 5), "1.5"), np.zeros((4, 5), dtype="datetime64[s]")):
        with pytest.raises(TypeError, match="must hold real numbers"):
            srf.filter(bad)
    assert srf.filter(np.zeros((0, 4, 5)), noise_var=np.ones((0, 4, 5))).shape == (0, 4, 5)


def test_numeric_strings_and_bools_in_object_arrays_are_refused():
    """(float() had parsed "1.5" and taken True as 1 in object arrays: identify, link's
    columns, the filters and the tracker accepted them)"""
    z = np.random.default_rng(0).standard_normal((8, 8)).astype(object)
    for bad in ("1.5", True, None, 1j):
        z[3, 4] = bad
        with pytest.raises(TypeError, match="must hold real numbers"):
            kf.ScalarRowFilter(MODEL, 0.5, 8).filter(z)
        with pytest.raises(TypeError, match="must hold real numbers"):
            kf.identify(z)
        with pytest.raises(TypeError, match="must hold real numbers"):
            kf.BranchingTracker(2).update(np.array([[1.0, bad]], dtype=object))
    for bad in (np.array(["1", "2"]), ["1", "2"]):
        with pytest.raises(TypeError, match="lags must hold real numbers"):
            kf.ARFieldModel(0.5, 1).correlation(bad)
    with pytest.raises(TypeError, match="must hold real numbers"):
        kf.sample_correlation(np.array([["1", "2"], ["3", "4"]]), 1)
    z[3, 4] = 10**400
    with pytest.raises(ValueError, match="beyond float64"):
        kf.identify(z)


def test_what_the_bad_input_harness_found():
    """tests/robustness found these (issue 49): a Yule–Walker prediction of an image with an
    infinite pixel was inf, silently; link read pos_columns="xy" as the columns x and y;
    BranchingTracker(2**62) was a bare MemoryError; a stream whose model's start is beyond
    float64 was accepted until its first frame."""
    import pandas as pd

    image = MODEL.sample((12, 16), seed=1)
    fit = kf.yule_walker(image, (1, 1))
    for value in (np.inf, -np.inf):
        bad = image.copy()
        bad[4, 5] = value
        with pytest.raises(ValueError, match="infinite pixels"):
            fit.predict(bad)
    with pytest.raises(ValueError, match="overflows float64"):
        fit.predict(1.5e308 * (-1.0) ** np.add.outer(np.arange(12), np.arange(16)))
    holes = image.copy()
    holes[4, 5] = np.nan  # missing: NaN where the template touches it, finite elsewhere
    predicted = fit.predict(holes)
    touched = np.zeros(image.shape, bool)
    touched[[4, 5, 5], [6, 5, 6]] = True  # the pixels whose template holds (4, 5)
    touched[0, :] = touched[:, 0] = True  # and those whose template leaves the image
    assert np.isnan(predicted[touched]).all() and np.isfinite(predicted[~touched]).all()
    det = pd.DataFrame({"frame": [0, 1], "x": [1.0, 2.0], "y": [3.0, 4.0]})
    for key in ("pos_columns", "features"):
        with pytest.raises(TypeError, match=f"{key} must be a sequence of column names"):
            kf.link(det, measurement_std=0.5, process_std=0.1, **{key: "xy"})
    with pytest.raises(ValueError, match="n_params must be at most 65536"):
        kf.BranchingTracker(2**62)
    with pytest.raises(ValueError, match="beyond float64"):
        kf.FieldStream(kf.ARFieldModel([0.5, 0.99, 0.5], [1, 8, 1]), (8, 8), seed=0)
