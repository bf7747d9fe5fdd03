"""The demo report's figures (matplotlib, an optional extra): every one titled, with labelled
axes and colour bars; returned as PNG bytes."""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from ..io._optional import optional


def _pyplot() -> Any:
    matplotlib = optional("matplotlib", "the demo report")
    matplotlib.use("Agg")
    return optional("matplotlib.pyplot", "the demo report")


def png(fig: Any) -> bytes:
    """The figure as PNG bytes (and closed)."""
    plt = _pyplot()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    return buffer.getvalue()


def _image(ax: Any, image: np.ndarray, title: str, label: str, cmap: str = "gray", **kw) -> None:
    shown = ax.imshow(image, cmap=cmap, **kw)
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    ax.figure.colorbar(shown, ax=ax, shrink=0.8, label=label)


def fields(clutter: np.ndarray, clean: np.ndarray, observed: np.ndarray, model: str) -> bytes:
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), constrained_layout=True)
    low, high = np.percentile(observed, [0.5, 99.5])
    _image(axes[0], clutter, f"clutter: one frame of the AR background\n{model}", "intensity")
    _image(axes[1], clean, "clutter + point targets (no noise)", "intensity")
    _image(axes[2], observed, "observed: + white noise", "intensity", vmin=low, vmax=high)
    fig.suptitle("The simulated scene, frame 0")
    return png(fig)


def filtering(
    observed: np.ndarray,
    filtered: np.ndarray,
    error_map: np.ndarray,
    detect: np.ndarray,
    caption: str,
) -> bytes:
    plt = _pyplot()
    from matplotlib.colors import LogNorm

    fig, axes = plt.subplots(2, 2, figsize=(11, 9.5), constrained_layout=True)
    low, high = np.percentile(observed, [0.5, 99.5])
    _image(axes[0, 0], observed, "observed frame", "intensity", vmin=low, vmax=high)
    _image(
        axes[0, 1],
        filtered,
        "clutter estimate (ScalarRowFilter, smoothed)",
        "intensity",
        vmin=low,
        vmax=high,
    )
    _image(
        axes[1, 0],
        error_map,
        "predicted error variance of the filter (log scale: the borders are worse)",
        "error variance",
        cmap="viridis",
        norm=LogNorm(),
    )
    _image(
        axes[1, 1], detect, "residual correlated with the spot shape", "noise stds", cmap="magma"
    )
    fig.suptitle(caption)
    return png(fig)


def tracks_over_frame(
    frame: np.ndarray, tracks: pd.DataFrame, truth: pd.DataFrame, title: str
) -> bytes:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 7), constrained_layout=True)
    shown = ax.imshow(frame, cmap="gray")
    fig.colorbar(shown, ax=ax, shrink=0.8, label="matched residual (noise stds)")
    for i, (_, target) in enumerate(truth.groupby("particle")):
        ax.plot(target.x, target.y, "w:", lw=1.2, label="true path" if i == 0 else None)
    for _, track in tracks.groupby("particle"):
        line = ax.plot(track.x, track.y, lw=1.6)[0]
        ax.annotate(
            str(track.particle.iloc[-1]),
            (track.x.iloc[-1], track.y.iloc[-1]),
            color=line.get_color(),
            fontsize=8,
            xytext=(3, 3),
            textcoords="offset points",
        )
    ax.plot([], [], "C0-", label="track (number = particle)")
    ax.set_xlim(0, frame.shape[1] - 1)
    ax.set_ylim(frame.shape[0] - 1, 0)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    ax.set_title(title, fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    return png(fig)


def detection_and_types(p_o: np.ndarray, confusion: pd.DataFrame, gate: float) -> bytes:
    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 4.5), constrained_layout=True)
    left.plot(np.arange(len(p_o)), p_o, "o-", ms=3)
    left.set_ylim(0, 1.05)
    left.set_xlabel("frame")
    left.set_ylabel(f"P_o (targets with a track point within {gate:g} px)")
    left.set_title(f"probability of correct detection per frame (mean {np.nanmean(p_o):.3f})")
    left.grid(alpha=0.3)
    counts = confusion.to_numpy()
    shown = right.imshow(counts, cmap="Blues", vmin=0)
    for (i, j), n in np.ndenumerate(counts):
        right.text(
            j,
            i,
            str(n),
            ha="center",
            va="center",
            color="white" if n > counts.max() / 2 else "black",
        )
    right.set_xticks(range(counts.shape[1]), confusion.columns)
    right.set_yticks(range(counts.shape[0]), confusion.index)
    right.set_xlabel("type decided for the track (TypeIdentifier.run_tracks)")
    right.set_ylabel("true type of the target")
    right.set_title("type confusion matrix (targets)")
    fig.colorbar(shown, ax=right, shrink=0.8, label="number of targets")
    return png(fig)


