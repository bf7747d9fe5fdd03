"""Makes the pictures of the user guide and the README (``docs/images/guide_*.png``).

Run once after a change that moves them, and commit the PNGs (each is checked to stay under
200 kB by ``tests/test_docs.py``)::

    python docs/scripts/make_figures.py [name ...]   # e.g. sequence; none: every picture

Needs matplotlib, scikit-image (the ``camera`` test image) and SciPy (the adaptive Wiener
anchor). Every picture is seeded, so a re-run draws the same data; a few seconds in all.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

import kalmanfield as kf  # noqa: E402

OUT = Path(__file__).resolve().parent.parent / "images"
SEED = 2026


def save(fig, name: str) -> None:
    """The figure as a palette PNG (a few times smaller than matplotlib's RGBA)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    image = Image.open(buffer).convert("RGB").quantize(colors=128, method=Image.MEDIANCUT)
    path = OUT / name
    image.save(path, optimize=True)
    print(f"{path.relative_to(OUT.parent.parent)}: {path.stat().st_size / 1e3:.0f} kB")


def panels(images, titles, name, cmap="gray", height=2.6):
    fig, axes = plt.subplots(1, len(images), figsize=(height * len(images), height + 0.3))
    for ax, image, title in zip(axes, images, titles):
        ax.imshow(image, cmap=cmap, interpolation="nearest")
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    save(fig, name)


def field_figures() -> None:
    models = {
        "(1,1), ρ = 0.95": kf.ARFieldModel([0.95, 0.95], [1, 1]),
        "(2,2), ρ = 0.9": kf.ARFieldModel([0.9, 0.9], [2, 2]),
        "(4,4), ρ = 0.8": kf.ARFieldModel([0.8, 0.8], [4, 4]),
        "(2,1), ρ = (0.98, 0.7)": kf.ARFieldModel([0.98, 0.7], [2, 1]),
    }
    images = [m.sample((192, 192), seed=SEED) for m in models.values()]
    panels(images, list(models), "guide_field.png")
    product = kf.sample_product_field(models["(2,2), ρ = 0.9"], (192, 192), seed=SEED)
    video = kf.ARFieldModel([0.9, 0.9, 0.9], [1, 2, 2]).stream((192, 192), seed=SEED)
    frames = video.take(8)
    panels(
        [np.sign(product) * np.sqrt(np.abs(product)), frames[0], frames[1], frames[7]],
        ["product field (2,2), √|x|·sign", "stream frame 0", "frame 1", "frame 7"],
        "guide_field_stream.png",
    )


def identification_figure() -> None:
    x = kf.ARFieldModel([0.9, 0.7], [2, 1]).sample((256, 256), seed=SEED)
    fit = kf.identify(x)
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.0))
    axes[0].imshow(x, cmap="gray")
    axes[0].set_title("field (2,1), ρ = (0.9, 0.7)", fontsize=9)
    axes[0].set_axis_off()
    fit.plot(axes[1:])
    for ax, axis_fit in zip(axes[1:], fit.fits):
        ax.set_title(
            f"axis {axis_fit.axis}: n = {axis_fit.order}, ρ̂ = {axis_fit.rho:.3f}", fontsize=9
        )
    fig.tight_layout()
    save(fig, "guide_identification.png")


