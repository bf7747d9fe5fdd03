"""match_template: Rust == the NumPy twin, the standard tools, sub-pixel peaks, NaN and bad
input."""

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from kalmanfield import match_template
from kalmanfield.reference import template as ref

SHAPES = [(60, 80, 5, 7), (70, 90, 21, 25), (40, 40, 40, 40), (33, 47, 1, 9), (50, 64, 12, 3)]


def _windows(H, W, h, w):
    yield None
    yield (0, 0, W, H)
    yield (W - w, H - h, W, H)  # bottom-right corner, a single position
    yield (0, min(5, H - h), min(w + 4, W), H)  # left border
    yield (max(W - w - 6, 0), 0, W, min(h + 3, H))  # top and right borders


@pytest.mark.parametrize("H,W,h,w", SHAPES)
@pytest.mark.parametrize("method", ["ncc", "correlation"])
def test_surface_equals_twin(H, W, h, w, method):
    rng = np.random.default_rng(H * W + h)
    frame = rng.standard_normal((H, W)) * 3 + 10
    template = rng.standard_normal((h, w))
    for window in _windows(H, W, h, w):
        x, y, score, s = match_template(
            frame, template, window=window, method=method, return_surface=True
        )
        xr, yr, score_r, s_r = ref.match_template(frame, template, window, method)
        scale = 1.0 if method == "ncc" else np.abs(s_r).max()
        np.testing.assert_allclose(s, s_r, rtol=0, atol=1e-10 * scale)
        assert (x, y, score) == pytest.approx((xr, yr, score_r), abs=1e-9 * scale)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_pixel_types_equal_twin(dtype):
    rng = np.random.default_rng(3)
    frame = rng.integers(0, 200, (45, 52)).astype(dtype)
    template = frame[10:22, 30:39].copy()
    template[3, 3] += 7  # not an exact copy
    for window in (None, (20, 4, 52, 30)):
        x, y, score, s = match_template(frame, template, window=window, return_surface=True)
        s_r = ref.surface(frame, template, window)
        np.testing.assert_allclose(s, s_r, rtol=0, atol=1e-10)
    assert (round(x), round(y)) == (30, 10)


def test_flat_windows_score_zero_and_flat_template_is_an_error():
    frame = np.random.default_rng(0).standard_normal((30, 30))
    frame[:12, :12] = 4.5  # flat, including windows of an integer-like level
    s = match_template(frame, frame[14:18, 3:8], return_surface=True)[3]
    assert np.all(s[:9, :8] == 0.0)
    with pytest.raises(ValueError, match="constant"):
        match_template(frame, np.full((3, 3), 2.0))
    x, y, score = match_template(frame, np.full((3, 3), 2.0), method="correlation")
    assert score == pytest.approx(frame[int(y) : int(y) + 3, int(x) : int(x) + 3].sum() * 2)


def test_score_one_at_an_embedded_copy_and_other_tools_agree():
    cv2 = pytest.importorskip("cv2")
    skimage_feature = pytest.importorskip("skimage.feature")
    rng = np.random.default_rng(5)
    frame = rng.standard_normal((120, 140)).astype(np.float32)
    template = frame[40:72, 77:109].copy()
    x, y, score, s = match_template(frame, template, subpixel=False, return_surface=True)
    assert (x, y) == (77, 40) and score == pytest.approx(1.0, abs=1e-12)
    opencv = cv2.matchTemplate(frame, template, cv2.TM_CCOEFF_NORMED)
    np.testing.assert_allclose(s, opencv, atol=2e-5)  # OpenCV sums in float32
    sk = skimage_feature.match_template(frame.astype(np.float64), template.astype(np.float64))
    np.testing.assert_allclose(s, sk, atol=1e-6)


def test_quadratic_peak_is_exact():
    # a 1 × 1 template under plain correlation returns the frame itself as the surface
    yy, xx = np.mgrid[0:20, 0:24]
    x0, y0 = 11.37, 8.62
    frame = 5 - 0.3 * (xx - x0) ** 2 - 0.2 * (yy - y0) ** 2 - 0.1 * (xx - x0) * (yy - y0)
    x, y, _ = match_template(frame, [[1.0]], method="correlation")
    assert (x, y) == pytest.approx((x0, y0), abs=1e-9)


@pytest.mark.parametrize("dx,dy", [(0.0, 0.0), (0.3, -0.2), (-0.45, 0.45), (0.12, 0.37)])
def test_shifted_gaussian_peak_within_005_px(dx, dy):
    yy, xx = np.mgrid[0:64, 0:64]

    def blob(cx, cy, sigma=2.5):
        return np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * sigma**2))

    frame = blob(30 + dx, 25 + dy)
    # the known peak itself (1 × 1 plain correlation: the surface is the Gaussian)
    x, y, _ = match_template(frame, [[1.0]], method="correlation")
    assert abs(x - (30 + dx)) < 0.05 and abs(y - (25 + dy)) < 0.05
    # a template cut from an unshifted blob: its NCC peak is at the shift
    template = blob(32, 32)[22:43, 22:43]
    x, y, _ = match_template(frame, template)
    assert abs(x - (20 + dx)) < 0.05 and abs(y - (15 + dy)) < 0.05


def test_nan_pixels_are_missing():
    rng = np.random.default_rng(2)
    frame = rng.standard_normal((40, 50))
    template = frame[5:12, 30:38].copy()
    frame[20, 10] = np.nan
    s = match_template(frame, template, return_surface=True)[3]
    s_r = ref.surface(frame, template)
    np.testing.assert_allclose(s, s_r, atol=1e-10)  # NaN at the same places
    assert np.isnan(s[14:21, 3:11]).all() and np.isfinite(s[:14]).all()
    x, y, score = match_template(frame, template)
    assert (round(x), round(y), round(score, 9)) == (30, 5, 1.0)
    frame[:] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        match_template(frame, template)


