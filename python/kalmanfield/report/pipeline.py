"""The demo: simulate a scene, denoise it with the row filters, detect and track the point
targets, find change points on the tracks, identify the targets' types, detect the extended
objects, score everything against the truth and write the report."""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import tqdm

from .. import __version__
from ..extended import DetectedObject, detect_moving_objects
from ..field import ARFieldModel
from ..filterbank import TypeIdentifier
from ..identification import model_from_noisy
from ..rowfilter import ScalarRowFilter, wiener_bound
from ..tracking import BranchingTracker, segment
from ..trajectory import ChangeDetector, KalmanFilterCV
from . import figures, html
from .metrics import (
    GATE,
    change_scores,
    detection_probability,
    extended_scores,
    farther,
    identity_scores,
    type_confusion_matrix,
)
from .scene import EXTENDED_RADIUS, Scene, simulate_scene

#: the tracker of the demo (px, frames): nearly constant velocity with rare manoeuvres
TRACKER: dict[str, Any] = dict(
    process_std=0.15, measurement_std=0.5, max_misses=3, maneuver_std=1.5, maneuver_prob=0.01
)
#: the change detector's model of a measured coordinate (px): CUSUM of the Kalman innovations
DETECTOR = dict(P=2.0, Q=0.05, R=0.5, P_vel=1.0, Q_vel=0.05)


@dataclass
class DemoSettings:
    """What the demo simulates and where it writes (the ``kalmanfield demo`` options)."""

    out: Path = Path("demo_out")
    size: int = 256
    n_frames: int = 60
    n_targets: int = 8
    n_extended: int = 2
    amplitude: float = 6.0
    noise_std: float = 1.0
    threshold: float = 4.0
    seed: int = 2026
    save_arrays: bool = False
    progress: bool = True


@dataclass
class DemoResult:
    """The numbers of the run and the files written."""

    numbers: dict[str, Any]
    files: dict[str, Path] = field(default_factory=dict)


@dataclass
class Stages:
    """What every stage of the demo produced, read by the figures and the files."""

    scene: Scene
    filtered: np.ndarray
    error_map: np.ndarray
    detect: np.ndarray
    tracks: pd.DataFrame
    measured: pd.DataFrame
    alarms: dict
    follows: dict
    p_o: np.ndarray
    decided: pd.DataFrame
    confusion: pd.DataFrame
    objects: list[DetectedObject]
    extended: pd.DataFrame
    numbers: dict[str, Any]


#: pixels farther than this from every target are the clutter-only pixels of the MSE (px)
AWAY = 8.0


def _clutter_pixels(scene: Scene) -> np.ndarray:
    """True where no target lies within AWAY px (no extended object within AWAY px of its
    outline): the pixels where the observed frame is the clutter plus white noise, the model
    the Wiener bound is about."""
    f, h, w = scene.observed.shape
    mask = np.ones((f, h, w), bool)
    rows, cols = np.ogrid[:h, :w]
    for table, radius in ((scene.truth, AWAY), (scene.extended, AWAY + EXTENDED_RADIUS)):
        for frame, x, y in table[["frame", "x", "y"]].itertuples(index=False):
            mask[int(frame)] &= (cols - x) ** 2 + (rows - y) ** 2 > radius**2
    return mask


def _fit_clutter(
    observed: np.ndarray, threshold: float
) -> tuple[ARFieldModel, float, float, float]:
    """The clutter's model, mean and noise variance fitted to the noisy frames twice: the
    second time without the pixels within 3 px of where the first fit's matched residual
    exceeds `threshold` (the targets and extended objects, which would bias the fit towards a
    smoother, lower-order model); and the fraction of pixels left out."""
    w = observed.shape[-1]
    model, mean, noise_var = model_from_noisy(observed)
    first = ScalarRowFilter(model, noise_var, w, smooth=True, mean=mean).filter(observed)
    bright = matched(observed - first) / np.sqrt(noise_var) > threshold
    # correlating the indicator with the 7-tap kernel marks every pixel within 3 px of it
    near = matched(bright.astype(float)) > 0
    masked = np.where(near, np.nan, observed)
    model, mean, noise_var = model_from_noisy(masked)
    return model, mean, noise_var, float(near.mean())


