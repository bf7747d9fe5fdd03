"""Trajectories of a parameter: the possibility-theory ("fuzzy") filter, the Kalman filter of
the same model, change-point detection, batched over many series [K95].

The method page is *Fuzzy filter* (§4–4.6), the user guide *Trajectory*. ``MotionFilter``,
the base class of the two filters, is importable from here for type annotations.
"""

from .change_detector import DEFAULT_CONFIDENCE, METHODS, ChangeDetector, ChangePoints
from .fuzzy_filter import FuzzyFilter
from .kalman_filter import KalmanFilterCV
from .memory import effective_memory
from .motion_filter import MotionFilter as MotionFilter  # the base class, for annotations
from .motion_filter import TrajectoryEstimates
from .plots import SOURCE_FIGURES, plot_change_points, plot_gain_comparison, plot_gains

__all__ = [
    "DEFAULT_CONFIDENCE",
    "METHODS",
    "SOURCE_FIGURES",
    "ChangeDetector",
    "ChangePoints",
    "FuzzyFilter",
    "KalmanFilterCV",
    "TrajectoryEstimates",
    "effective_memory",
    "plot_change_points",
    "plot_gain_comparison",
    "plot_gains",
]
