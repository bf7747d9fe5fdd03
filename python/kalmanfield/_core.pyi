import numpy as np
import numpy.typing as npt

MAX_ORDER: int

class FieldModel:
    def __init__(self, rho: list[float], order: list[int], sigma: float) -> None: ...
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