def test_masked_pixels_are_missing_and_docstring_example():
    rng = np.random.default_rng(4)
    frame = np.ma.masked_array(rng.standard_normal((30, 30)), mask=False)
    frame.mask[10, 10] = True
    template = frame.data[2:8, 20:27].copy()
    s = match_template(frame, template, return_surface=True)[3]
    assert np.isnan(s[5:11, 4:11]).all() and np.isfinite(s[:5]).all()
    import doctest

    import kalmanfield.template.matching as matching

    assert doctest.testmod(matching).failed == 0


def test_refinement_equals_twin_at_borders_and_nan():
    rng = np.random.default_rng(9)
    for _ in range(30):
        s = rng.standard_normal((5, 6))
        s[rng.integers(0, 5), rng.integers(0, 6)] = np.nan
        frame = s  # 1 × 1 plain correlation: surface = frame
        x, y, score = match_template(frame, [[1.0]], method="correlation")
        iy, ix = np.unravel_index(np.nanargmax(s), s.shape)
        dx, dy = ref.refine_peak(s, ix, iy)
        assert (x, y) == pytest.approx((ix + dx, iy + dy), abs=1e-12)


@given(
    st.integers(8, 40),
    st.integers(8, 40),
    st.integers(1, 8),
    st.integers(1, 8),
    st.integers(0, 2**32 - 1),
    st.sampled_from(["ncc", "correlation"]),
)
def test_random_windows_equal_twin(H, W, h, w, seed, method):
    assume(method == "correlation" or h * w > 1)  # a 1 × 1 template is constant
    rng = np.random.default_rng(seed)
    frame = rng.standard_normal((H, W))
    template = rng.standard_normal((h, w))
    x0, y0 = rng.integers(0, W - w + 1), rng.integers(0, H - h + 1)
    x1, y1 = rng.integers(x0 + w, W + 1), rng.integers(y0 + h, H + 1)
    window = (int(x0), int(y0), int(x1), int(y1))
    s = match_template(frame, template, window=window, method=method, return_surface=True)[3]
    np.testing.assert_allclose(s, ref.surface(frame, template, window, method), atol=1e-10 * w * h)


class TestBadInput:
    frame = np.random.default_rng(0).standard_normal((20, 30))

    @pytest.mark.parametrize(
        "template,window,error,match",
        [
            (np.ones((21, 3)), None, ValueError, "larger than"),
            (np.ones((3, 31)), None, ValueError, "larger than"),
            (np.ones((5, 5)), (0, 0, 4, 10), ValueError, "larger than"),
            (np.ones((0, 3)), None, ValueError, "empty"),
            (np.ones(5), None, ValueError, "2-D"),
            (np.ones((2, 2)), (0, 0, 31, 10), ValueError, "outside"),
            (np.ones((2, 2)), (25, 0, 40, 10), ValueError, "outside"),
            (np.ones((2, 2)), (5, 5, 5, 10), ValueError, "empty"),
            (np.ones((2, 2)), (-1, 0, 5, 5), ValueError, "non-negative"),
            (np.ones((2, 2)), (0, 0, 5), ValueError, "4 entries"),
            (np.ones((2, 2)), (0, 0, 5.0, 5), TypeError, "integers"),
            (np.ones((2, 2)), 7, TypeError, "sequence"),
            (np.ones((2, 2), np.float32), None, TypeError, "dtype"),
            (np.ones((2, 2), complex), None, TypeError, "dtype"),
            ([[1, 2], [3, np.nan]], None, ValueError, "non-finite"),
            ([[1.0, 2.0], [3.0, np.inf]], None, ValueError, "non-finite"),
        ],
    )
    def test_bad_template_or_window(self, template, window, error, match):
        with pytest.raises(error, match=match):
            match_template(self.frame, template, window=window)

    def test_bad_frames(self):
        t = np.ones((2, 2))
        t[0, 0] = 0
        with pytest.raises(ValueError, match="2-D"):
            match_template(np.ones((3, 4, 5)), t)
        with pytest.raises(ValueError, match="empty"):
            match_template(np.ones((0, 4)), t)
        with pytest.raises(TypeError, match="real"):
            match_template(np.ones((4, 4), complex), t.astype(complex))
        with pytest.raises(TypeError, match="real"):
            match_template(np.array([["a", "b"], ["c", "d"]]), t)
        infinite = np.zeros((5, 5))
        infinite[2, 3] = np.inf
        with pytest.raises(ValueError, match=r"infinite pixel at \(x, y\) = \(3, 2\)"):
            match_template(infinite, t)
        with pytest.raises(ValueError, match="method"):
            match_template(np.ones((5, 5)), t, method="sqdiff")
        with pytest.raises(TypeError, match="not exactly representable"):
            match_template(np.ones((5, 5), np.uint8), [[0.5, 1], [2, 3]])
        huge = np.zeros((5, 5))
        huge[0, 0] = 1e200
        with pytest.raises(ValueError, match="rescale"):
            match_template(huge, t)

    def test_list_template_takes_the_frame_dtype(self):
        frame = (self.frame * 10 + 100).astype(np.uint8)
        x, y, s = match_template(frame, frame[3:7, 4:9].tolist(), subpixel=False)
        assert (x, y, s) == (4, 3, pytest.approx(1.0))