def rowfilter_figures() -> None:
    model, noise_var, size = kf.ARFieldModel([0.9, 0.9], [2, 2]), 1.0, 192
    x = model.sample((size, size), seed=SEED)
    z = x + np.random.default_rng(SEED).normal(0.0, np.sqrt(noise_var), x.shape)
    causal = kf.VectorRowFilter(model, noise_var, size).filter(z)
    smoothed = kf.ScalarRowFilter(model, noise_var, size, smooth=True).filter(z)
    lo, hi = x.min(), x.max()

    def mse(e):
        return np.mean((e - x) ** 2)

    panels(
        [x, np.clip(z, lo, hi), np.clip(causal, lo, hi), np.clip(smoothed, lo, hi)],
        [
            "field x, (2,2), ρ = 0.9",
            f"z = x + θ, MSE {mse(z):.2f}",
            f"VectorRowFilter, MSE {mse(causal):.3f}",
            f"ScalarRowFilter smoothed, MSE {mse(smoothed):.3f}",
        ],
        "guide_rowfilter.png",
    )
    holes = z.copy()
    holes[60:100, 70:130] = np.nan
    filled = kf.ScalarRowFilter(model, noise_var, size, smooth=True).filter(holes)
    causal_map = kf.ScalarRowFilter(model, noise_var, size).error_variance(
        size, noise_var=np.where(np.isnan(holes), np.inf, noise_var)
    )
    fig, axes = plt.subplots(1, 3, figsize=(8.4, 2.9))
    for ax, image, title in zip(
        axes,
        [np.clip(holes, lo, hi), np.clip(filled, lo, hi)],
        ["z with a missing block (NaN)", "ScalarRowFilter smoothed"],
    ):
        ax.imshow(image, cmap="gray")
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    shown = axes[2].imshow(causal_map, cmap="magma")
    axes[2].set_title("causal error_variance map", fontsize=9)
    axes[2].set_axis_off()
    fig.colorbar(shown, ax=axes[2], fraction=0.046)
    save(fig, "guide_rowfilter_missing.png")


def denoising_figure() -> None:
    from scipy.signal import wiener
    from skimage import data, img_as_float

    clean = img_as_float(data.camera())[96:352, 128:384]
    noisy = clean + np.random.default_rng(0).normal(0.0, 0.1, clean.shape)

    def psnr(e):
        return 10 * np.log10(1.0 / np.mean((e - clean) ** 2))

    ours, anchor = kf.denoise(noisy), wiener(noisy, (5, 5))
    panels(
        [clean, noisy, anchor, ours],
        [
            "camera (crop)",
            f"noisy, σ = 0.1 ({psnr(noisy):.1f} dB)",
            f"scipy.signal.wiener 5×5 ({psnr(anchor):.1f} dB)",
            f"kf.denoise ({psnr(ours):.1f} dB)",
        ],
        "guide_denoising.png",
    )


def tracking_figure() -> None:
    size, n_frames, rng = 192, 50, np.random.default_rng(SEED)
    position = rng.uniform(30, size - 30, (6, 2))
    angle = rng.uniform(0, 2 * np.pi, 6)
    velocity = 2.0 * np.column_stack([np.cos(angle), np.sin(angle)])
    background = kf.ARFieldModel([0.9, 0.9, 0.9], [1, 2, 2]).stream((size, size), seed=SEED)
    tracker = kf.BranchingTracker(
        2, process_std=0.2, measurement_std=0.5, max_misses=3, maneuver_std=2.0, maneuver_prob=0.001
    )
    grid, truth = np.arange(size), []
    for _ in range(n_frames):
        truth.append(position.copy())
        frame = next(background).copy()
        for px, py in position:
            frame += 6.0 * np.outer(
                np.exp(-((grid - py) ** 2) / 2), np.exp(-((grid - px) ** 2) / 2)
            )
        tracker.update(kf.segment(frame, 4.0))
        position = position + velocity
        bounce = (position < 5) | (position > size - 5)
        velocity[bounce] *= -1
        position = np.clip(position, 5, size - 5)
    tracks, paths = tracker.tracks(), np.array(truth)
    detections = kf.segment(frame, 4.0)
    fig, axes = plt.subplots(1, 2, figsize=(8, 4.2))
    axes[0].imshow(frame, cmap="gray")
    axes[0].plot(detections.x, detections.y, "r+", ms=6)
    axes[0].set_title(f"last frame: {len(detections)} segments (+), 6 targets", fontsize=9)
    axes[1].imshow(frame, cmap="gray", alpha=0.5)
    for i in range(paths.shape[1]):
        axes[1].plot(paths[:, i, 0], paths[:, i, 1], "k:", lw=0.8)
    for _, track in tracks.groupby("particle"):
        axes[1].plot(track.x, track.y, lw=1.6)
    axes[1].set_title(
        f"BranchingTracker: {tracks.particle.nunique()} tracks (truth dotted)", fontsize=9
    )
    for ax in axes:
        ax.set_axis_off()
    save(fig, "guide_tracking.png")


