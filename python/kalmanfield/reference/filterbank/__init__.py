"""NumPy twin of the Rust ``filterbank`` domain (method page *Kalman filter bank*): the bank of
Kalman filters with its per-frame decisions (maximum posterior or Wald's test), and the IMM
estimator, both vectorised over a batch of trajectories."""

from .bank import UNDECIDED, bank_run, posterior, wald_thresholds
from .imm import imm_run

__all__ = ["UNDECIDED", "bank_run", "imm_run", "posterior", "wald_thresholds"]
