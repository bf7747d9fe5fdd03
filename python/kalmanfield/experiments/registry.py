"""The Monte Carlo experiments by name, each split into independent jobs, so that the command
line (``kalmanfield experiment NAME``) and :func:`kalmanfield.dask.run_experiment` run any of
them, in one process or spread over a cluster, with the same result."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import tqdm

from .type_confusion import combine, plan, run_job


@dataclass(frozen=True)
class Option:
    """A setting of an experiment that the command line offers as ``--<name>``."""

    name: str
    kind: type
    default: Any
    help: str


@dataclass(frozen=True)
class Experiment:
    """An experiment split into jobs: ``plan(**settings)`` lists independent jobs (each with
    its own seed), ``run_job(job)`` computes one, ``combine(jobs, partials)`` makes the result
    (an object with a ``table`` DataFrame and a ``plot(ax)`` method)."""

    name: str
    summary: str
    plan: Callable[..., Sequence[Any]]
    run_job: Callable[[Any], Any]
    combine: Callable[[Sequence[Any], Sequence[Any]], Any]
    options: tuple[Option, ...] = field(default=())


#: name → experiment; a new one is one more entry
EXPERIMENTS: dict[str, Experiment] = {
    "type-confusion": Experiment(
        "type-confusion",
        "confusion probability of the type against the frame number ([I], fig. 3)",
        plan,
        run_job,
        combine,
        (
            Option("n_frames", int, 100, "frames per trajectory"),
            Option("runs", int, 1000, "trajectories per type"),
            Option("seed", int, 0, "seed of the simulations"),
        ),
    ),
    # "k93": Experiment(...),  # issue 52: the source's detection experiment (P_o table)
}


def experiment(name: str) -> Experiment:
    """The registered experiment `name` (ValueError listing the names otherwise)."""
    if name not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {name!r}; known: {', '.join(sorted(EXPERIMENTS))}")
    return EXPERIMENTS[name]


def run_experiment(name: str, *, progress: bool = False, **settings: Any) -> Any:
    """Run experiment `name` in this process, job after job."""
    spec = experiment(name)
    jobs = list(spec.plan(**settings))
    partials = [spec.run_job(job) for job in tqdm.tqdm(jobs, disable=not progress, desc=name)]
    return spec.combine(jobs, partials)
