"""kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
sequences, with a Rust core.

The package is organised by domain: :mod:`kalmanfield.field` (random fields),
:mod:`kalmanfield.identification`, :mod:`kalmanfield.rowfilter` (row Kalman filters),
:mod:`kalmanfield.denoising`, :mod:`kalmanfield.tracking`, :mod:`kalmanfield.filterbank`
(object types from trajectories) and :mod:`kalmanfield.trajectory` (fuzzy and Kalman filters
of a parameter's trajectory, change points); every public name is also here at the top level.
The sources' Monte Carlo studies are in :mod:`kalmanfield.experiments`. The method pages of the
documentation give the formulas and sources.
"""

from . import _compat
from .denoising import denoise, estimate_noise_var, estimate_sigma, local_moments
from .field import ARFieldModel, FieldStream, sample_product_field
from .filterbank import IMMEstimator, LinearGaussianModel, TypeIdentifier
from .identification import (
    AxisFit,
    IdentifiedModel,
    WhitenessTest,
    YuleWalkerModel,
    identify,
    model_from_noisy,
    sample_correlation,
    yule_walker,
)
from .rowfilter import ScalarRowFilter, VectorRowFilter, wiener_bound, wiener_error_map
from .tracking import BranchingTracker, TrackerConfig, link, segment
from .trajectory import ChangeDetector, FuzzyFilter, KalmanFilterCV, effective_memory

__all__ = [
    "ARFieldModel",
    "AxisFit",
    "BranchingTracker",
    "ChangeDetector",
    "FieldStream",
    "FuzzyFilter",
    "IMMEstimator",
    "IdentifiedModel",
    "KalmanFilterCV",
    "LinearGaussianModel",
    "ScalarRowFilter",
    "TrackerConfig",
    "TypeIdentifier",
    "VectorRowFilter",
    "WhitenessTest",
    "YuleWalkerModel",
    "denoise",
    "effective_memory",
    "estimate_noise_var",
    "estimate_sigma",
    "identify",
    "link",
    "local_moments",
    "model_from_noisy",
    "sample_correlation",
    "sample_product_field",
    "segment",
    "wiener_bound",
    "wiener_error_map",
    "yule_walker",
]
__version__ = "0.1.0"

# Public objects say they are kalmanfield's: pickles and reprs do not depend on the module
# that defines them inside the package.
for _name in __all__:
    globals()[_name].__module__ = __name__
del _name

_compat.install_aliases()