def _denoise(scene: Scene, threshold: float) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Row-filters the frames with a model fitted to them: the estimate of the clutter. Its
    MSE on the clutter-only pixels beside the filter's predicted error variance, the
    known-model filter's and the Wiener bound."""
    f, h, w = scene.observed.shape
    model, mean, noise_var, left_out = _fit_clutter(scene.observed, threshold)
    fitted = ScalarRowFilter(model, noise_var, w, smooth=True, mean=mean)
    filtered = fitted.filter(scene.observed)
    error_map = fitted.error_variance(h)
    known = ScalarRowFilter(scene.frame_model, scene.noise_var, w, smooth=True)
    away = _clutter_pixels(scene)

    def mse(estimate: np.ndarray) -> float:
        return float(np.mean((estimate - scene.clutter)[away] ** 2))

    errors = {
        "noisy frames": mse(scene.observed),
        "row filter, model fitted to the noisy frames": mse(filtered),
        "row filter, true model": mse(known.filter(scene.observed)),
        "predicted error variance (fitted filter's map, mean)": float(error_map.mean()),
        "Wiener bound (no estimator of the clutter does better)": wiener_bound(
            scene.frame_model, scene.noise_var, (h, w)
        ),
    }
    fit = {
        "model": repr(model),
        "summary": f"order {model.order}, rho {np.round(model.rho, 3).tolist()}, "
        f"sigma {model.sigma:.3f}, noise std {np.sqrt(noise_var):.3f}",
        "noise_var": noise_var,
        "true_noise_var": scene.noise_var,
        "pixels_left_out": left_out,
    }
    return filtered, error_map, {"mse": errors, "fit": fit, "away_px": AWAY}


def matched(residual: np.ndarray, radius: int = 3) -> np.ndarray:
    """The residual frames (F, H, W) correlated with a target's spot (a Gaussian of σ = 1 px,
    unit energy), separably: white noise keeps its variance, a spot of peak a rises to
    ≈ 1.77 a."""
    taps = np.exp(-(np.arange(-radius, radius + 1) ** 2) / 2.0)
    taps /= np.sqrt(np.sum(taps**2))
    out = residual
    for axis in (1, 2):
        pad = [(0, 0)] * 3
        pad[axis] = (radius, radius)
        padded = np.pad(out, pad)
        n = out.shape[axis]
        out = sum(w * np.take(padded, np.arange(k, k + n), axis=axis) for k, w in enumerate(taps))
    return out


def _track(detect: np.ndarray, threshold: float) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Segments every frame and tracks the spots: (tracks, detections of every frame)."""
    tracker = BranchingTracker(2, **TRACKER)
    tables = []
    for f, frame in enumerate(detect):
        spots = segment(frame, threshold, frame_no=f)
        tracker.update(spots[["x", "y"]].to_numpy())
        tables.append(spots)
    return tracker.tracks(), pd.concat(tables, ignore_index=True)


def _measured(tracks: pd.DataFrame, detections: pd.DataFrame) -> pd.DataFrame:
    """The measured (segment) positions of every track's detected frames."""
    hit = tracks[tracks["detection"] >= 0]
    spots = detections.iloc[hit["detection"].to_numpy()]
    return pd.DataFrame(
        {
            "frame": hit["frame"].to_numpy(),
            "particle": hit["particle"].to_numpy(),
            "x": spots["x"].to_numpy(),
            "y": spots["y"].to_numpy(),
        }
    )


