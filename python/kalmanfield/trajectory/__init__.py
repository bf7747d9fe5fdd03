"""Trajectories of a parameter: the possibility-theory ("fuzzy") filter, the Kalman filter of
the same model, change-point detection, batched over many series (SPEC §4, [K95]).

The method page is *Fuzzy filter* (``docs/methods/fuzzy_filter.md``), the user guide
*Trajectory* (``docs/guide/trajectory.md``).
"""

from .change_detector import DEFAULT_CONFIDENCE, METHODS, ChangeDetector, ChangePoints
from .fuzzy_filter import FuzzyFilter
from .kalman_filter import KalmanFilterCV
from .memory import effective_memory
from .motion_filter import MotionFilter, TrajectoryEstimates
from .plots import SOURCE_FIGURES, plot_change_points, plot_gain_comparison, plot_gains

__all__ = [
    "DEFAULT_CONFIDENCE",
    "METHODS",
    "SOURCE_FIGURES",
    "ChangeDetector",
    "ChangePoints",
    "FuzzyFilter",
    "KalmanFilterCV",
    "MotionFilter",
    "TrajectoryEstimates",
    "effective_memory",
    "plot_change_points",
    "plot_gain_comparison",
    "plot_gains",
]
