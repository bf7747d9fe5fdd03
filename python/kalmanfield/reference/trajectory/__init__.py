"""Plain-NumPy twin of the trajectory kernels (source [K95]): the fuzzy and Kalman gains, the
filters (one series, and vectorised over all series at once), the change detectors, the CUSUM
threshold and the effective memory. Written from the method page *Fuzzy filter* (§4–4.5),
independently of the Rust code."""

from .cusum import cusum_arl, cusum_threshold
from .detection import detect
from .filtering import filter_batch, filter_series, least_squares_start
from .gains import Spreads, gain_sequence
from .memory import effective_memory

__all__ = [
    "Spreads",
    "cusum_arl",
    "cusum_threshold",
    "detect",
    "effective_memory",
    "filter_batch",
    "filter_series",
    "gain_sequence",
    "least_squares_start",
]
