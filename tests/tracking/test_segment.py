"""kalmanfield.segment (method page *Tracking*, §3): the Rust kernel against the NumPy reference and
scipy.ndimage, analytic cases, the label image, and bad input."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy import ndimage

import kalmanfield as kf
from kalmanfield import _core
from kalmanfield.reference.tracking.segment import segment as reference_segment
from kalmanfield.tracking.segment import COLUMNS

KERNEL_DTYPES = (np.uint8, np.uint16, np.float32, np.float64)
INT_COLUMNS = ("area", "bbox_x0", "bbox_y0", "bbox_x1", "bbox_y1", "label")


def assert_same(table: pd.DataFrame, expected: pd.DataFrame) -> None:
    assert list(table.columns) == list(expected.columns)
    assert len(table) == len(expected)
    for name in table.columns:
        if name in INT_COLUMNS:
            assert table[name].dtype == np.int64
            np.testing.assert_array_equal(table[name], expected[name], err_msg=name)
        else:
            assert table[name].dtype == np.float64
            np.testing.assert_allclose(
                table[name], expected[name], rtol=1e-12, atol=1e-12, err_msg=name
            )


def check_against_reference(frame, threshold, min_area, connectivity):
    table, labels = kf.segment(frame, threshold, min_area, connectivity, labels=True)
    expected, expected_labels = reference_segment(frame, threshold, min_area, connectivity)
    assert_same(table, expected)
    np.testing.assert_array_equal(labels, expected_labels)
    assert labels.dtype == np.int32 and labels.shape == np.shape(frame)


def element_strategy(dtype):
    if np.issubdtype(dtype, np.integer):
        return st.integers(0, 9)
    return st.floats(-5, 5, width=np.dtype(dtype).itemsize * 8)


@st.composite
def frames(draw):
    dtype = draw(st.sampled_from(KERNEL_DTYPES))
    shape = draw(hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=10))
    return draw(hnp.arrays(dtype, shape, elements=element_strategy(dtype)))


@given(
    frame=frames(),
    threshold=st.floats(-6, 10),
    min_area=st.integers(1, 4),
    connectivity=st.sampled_from([4, 8]),
)
def test_rust_matches_reference_on_small_frames(frame, threshold, min_area, connectivity):
    check_against_reference(frame, threshold, min_area, connectivity)


def smooth_noise(shape, dtype, seed):
    """Correlated noise scaled to the dtype's range: large, irregular segments."""
    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.normal(size=shape), 1.5)
    field = (field - field.min()) / np.ptp(field)
    if np.issubdtype(dtype, np.integer):
        return (field * np.iinfo(dtype).max).astype(dtype)
    return (field * 200.0 - 50.0).astype(dtype)


@pytest.mark.parametrize("dtype", KERNEL_DTYPES)
@pytest.mark.parametrize("connectivity", [4, 8])
def test_rust_matches_reference_on_larger_frames(dtype, connectivity):
    frame = smooth_noise((48, 61), dtype, seed=7)
    threshold = float(np.quantile(frame, 0.6))
    check_against_reference(frame, threshold, 3, connectivity)