def _alarms(measured: pd.DataFrame, min_length: int = 8) -> tuple[dict, dict]:
    """Alarm frames of the change detector on the x and y series of every track (missed
    frames NaN), and each track's length."""
    alarms, lengths = {}, {}
    for particle, track in measured.groupby("particle"):
        frames = np.arange(track.frame.min(), track.frame.max() + 1)
        if len(frames) < min_length:
            continue
        series = track.set_index("frame").reindex(frames)[["x", "y"]].to_numpy().T
        found = ChangeDetector(KalmanFilterCV(**DETECTOR), "cusum").run(series, frames * 1.0)
        alarms[int(particle)] = np.unique(frames[found.alarm.any(axis=0)])
        lengths[int(particle)] = len(frames)
    return alarms, lengths


def _types(measured: pd.DataFrame, alarms: dict, types: list) -> pd.DataFrame:
    """The type of every track, decided by the filter bank on its longest stretch without a
    change point (a sudden turn is no evidence of agility)."""
    pieces = []
    for particle, track in measured.groupby("particle"):
        cuts = np.searchsorted(alarms.get(int(particle), np.zeros(0)), track["frame"], "right")
        longest = np.bincount(cuts).argmax()
        pieces.append(track[cuts == longest])
    return TypeIdentifier.run_tracks(pd.concat(pieces, ignore_index=True), types)


def run_demo(settings: DemoSettings) -> DemoResult:
    """Runs the demo and writes its report into ``settings.out``."""
    out = Path(settings.out)
    out.mkdir(parents=True, exist_ok=True)
    bar = tqdm.tqdm(total=8, desc="demo", unit="step", disable=not settings.progress)
    start = time.perf_counter()

    def step(name: str) -> None:
        bar.set_postfix_str(name)
        bar.update()

    scene = simulate_scene(
        settings.size,
        settings.n_frames,
        settings.n_targets,
        settings.amplitude,
        settings.noise_std,
        settings.seed,
        settings.n_extended,
    )
    step("scene simulated")
    filtered, error_map, filtering = _denoise(scene, settings.threshold)
    step("frames filtered")
    # the row filter predicts the clutter; the targets stand out in the residual, correlated
    # with their spot shape and thresholded in units of the estimated noise std
    noise_std = float(np.sqrt(filtering["fit"]["noise_var"]))
    detect = matched(scene.observed - filtered) / noise_std
    tracks, detections = _track(detect, settings.threshold)
    step("targets tracked")
    # track points on an extended object (and on no point target) are its fragments: they
    # are scored with the extended objects
    points = tracks[["frame", "particle", "x", "y"]]
    on_target = ~farther(points, scene.truth, GATE)
    hyp = points[on_target | farther(points, scene.extended, EXTENDED_RADIUS + GATE)]
    scores = identity_scores(scene.truth, hyp)
    follows = scores.pop("follows")
    p_o = detection_probability(scene.truth, hyp, settings.n_frames)
    measured = _measured(tracks, detections)
    alarms, lengths = _alarms(measured)
    changes = change_scores(alarms, lengths, scene.changes, follows)
    step("change points found")
    decided = _types(measured, alarms, scene.types)
    names = [m.name for m in scene.types]
    confusion = type_confusion_matrix(decided, scene.truth, follows, names)
    step("types identified")
    # co-moving fragments up to their own size apart are one object (the discs here lie 5.4
    # px apart, 0.9 × their diameter; by default only touching fragments group)
    objects = detect_moving_objects(
        detect, noise_std=1.0, threshold=settings.threshold, cohesion=1.0
    )
    extended = extended_scores(scene.extended, [o.track for o in objects], EXTENDED_RADIUS)
    step("extended objects detected")
    numbers = _numbers(settings, scene, filtering, scores, p_o, changes, confusion, tracks)
    numbers["extended_objects"] = {
        "objects": settings.n_extended,
        "detected_objects": len(objects),
        "gate_px": EXTENDED_RADIUS,
        "per_object": extended.to_dict("records"),
    }
    run = Stages(
        scene,
        filtered,
        error_map,
        detect,
        tracks,
        measured,
        alarms,
        follows,
        p_o,
        decided,
        confusion,
        objects,
        extended,
        numbers,
    )
    files = _write(out, settings, run, step)
    numbers["seconds"] = round(time.perf_counter() - start, 2)
    (out / "numbers.json").write_text(json.dumps(numbers, indent=2) + "\n", encoding="utf-8")
    bar.close()
    return DemoResult(numbers, files)