def change_points(
    series: pd.DataFrame, alarms: np.ndarray, change_frame: int | None, title: str
) -> bytes:
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True, constrained_layout=True)
    for ax, column in zip(axes, ("x", "y")):
        ax.plot(series["frame"], series[column], ".-", ms=4, label=f"measured {column}")
        if change_frame is not None:
            ax.axvline(change_frame, color="k", ls="--", label="true change")
        for k, frame in enumerate(alarms):
            ax.axvline(
                frame, color="C3", lw=1.5, label="alarm (ChangeDetector)" if k == 0 else None
            )
        ax.set_ylabel(f"{column} (px)")
        ax.legend(fontsize=8, loc="best")
        ax.grid(alpha=0.3)
    axes[1].set_xlabel("frame")
    axes[0].set_title(title, fontsize=10)
    return png(fig)


def animation_frames(
    frames: np.ndarray, tracks: pd.DataFrame, tail: int = 12, side: int = 256
) -> list[np.ndarray]:
    """RGB frames (uint8) of the filtered sequence with every track's last `tail` points
    and its number drawn over it."""
    plt = _pyplot()
    dpi = 80
    fig = plt.figure(figsize=(side / dpi, side / dpi), dpi=dpi)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    low, high = np.percentile(frames, [0.5, 99.5])
    shown = ax.imshow(frames[0], cmap="gray", vmin=low, vmax=high)
    label = ax.text(4, 12, "", color="yellow", fontsize=9)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    groups = {p: t for p, t in tracks.groupby("particle")}
    out = []
    for f, frame in enumerate(frames):
        shown.set_data(frame)
        drawn = []
        for particle, track in groups.items():
            recent = track[(track.frame <= f) & (track.frame > f - tail)]
            if len(recent) and recent.frame.iloc[-1] == f:
                colour = colours[int(particle) % len(colours)]
                drawn += ax.plot(recent.x, recent.y, "-", color=colour, lw=1.5)
                drawn.append(
                    ax.text(
                        recent.x.iloc[-1] + 3,
                        recent.y.iloc[-1] - 3,
                        str(particle),
                        color=colour,
                        fontsize=7,
                    )
                )
        label.set_text(f"frame {f}: matched residual and tracks")
        fig.canvas.draw()
        out.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
        for artist in drawn:
            artist.remove()
    plt.close(fig)
    return out


def extended_objects(
    frame: np.ndarray,
    masks: list[np.ndarray],
    tracks: list[pd.DataFrame],
    title: str,
    truth: Sequence[pd.DataFrame] = (),
) -> bytes:
    """The detected objects' masks outlined on a frame, with their centre tracks and the
    true centre paths (dotted)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 6), constrained_layout=True)
    _image(ax, frame, title, "matched residual (noise std)")
    for path in truth:
        ax.plot(path["x"], path["y"], ":", color="white", lw=1.2)
    for k, (mask, track) in enumerate(zip(masks, tracks)):
        colour = plt.cm.tab10(k % 10)
        if mask.any():
            ax.contour(mask.astype(float), levels=[0.5], colors=[colour], linewidths=1.2)
        ax.plot(track["x"], track["y"], "-", color=colour, lw=1.2, label=f"object {k}")
    if tracks:
        ax.legend(loc="upper right", fontsize=8)
    return png(fig)


def animation_palette(greys: int = 16) -> list[tuple[int, int, int]]:
    """The GIF's colours: `greys` grey levels for the frames (noise-like frames compress
    about 3× better than with 256 colours), the tracks' colours and the label's yellow."""
    from matplotlib.colors import to_rgb

    plt = _pyplot()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"] + ["yellow"]
    levels = [(v, v, v) for v in np.linspace(0, 255, greys).round().astype(int).tolist()]
    rgb = [to_rgb(colour) for colour in colours]
    return levels + [(round(255 * r), round(255 * g), round(255 * b)) for r, g, b in rgb]