@pytest.mark.parametrize("connectivity", [4, 8])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_matches_scipy_ndimage(connectivity, seed):
    frame = smooth_noise((40, 50), np.float64, seed) + np.random.default_rng(seed).normal(
        0, 2, (40, 50)
    )
    threshold = 90.0
    table, labels = kf.segment(frame, threshold, 1, connectivity, labels=True)

    structure = ndimage.generate_binary_structure(2, 1 if connectivity == 4 else 2)
    scipy_labels, n = ndimage.label(frame > threshold, structure)
    assert n == len(table) > 3
    # Same partition: each scipy label maps to exactly one of ours and vice versa.
    pairs = np.unique(np.stack([scipy_labels.ravel(), labels.ravel()]), axis=1)
    assert pairs.shape[1] == n + 1
    ours = np.zeros(n + 1, dtype=int)
    ours[pairs[0]] = pairs[1]
    index = np.arange(1, n + 1)
    rows = table.set_index("label").loc[ours[index]]

    excess = np.where(frame > threshold, frame - threshold, 0.0)
    centres = np.array(ndimage.center_of_mass(excess, scipy_labels, index))
    np.testing.assert_allclose(rows[["y", "x"]].to_numpy(), centres, rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(
        rows.area, ndimage.sum_labels(np.ones_like(frame), scipy_labels, index)
    )
    boxes = ndimage.find_objects(scipy_labels)
    bbox = np.array([[b[1].start, b[0].start, b[1].stop - 1, b[0].stop - 1] for b in boxes])
    np.testing.assert_array_equal(rows[["bbox_x0", "bbox_y0", "bbox_x1", "bbox_y1"]], bbox)
    np.testing.assert_allclose(rows.amplitude, ndimage.mean(frame, scipy_labels, index), rtol=1e-12)


def gaussian_blob(shape, centre, sigma, amplitude=100.0):
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    return amplitude * np.exp(-((xx - centre[0]) ** 2 + (yy - centre[1]) ** 2) / (2 * sigma**2))


@pytest.mark.parametrize("centre", [(31.3, 30.7), (20.5, 40.25), (17.0, 44.9)])
@pytest.mark.parametrize("sigma,threshold", [(3.0, 1e-6), (3.0, 1.0), (1.5, 5.0), (1.0, 10.0)])
def test_gaussian_blob_centroid_and_extent(centre, sigma, threshold):
    frame = gaussian_blob((64, 64), centre, sigma)
    table = kf.segment(frame, threshold)
    assert len(table) == 1
    row = table.iloc[0]
    assert abs(row.x - centre[0]) < 0.05 and abs(row.y - centre[1]) < 0.05

    # The definition, evaluated directly on the pixels.
    ys, xs = np.nonzero(frame > threshold)
    w = frame[ys, xs] - threshold
    cx, cy = np.sum(w * xs) / w.sum(), np.sum(w * ys) / w.sum()
    assert row.x == pytest.approx(cx, abs=1e-12) and row.y == pytest.approx(cy, abs=1e-12)
    assert row.extent_x == pytest.approx(np.sqrt(np.sum(w * (xs - cx) ** 2) / w.sum()), rel=1e-12)
    assert row.extent_y == pytest.approx(np.sqrt(np.sum(w * (ys - cy) ** 2) / w.sum()), rel=1e-12)
    assert row.area == len(w) and row.amplitude == pytest.approx(frame[ys, xs].mean(), rel=1e-12)


def test_wide_blob_over_low_threshold_has_extent_sigma():
    """Sampled at integer points, a Gaussian of σ ≥ 1 keeps its variance to ~1e-8."""
    table = kf.segment(gaussian_blob((64, 64), (31.3, 30.7), 3.0), 1e-6)
    assert table.extent_x[0] == pytest.approx(3.0, rel=1e-5)
    assert table.extent_y[0] == pytest.approx(3.0, rel=1e-5)


def test_min_area_drops_segments_and_their_labels():
    frame = np.zeros((6, 9), dtype=np.uint8)
    frame[0, 0] = 5  # area 1
    frame[2:4, 2:4] = 5  # area 4
    frame[5, 6:9] = 5  # area 3
    table, labels = kf.segment(frame, 0, min_area=3, labels=True)
    assert table.area.tolist() == [4, 3] and table.label.tolist() == [1, 2]
    assert labels[0, 0] == 0 and (labels[2:4, 2:4] == 1).all() and (labels[5, 6:] == 2).all()
    assert kf.segment(frame, 0, min_area=5).empty


@pytest.mark.parametrize("connectivity", [4, 8])
def test_label_image_matches_table(connectivity):
    frame = smooth_noise((50, 70), np.float32, seed=3)
    table, labels = kf.segment(frame, 80.0, 2, connectivity, labels=True)
    assert table.label.tolist() == list(range(1, len(table) + 1))
    np.testing.assert_array_equal(np.bincount(labels.ravel())[1:], table.area)
    for row in table.itertuples():
        ys, xs = np.nonzero(labels == row.label)
        assert (xs.min(), ys.min(), xs.max(), ys.max()) == (
            row.bbox_x0,
            row.bbox_y0,
            row.bbox_x1,
            row.bbox_y1,
        )
    # Raster order of the first pixel: first occurrences of the labels are increasing.
    flat = labels.ravel()
    first = [np.argmax(flat == k) for k in table.label]
    assert first == sorted(first)
    assert (frame[labels > 0] > 80.0).all()


def test_input_conversions():
    base = smooth_noise((20, 30), np.uint8, seed=5)
    expected = kf.segment(base, 100)
    assert_same(kf.segment(base.astype(np.int32), 100), expected)
    assert_same(kf.segment(base.tolist(), 100), expected)
    assert_same(kf.segment(base.astype(">u2"), 100), expected)
    assert_same(kf.segment(np.asfortranarray(base), 100), expected)
    wide = np.repeat(base, 2, axis=1)
    assert_same(kf.segment(wide[:, ::2], 100), expected)
    assert_same(kf.segment(base > 100, 0.5)[["area", "label"]], expected[["area", "label"]])


def test_frame_column_and_empty_frames():
    table = kf.segment(np.eye(4), 0.5, frame_no=7)
    assert list(table.columns) == ["frame", *COLUMNS]
    assert table.frame.dtype == np.int64 and (table.frame == 7).all()
    for shape in [(0, 5), (3, 0), (0, 0)]:
        empty, labels = kf.segment(np.zeros(shape), 0.0, labels=True, frame_no=0)
        assert empty.empty and list(empty.columns) == ["frame", *COLUMNS]
        assert labels.shape == shape and labels.dtype == np.int32
    assert kf.segment(np.zeros((3, 3)), 0.0).dtypes.equals(table.dtypes.drop("frame"))


@pytest.mark.parametrize(
    "args,kwargs,exc,match",
    [
        ((np.zeros((2, 2, 3, 4)), 0.0), {}, ValueError, "2-D"),
        ((np.zeros(5), 0.0), {}, ValueError, "2-D"),
        ((np.array([[0.0, np.nan]]), 0.0), {}, ValueError, "NaN"),
        ((np.array([[0.0, np.inf]], dtype=np.float32), 0.0), {}, ValueError, "infinite"),
        ((np.zeros((3, 3)), 0.0, 1, 6), {}, ValueError, "connectivity"),
        ((np.zeros((3, 3)), 0.0, 1, 4.0), {}, TypeError, "connectivity"),
        ((np.zeros((3, 3)), 0.0, 0), {}, ValueError, "min_area"),
        ((np.zeros((3, 3)), 0.0, 1.5), {}, TypeError, "min_area"),
        ((np.zeros((3, 3), dtype=complex), 0.0), {}, TypeError, "real numbers"),
        ((np.array([["a", "b"]]), 0.0), {}, TypeError, "real numbers"),
        ((np.array([[object()]]), 0.0), {}, TypeError, "real numbers"),
        ((np.zeros((3, 3)), np.nan), {}, ValueError, "threshold"),
        ((np.zeros((3, 3)), -np.inf), {}, ValueError, "threshold"),
        ((np.zeros((3, 3)), "1"), {}, ValueError, "threshold"),
        ((np.zeros((3, 3)), 0.0), {"frame_no": 1.0}, TypeError, "frame_no"),
    ],
)
def test_bad_input(args, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        kf.segment(*args, **kwargs)


def test_core_rejects_bad_arrays_without_panicking():
    """The binding layer checks too (defence in depth)."""
    with pytest.raises(TypeError, match="numpy array"):
        _core.segment([[1.0]], 0.0, 1, 8)
    with pytest.raises(TypeError, match="dtype"):
        _core.segment(np.zeros((3, 3), dtype=np.int64), 0.0, 1, 8)
    with pytest.raises(ValueError, match="2-D"):
        _core.segment(np.zeros((2, 2, 2)), 0.0, 1, 8)
    with pytest.raises(ValueError, match="C-contiguous"):
        _core.segment(np.zeros((4, 4))[:, ::2], 0.0, 1, 8)
    with pytest.raises(ValueError, match="connectivity"):
        _core.segment(np.zeros((3, 3)), 0.0, 1, 5)
    with pytest.raises(ValueError, match="min_area"):
        _core.segment(np.zeros((3, 3)), 0.0, 0, 8)
    with pytest.raises(OverflowError):
        _core.segment(np.zeros((3, 3)), 0.0, -1, 8)


@pytest.mark.parametrize("dtype", [np.uint8, np.float32, np.float64])
def test_stack_equals_frame_by_frame(dtype):
    """A 3-D stack is segmented in parallel over the frames; the table and label images
    equal those of the frames one at a time, with frame = frame_no + index."""
    rng = np.random.default_rng(7)
    stack = (rng.random((6, 40, 30)) * 200).astype(dtype)
    table, labels = kf.segment(stack, 150, 2, 8, labels=True, frame_no=10)
    parts = [kf.segment(f, 150, 2, 8, labels=True, frame_no=10 + i) for i, f in enumerate(stack)]
    expected = pd.concat([p[0] for p in parts], ignore_index=True)
    pd.testing.assert_frame_equal(table, expected)
    np.testing.assert_array_equal(labels, np.stack([p[1] for p in parts]))
    assert table.frame.is_monotonic_increasing and table.frame.min() >= 10
    assert list(kf.segment(stack, 150).columns) == ["frame", *COLUMNS]  # frame always present
    empty, empty_labels = kf.segment(np.zeros((3, 0, 4)), 0.0, labels=True)
    assert empty.empty and list(empty.columns) == ["frame", *COLUMNS]
    assert empty_labels.shape == (3, 0, 4)
    with pytest.raises(ValueError, match="3-D"):
        _core.segment_stack(np.zeros((2, 2)), 0.0, 1, 8)
    with pytest.raises(ValueError, match="NaN"):
        kf.segment(np.full((2, 3, 3), np.nan), 0.0)