def _numbers(settings, scene, filtering, scores, p_o, changes, confusion, tracks) -> dict:
    delays = changes.delays["delay"]
    correct = sum(int(confusion.loc[n, n]) for n in confusion.index)
    return {
        "version": __version__,
        "settings": {k: str(v) if isinstance(v, Path) else v for k, v in asdict(settings).items()},
        "targets": int(scene.truth["particle"].nunique()),
        "tracks": int(tracks["particle"].nunique()),
        "filtering": filtering,
        "tracking": {**scores, "mean_P_o": float(np.nanmean(p_o)), "gate_px": GATE},
        "change_points": {
            "true_changes": len(delays),
            "detected": int(delays.notna().sum()),
            "mean_delay_frames": float(delays.mean()) if delays.notna().any() else None,
            "delays": [None if np.isnan(d) else d for d in delays],
            "false_alarms": changes.false_alarms,
            "track_frames": changes.track_frames,
        },
        "types": {"correct": correct, "targets": int(confusion.to_numpy().sum())},
    }


def _write(out: Path, settings: DemoSettings, run: Stages, step: Any) -> dict[str, Path]:
    scene, filtered, tracks = run.scene, run.filtered, run.tracks
    files: dict[str, Path] = {}
    table = tracks.merge(run.decided[["particle", "type"]], on="particle", how="left")
    files["tracks"] = out / "tracks.csv"
    table.to_csv(files["tracks"], index=False)
    if settings.save_arrays:
        for name, array in (
            ("observed", scene.observed),
            ("filtered", filtered),
            ("clean", scene.clean),
        ):
            files[name] = out / f"{name}.npy"
            np.save(files[name], array)
        files["truth"] = out / "truth.csv"
        scene.truth.to_csv(files["truth"], index=False)
    gif_frames = figures.animation_frames(run.detect, tracks)
    files["animation"] = out / "tracks.gif"
    _save_gif(files["animation"], gif_frames)
    step("animation written")
    pictures = _pictures(run)
    files["report"] = out / "index.html"
    files["report"].write_text(
        _report(run.numbers, pictures, files["animation"].read_bytes()), encoding="utf-8"
    )
    files["numbers"] = out / "numbers.json"
    step("report written")
    return files


def _save_gif(path: Path, frames: list[np.ndarray], fps: float = 8.0) -> None:
    from PIL import Image  # matplotlib's own dependency

    colours = [c for rgb in figures.animation_palette() for c in rgb]
    palette = Image.new("P", (1, 1))
    palette.putpalette(colours + [0] * (768 - len(colours)))
    images = [
        Image.fromarray(f).convert("RGB").quantize(palette=palette, dither=Image.Dither.NONE)
        for f in frames
    ]
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=int(1000 / fps),
        loop=0,
        optimize=True,
    )


