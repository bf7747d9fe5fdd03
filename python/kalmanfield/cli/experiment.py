"""``kalmanfield experiment NAME``: the sources' Monte Carlo studies, as a table and a plot."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..experiments.registry import EXPERIMENTS, run_experiment
from ..io._optional import optional
from ._common import OK, common, positive_int, say


def register(commands: argparse._SubParsersAction) -> None:
    p = commands.add_parser(
        "experiment",
        help="run a Monte Carlo experiment of the sources: CSV table + plot",
        description="Runs a registered Monte Carlo experiment and writes <name>.csv (its "
        "table) and <name>.png (its plot); with --scheduler its jobs run on a Dask cluster.",
    )
    names = p.add_subparsers(dest="experiment", metavar="NAME", required=True)
    for name, spec in EXPERIMENTS.items():
        q = names.add_parser(name, help=spec.summary, description=f"The {spec.summary}.")
        for option in spec.options:
            if option.name == "seed":
                continue
            q.add_argument(
                f"--{option.name.replace('_', '-')}",
                dest=option.name,
                type=positive_int if option.kind is int else option.kind,
                default=option.default,
                help=f"{option.help} (default {option.default})",
            )
        q.add_argument("--out", type=Path, default=Path("."), help="output folder (default .)")
        q.add_argument(
            "--scheduler",
            metavar="ADDRESS",
            help="a dask.distributed scheduler (tcp://host:8786) to run the jobs on",
        )
        seeds = [o.default for o in spec.options if o.name == "seed"]
        common(q, seed=seeds[0] if seeds else None)
        q.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    spec = EXPERIMENTS[args.experiment]
    settings = {o.name: getattr(args, o.name) for o in spec.options}
    optional("matplotlib", "the experiment's plot")
    if args.scheduler:
        from ..dask import run_experiment as on_cluster

        distributed = optional("distributed", "--scheduler")
        with distributed.Client(args.scheduler) as client:
            result = on_cluster(args.experiment, client, **settings)
    else:
        result = run_experiment(args.experiment, progress=not args.quiet, **settings)
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.out / args.experiment
    result.table.to_csv(stem.with_suffix(".csv"), index=False)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = result.plot()
    ax.set_title(f"{args.experiment}: {spec.summary}", fontsize=10)
    ax.figure.savefig(stem.with_suffix(".png"), dpi=100, bbox_inches="tight")
    plt.close(ax.figure)
    say(args, f"wrote {stem.with_suffix('.csv')} and {stem.with_suffix('.png')}")
    return OK
