"""The demo's scene: AR-field clutter, moving point targets of two motion types (some with a
sudden change of velocity), extended objects made of fragments, white noise; with the
truth."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..extended.simulate import target_mask
from ..field import ARFieldModel
from ..filterbank import LinearGaussianModel

#: the clutter: a (1, 2, 2) space–time AR field (axis 0 is time), σ = 1
BACKGROUND = ARFieldModel([0.9, 0.9, 0.9], [1, 2, 2])
#: an extended object: three disc fragments (diameter 6 px) at these offsets (px) from its
#: centre, the group turned by a random angle and moving rigidly
FRAGMENT_OFFSETS = np.array([[-7.0, -3.0], [7.0, -3.0], [0.0, 6.0]])
FRAGMENT_DIAMETER = 6.0
#: per frame and fragment, the probability that the fragment is dark (it vanishes and
#: reappears)
P_VANISH = 0.15
#: an extended object's speed (px/frame), constant, in a random direction
EXTENDED_SPEED = 0.8
#: an extended object covers the disc of this radius (px) around its centre
EXTENDED_RADIUS = float(np.hypot(*FRAGMENT_OFFSETS.T).max() + FRAGMENT_DIAMETER / 2)


def motion_types(measurement_std: float) -> list[LinearGaussianModel]:
    """The two target types, in px and frames: a calm one (Markov velocity, ρ = 0.999,
    stationary std 0.5 px/frame) and an agile one (Singer acceleration, ρ = 0.7, stationary
    std 0.1 px/frame²); 40 frames tell them apart 98 % of the time."""
    calm = LinearGaussianModel.markov_velocity(
        1.0, rho=0.999, sigma=0.5, measurement_std=measurement_std, name="calm"
    )
    agile = LinearGaussianModel.singer(
        1.0, rho=0.7, sigma_a=0.1, measurement_std=measurement_std, name="agile"
    )
    return [calm, agile]


@dataclass
class Scene:
    """A simulated scene.

    Attributes
    ----------
    observed : (F, H, W) frames: clutter + targets + white noise.
    clean : (F, H, W) frames without the white noise.
    clutter : (F, H, W) the clutter alone.
    truth : DataFrame ``frame, particle, x, y, type`` of the point targets inside the frames.
    extended : DataFrame ``frame, object, x, y, vx, vy`` of the extended objects' centres
        inside the frames.
    changes : DataFrame ``particle, frame, dv_x, dv_y``: the sudden velocity changes.
    noise_var : the white noise's variance.
    background : the clutter's space–time model.
    types : the motion models of the target types (index = ``type``).
    amplitude : the peak of a target's spot.
    """

    observed: np.ndarray
    clean: np.ndarray
    clutter: np.ndarray
    truth: pd.DataFrame
    extended: pd.DataFrame
    changes: pd.DataFrame
    noise_var: float
    background: ARFieldModel
    types: list[LinearGaussianModel]
    amplitude: float

    @property
    def frame_model(self) -> ARFieldModel:
        """The model of one clutter frame (the spatial axes of the background)."""
        b = self.background
        return ARFieldModel(b.rho[1:], b.order[1:], b.sigma)


def spots(positions: np.ndarray, shape: tuple[int, int], amplitude: float) -> np.ndarray:
    """Gaussian spots (σ = 1 px) of peak `amplitude` at the (x, y) `positions`."""
    rows, cols = np.arange(shape[0]), np.arange(shape[1])
    gy = np.exp(-((rows[None, :] - positions[:, 1:2]) ** 2) / 2.0)  # (n, H)
    gx = np.exp(-((cols[None, :] - positions[:, 0:1]) ** 2) / 2.0)  # (n, W)
    return amplitude * gy.T @ gx


def target_paths(
    n_targets: int, n_frames: int, size: int, rng: np.random.Generator, types: list
) -> tuple[np.ndarray, np.ndarray, pd.DataFrame]:
    """(F, n, 2) true positions, the type of each target, and the velocity changes: half of
    the targets turn suddenly (a velocity jump of 1.5 px/frame) at a frame in the middle
    third."""
    positions = np.empty((n_frames, n_targets, 2))
    kinds = np.arange(n_targets) % len(types)
    changes = []
    for i in range(n_targets):
        model = types[kinds[i]]
        start = np.zeros(model.state_dim)
        axis_dim = model.state_dim // 2
        start[0], start[axis_dim] = rng.uniform(0.3 * size, 0.7 * size, 2)
        angle = rng.uniform(0, 2 * np.pi)
        start[1], start[axis_dim + 1] = 0.7 * np.cos(angle), 0.7 * np.sin(angle)
        states, _ = model.simulate(n_frames, seed=rng, start=start)
        path = states[:, [0, axis_dim]]
        if i % 2 == 0:
            at = int(rng.integers(n_frames // 3, 2 * n_frames // 3))
            turn = rng.uniform(0, 2 * np.pi)
            dv = 1.5 * np.array([np.cos(turn), np.sin(turn)])
            path[at:] += dv * np.arange(1, n_frames - at + 1)[:, None]
            changes.append({"particle": i, "frame": at, "dv_x": dv[0], "dv_y": dv[1]})
        positions[:, i] = path
    table = pd.DataFrame(changes, columns=["particle", "frame", "dv_x", "dv_y"])
    return positions, kinds, table


def extended_objects(
    n_objects: int, n_frames: int, size: int, amplitude: float, rng: np.random.Generator
) -> tuple[np.ndarray, pd.DataFrame]:
    """(F, H, W) brightness of `n_objects` extended objects and the truth of their centres.

    Each starts uniformly in the middle 40 % of the frame and moves at EXTENDED_SPEED in a
    random direction; its fragments have the brightness amplitude × U(0.7, 1.3), drawn once,
    and each is dark in a frame with probability P_VANISH."""
    grid = np.meshgrid(np.arange(size, dtype=float), np.arange(size, dtype=float))
    image = np.zeros((n_frames, size, size))
    rows = []
    for k in range(n_objects):
        start = rng.uniform(0.3 * size, 0.7 * size, 2)
        heading, turn = rng.uniform(0, 2 * np.pi, 2)
        velocity = EXTENDED_SPEED * np.array([np.cos(heading), np.sin(heading)])
        rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        offsets = FRAGMENT_OFFSETS @ rotation.T
        brightness = amplitude * rng.uniform(0.7, 1.3, len(offsets))
        for f in range(n_frames):
            centre = start + f * velocity
            lit = rng.uniform(size=len(offsets)) >= P_VANISH
            for (dx, dy), b in zip(offsets[lit], brightness[lit]):
                disc = target_mask("disc", FRAGMENT_DIAMETER, centre[0] + dx, centre[1] + dy, grid)
                image[f] += b * disc
            if np.all((centre >= 0) & (centre <= size - 1)):
                rows.append((f, k, centre[0], centre[1], velocity[0], velocity[1]))
    return image, pd.DataFrame(rows, columns=["frame", "object", "x", "y", "vx", "vy"])


def simulate_scene(
    size: int = 256,
    n_frames: int = 60,
    n_targets: int = 8,
    amplitude: float = 6.0,
    noise_std: float = 1.0,
    seed: int = 0,
    n_extended: int = 2,
) -> Scene:
    """Simulate the demo's scene (seeded: the same scene for the same arguments)."""
    rng = np.random.default_rng(seed)
    types = motion_types(measurement_std=0.5)
    paths, kinds, changes = target_paths(n_targets, n_frames, size, rng, types)
    stream = BACKGROUND.stream((size, size), seed=seed)
    clutter = stream.take(n_frames)
    clean = np.empty_like(clutter)
    rows = []
    for f in range(n_frames):
        inside = np.all((paths[f] >= 2) & (paths[f] <= size - 3), axis=1)
        clean[f] = clutter[f] + spots(paths[f][inside], (size, size), amplitude)
        for i in np.flatnonzero(inside):
            rows.append((f, i, paths[f, i, 0], paths[f, i, 1], kinds[i]))
    objects, extended = extended_objects(n_extended, n_frames, size, amplitude, rng)
    clean += objects
    observed = clean + rng.normal(0.0, noise_std, clean.shape)
    truth = pd.DataFrame(rows, columns=["frame", "particle", "x", "y", "type"])
    return Scene(
        observed,
        clean,
        clutter,
        truth,
        extended,
        changes,
        noise_std**2,
        BACKGROUND,
        types,
        amplitude,
    )
