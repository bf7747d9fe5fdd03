"""Monte Carlo confusion probability of type identification vs frame number [I, fig. 3]."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import tqdm

from .._validation import (
    SeedLike,
    positive_float,
    positive_int,
    real_array,
    resolve_seed,
)
from ..filterbank import LinearGaussianModel, TypeIdentifier
from ..filterbank._batch import bank_models
from ..filterbank.model import check_motion_memory

#: labels of the two banks of :func:`source_banks`
VELOCITY, ACCELERATION = "velocity (7)", "velocity + acceleration (8)"

#: z of the two-sided 95 % Wilson interval
_Z95 = 1.959963984540054


def source_banks(
    rho: tuple[float, float] = (0.9, 0.5),
    driving_std: float = 0.1,
    measurement_std: float = 3.0,
    ndim: int = 2,
    dt: float = 1.0,
) -> dict[str, list[LinearGaussianModel]]:
    """The two banks of the source's experiment.

    Each bank holds two types differing by the correlation coefficient ρ_i, either of the
    velocity ([I] eq. 7: :meth:`~kalmanfield.LinearGaussianModel.markov_velocity`) or of the
    acceleration ([I] eq. 8: :meth:`~kalmanfield.LinearGaussianModel.singer`), both driven
    by white noise of std `driving_std` (so the stationary std is
    driving_std / √(1 − ρ_i²)).

    Parameters
    ----------
    rho : tuple of float, default (0.9, 0.5)
        The types' correlation coefficients, each in (−1, 1).
    driving_std : float, default 0.1
        Standard deviation of the white noise driving the Markov component (positive).
    measurement_std : float, default 3.0
        Standard deviation σ_z of the measured positions (positive).
    ndim : int, default 2
        Number of spatial axes.
    dt : float, default 1.0
        Time step between frames.

    Returns
    -------
    dict of str to list of LinearGaussianModel
        Two banks, keyed by the labels ``VELOCITY`` (``"velocity (7)"``) and
        ``ACCELERATION`` (``"velocity + acceleration (8)"``), each with one model per ρ_i.

    Raises
    ------
    ValueError
        Fewer than two ρ_i, a ρ_i outside (−1, 1), or a non-positive std, `ndim` or `dt`.
    MemoryError
        An `ndim` whose state matrices would not fit in memory.

    Notes
    -----
    Priors: position N(0, (10 σ_z)²), velocity N(0, 1) where it is not stationary, the
    Markov component at its stationary variance (§6.7 of :doc:`/methods/kalman_bank`).

    Examples
    --------
    >>> from kalmanfield.experiments import ACCELERATION, source_banks
    >>> banks = source_banks(rho=(0.9, 0.5))
    >>> [m.name for m in banks[ACCELERATION]]
    ['rho=0.9 (a)', 'rho=0.5 (a)']
    """
    sz = positive_float(measurement_std, "measurement_std")
    w = positive_float(driving_std, "driving_std")
    coefficients = real_array(rho, "rho")
    if coefficients.ndim != 1 or coefficients.size < 2:
        raise ValueError(f"rho must hold one coefficient per type, at least two, got {rho!r}")
    ndim = positive_int(ndim, "ndim")
    check_motion_memory(3, ndim)
    banks: dict[str, list[LinearGaussianModel]] = {VELOCITY: [], ACCELERATION: []}
    for r in coefficients.tolist():
        if not -1 < r < 1:
            raise ValueError(f"rho must lie in (-1, 1), got {r}")
        sigma = w / np.sqrt(1.0 - r * r)
        p_velocity = np.diag([(10 * sz) ** 2, sigma**2] * ndim)
        velocity = LinearGaussianModel.markov_velocity(
            dt, r, sigma, ndim, sz, name=f"rho={r:g} (v)", x0=np.zeros(2 * ndim), P0=p_velocity
        )
        p_acceleration = np.diag([(10 * sz) ** 2, 1.0, sigma**2] * ndim)
        acceleration = LinearGaussianModel.singer(
            dt, r, sigma, ndim, sz, name=f"rho={r:g} (a)", x0=np.zeros(3 * ndim), P0=p_acceleration
        )
        banks[VELOCITY].append(velocity)
        banks[ACCELERATION].append(acceleration)
    return banks


@dataclass
class TypeConfusion:
    """The result of :func:`type_confusion`: confusion probability per bank and frame.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per bank and frame: ``bank``, ``frame`` (1-based), ``confusion``
        (probability that the maximum-posterior type is wrong, averaged over the true
        types), ``low`` and ``high`` (95 % Wilson interval) and ``trials`` (runs × types).

    Examples
    --------
    >>> from kalmanfield.experiments import ACCELERATION, VELOCITY, type_confusion
    >>> result = type_confusion(n_frames=10, runs=100, progress=False)
    >>> sorted(result.table["bank"].unique()) == sorted([VELOCITY, ACCELERATION])
    True
    """

    table: pd.DataFrame

    def confusion(self, bank: str) -> pd.Series:
        """The confusion probability per frame of one bank.

        Parameters
        ----------
        bank : str
            The bank's label (a key of the `models` given to :func:`type_confusion`).

        Returns
        -------
        pandas.Series
            The confusion probability, indexed by frame (1-based).

        Examples
        --------
        >>> from kalmanfield.experiments import VELOCITY, type_confusion
        >>> result = type_confusion(n_frames=10, runs=100, progress=False)
        >>> result.confusion(VELOCITY).index.tolist() == list(range(1, 11))
        True
        """
        rows = self.table[self.table["bank"] == bank]
        return rows.set_index("frame")["confusion"]

    def ratio(self, numerator: str, denominator: str) -> pd.Series:
        """The ratio of two banks' confusion probabilities, per frame.

        Parameters
        ----------
        numerator : str
            The label of the bank in the numerator.
        denominator : str
            The label of the bank in the denominator.

        Returns
        -------
        pandas.Series
            Confusion of `numerator` / confusion of `denominator`, indexed by frame (inf or
            NaN where the denominator is 0).

        Examples
        --------
        >>> from kalmanfield.experiments import ACCELERATION, VELOCITY, type_confusion
        >>> result = type_confusion(n_frames=10, runs=100, progress=False)
        >>> len(result.ratio(VELOCITY, ACCELERATION))
        10
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.confusion(numerator) / self.confusion(denominator)

    def plot(self, ax: Any = None) -> Any:
        """Plot the confusion probability against the frame, one line per bank.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            The axes to draw on (default: a new figure's).

        Returns
        -------
        matplotlib.axes.Axes
            The axes, with each bank's 95 % interval shaded.

        Notes
        -----
        Needs matplotlib (an optional extra), imported when called.

        Examples
        --------
        >>> import matplotlib
        >>> matplotlib.use("Agg")
        >>> from kalmanfield.experiments import type_confusion
        >>> ax = type_confusion(n_frames=10, runs=100, progress=False).plot()
        >>> ax.get_ylabel()
        'confusion probability'
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        for bank, rows in self.table.groupby("bank", sort=False):
            line = ax.plot(rows["frame"], rows["confusion"], label=bank)[0]
            ax.fill_between(
                rows["frame"], rows["low"], rows["high"], color=line.get_color(), alpha=0.25
            )
        ax.set_xlabel("frame")
        ax.set_ylabel("confusion probability")
        ax.set_ylim(bottom=0)
        ax.legend()
        return ax


def _wilson(errors: np.ndarray, trials: int) -> tuple[np.ndarray, np.ndarray]:
    p = errors / trials
    z2 = _Z95**2
    centre = (p + z2 / (2 * trials)) / (1 + z2 / trials)
    half = _Z95 * np.sqrt(p * (1 - p) / trials + z2 / (4 * trials**2)) / (1 + z2 / trials)
    return centre - half, centre + half


def type_confusion(
    models: Mapping[str, Sequence[LinearGaussianModel]] | None = None,
    n_frames: int = 100,
    runs: int = 1000,
    seed: SeedLike = 0,
    progress: bool = True,
    threads: int | None = None,
) -> TypeConfusion:
    """Monte Carlo confusion probability of the type against the frame number [I, fig. 3].

    For every bank, ``runs`` trajectories of each type are simulated from that type's model
    (its prior included) and identified by the bank (maximum posterior, equal priors); the
    confusion probability at frame k is the fraction of wrong decisions after k frames,
    averaged over the types.

    Parameters
    ----------
    models : mapping of str to sequence of LinearGaussianModel, optional
        Banks by label. Default: :func:`source_banks` (velocity-only vs velocity +
        acceleration types with ρ = 0.9 and 0.5, driving std 0.1, measurement std 3).
    n_frames : int, default 100
        Frames per trajectory.
    runs : int, default 1000
        Trajectories per type (the source averaged 100).
    seed : int, numpy.random.Generator or None, default 0
        Seed of the simulations (bank b, type i uses a stream derived from it).
    progress : bool, default True
        Show a tqdm progress bar over the banks' types.
    threads : int, optional
        Threads of the identification (default all cores).

    Returns
    -------
    TypeConfusion
        The table (with 95 % Wilson intervals) and a ``plot`` method.

    Raises
    ------
    ValueError
        A non-positive `n_frames` or `runs`, a bad seed, or a bank that
        :class:`~kalmanfield.TypeIdentifier` refuses.
    TypeError
        A bank that is not a sequence of LinearGaussianModel.

    See Also
    --------
    source_banks : The default banks.

    Notes
    -----
    §6.7 of :doc:`/methods/kalman_bank` lists the parameters where acceleration modelling
    cuts the confusion by more than 2× and where it does not.

    Examples
    --------
    >>> from kalmanfield.experiments import type_confusion
    >>> result = type_confusion(n_frames=20, runs=200, progress=False)
    >>> result.table.columns.tolist()
    ['bank', 'frame', 'confusion', 'low', 'high', 'trials']
    """
    jobs = plan(models, n_frames, runs, seed, threads)
    partials = [
        run_job(job) for job in tqdm.tqdm(jobs, disable=not progress, desc="type confusion")
    ]
    return combine(jobs, partials)


@dataclass(frozen=True)
class Job:
    """One independent piece of :func:`type_confusion`: `runs` trajectories of type `index`
    of bank `label`, identified by that bank, from their own seed."""

    label: str
    index: int
    bank: tuple[LinearGaussianModel, ...]
    n_frames: int
    runs: int
    seed: np.random.SeedSequence
    threads: int | None


def plan(
    models: Mapping[str, Sequence[LinearGaussianModel]] | None = None,
    n_frames: int = 100,
    runs: int = 1000,
    seed: SeedLike = 0,
    threads: int | None = None,
) -> list[Job]:
    """The jobs of :func:`type_confusion` (same arguments), one per bank and type, each with
    its own child of the seed: run in any order or place, they give the same bits."""
    banks: dict[str, Sequence[LinearGaussianModel]] = dict(
        source_banks() if models is None else models
    )
    frames, runs = positive_int(n_frames, "n_frames"), positive_int(runs, "runs")
    root = np.random.SeedSequence(resolve_seed(seed))
    checked = {label: tuple(bank_models(bank)) for label, bank in banks.items()}
    pairs = [(label, i) for label, bank in checked.items() for i in range(len(bank))]
    if not pairs:
        raise ValueError("models must hold at least one bank")
    return [
        Job(label, i, checked[label], frames, runs, child, threads)
        for (label, i), child in zip(pairs, root.spawn(len(pairs)))
    ]


def run_job(job: Job) -> np.ndarray:
    """The wrong decisions of one job, per frame (an int64 array of length n_frames)."""
    rng = np.random.default_rng(job.seed)
    _, z = job.bank[job.index].simulate(job.n_frames, job.runs, seed=rng)
    decisions = TypeIdentifier(job.bank).run(z, threads=job.threads)
    return np.asarray((decisions != job.index).sum(axis=0), dtype=np.int64)


def combine(jobs: Sequence[Job], partials: Sequence[np.ndarray]) -> TypeConfusion:
    """The result of :func:`type_confusion` from its jobs' partial results (job order)."""
    errors: dict[str, np.ndarray] = {}
    sizes: dict[str, int] = {}
    for job, wrong in zip(jobs, partials):
        errors[job.label] = errors.get(job.label, np.zeros(job.n_frames)) + wrong
        sizes[job.label] = len(job.bank)
    rows = []
    for label, wrong in errors.items():
        trials = jobs[0].runs * sizes[label]
        low, high = _wilson(wrong, trials)
        rows.append(
            pd.DataFrame(
                {
                    "bank": label,
                    "frame": np.arange(1, len(wrong) + 1),
                    "confusion": wrong / trials,
                    "low": low,
                    "high": high,
                    "trials": trials,
                }
            )
        )
    return TypeConfusion(pd.concat(rows, ignore_index=True))
