from typing import Any, final

import numpy as np
import numpy.typing as npt

MAX_ORDER: int

class NonFiniteError(ValueError):
    """A NaN or infinite value where a kernel needs a finite one."""

@final
class FieldModel:
    def __new__(cls, rho: list[float], order: list[int], sigma: float) -> FieldModel: ...
    def beta(self) -> float: ...
    def template(self) -> npt.NDArray[np.float64]: ...
    def correlation(self, lags: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def anisotropy(self) -> float: ...
    def boundary(self, axis: int) -> tuple[list[list[float]], list[float]]: ...
    def sample_into(
        self,
        out: np.ndarray,
        seed: int,
        noise: npt.NDArray[np.float64] | None = None,
        threads: int | None = None,
    ) -> None: ...
    def stream_into(
        self,
        out: np.ndarray,
        history: list[np.ndarray],
        t: int,
        seed: int,
        noise: npt.NDArray[np.float64] | None = None,
        threads: int | None = None,
    ) -> None: ...
    def product_into(
        self,
        out: np.ndarray,
        seed: int,
        noise: list[npt.NDArray[np.float64]] | None = None,
        threads: int | None = None,
    ) -> None: ...

MAX_DIFFERENCE_ORDER: int

def difference_gram(
    data: npt.NDArray[np.float64], axis: int, max_order: int, threads: int | None = None
) -> tuple[npt.NDArray[np.float64], int]: ...
def lag_products(
    data: npt.NDArray[np.float64], axis: int, max_lag: int, threads: int | None = None
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.uint64]]: ...
def whiten_axis_into(data: npt.NDArray[np.float64], axis: int, rho: float, order: int) -> None: ...
def chi2_sf(x: float, dof: float) -> float: ...
def chi2_quantile(p: float, dof: float) -> float: ...

_Pixels = (
    npt.NDArray[np.uint8]
    | npt.NDArray[np.uint16]
    | npt.NDArray[np.float32]
    | npt.NDArray[np.float64]
)

def segment(
    frame: _Pixels,
    threshold: float,
    min_area: int,
    connectivity: int,
) -> tuple[dict[str, np.ndarray], npt.NDArray[np.int32]]: ...
def segment_stack(
    stack: _Pixels,
    threshold: float,
    min_area: int,
    connectivity: int,
) -> tuple[dict[str, np.ndarray], npt.NDArray[np.int32]]: ...

@final
class VectorRowFilter:
    def __new__(cls, model: FieldModel, noise_var: float, width: int) -> VectorRowFilter: ...
    def filter_into(
        self,
        z: npt.NDArray[np.float64],
        out: npt.NDArray[np.float64],
        smooth: bool,
        threads: int | None = None,
    ) -> None: ...
    def error_variance(self, height: int, smooth: bool) -> npt.NDArray[np.float64]: ...

@final
class ScalarRowFilter:
    def __new__(
        cls,
        model: FieldModel,
        noise_var: float,
        width: int,
        ar_order: int | None = None,
        modes: str = "ends",
        row_models: str = "propagated",
    ) -> ScalarRowFilter: ...
    def bandwidth(self) -> int: ...
    def ends_span(self) -> int | None: ...
    def error_variance(
        self, height: int, weights: npt.NDArray[np.float64] | None = None
    ) -> npt.NDArray[np.float64]: ...
    def filter_into(
        self,
        z: npt.NDArray[np.float64],
        out: npt.NDArray[np.float64],
        smooth: bool,
        threads: int | None = None,
        weights: npt.NDArray[np.float64] | None = None,
    ) -> None: ...

def local_moments_into(
    z: npt.NDArray[np.float64],
    radius: int,
    mean: npt.NDArray[np.float64],
    var: npt.NDArray[np.float64],
) -> None: ...
def axis_correlation_table(
    rhos: npt.NDArray[np.float64], order: int, lags: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]: ...
def haar_noise_var(z: npt.NDArray[np.float64]) -> float: ...
def default_ar_order(n_y: int, n_x: int) -> int: ...
def model_ar_order(n_x: int) -> int: ...
def adaptive_denoise_into(
    z: npt.NDArray[np.float64],
    noise_var: float,
    model: FieldModel,
    radius: int,
    smooth: bool,
    out: npt.NDArray[np.float64],
    threads: int | None = None,
    row_models: str = "nominal",
) -> None: ...

SIGNAL_FLOOR: float
NOMINAL_SAMPLE: int

def wiener_bound(model: FieldModel, noise_var: float, height: int, width: int) -> float: ...
def wiener_map(
    model: FieldModel, noise_var: float, height: int, width: int
) -> npt.NDArray[np.float64]: ...

MAX_MOTION_ORDER: int

def tracker_defaults(k: int) -> dict[str, Any]: ...

