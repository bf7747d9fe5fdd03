"""Identify an object's type from its trajectory with a bank of Kalman filters, and track
objects that switch type with the IMM estimator (method page *Kalman filter bank*; user guide
*Filter bank*)."""

from .identifier import TypeIdentifier
from .imm import IMMEstimator, IMMRun
from .model import LinearGaussianModel

__all__ = ["IMMEstimator", "IMMRun", "LinearGaussianModel", "TypeIdentifier"]