def _pictures(run: Stages) -> list[tuple[bytes, str]]:
    scene, detect, numbers = run.scene, run.detect, run.numbers
    fit = numbers["filtering"]["fit"]
    out = [
        (
            figures.fields(
                scene.clutter[0], scene.clean[0], scene.observed[0], repr(scene.background)
            ),
            "Figure 1 — fields. Left: one frame of the clutter, a (1, 2, 2) space–time AR field "
            "(ARFieldModel / FieldStream, axis 0 time); middle: with the point targets "
            "(Gaussian spots); right: the observed frame, with white noise added.",
        ),
        (
            figures.filtering(
                scene.observed[0],
                run.filtered[0],
                run.error_map,
                detect[0],
                f"frame 0; model fitted to the noisy frames: {fit['summary']}",
            ),
            "Figure 2 — filtered frame and error map. The observed frame; its clutter as "
            "estimated by the smoothed O(W) row Kalman filter (ScalarRowFilter) with the model "
            "and noise level fitted to the noisy frames (model_from_noisy, twice: the second "
            "time without the pixels near the targets the first fit's residual shows); the "
            "filter's "
            "predicted error-variance map (higher at the borders, which see fewer neighbours); "
            "and the residual (observed − estimate) correlated with the spot shape, in units "
            "of the noise std, where the targets are detected (segment, threshold "
            f"{numbers['settings']['threshold']:g}).",
        ),
        (
            figures.tracks_over_frame(
                detect[-1],
                run.tracks,
                scene.truth,
                f"BranchingTracker tracks over the last detection frame "
                f"(IDF1 {numbers['tracking']['idf1']:.3f}, MOTA {numbers['tracking']['mota']:.3f})",
            ),
            "Figure 3 — tracks over frames. Every track (colour, numbered) and every true "
            "target path (dotted white) over all frames, drawn on the last detection frame (the "
            "matched residual).",
        ),
        (
            figures.detection_and_types(run.p_o, run.confusion, GATE),
            "Figure 4 — P_o and type confusion. Left: the probability of correct detection per "
            f"frame (a target counts when a track point lies within {GATE:g} px of it). Right: "
            "the targets by true type and the type TypeIdentifier.run_tracks decided for the "
            "track that follows them, on the track's longest stretch between change points "
            "(a bank of two Kalman filters: calm Markov velocity vs agile Singer "
            "acceleration).",
        ),
    ]
    extended = _extended_objects(run)
    if extended is not None:
        out.append(extended)
    changed = scene.changes.itertuples()
    for change in changed:
        track = run.follows.get(int(change.particle))
        if track is None or track not in run.alarms:
            continue
        series = run.measured[run.measured.particle == track].sort_values("frame")
        out.append(
            (
                figures.change_points(
                    series,
                    run.alarms[track],
                    int(change.frame),
                    f"track {track} (target {change.particle}, velocity jump at frame "
                    f"{change.frame})",
                ),
                f"Figure {len(out) + 1} — change points. The measured x and y of track "
                f"{track}; the true velocity jump of its target (dashed) and the alarms of "
                "ChangeDetector (CUSUM of the Kalman innovations, red) on its x and y series.",
            )
        )
        break
    return out


def _extended_objects(run: Stages) -> tuple[bytes, str] | None:
    """The detected objects that follow the true extended objects longest, outlined on the
    last frame in which most of them are detected, with their centre tracks and the true
    paths; None when no object was followed."""
    best = [int(b) for b in run.extended.get("best", []) if b >= 0]
    if not best:
        return None
    objects = [run.objects[b] for b in best]
    seen = np.concatenate([o.frames for o in objects])
    frames, counts = np.unique(seen, return_counts=True)
    frame = int(frames[counts == counts.max()].max())
    paths = [t for _, t in run.scene.extended.groupby("object")]
    picture = figures.extended_objects(
        run.detect[frame],
        [o.mask(frame) for o in objects],
        [o.track for o in objects],
        f"detect_moving_objects, frame {frame}: the objects following the true ones longest",
        paths,
    )
    return (
        picture,
        "Figure 5 — extended objects. Each true extended object (three disc fragments moving "
        "together, each dark in a frame with probability 0.15; true path dotted white) and "
        "the object kalmanfield.detect_moving_objects followed it with longest (a group of "
        "segment sequences sharing one velocity): the outline of its segments in this frame "
        "and the track of its centre.",
    )


