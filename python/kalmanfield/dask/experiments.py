"""The Monte Carlo experiments on a dask.distributed cluster, one task per job."""

from __future__ import annotations

from typing import Any

from ..experiments.registry import experiment
from ..io._optional import optional


def run_experiment(name: str, client: Any = None, **settings: Any) -> Any:
    """Run a registered Monte Carlo experiment, its jobs spread over a Dask cluster.

    Parameters
    ----------
    name : str
        The experiment: ``"type-confusion"`` (:func:`kalmanfield.experiments.type_confusion`).
    client : distributed.Client, optional
        The cluster's client; None runs the jobs on dask's default scheduler (threads of this
        process).
    **settings
        The experiment's settings (for ``"type-confusion"`` those of
        :func:`~kalmanfield.experiments.type_confusion` but ``progress``: ``models``,
        ``n_frames``, ``runs``, ``seed``, ``threads``).

    Returns
    -------
    object
        The experiment's result (for ``"type-confusion"`` a
        :class:`~kalmanfield.experiments.TypeConfusion`), equal bit for bit to the in-memory
        run with the same settings, whatever the number of workers: every job has its own
        child of the seed.

    Raises
    ------
    ValueError
        An unknown experiment (the message lists the names), or settings it refuses.
    ImportError
        dask (or, with a client, distributed) is not installed (the ``dask`` extra).

    Examples
    --------
    >>> import kalmanfield.dask as kfd
    >>> from kalmanfield.experiments import type_confusion
    >>> spread = kfd.run_experiment("type-confusion", n_frames=10, runs=50, seed=1)
    >>> here = type_confusion(n_frames=10, runs=50, seed=1, progress=False)
    >>> spread.table.equals(here.table)
    True
    """
    spec = experiment(name)
    jobs = list(spec.plan(**settings))
    if client is None:
        dask = optional("dask", "kalmanfield.dask.run_experiment")
        partials = dask.compute(*[dask.delayed(spec.run_job)(job) for job in jobs])
    else:
        futures = client.map(spec.run_job, jobs, pure=False)
        partials = client.gather(futures)
    return spec.combine(jobs, list(partials))
