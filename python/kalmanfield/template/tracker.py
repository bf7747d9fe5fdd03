"""The search-recurrent fragment tracker (method page *Template tracker*, §5.4): the
correlation search of :func:`match_template` inside a window placed and sized by a Kalman
predictor; the Rust core ``_core.TemplateTracker``, its twin
:mod:`kalmanfield.reference.template.tracker`."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
from tqdm.auto import tqdm

from .. import _core
from .._validation import positive_float, real_number
from ._inputs import frame_array, pixel_dtype, template_array

#: columns of :meth:`TemplateTracker.track` (``particle`` first for several templates)
COLUMNS = (
    "frame",
    "x",
    "y",
    "vx",
    "vy",
    "score",
    "window_w",
    "window_h",
    "reacquired",
    "x_measured",
    "y_measured",
    "coasted",
)

Position = tuple[float, float]


@dataclass(frozen=True)
class TemplateUpdate:
    """What one frame did to one template (positions are the template's top-left pixel).

    Returned by :meth:`TemplateTracker.update`.

    Parameters
    ----------
    x, y : float
        The filtered position.
    vx, vy : float
        The filtered velocity (pixels per unit of ``dt``).
    state : ndarray
        The whole state estimate, order (x, vx[, ax], y, vy[, ay]).
    covariance : ndarray
        Its covariance.
    score : float
        The NCC peak in the search window (NaN when no window could be searched).
    x_measured, y_measured : float
        The position fed to the filter (NaN on a coasted frame).
    window : (x0, y0, x1, y1) or None
        The searched region, x1 and y1 exclusive (None when off the frame).
    collapsed : bool
        The score collapsed and the whole frame was searched.
    reacquired : bool
        The whole-frame peak was accepted and the track restarted there.

    Examples
    --------
    >>> import numpy as np
    >>> from kalmanfield import TemplateTracker
    >>> frame = np.random.default_rng(1).standard_normal((60, 60))
    >>> step = TemplateTracker(frame[10:20, 30:40], (30, 10), process_std=0.1).update(frame)
    >>> round(step.x), round(step.y), step.window, step.coasted
    (30, 10, (24, 4, 46, 26), False)
    """

    x: float
    y: float
    vx: float
    vy: float
    state: np.ndarray
    covariance: np.ndarray
    score: float
    x_measured: float
    y_measured: float
    window: tuple[int, int, int, int] | None
    collapsed: bool
    reacquired: bool

    @property
    def coasted(self) -> bool:
        """No measurement entered the filter on this frame."""
        return bool(np.isnan(self.x_measured))


def _is_template_list(template: Any) -> bool:
    if isinstance(template, (list, tuple)) and template:
        return all(np.ndim(t) == 2 for t in template)
    return isinstance(template, np.ndarray) and template.ndim == 3


def _position(value: Any, name: str) -> Position:
    try:
        x, y = value
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a pair (x, y), got {value!r}") from None
    px, py = real_number(x, name), real_number(y, name)
    if abs(px) > 1e9 or abs(py) > 1e9:
        raise ValueError(f"{name} must lie within ±1e9, got ({px}, {py})")
    return px, py


class TemplateTracker:
    """Search-recurrent tracker of image fragments (method page *Template tracker*, §5.4).

    Per frame and template: a Kalman predictor places a search window of ± ``gate``
    standard deviations of the predicted position (plus the template); the NCC peak inside
    it (:func:`match_template`, sub-pixel) is the measurement of a Kalman filter with a
    constant-acceleration (or constant-velocity) state per axis. A collapsed score triggers a
    search around the last position (a stop or a turn) and then of the whole frame
    (re-acquisition).

    Parameters
    ----------
    template : 2-D array-like, or a sequence of them (several targets)
        The fragment(s) to follow. With a sequence, every :meth:`update` tracks all of them
        on the same frame (one conversion of the frame, windows searched in parallel, one
        frame spectrum shared by the whole-frame searches) and returns a list.
    position : (x, y), or a sequence of them
        The template's top-left pixel (column, row) in the first frame given to
        :meth:`update`; the same convention as :func:`match_template` everywhere.
    measurement_std : float
        Std (pixels) of a found position, the filter's R = measurement_std² I.
    process_std : float
        √q, q the power spectral density of the white noise driving the highest derivative:
        about the std of the per-frame change of the acceleration (``"acceleration"``) or of
        the velocity (``"velocity"``) at ``dt = 1``.
    dt : float
        Time between frames (velocities are pixels per unit of ``dt``).
    gate : float
        Half-width of the search window in predicted standard deviations.
    model : {"acceleration", "velocity"}
        State per axis (x, vx, ax) as the source's λ (§5), or (x, vx).
    update_template : float in (0, 1], optional
        Template update rate α: after an accepted measurement whose score is at least the
        reference score, template ← (1 − α)·template + α·(frame under it). None: fixed.
    collapse : float in [0, 1)
        The score collapses below ``collapse`` × the reference score (running mean of the
        accepted scores, weight 1/10 for the newest).
    reacquire_z : float, optional
        A whole-frame peak is accepted only if it stands this many robust standard
        deviations (1.4826·MAD) above the surface's median; default √(2 ln M) + 1 for M
        positions (the typical largest of M independent null scores, plus one).
    initial_std : sequence of floats, optional
        Prior std of position, velocity (and acceleration); default (measurement_std,
        5/dt, 1/dt²). Also the covariance a re-acquired track restarts with, and the
        velocity (acceleration) variances a coasted frame adds. Set the velocity std to the
        expected speed: it sizes the first windows.
    subpixel : bool
        Refine the peaks (see :func:`match_template`).

    Raises
    ------
    TypeError, ValueError
        Bad templates (empty, not 2-D, constant, non-finite), positions or settings.

    Notes
    -----
    Frames must have the template's dtype (an array-like template takes the first frame's).
    The rules (window, collapse, manoeuvre, re-acquisition, template update) are on the
    method page *Template tracker*. The tracker pickles mid-stream and resumes exactly.

    Examples
    --------
    >>> import numpy as np
    >>> from kalmanfield import TemplateTracker
    >>> rng = np.random.default_rng(0)
    >>> scene = rng.standard_normal((80, 400))
    >>> frames = [scene[:, 2 * k : 2 * k + 100] for k in range(20)]
    >>> tracker = TemplateTracker(frames[0][30:45, 60:75], (60, 30), process_std=0.1)
    >>> step = [tracker.update(f) for f in frames][-1]
    >>> round(step.x), round(step.y)
    (22, 30)
    """

    def __init__(
        self,
        template: npt.ArrayLike | Sequence[npt.ArrayLike],
        position: Position | Sequence[Position],
        *,
        measurement_std: float = 1.0,
        process_std: float,
        dt: float = 1.0,
        gate: float = 3.0,
        model: str = "acceleration",
        update_template: float | None = None,
        collapse: float = 0.5,
        reacquire_z: float | None = None,
        initial_std: Sequence[float] | None = None,
        subpixel: bool = True,
    ) -> None:
        self._multi = _is_template_list(template)
        raw: list[Any] = list(template) if self._multi else [template]  # type: ignore[arg-type]
        positions = list(position) if self._multi else [position]  # type: ignore[arg-type]
        if len(positions) != len(raw):
            raise ValueError(
                f"one position per template is needed: {len(raw)} templates, "
                f"{len(positions)} positions"
            )
        arrays = [t for t in raw if isinstance(t, np.ndarray)]
        self._dtype: np.dtype | None = pixel_dtype(arrays[0].dtype) if arrays else None
        self._raw_templates = raw
        if model not in ("acceleration", "velocity"):
            raise ValueError(f"model must be 'acceleration' or 'velocity', got {model!r}")
        dt = positive_float(dt, "dt")
        measurement_std = positive_float(measurement_std, "measurement_std")
        order = 3 if model == "acceleration" else 2
        if initial_std is None:
            initial = [measurement_std, 5.0 / dt, 1.0 / dt**2][:order]
        else:
            initial = [positive_float(s, "initial_std") for s in initial_std]
        process = real_number(process_std, "process_std")
        if update_template is not None:
            update_template = real_number(update_template, "update_template")
        if not isinstance(subpixel, (bool, np.bool_)):
            raise TypeError(f"subpixel must be a bool, got {subpixel!r}")
        self._config: dict[str, Any] = dict(
            positions=[_position(p, "position") for p in positions],
            model=model,
            process_std=process,
            measurement_std=measurement_std,
            dt=dt,
            gate=positive_float(gate, "gate"),
            initial_std=initial,
            collapse=real_number(collapse, "collapse"),
            reacquire_z=None if reacquire_z is None else real_number(reacquire_z, "reacquire_z"),
            update_template=update_template,
            subpixel=bool(subpixel),
        )
        self._core: Any = None
        self._frame = 0
        if self._dtype is not None:
            self._build(self._dtype)

    def _build(self, dtype: np.dtype) -> None:
        templates = [template_array(t, dtype) for t in self._raw_templates]
        self._core = _core.TemplateTracker(templates, **self._config)
        self._dtype = dtype

    # ------------------------------------------------------------------ properties
    @property
    def n_templates(self) -> int:
        """Number of templates tracked."""
        return len(self._raw_templates)

    @property
    def frame(self) -> int:
        """Frames processed so far."""
        return self._frame

    @property
    def templates(self) -> list[np.ndarray]:
        """The current templates (float64; they change with ``update_template``)."""
        if self._core is None:
            return [np.asarray(t, dtype=np.float64) for t in self._raw_templates]
        return list(self._core.templates())

    @property
    def config(self) -> dict[str, Any]:
        """The validated settings."""
        return dict(self._config)

    def model_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The Kalman model of the linear link (state order x, vx[, ax], y, …).

        Returns
        -------
        F : ndarray
            Transition matrix.
        Q : ndarray
            Process noise covariance.
        H : ndarray
            Measurement matrix (picks the positions).
        R : ndarray
            Measurement noise covariance, ``measurement_std² I``.

        Raises
        ------
        ValueError
            Before the first frame (the model is built with the first frame's dtype).
        """
        if self._core is None:
            raise ValueError("the model is built with the first frame's dtype; update first")
        f, q, h, r = self._core.model_matrices()
        return f, q, h, r

    # ------------------------------------------------------------------ per frame
    def update(self, frame: npt.ArrayLike) -> TemplateUpdate | list[TemplateUpdate]:
        """Track the template(s) through the next frame.

        Parameters
        ----------
        frame : 2-D array-like
            The next frame, of the templates' dtype (see :func:`match_template`); NaN pixels
            are missing.

        Returns
        -------
        TemplateUpdate or list of TemplateUpdate
            What the frame did to the template (one per template for several templates).

        Raises
        ------
        TypeError
            A frame of another dtype than the templates'.
        ValueError
            A frame that is not 2-D, smaller than a template or holding an infinite pixel;
            the tracker is unchanged then.
        """
        image = frame_array(frame)
        if self._core is None:
            self._build(image.dtype)
        elif image.dtype != self._dtype:
            raise TypeError(
                f"the frame's dtype {image.dtype} differs from the templates' {self._dtype}"
            )
        out = self._core.update(image)
        self._frame += 1
        steps = [_step(out, k) for k in range(self.n_templates)]
        return steps if self._multi else steps[0]

    def track(self, frames: Iterable[npt.ArrayLike], progress: bool = False) -> pd.DataFrame:
        """Run :meth:`update` over `frames`.

        Parameters
        ----------
        frames : iterable of 2-D array-like
            A 3-D array (frame, row, column) or any iterable of frames.
        progress : bool
            Show a tqdm progress bar.

        Returns
        -------
        pandas.DataFrame
            One row per frame (and template): ``frame`` (running frame number of this
            tracker), ``particle`` (template index, several templates only), ``x``, ``y``,
            ``vx``, ``vy``, ``score``, ``window_w``, ``window_h`` (searched region, 0 when
            none), ``reacquired``, ``x_measured``, ``y_measured``, ``coasted``. Streaming
            (update after update) gives the same rows.
        """
        rows: list[dict[str, Any]] = []
        total = len(frames) if hasattr(frames, "__len__") else None  # type: ignore[arg-type]
        for frame in tqdm(frames, total=total, disable=not progress, desc="tracking"):
            number = self._frame
            result = self.update(frame)
            steps = result if isinstance(result, list) else [result]
            for k, s in enumerate(steps):
                x0, y0, x1, y1 = s.window if s.window is not None else (0, 0, 0, 0)
                row: dict[str, Any] = {"frame": number}
                if self._multi:
                    row["particle"] = k
                row.update(
                    x=s.x,
                    y=s.y,
                    vx=s.vx,
                    vy=s.vy,
                    score=s.score,
                    window_w=x1 - x0,
                    window_h=y1 - y0,
                    reacquired=s.reacquired,
                    x_measured=s.x_measured,
                    y_measured=s.y_measured,
                    coasted=s.coasted,
                )
                rows.append(row)
        columns = (("particle",) if self._multi else ()) + COLUMNS
        order = ["frame", *[c for c in columns if c != "frame"]]
        return pd.DataFrame(rows, columns=order)

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        return {
            "multi": self._multi,
            "config": self._config,
            "raw_templates": self._raw_templates,
            "dtype": None if self._dtype is None else self._dtype.str,
            "frame": self._frame,
            "state": None if self._core is None else self._core.state_values(),
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._multi = bool(state["multi"])
        self._config = dict(state["config"])
        self._raw_templates = list(state["raw_templates"])
        self._frame = int(state["frame"])
        self._core = None
        self._dtype = None if state["dtype"] is None else np.dtype(state["dtype"])
        if self._dtype is not None:
            self._build(self._dtype)
        if state["state"] is not None:
            self._core.load_state(np.ascontiguousarray(state["state"], dtype=np.float64))

    def __repr__(self) -> str:
        return (
            f"TemplateTracker(templates={self.n_templates}, model={self._config['model']!r}, "
            f"frames={self._frame})"
        )


def _step(out: dict[str, np.ndarray], k: int) -> TemplateUpdate:
    state = out["state"][k]
    order = state.size // 2
    window = tuple(int(v) for v in out["window"][k])
    return TemplateUpdate(
        x=float(state[0]),
        y=float(state[order]),
        vx=float(state[1]),
        vy=float(state[order + 1]),
        state=state.copy(),
        covariance=out["cov"][k].copy(),
        score=float(out["score"][k]),
        x_measured=float(out["x_measured"][k]),
        y_measured=float(out["y_measured"][k]),
        window=None if window[0] < 0 else window,  # type: ignore[arg-type]
        collapsed=bool(out["collapsed"][k]),
        reacquired=bool(out["reacquired"][k]),
    )


__all__ = ["TemplateTracker", "TemplateUpdate"]
