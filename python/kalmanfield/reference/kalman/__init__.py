"""NumPy twin of the Rust ``kalman`` domain (method page *Kalman filter bank*): the linear-
Gaussian model (F, Q, H, R), one predict step, the Joseph-form update with its innovation
log-likelihood, and the four motion models (block-diagonal over the axes, positions
observed, R = measurement_std² I)."""

from .density import sequence_log_density
from .motion import constant_acceleration, constant_velocity, markov_velocity, singer
from .recursion import LN_2PI, check_covariance, filter_sequence, gain, predict, update

__all__ = [
    "LN_2PI",
    "check_covariance",
    "constant_acceleration",
    "constant_velocity",
    "filter_sequence",
    "gain",
    "markov_velocity",
    "predict",
    "sequence_log_density",
    "singer",
    "update",
]