def trajectory_figures() -> None:
    from kalmanfield.trajectory import plot_change_points, plot_gain_comparison

    for figure in (1, 2):
        save(plot_gain_comparison(figure, n=15), f"guide_trajectory_gains_fig{figure}.png")
    rng = np.random.default_rng(7)
    t = np.arange(200.0)
    truth = np.where(t < 120, 0.3 * t, 0.3 * 120 - 0.2 * (t - 120))  # a velocity jump at 120
    truth[60:] += 6.0  # and a position jump at 60
    z = truth + rng.normal(0, 1.0, t.size)
    found = kf.ChangeDetector(kf.FuzzyFilter(P=2.0, Q=0.05, R=1.0, P_vel=0.5, Q_vel=0.002)).run(z)
    fig, ax = plt.subplots(figsize=(7, 3))
    plot_change_points(z, found, ax=ax)
    ax.plot(t, truth, "--", color="0.2", lw=0.8, label="truth")
    ax.legend(fontsize=8)
    ax.set_title(f"cusum alarms at samples {[int(i) for i in found.indices()]}", fontsize=9)
    save(fig, "guide_trajectory_change_points.png")


def sequence_figure() -> None:
    model, size, n_frames = kf.ARFieldModel([0.98, 0.9, 0.9], [1, 2, 2]), 128, 30
    x = model.sample((n_frames, size, size), seed=SEED)
    z = x + np.random.default_rng(SEED).normal(0.0, 3.0, x.shape)
    per_frame = kf.denoise(z, noise_var=9.0)
    in_time = kf.denoise(z, noise_var=9.0, temporal=True)
    last, lo, hi = n_frames - 1, x.min(), x.max()

    def mse(e, axes=None):
        return np.mean((e - x) ** 2, axis=axes)

    at_last = mse(z, (1, 2))[last], mse(per_frame, (1, 2))[last], mse(in_time, (1, 2))[last]

    fig, axes = plt.subplots(1, 5, figsize=(14, 3.0), gridspec_kw={"width_ratios": [1] * 4 + [1.3]})
    shown = [
        (z, f"noisy frame {last}, MSE {at_last[0]:.2f}"),
        (per_frame, f"denoise frame by frame, MSE {at_last[1]:.3f}"),
        (in_time, f"denoise(temporal=True), MSE {at_last[2]:.3f}"),
        (x, "truth, (1,2,2), ρ = (0.98, 0.9, 0.9)"),
    ]
    for ax, (stack, title) in zip(axes, shown):
        ax.imshow(np.clip(stack[last], lo, hi), cmap="gray", interpolation="nearest")
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    frames = np.arange(n_frames)
    axes[4].plot(frames, mse(per_frame, (1, 2)), label="frame by frame")
    axes[4].plot(frames, mse(in_time, (1, 2)), label="sequence filter")
    axes[4].set_xlabel("frame", fontsize=9)
    axes[4].set_title("MSE per frame (noise variance 9)", fontsize=9)
    axes[4].legend(fontsize=8)
    axes[4].tick_params(labelsize=8)
    fig.tight_layout()
    save(fig, "guide_sequence.png")


FIGURES = {
    "field": field_figures,
    "identification": identification_figure,
    "rowfilter": rowfilter_figures,
    "denoising": denoising_figure,
    "tracking": tracking_figure,
    "trajectory": trajectory_figures,
    "sequence": sequence_figure,
}


def main() -> None:
    """Every picture, or those named on the command line (e.g. ``sequence``)."""
    OUT.mkdir(exist_ok=True)
    names = sys.argv[1:] or list(FIGURES)
    unknown = sorted(set(names) - set(FIGURES))
    if unknown:
        raise SystemExit(f"unknown figures {unknown}; known: {', '.join(FIGURES)}")
    for name in names:
        FIGURES[name]()


if __name__ == "__main__":
    main()