def _extended_table(found: dict) -> str:
    def speed(v: Any) -> str:
        return "–" if v is None else f"({v[0]:+.2f}, {v[1]:+.2f})"

    rows = [
        (
            r["object"],
            r["frames"],
            f"{r['P_o']:.2f}",
            r["detected_as"],
            r["longest"],
            speed(r["v_true"]),
            speed(r["v_found"]),
        )
        for r in found["per_object"]
    ]
    return html.table(
        [
            "object",
            "frames in view",
            "P_o",
            "detected objects on it",
            "frames of the longest",
            "true velocity (px/frame)",
            "its velocity",
        ],
        rows,
    ) + (
        f"<p>kalmanfield.detect_moving_objects on the detection frames found "
        f"{found['detected_objects']} objects (point targets and clutter included). A true "
        f"object counts as detected in a frame when a detected object's centre lies within "
        f"{found['gate_px']:.1f} px (its radius) of its centre; one detected object on it "
        "throughout is the ideal, more means its fragments were followed as separate "
        "objects. Track points within that radius (plus the point gate) and on no point target "
        "are left out of the point targets' scores above.</p>"
    )


def _report(numbers: dict, pictures: list[tuple[bytes, str]], gif: bytes) -> str:
    s = numbers["settings"]
    mse = numbers["filtering"]["mse"]
    tr = numbers["tracking"]
    cp = numbers["change_points"]
    ty = numbers["types"]
    sections = [
        (
            "Denoising: MSE of the clutter estimate",
            html.table(["estimate", "MSE"], [(k, f"{v:.4f}") for k, v in mse.items()])
            + f"<p>Over the pixels farther than {numbers['filtering']['away_px']:g} px from "
            "every target, where the observed frame is the clutter plus white noise: the model "
            "the Wiener bound is about.</p>",
        ),
        (
            "Tracking against the truth",
            html.table(
                ["score", "value"],
                [
                    ("IDF1", f"{tr['idf1']:.3f}"),
                    ("MOTA", f"{tr['mota']:.3f}"),
                    ("ID switches", tr["switches"]),
                    ("missed target positions", tr["misses"]),
                    ("false track points", tr["false_positives"]),
                    (f"mean P_o (within {tr['gate_px']:g} px)", f"{tr['mean_P_o']:.3f}"),
                    ("targets / tracks", f"{numbers['targets']} / {numbers['tracks']}"),
                ],
            )
            + f"<p>Scored by {tr['scored_by']}.</p>",
        ),
        (
            "Change points and types",
            html.table(
                ["quantity", "value"],
                [
                    ("true velocity changes", cp["true_changes"]),
                    ("detected within 10 frames", cp["detected"]),
                    (
                        "detection delays (frames)",
                        ", ".join("missed" if d is None else f"{d:g}" for d in cp["delays"]) or "–",
                    ),
                    (
                        "mean delay (frames)",
                        "–"
                        if cp["mean_delay_frames"] is None
                        else f"{cp['mean_delay_frames']:.1f}",
                    ),
                    ("false alarms / track frames", f"{cp['false_alarms']} / {cp['track_frames']}"),
                    ("targets of the right type", f"{ty['correct']} / {ty['targets']}"),
                ],
            ),
        ),
        ("Extended objects", _extended_table(numbers["extended_objects"])),
        ("Figures", "".join(html.figure(data, caption) for data, caption in pictures)),
        (
            "Animation",
            html.figure(
                gif,
                f"Figure {len(pictures) + 1} — the detection frames (matched residual) with "
                "the tracks (last 12 points of each, numbered), also written as tracks.gif.",
                mime="image/gif",
            ),
        ),
    ]
    intro = (
        f"kalmanfield {numbers['version']}: {s['n_frames']} frames of {s['size']}² px, "
        f"{s['n_targets']} point targets and {s['n_extended']} extended objects of amplitude "
        f"{s['amplitude']:g} over AR clutter "
        f"(σ = 1) plus white noise (σ = {s['noise_std']:g}), seed {s['seed']}. Files: "
        "<code>tracks.csv</code> (every track point with its decided type), "
        "<code>tracks.gif</code>, <code>numbers.json</code>."
    )
    return html.page("kalmanfield demo report", sections, intro)
