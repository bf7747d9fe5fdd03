"""The settings of :func:`kalmanfield.detect_moving_objects` and their defaults."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from .._validation import nonnegative_int, positive_float, positive_int, probability, real_number

__all__ = ["DetectorOptions"]


@dataclass(frozen=True)
class DetectorOptions:
    """Everything that tunes the detector; lengths in pixels, speeds in pixels per time unit
    (``None`` = the default stated per field, from ``dt`` and ``noise_std``)."""

    #: box-smoothing width applied before thresholding (1 = none)
    smooth: int = 3
    #: threshold = median of the smoothed frame + threshold_k × noise std of the smoothed frame
    threshold_k: float = 3.0
    #: 0: off; w > 0: the mean over a w × w box of the smoothed frame (its local background
    #: level) is subtracted before thresholding (textured backgrounds, e.g. an AR field)
    background_width: int = 0
    #: segments of fewer pixels are dropped
    min_area: int = 3
    connectivity: int = 8
    #: centroid motion order ν (1 or 2)
    order: int = 1
    #: std of a fragment's centroid (px)
    position_std: float = 1.0
    #: std of the velocity's random step per frame; default 0.2 px per frame, i.e. 0.2/dt
    process_std: float | None = None
    #: std of a fragment's mean amplitude; default noise_std
    amplitude_std: float | None = None
    log_area_std: float = 0.5
    feature_drift: float = 0.5
    #: prior std of a new fragment's own velocity; default 3 px per frame
    initial_speed_std: float | None = None
    gate_margin: float = 2.0
    #: a member's speed must exceed it; default 0.25 px per frame
    min_speed: float | None = None
    #: members' velocities agree within it; default 0.5 px per frame
    velocity_tolerance: float | None = None
    #: co-moving groups whose boxes lie within cohesion × the smaller one's extent of each
    #: other become one object (0: off, only within gate_margin; 1: fragments spaced up to
    #: their own size apart)
    cohesion: float = 0.0
    max_misses: int = 2

    @classmethod
    def build(cls, options: dict[str, Any]) -> DetectorOptions:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise TypeError(f"unknown option(s) {unknown}; known: {sorted(known)}")
        out = replace(cls(), **options)
        positive_int(out.smooth, "smooth")
        real_number(out.threshold_k, "threshold_k")
        positive_int(out.min_area, "min_area")
        nonnegative_int(out.background_width, "background_width")
        if out.connectivity not in (4, 8):
            raise ValueError(f"connectivity must be 4 or 8, got {out.connectivity!r}")
        if out.order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {out.order!r}")
        nonnegative_int(out.max_misses, "max_misses")
        for name in ("position_std", "log_area_std", "gate_margin"):
            positive_float(getattr(out, name), name)
        return out

    def core_config(
        self, *, dt: float, noise_std: float, confidence: float, memory: int, seed_groups: bool
    ) -> dict[str, Any]:
        """The keyword arguments of ``_core.GroupTracker``."""

        def per_frame(value: float | None, default: float) -> float:
            return float(default / dt if value is None else value)

        return {
            "order": self.order,
            "dt": dt,
            "position_std": float(self.position_std),
            "process_std": per_frame(self.process_std, 0.2),
            "amplitude_std": float(noise_std if self.amplitude_std is None else self.amplitude_std),
            "log_area_std": float(self.log_area_std),
            "feature_drift": float(self.feature_drift),
            "confidence": probability(confidence, "confidence"),
            "memory": memory,
            "initial_speed_std": per_frame(self.initial_speed_std, 3.0),
            "gate_margin": float(self.gate_margin),
            "min_speed": per_frame(self.min_speed, 0.25),
            "velocity_tolerance": per_frame(self.velocity_tolerance, 0.5),
            "cohesion": float(self.cohesion),
            "max_misses": self.max_misses,
            "seed_groups": seed_groups,
        }

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)