@final
class BranchingTracker:
    def __new__(cls, config: Any) -> BranchingTracker: ...
    def update(self, measurements: npt.NDArray[np.float64], time: float | None = None) -> None: ...
    def tracks(self) -> dict[str, np.ndarray]: ...
    def online(self) -> dict[str, np.ndarray]: ...
    def stats(self) -> npt.NDArray[np.int64]: ...
    def frame_offsets(self) -> npt.NDArray[np.int64]: ...
    @property
    def frame(self) -> int: ...
    @property
    def time(self) -> float | None: ...
    @property
    def n_hypotheses(self) -> int: ...
    @property
    def n_nodes(self) -> int: ...
    def state_bytes(self) -> bytes: ...
    def load_state(self, state: bytes) -> None: ...

# ---- kalman: generic linear-Gaussian recursions (method page "Kalman filter bank")
_Matrices = tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
]

def kalman_constant_velocity(
    dt: float, q: float, ndim: int, measurement_std: float
) -> _Matrices: ...
def kalman_constant_acceleration(
    dt: float, q: float, ndim: int, measurement_std: float
) -> _Matrices: ...
def kalman_singer(
    dt: float, rho: float, sigma_a: float, ndim: int, measurement_std: float
) -> _Matrices: ...
def kalman_markov_velocity(
    dt: float, rho: float, sigma: float, ndim: int, measurement_std: float
) -> _Matrices: ...
def kalman_filter(
    f: npt.NDArray[np.float64],
    q: npt.NDArray[np.float64],
    h: npt.NDArray[np.float64],
    r: npt.NDArray[np.float64],
    mean: npt.NDArray[np.float64],
    cov: npt.NDArray[np.float64],
    measurements: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

# ---- filterbank: type identification by a bank of Kalman filters, IMM
MAX_MEASUREMENT: float

_ModelArrays = tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
]

def filterbank_check_model(
    f: npt.NDArray[np.float64],
    q: npt.NDArray[np.float64],
    h: npt.NDArray[np.float64],
    r: npt.NDArray[np.float64],
    x0: npt.NDArray[np.float64],
    p0: npt.NDArray[np.float64],
) -> _ModelArrays: ...

@final
class TypeIdentifier:
    def __new__(
        cls,
        models: list[_ModelArrays] | list[tuple[np.ndarray, ...]],
        priors: list[float],
        alpha: float | None = None,
        beta: float | None = None,
    ) -> TypeIdentifier: ...
    def run(
        self,
        measurements: npt.NDArray[np.float64],
        log_likelihoods: bool = False,
        threads: int | None = None,
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64] | None]: ...
    def log_likelihoods(self) -> npt.NDArray[np.float64]: ...
    def posterior(self) -> npt.NDArray[np.float64]: ...
    def decisions(self) -> npt.NDArray[np.int64]: ...
    @property
    def n_trajectories(self) -> int: ...
    @property
    def frame(self) -> int: ...
    def state_bytes(self) -> bytes: ...
    def load_state(self, state: bytes) -> None: ...

