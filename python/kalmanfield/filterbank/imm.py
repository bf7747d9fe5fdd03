"""The interacting-multiple-model (IMM) estimator over a bank, Rust core."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import pickled_fields, real_array, thread_count
from ._batch import bank_models, frame_batch, restored_batched, run_batch, stream_shape
from .identifier import _priors
from .model import LinearGaussianModel


class IMMRun(NamedTuple):
    """What :meth:`IMMEstimator.run` returns (a leading trajectory axis for a batch)."""

    #: combined state estimate after every frame, (n_frames, n)
    state: np.ndarray
    #: mode probabilities after every frame, (n_frames, K)
    mode_probabilities: np.ndarray
    #: ln p(z_k | z_1..z_(k−1)) per frame (0 on missed frames), (n_frames,)
    log_likelihood: np.ndarray


class IMMEstimator:
    """Interacting-multiple-model estimator, for objects that change type mid-track.

    K models of one state space switch by a Markov chain. Each frame mixes the models'
    estimates with the mode transition probabilities, predicts and updates every model,
    reweights the modes by their innovation likelihoods and combines the estimates (Blom &
    Bar-Shalom; the conventions of FilterPy's ``IMMEstimator``, to which it is tested equal).

    Parameters
    ----------
    models : sequence of LinearGaussianModel
        At least two models with the same state and measurement lengths (embed a smaller
        model in the larger state space first: e.g. a velocity model as a Singer model with
        ρ = 0 and σ_a = 0).
    transition : array-like, (K, K)
        M[i, j] = P(mode j at frame k | mode i at frame k − 1); rows sum to 1.
    mu : array-like, optional
        Mode probabilities before the first frame (default uniform).

    Raises
    ------
    ValueError
        Fewer than two models, models of different state or measurement lengths, a
        transition matrix that is not K × K or whose rows are not probability vectors,
        mode probabilities not summing to 1.
    TypeError
        Models that are not LinearGaussianModel.

    See Also
    --------
    TypeIdentifier : One type per trajectory, decided from the whole track.

    Notes
    -----
    Batches (B, n_frames, m) run in Rust, one thread task per trajectory (the mixing makes
    every trajectory's covariances data-dependent, so nothing is shared). A NaN row is a
    missed frame: states predicted, μ ← c̄ = μ M (FilterPy has no missed-frame rule). The
    estimator pickles mid-stream and resumes exactly. The recursion is §6.6 of
    :doc:`/methods/kalman_bank`.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> calm = kf.LinearGaussianModel.singer(1.0, rho=0.0, sigma_a=0.0, name="calm")
    >>> agile = kf.LinearGaussianModel.singer(1.0, rho=0.8, sigma_a=1.0, name="agile")
    >>> imm = kf.IMMEstimator([calm, agile], [[0.95, 0.05], [0.05, 0.95]])
    >>> out = imm.run(agile.simulate(30, seed=2)[1])
    >>> out.state.shape, out.mode_probabilities.shape
    ((30, 6), (30, 2))
    """

    def __init__(
        self,
        models: Sequence[LinearGaussianModel],
        transition: npt.ArrayLike,
        mu: npt.ArrayLike | None = None,
    ) -> None:
        self._models = bank_models(models)
        k = len(self._models)
        dims = {m.state_dim for m in self._models}
        if len(dims) > 1:
            raise ValueError(f"the IMM mixes states: all models need one state length, got {dims}")
        m = real_array(transition, "transition")
        if m.shape != (k, k):
            raise ValueError(f"transition must be {k}×{k} for {k} models, got shape {m.shape}")
        for row in m:
            _priors(row, k)  # each row a probability vector
        self._transition = m
        self._mu = _priors(mu, k)
        self._core = self._new_core()
        self._batched: bool | None = None

    def _new_core(self) -> _core.IMMEstimator:
        arrays = [m.arrays() for m in self._models]
        return _core.IMMEstimator(arrays, self._transition, self._mu)

    @property
    def models(self) -> list[LinearGaussianModel]:
        """The modes' models (a list of LinearGaussianModel)."""
        return list(self._models)

    @property
    def transition(self) -> np.ndarray:
        """The mode transition matrix M (K × K, a copy)."""
        return self._transition.copy()

    @property
    def frame(self) -> int:
        """The number of frames processed."""
        return self._core.frame

    @property
    def x(self) -> np.ndarray:
        """The combined state estimate: (n,), or (B, n) for a batch."""
        if self._batched is None:
            return self._prior_mixture()[0]
        return self._shaped(self._core.combined()[0])

    @property
    def P(self) -> np.ndarray:  # noqa: N802 - FilterPy's name
        """The combined state covariance: (n, n), or (B, n, n) for a batch."""
        if self._batched is None:
            return self._prior_mixture()[1]
        return self._shaped(self._core.combined()[1])

    @property
    def mu(self) -> np.ndarray:
        """The mode probabilities: (K,), or (B, K) for a batch."""
        if self._batched is None:
            return np.array(self._mu)
        return self._shaped(self._core.mode_probabilities())

    def _prior_mixture(self) -> tuple[np.ndarray, np.ndarray]:
        mu = np.array(self._mu)
        means = np.array([m.x0 for m in self._models])
        x = mu @ means
        d = means - x
        covs = np.array([m.P0 for m in self._models])
        return x, np.einsum("j,jab->ab", mu, covs + d[:, :, None] * d[:, None, :])

    def _shaped(self, a: np.ndarray) -> np.ndarray:
        return a if self._batched else a[0]

    def update(self, measurement: npt.ArrayLike, threads: int | None = None) -> np.ndarray:
        """Process one frame.

        Parameters
        ----------
        measurement : array-like
            (m,) for one trajectory, (B, m) for a batch; a row of NaN is a missed frame.
        threads : int, optional
            Number of threads for a batch (None: all cores).

        Returns
        -------
        numpy.ndarray
            :attr:`x`, the combined state estimate after the frame: (n,), or (B, n).

        Raises
        ------
        ValueError
            A frame of the wrong shape, a row partly NaN or with an infinite value, or a
            frame that does not continue the stream (one trajectory against a batch, or
            another batch size).

        Examples
        --------
        >>> import kalmanfield as kf
        >>> calm = kf.LinearGaussianModel.singer(1.0, rho=0.0, sigma_a=0.0, name="calm")
        >>> agile = kf.LinearGaussianModel.singer(1.0, rho=0.8, sigma_a=1.0, name="agile")
        >>> imm = kf.IMMEstimator([calm, agile], [[0.95, 0.05], [0.05, 0.95]])
        >>> imm.update([1.0, 0.5]).shape, imm.mu.shape, imm.frame
        ((6,), (2,), 1)
        """
        z, batched = frame_batch(measurement, self._models[0].measurement_dim)
        self._advance(z, batched, threads)
        return self.x

    def run(self, measurements: npt.ArrayLike, threads: int | None = None) -> IMMRun:
        """Process a run of frames, continuing the stream.

        Parameters
        ----------
        measurements : array-like
            (n_frames, m) for one trajectory, (n_trajectories, n_frames, m) for a batch; a
            row of NaN is a missed frame.
        threads : int, optional
            Number of threads for a batch (None: all cores).

        Returns
        -------
        IMMRun
            A named tuple of the per-frame ``state`` (n_frames, n), ``mode_probabilities``
            (n_frames, K) and ``log_likelihood`` (n_frames,): ln p(z_k | z_1..z_(k−1)), 0
            on missed frames; a leading trajectory axis for a batch.

        Raises
        ------
        ValueError
            Measurements of the wrong shape, a row partly NaN or with an infinite value, or
            a run that does not continue the stream (one trajectory against a batch, or
            another batch size).

        Examples
        --------
        >>> import kalmanfield as kf
        >>> calm = kf.LinearGaussianModel.singer(1.0, rho=0.0, sigma_a=0.0, name="calm")
        >>> agile = kf.LinearGaussianModel.singer(1.0, rho=0.8, sigma_a=1.0, name="agile")
        >>> imm = kf.IMMEstimator([calm, agile], [[0.95, 0.05], [0.05, 0.95]])
        >>> out = imm.run(agile.simulate(20, 4, seed=0)[1])  # a batch of 4 trajectories
        >>> out.state.shape, out.mode_probabilities.shape, out.log_likelihood.shape
        ((4, 20, 6), (4, 20, 2), (4, 20))
        """
        z, batched = run_batch(measurements, self._models[0].measurement_dim)
        state, modes, ll = self._advance(z, batched, threads)
        if not batched:
            return IMMRun(state[0], modes[0], ll[0])
        return IMMRun(state, modes, ll)

    def _advance(self, z: np.ndarray, batched: bool, threads: int | None) -> Any:
        stream_shape(batched, self._batched, z.shape[0], self._core.n_trajectories)
        out = self._core.run(z, thread_count(threads))
        self._batched = batched
        return out

    def __getstate__(self) -> dict[str, Any]:
        return {
            "models": self._models,
            "transition": self._transition,
            "mu": self._mu,
            "batched": self._batched,
            "state": self._core.state_bytes(),
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        # through the constructor's checks: a pickle is input like any other
        fields = pickled_fields(state, "IMMEstimator", "models", "transition", "mu", "batched")
        models, transition, mu, batched = fields
        self.__init__(models, transition, mu)  # type: ignore[misc]
        self._core.load_state(pickled_fields(state, "IMMEstimator", "state")[0])
        self._batched = restored_batched(batched, self._core.n_trajectories)

    def __repr__(self) -> str:
        names = [m.name for m in self._models]
        return f"IMMEstimator(models={names}, frames={self.frame})"
