"""kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
sequences, with a Rust core.

The package is organised by domain: :mod:`kalmanfield.field` (random fields),
:mod:`kalmanfield.identification`, :mod:`kalmanfield.rowfilter` (row Kalman filters),
:mod:`kalmanfield.denoising`, :mod:`kalmanfield.tracking`, :mod:`kalmanfield.filterbank`
(object types from trajectories), :mod:`kalmanfield.trajectory` (fuzzy and Kalman filters
of a parameter's trajectory, change points) and :mod:`kalmanfield.template` (template search and
the Kalman-steered template tracker); every public name is also here at the top level.
The sources' Monte Carlo studies are in :mod:`kalmanfield.experiments`. The method pages of the
documentation give the formulas and sources.
"""

from importlib import metadata as _metadata

from . import _compat
from .denoising import denoise, estimate_noise_var, estimate_sigma, local_moments
from .extended import (
    DetectedObject,
    MovingObjectDetector,
    Scene,
    Target,
    detect_moving_objects,
    simulate_scene,
)
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
from .sequence import SequenceFilter
from .template import TemplateTracker, TemplateUpdate, match_template
from .tracking import BranchingTracker, TrackerConfig, link, segment
from .trajectory import ChangeDetector, FuzzyFilter, KalmanFilterCV, effective_memory

__all__ = [
    "ARFieldModel",
    "AxisFit",
    "BranchingTracker",
    "ChangeDetector",
    "DetectedObject",
    "FieldStream",
    "FuzzyFilter",
    "IMMEstimator",
    "IdentifiedModel",
    "KalmanFilterCV",
    "LinearGaussianModel",
    "MovingObjectDetector",
    "ScalarRowFilter",
    "Scene",
    "SequenceFilter",
    "Target",
    "TemplateTracker",
    "TemplateUpdate",
    "TrackerConfig",
    "TypeIdentifier",
    "VectorRowFilter",
    "WhitenessTest",
    "YuleWalkerModel",
    "denoise",
    "detect_moving_objects",
    "effective_memory",
    "estimate_noise_var",
    "estimate_sigma",
    "identify",
    "link",
    "local_moments",
    "match_template",
    "model_from_noisy",
    "sample_correlation",
    "sample_product_field",
    "segment",
    "simulate_scene",
    "wiener_bound",
    "wiener_error_map",
    "yule_walker",
]
try:  # the version is Cargo.toml's, through the installed package's metadata
    __version__ = _metadata.version("kalmanfield")
except _metadata.PackageNotFoundError:  # a source tree on sys.path, not installed
    __version__ = "0+unknown"

# Public objects say they are kalmanfield's: pickles and reprs do not depend on the module
# that defines them inside the package.
for _name in __all__:
    globals()[_name].__module__ = __name__
del _name

_compat.install_aliases()