@final
class IMMEstimator:
    def __new__(
        cls,
        models: list[_ModelArrays] | list[tuple[np.ndarray, ...]],
        transition: npt.NDArray[np.float64],
        mu: list[float],
    ) -> IMMEstimator: ...
    def run(
        self, measurements: npt.NDArray[np.float64], threads: int | None = None
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def combined(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def mode_probabilities(self) -> npt.NDArray[np.float64]: ...
    @property
    def n_trajectories(self) -> int: ...
    @property
    def frame(self) -> int: ...
    def state_bytes(self) -> bytes: ...
    def load_state(self, state: bytes) -> None: ...

# ---- trajectory: fuzzy and Kalman trajectory filters, change points (method page "Fuzzy filter")
MAX_SPREAD: float
MAX_SAMPLE: float
MAX_WINDOW: int

@final
class TrajectoryModel:
    def __new__(
        cls,
        rule: str,
        p: float,
        q: float,
        r: float,
        p_vel: float,
        q_vel: float,
        r_vel: float | None = None,
    ) -> TrajectoryModel: ...
    def gains(self, times: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def filter(
        self,
        z: npt.NDArray[np.float64],
        times: npt.NDArray[np.float64] | None = None,
        z_vel: npt.NDArray[np.float64] | None = None,
        threads: int | None = None,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def filter_into(
        self,
        z: npt.NDArray[np.float64],
        pos: npt.NDArray[np.float64],
        vel: npt.NDArray[np.float64],
        times: npt.NDArray[np.float64] | None = None,
        z_vel: npt.NDArray[np.float64] | None = None,
        threads: int | None = None,
    ) -> None: ...
    @property
    def rule(self) -> str: ...

@final
class FilterBank:
    def __new__(cls, model: TrajectoryModel, series: int) -> FilterBank: ...
    def step(
        self,
        t: float,
        z: npt.NDArray[np.float64],
        z_vel: npt.NDArray[np.float64] | None = None,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    @property
    def series(self) -> int: ...
    @property
    def last_time(self) -> float | None: ...
    def state(self) -> npt.NDArray[np.float64]: ...
    def load_state(self, state: npt.NDArray[np.float64]) -> None: ...

@final
class DetectorConfig:
    def __new__(
        cls, method: str, confidence: float, window: int, drift: float
    ) -> DetectorConfig: ...
    @property
    def threshold(self) -> float: ...

@final
class DetectorBank:
    def __new__(
        cls, model: TrajectoryModel, config: DetectorConfig, series: int
    ) -> DetectorBank: ...
    def step(
        self,
        t: float,
        z: npt.NDArray[np.float64],
        z_vel: npt.NDArray[np.float64] | None = None,
    ) -> tuple[
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.bool_],
        npt.NDArray[np.float64],
    ]: ...
    @property
    def series(self) -> int: ...
    @property
    def last_time(self) -> float | None: ...
    def state(self) -> npt.NDArray[np.float64]: ...
    def load_state(self, state: npt.NDArray[np.float64]) -> None: ...

def detect_changes(
    model: TrajectoryModel,
    config: DetectorConfig,
    z: npt.NDArray[np.float64],
    times: npt.NDArray[np.float64] | None = None,
    z_vel: npt.NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.bool_],
    npt.NDArray[np.float64],
]: ...
def cusum_threshold(confidence: float, drift: float) -> float: ...
def cusum_arl(h: float, drift: float) -> float: ...
def effective_memory(alpha: float, beta: float, tau: float, level: float) -> int: ...

# ---- template: correlation search, search-recurrent tracker (method page "Template tracker")
def match_template(
    frame: _Pixels,
    template: npt.NDArray[np.float64],
    window: tuple[int, int, int, int] | None,
    method: str,
    subpixel: bool,
    return_surface: bool,
) -> tuple[float, float, float, npt.NDArray[np.float64] | None]: ...

@final
class TemplateTracker:
    def __new__(
        cls,
        templates: list[npt.NDArray[np.float64]],
        positions: list[tuple[float, float]],
        model: str,
        process_std: float,
        measurement_std: float,
        dt: float,
        gate: float,
        initial_std: list[float],
        collapse: float,
        reacquire_z: float | None,
        update_template: float | None,
        subpixel: bool,
    ) -> TemplateTracker: ...
    def update(self, frame: _Pixels) -> dict[str, np.ndarray]: ...
    def state_values(self) -> npt.NDArray[np.float64]: ...
    def load_state(self, values: npt.NDArray[np.float64]) -> None: ...
    def templates(self) -> list[npt.NDArray[np.float64]]: ...
    def states(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def model_matrices(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def frames(self) -> int: ...
    @property
    def n_targets(self) -> int: ...

# -- sequence ------------------------------------------------------------------------------
@final
class ModalSequenceFilter:
    def __new__(
        cls, model: FieldModel, noise_var: float, height: int, width: int, lag: int
    ) -> ModalSequenceFilter: ...
    def step(
        self, z: npt.NDArray[np.float64], threads: int | None = None
    ) -> npt.NDArray[np.float64] | None: ...
    def pending(self) -> npt.NDArray[np.float64]: ...
    def error_variance(self, threads: int | None = None) -> npt.NDArray[np.float64]: ...
    def state(self) -> tuple[int, npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def set_state(
        self, frames: int, means: npt.NDArray[np.float64], covs: npt.NDArray[np.float64]
    ) -> None: ...

@final
class FastSequenceFilter:
    def __new__(
        cls,
        model: FieldModel,
        error_model: FieldModel,
        smoothing: float,
        noise_var: float,
        height: int,
        width: int,
    ) -> FastSequenceFilter: ...
    def step(
        self, z: npt.NDArray[np.float64], threads: int | None = None
    ) -> npt.NDArray[np.float64]: ...
    def error_variance(self) -> npt.NDArray[np.float64]: ...
    def state(self) -> tuple[int, npt.NDArray[np.float64]]: ...
    def set_state(self, frames: int, history: npt.NDArray[np.float64]) -> None: ...

# -- extended (stage 2 of the detector, §3.4) ------------------------------------------------
def extended_smooth(
    image: npt.NDArray[np.float64], width: int, out: npt.NDArray[np.float64] | None = None
) -> npt.NDArray[np.float64]: ...
def extended_level(image: npt.NDArray[np.float64]) -> float: ...
def extended_assign(
    sequence: npt.NDArray[np.int64],
    segment: npt.NDArray[np.int64],
    index: npt.NDArray[np.float64],
) -> npt.NDArray[np.int64]: ...

@final
class GroupTracker:
    def __new__(
        cls,
        *,
        order: int,
        dt: float,
        position_std: float,
        process_std: float,
        amplitude_std: float,
        log_area_std: float,
        feature_drift: float,
        confidence: float,
        memory: int,
        initial_speed_std: float,
        gate_margin: float,
        min_speed: float,
        velocity_tolerance: float,
        cohesion: float,
        max_misses: int,
        seed_groups: bool,
    ) -> GroupTracker: ...
    def step(self, segments: npt.NDArray[np.float64]) -> dict[str, Any]: ...
    def seed(
        self, segments: npt.NDArray[np.float64], vx: float, vy: float, length: int = 1
    ) -> int: ...
    @property
    def frame(self) -> int: ...
    @property
    def n_groups(self) -> int: ...
    @property
    def n_sequences(self) -> int: ...
    def state_bytes(self) -> bytes: ...
    @staticmethod
    def from_state(state: bytes) -> GroupTracker: ...
