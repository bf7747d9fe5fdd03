"""Scenes with ground truth for the detector (method page *Extended objects*, §3.5): targets
moving by the source's model, clutter spots, foreign objects, white noise, optionally an AR
field background."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from .._validation import (
    SeedLike,
    nonnegative_int,
    positive_float,
    positive_int,
    real_number,
    resolve_seed,
)

__all__ = ["Scene", "Target", "simulate_scene", "target_mask"]

_SHAPES = ("rhombus", "disc", "rectangle")


@dataclass(frozen=True)
class Target:
    """One simulated target.

    Parameters
    ----------
    shape : {"rhombus", "disc", "rectangle"} or array_like of bool, default "rhombus"
        The silhouette: rhombus of side `size` (the source's; ``|dx| + |dy| ≤ size/√2``), disc of
        diameter `size`, rectangle `size` × `size`/2, or a given bool mask (centred).
    size : float, default 10.0
        Side / diameter in pixels.
    fragments : int, default 1
        1: uniform brightness. n > 1: the silhouette is cut into n vertical stripes with
        1-pixel gaps; stripe k has brightness amplitude × b_k, b_k ~ U(0.7, 1.3) drawn once.
    p_vanish : float, default 0.0
        Per frame and stripe, the probability that the stripe is dark in that frame.
    velocity : (float, float), optional
        Mean initial velocity (px per time unit); default: a random direction, speed uniform
        in [0.5, 1] × the speed that keeps the target in the frame.
    process_std : float, default 0.5
        The std σ_w of the velocity's random step per frame (the model (3.7) of §3.5).
    trajectory : array_like, optional
        (n_frames, 2) centres (x, y) to follow instead of the motion model.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> kf.Target(shape="disc", size=8.0).size
    8.0
    """

    shape: Any = "rhombus"
    size: float = 10.0
    fragments: int = 1
    p_vanish: float = 0.0
    velocity: tuple[float, float] | None = None
    process_std: float = 0.5
    trajectory: Any = None


@dataclass
class Scene:
    """A simulated scene: frames and ground truth.

    Parameters
    ----------
    frames : numpy.ndarray
        (F, H, W) float64 frames.
    truth : pandas.DataFrame
        ``frame``, ``target``, ``x``, ``y``, ``vx``, ``vy``: each target's true centre and
        velocity per frame.
    masks : numpy.ndarray
        (F, T, H, W) bool: each target's pixels per frame (dark stripes included).
    clutter : numpy.ndarray
        (F,) int: clutter spots drawn in each frame.
    noise_std : float
        The std σ of the white noise.
    amplitude : float
        Target amplitude: snr × noise_std.
    extras : dict, optional
        Room for the caller's annotations (empty).

    Examples
    --------
    >>> import kalmanfield as kf
    >>> s = kf.simulate_scene((32, 32), 4, targets=1, snr=3.0, p_false=0.0, dt=1.0, seed=0)
    >>> s.frames.shape, s.masks.shape
    ((4, 32, 32), (4, 1, 32, 32))
    """

    frames: np.ndarray
    truth: pd.DataFrame
    masks: np.ndarray
    clutter: np.ndarray
    noise_std: float
    amplitude: float
    extras: dict[str, Any] = field(default_factory=dict)


def target_mask(
    shape: Any, size: float, cx: float, cy: float, grid: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """The pixels whose centres lie in the silhouette centred at (cx, cy)."""
    xx, yy = grid
    dx, dy = xx - cx, yy - cy
    if isinstance(shape, str):
        if shape == "rhombus":
            return np.abs(dx) + np.abs(dy) <= size / math.sqrt(2)
        if shape == "disc":
            return dx * dx + dy * dy <= (size / 2) ** 2
        if shape == "rectangle":
            return (np.abs(dx) <= size / 2) & (np.abs(dy) <= size / 4)
        raise ValueError(f"target shape must be one of {_SHAPES} or a bool mask, got {shape!r}")
    m = np.asarray(shape, dtype=bool)
    if m.ndim != 2 or not m.any():
        raise ValueError("a target mask must be a 2-D bool array with a True pixel")
    h, w = m.shape
    col = np.rint(dx + (w - 1) / 2).astype(int)
    row = np.rint(dy + (h - 1) / 2).astype(int)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    out = np.zeros(xx.shape, dtype=bool)
    out[inside] = m[row[inside], col[inside]]
    return out


def _path(t: Target, n: int, dt: float, start: np.ndarray, room: float, rng: np.random.Generator):
    """(n, 2) centres and velocities by (3.7): x += v τ + w τ, v += w, w ~ N(0, σ_w²)."""
    if t.trajectory is not None:
        pos = np.asarray(t.trajectory, dtype=float)
        if pos.shape != (n, 2) or not np.isfinite(pos).all():
            raise ValueError(f"trajectory must be a finite ({n}, 2) array")
        vel = np.gradient(pos, dt, axis=0) if n > 1 else np.zeros((n, 2))
        return pos, vel
    if t.velocity is None:
        fastest = room / max((n - 1) * dt, dt)
        angle = rng.uniform(0, 2 * math.pi)
        speed = rng.uniform(0.5, 1.0) * fastest
        mean_v = speed * np.array([math.cos(angle), math.sin(angle)])
    else:
        mean_v = np.asarray(t.velocity, dtype=float)
    sigma = positive_float(t.process_std, "process_std") if t.process_std else 0.0
    pos, vel = np.zeros((n, 2)), np.zeros((n, 2))
    pos[0] = start
    vel[0] = mean_v + sigma * rng.standard_normal(2)
    for mu in range(1, n):
        w = sigma * rng.standard_normal(2)
        pos[mu] = pos[mu - 1] + vel[mu - 1] * dt + w * dt
        vel[mu] = vel[mu - 1] + w
    return pos, vel


def _stripes(t: Target, dx: np.ndarray) -> np.ndarray:
    """Stripe number of each pixel (−1 = gap) for a target cut into `fragments` stripes."""
    if t.fragments == 1:
        return np.zeros(dx.shape, dtype=int)
    width = t.size * (1.0 if t.shape != "rhombus" else math.sqrt(2)) / t.fragments
    u = dx + t.size * (0.5 if t.shape != "rhombus" else 1 / math.sqrt(2))
    k = np.clip(np.floor(u / width).astype(int), 0, t.fragments - 1)
    gap = (u - k * width < 1.0) & (k > 0)
    return np.where(gap, -1, k)


def _targets(targets: int | Target | Sequence[Target]) -> list[Target]:
    if isinstance(targets, Target):
        return [targets]
    if isinstance(targets, (int, np.integer)) and not isinstance(targets, bool):
        return [Target() for _ in range(nonnegative_int(targets, "targets"))]
    out = list(targets)  # type: ignore[arg-type]
    if not all(isinstance(t, Target) for t in out):
        raise TypeError("targets must be an int or a sequence of Target")
    return out


def simulate_scene(
    shape: tuple[int, int],
    n_frames: int,
    *,
    targets: int | Target | Sequence[Target] = 1,
    snr: float = 3.0,
    p_false: float = 0.1,
    dt: float = 0.1,
    background: Any = None,
    seed: SeedLike = None,
    noise_std: float = 1.0,
    spots: int = 3,
    still_objects: int = 1,
    moving_objects: int = 1,
) -> Scene:
    """A frame sequence with moving targets, clutter and noise, and its ground truth.

    Parameters
    ----------
    shape : (int, int)
        Frame height and width.
    n_frames : int
        Number of frames F.
    targets : int, Target or sequence of Target, default 1
        An int n: n default targets (the source's 10-px rhombus). Targets start at the frame
        centre + N(0, 0.1²) px per axis (the source's x(0)), several targets spread on a
        circle of radius min(H, W)/6 around it.
    snr : float, default 3.0
        Target amplitude over the noise std: amplitude = snr × noise_std, exactly.
    p_false : float, default 0.1
        Probability that a frame holds clutter: then `spots` spots, each an ellipse with
        semi-axes U(1.5, 6) px, orientation U(0, π), centre uniform in the frame, brightness
        U(0.5, 1.5) × amplitude.
    dt : float, default 0.1
        Time between frames τ.
    background : ARFieldModel, optional
        Textured clutter added to every frame: a 3-axis model (time, rows, columns) gives a
        space–time field of shape (F, H, W); a 2-axis one a still texture.
    seed : int, numpy.random.Generator or None
        Seed (None: OS entropy).
    noise_std : float, default 1.0
        The std σ of the white Gaussian noise added to every pixel.
    spots : int, default 3
        Clutter spots in a frame that has clutter.
    still_objects, moving_objects : int, default 1
        Foreign objects, deterministic over the scene: rhombi of the target's size and
        brightness, placed uniformly (at least `size` from the border, and at least 2 × `size`
        from every target centre in every frame: redrawn up to 100 times); the moving ones move
        at a constant velocity of 0.3 × the first target's mean speed in a random direction
        (slower than the target, the source's Remark 1).

    Returns
    -------
    Scene
        The frames and the ground truth.

    Raises
    ------
    ValueError
        Non-positive sizes, `snr` or `dt`, `p_false` outside [0, 1], bad targets.

    Notes
    -----
    Target motion per axis follows the model (3.7) of §3.5: x(μ) = x(μ−1) + x′(μ−1)τ + wτ,
    x′(μ) = x′(μ−1) + w, w ~ N(0, process_std²); x′(0) = mean velocity + N(0, process_std²).
    Method page :doc:`/methods/extended_objects`.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> s = kf.simulate_scene((64, 64), 10, targets=1, snr=5.0, p_false=0.3, dt=0.1, seed=0)
    >>> list(s.truth.columns)
    ['frame', 'target', 'x', 'y', 'vx', 'vy']
    """
    h, w = (positive_int(v, "shape") for v in shape)
    n = positive_int(n_frames, "n_frames")
    amplitude = positive_float(snr, "snr") * positive_float(noise_std, "noise_std")
    dt = positive_float(dt, "dt")
    p_false = real_number(p_false, "p_false")
    if not 0.0 <= p_false <= 1.0:
        raise ValueError(f"p_false must lie in [0, 1], got {p_false}")
    spots = nonnegative_int(spots, "spots")
    rng = np.random.default_rng(resolve_seed(seed))
    grid = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    frames = np.zeros((n, h, w))
    tlist = _targets(targets)
    masks = np.zeros((n, len(tlist), h, w), dtype=bool)
    rows = []
    centre = np.array([(w - 1) / 2, (h - 1) / 2])
    mean_speed = None
    for k, t in enumerate(tlist):
        size = positive_float(t.size, "size")
        start = centre + 0.1 * rng.standard_normal(2)
        if len(tlist) > 1:
            a = 2 * math.pi * k / len(tlist)
            start = start + min(h, w) / 6 * np.array([math.cos(a), math.sin(a)])
        room = 0.8 * (min(h, w) / 2 - size)
        pos, vel = _path(t, n, dt, start, max(room, 1.0), rng)
        mean_speed = mean_speed or float(np.hypot(*vel[0]))
        gains = rng.uniform(0.7, 1.3, t.fragments) if t.fragments > 1 else np.ones(1)
        for mu in range(n):
            m = target_mask(t.shape, size, pos[mu, 0], pos[mu, 1], grid)
            stripe = _stripes(t, grid[0] - pos[mu, 0])
            lit = rng.uniform(size=len(gains)) >= t.p_vanish
            bright = np.where(
                stripe >= 0, gains[np.maximum(stripe, 0)] * lit[np.maximum(stripe, 0)], 0.0
            )
            masks[mu, k] = m
            frames[mu] += amplitude * m * bright
            rows.append((mu, k, pos[mu, 0], pos[mu, 1], vel[mu, 0], vel[mu, 1]))
    paths = np.array([[r[2], r[3]] for r in rows]).reshape(len(tlist), n, 2) if tlist else None
    _foreign(
        frames, grid, rng, amplitude, still_objects, moving_objects, mean_speed or 0.0, dt, paths
    )
    clutter = np.zeros(n, dtype=np.int64)
    for mu in range(n):
        if rng.uniform() < p_false:
            clutter[mu] = spots
            for _ in range(spots):
                _spot(frames[mu], grid, rng, amplitude)
    if background is not None:
        frames += _background(background, (n, h, w), rng)
    frames += noise_std * rng.standard_normal(frames.shape)
    truth = pd.DataFrame(rows, columns=["frame", "target", "x", "y", "vx", "vy"])
    return Scene(frames, truth, masks, clutter, float(noise_std), float(amplitude))


def _spot(frame: np.ndarray, grid, rng: np.random.Generator, amplitude: float) -> None:
    h, w = frame.shape
    a, b = rng.uniform(1.5, 6.0, 2)
    theta = rng.uniform(0, math.pi)
    cx, cy = rng.uniform(0, w), rng.uniform(0, h)
    dx, dy = grid[0] - cx, grid[1] - cy
    u = dx * math.cos(theta) + dy * math.sin(theta)
    v = -dx * math.sin(theta) + dy * math.cos(theta)
    frame[(u / a) ** 2 + (v / b) ** 2 <= 1.0] += rng.uniform(0.5, 1.5) * amplitude


def _foreign(frames, grid, rng, amplitude, still, moving, speed, dt, paths) -> None:
    """Foreign rhombi kept at least 2 × size from every target centre in every frame (up to
    100 draws each; the last draw is kept if none is that far)."""
    n, h, w = frames.shape
    size = 10.0
    steps = np.arange(n)[:, None] * dt
    for k in range(
        nonnegative_int(still, "still_objects") + nonnegative_int(moving, "moving_objects")
    ):
        for _ in range(100):
            c = np.array(
                [
                    rng.uniform(size, max(w - size, size + 1)),
                    rng.uniform(size, max(h - size, size + 1)),
                ]
            )
            v = np.zeros(2)
            if k >= still:
                a = rng.uniform(0, 2 * math.pi)
                v = 0.3 * speed * np.array([math.cos(a), math.sin(a)])
            path = c + v * steps
            if paths is None or np.hypot(*(paths - path).transpose(2, 0, 1)).min() >= 2 * size:
                break
        for mu in range(n):
            p = c + v * mu * dt
            frames[mu] += amplitude * target_mask("rhombus", size, p[0], p[1], grid)


def _background(model: Any, shape: tuple[int, int, int], rng: np.random.Generator) -> np.ndarray:
    from ..field import ARFieldModel

    if not isinstance(model, ARFieldModel):
        raise TypeError(f"background must be an ARFieldModel or None, got {type(model).__name__}")
    seed = int(rng.integers(2**63))
    if model.ndim == 3:
        return model.sample(shape, seed=seed)
    if model.ndim == 2:
        return np.broadcast_to(model.sample(shape[1:], seed=seed), shape)
    raise ValueError(f"background must have 2 or 3 axes, got {model.ndim}")
