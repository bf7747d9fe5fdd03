"""denoise meets scikit-image users where they are (issue 51): colour channels, the noise
level as σ or σ², the field model on every path, the better filter chosen for the image,
dtypes and ranges, masks — and the 0.1.0 spellings still work, with a warning."""

import warnings

import numpy as np
import pytest

import kalmanfield as kf

MODEL = kf.ARFieldModel([0.95, 0.9], [2, 1])


def noisy(shape=(64, 80), sigma=0.5, seed=0):
    x = MODEL.sample(shape, seed=seed)
    return x, x + np.random.default_rng(seed + 100).normal(0, sigma, shape)


def psnr(estimate, clean):
    peak = clean.max() - clean.min()
    return 10 * np.log10(peak**2 / np.mean((estimate - clean) ** 2))


# ------------------------------------------------------------------ colour channels
def test_a_colour_image_is_denoised_channel_by_channel():
    """(512, 512, 3) was read as 512 frames 3 pixels wide: 25.7 dB instead of 28.2."""
    x, z = noisy()
    scale = np.array([1.0, 3.0, 0.5])
    rgb = np.stack([z * s for s in scale], axis=-1)
    out = kf.denoise(rgb, channel_axis=-1)
    assert out.shape == rgb.shape
    for c in range(len(scale)):  # each channel alone, with its own noise level
        np.testing.assert_array_equal(out[..., c], kf.denoise(np.ascontiguousarray(rgb[..., c])))
    first = kf.denoise(np.moveaxis(rgb, -1, 0), channel_axis=0)
    np.testing.assert_array_equal(first, np.moveaxis(out, -1, 0))
    stack = np.stack([rgb, rgb[::-1]])  # (F, H, W, C): each channel a stack of its own
    by_channel = kf.denoise(stack, channel_axis=3)
    for c in range(3):
        np.testing.assert_array_equal(
            by_channel[..., c], kf.denoise(np.ascontiguousarray(stack[..., c]))
        )


def test_an_rgb_array_without_channel_axis_warns():
    _, z = noisy((40, 48))
    rgb = np.stack([z, z, z], axis=-1)
    with pytest.warns(UserWarning, match="channel_axis=-1"):
        kf.denoise(rgb, noise_var=0.25)
    with pytest.warns(UserWarning, match="channel_axis=-1"):
        kf.ScalarRowFilter(MODEL, 0.25, 3).filter(rgb)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kf.denoise(np.stack([z, z]), noise_var=0.25)  # a stack of two frames: no warning


@pytest.mark.parametrize("bad,error", [(3, ValueError), (-4, ValueError), (1.0, TypeError)])
def test_bad_channel_axis(bad, error):
    _, z = noisy((16, 20))
    with pytest.raises(error, match="channel_axis"):
        kf.denoise(np.stack([z, z, z], axis=-1), channel_axis=bad)


# ------------------------------------------------------------------ the noise level
def test_sigma_and_noise_var_are_the_same_setting():
    _, z = noisy()
    np.testing.assert_array_equal(kf.denoise(z, sigma=0.5), kf.denoise(z, noise_var=0.25))
    assert kf.estimate_sigma(z) == pytest.approx(np.sqrt(kf.estimate_noise_var(z)), rel=1e-15)
    with pytest.raises(ValueError, match="not both"):
        kf.denoise(z, sigma=0.5, noise_var=0.25)
    for bad in (0.0, -1.0, np.nan):
        with pytest.raises(ValueError, match="sigma"):
            kf.denoise(z, sigma=bad)


def test_the_noise_variance_by_position_is_deprecated_not_misread():
    """denoise(z, 0.1): a scikit-image user means σ = 0.1; 0.1.0 read a variance. By
    position it still is the variance (0.1.0's meaning), with a warning naming the keyword."""
    _, z = noisy()
    with pytest.warns(DeprecationWarning, match="noise_var"):
        legacy = kf.denoise(z, 0.25)
    np.testing.assert_array_equal(legacy, kf.denoise(z, noise_var=0.25))
    with pytest.raises(TypeError, match="positional"):
        kf.denoise(z, 0.25, MODEL, "stationary", True, 9)


