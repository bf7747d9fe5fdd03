"""``kalmanfield identify``: an image (or a stack) → its fitted model as JSON and the
correlation plot."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..identification import identify
from ..io import write_model
from ..io._optional import optional
from ._common import OK, common, load_data, positive_int, say


def register(commands: argparse._SubParsersAction) -> None:
    p = commands.add_parser(
        "identify",
        help="fit the AR model of an image or a stack: JSON + correlation plot",
        description="Identifies the separable multiple-root AR model of an image (a stack of "
        "frames: time first) by likelihood per axis (kalmanfield.identify); writes the model "
        "with its diagnostics as JSON and the sample against the fitted correlation as PNG, "
        "and prints the summary. Colour images are fitted with their channels as replicates.",
    )
    p.add_argument(
        "image", type=Path, help="an image, a TIFF/zarr/.npy stack or a folder of frames"
    )
    p.add_argument("--json", type=Path, help="model file (default <stem>_model.json)")
    p.add_argument("--plot", type=Path, help="correlation plot (default <stem>_correlation.png)")
    p.add_argument(
        "--max-order",
        type=positive_int,
        default=4,
        help="highest multiplicity tried per axis (default 4)",
    )
    common(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    optional("matplotlib", "the correlation plot")  # before the work, not after
    data, colour = load_data(args.image)
    fit = identify(data, args.max_order, channel_axis=-1 if colour else None)
    stem = args.image.stem
    json_path = args.json or Path(f"{stem}_model.json")
    plot_path = args.plot or Path(f"{stem}_correlation.png")
    write_model(json_path, fit)
    _plot(fit, plot_path, args.image.name)
    say(args, fit.summary(), f"wrote {json_path} and {plot_path}")
    return OK


def _plot(fit, path: Path, name: str) -> None:
    matplotlib = optional("matplotlib", "the correlation plot")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes = fit.plot()
    figure = axes[0].figure
    for ax, axis_fit in zip(axes, fit.fits):
        ax.set_title(f"axis {axis_fit.axis}: sample vs fitted correlation", fontsize=10)
    figure.suptitle(f"{name}: {fit.model!r}", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=100)
    plt.close(figure)