# ------------------------------------------------------------------ the model, the method
def test_model_is_the_field_model_on_every_path():
    """denoise(z, model=identify(clean).model) lost 3 dB: the adaptive path read it as the
    unit-variance detail model. Now a field model means the stationary filter."""
    x, z = noisy((96, 96))
    model = kf.identify(x).model
    given = kf.denoise(z, sigma=0.5, model=model)
    np.testing.assert_array_equal(given, kf.denoise(z, sigma=0.5, model=model, method="stationary"))
    assert psnr(given, x) > psnr(kf.denoise(z, sigma=0.5, method="adaptive"), x) + 1.0
    with pytest.raises(ValueError, match="detail_model"):
        kf.denoise(z, model=model, method="adaptive")
    detail = kf.ARFieldModel([0.6, 0.6], [1, 1])
    own = kf.denoise(z, sigma=0.5, method="adaptive", detail_model=detail)
    with pytest.warns(DeprecationWarning, match="detail_model"):  # 0.1.0: adaptive=True, model=
        legacy = kf.denoise(z, noise_var=0.25, model=detail, adaptive=True)
    np.testing.assert_array_equal(legacy, own)


@pytest.mark.parametrize("name", ["camera", "moon"])
def test_auto_picks_the_better_filter(name):
    """Adaptive wins on edges (camera: +2.8 dB), stationary on smooth scenes (moon at
    σ = 0.2: +3.3 dB); auto is within 0.05 dB of the better one on both."""
    data = pytest.importorskip("skimage.data")
    clean = getattr(data, name)()[128:384, 128:384] / 255.0
    z = clean + 0.15 * np.random.default_rng(0).standard_normal(clean.shape)
    scores = {m: psnr(kf.denoise(z, method=m), clean) for m in ("adaptive", "stationary", "auto")}
    assert scores["auto"] >= max(scores["adaptive"], scores["stationary"]) - 0.05, scores
    assert abs(scores["adaptive"] - scores["stationary"]) > 0.3, scores  # a real choice


def test_auto_is_the_same_whatever_ran_before():
    _, z = noisy()
    first = kf.denoise(z)
    kf.denoise(noisy(seed=3)[1])
    np.testing.assert_array_equal(kf.denoise(z), first)


# ------------------------------------------------------------------ dtypes, ranges, masks
def test_float32_in_float32_out():
    _, z = noisy()
    out = kf.denoise(z.astype(np.float32))
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, kf.denoise(z.astype(np.float32).astype(np.float64)), atol=1e-6)


def test_uint8_stays_on_its_scale_and_clip_keeps_it_in_range():
    """(−5.3…260.9 for a uint8 image, which img_as_ubyte refuses)"""
    data = pytest.importorskip("skimage.data")
    img = data.camera()[:128, :128]
    noisy8 = np.clip(img + np.random.default_rng(0).normal(0, 20, img.shape), 0, 255)
    noisy8 = noisy8.astype(np.uint8)
    out = kf.denoise(noisy8)
    assert out.dtype == np.float64
    assert abs(out.mean() - noisy8.mean()) < 2  # the image's own scale
    clipped = kf.denoise(noisy8, clip=True)
    assert clipped.min() >= 0 and clipped.max() <= 255
    np.testing.assert_array_equal(clipped, np.clip(out, 0, 255))
    floats = kf.denoise(noisy8 / 255.0, clip=True)
    assert floats.min() >= noisy8.min() / 255.0 and floats.max() <= noisy8.max() / 255.0


def test_a_mask_marks_missing_pixels_like_nan():
    _, z = noisy()
    holes = np.random.default_rng(1).random(z.shape) < 0.1
    np.testing.assert_array_equal(
        kf.denoise(z, mask=holes, sigma=0.5), kf.denoise(np.where(holes, np.nan, z), sigma=0.5)
    )
    with pytest.raises(ValueError, match="mask must have the shape"):
        kf.denoise(z, mask=holes[:-1])
    with pytest.raises(TypeError, match="boolean"):
        kf.denoise(z, mask=holes.astype(int))
