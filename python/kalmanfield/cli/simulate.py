"""``kalmanfield simulate``: fields and frame sequences of an AR model into files."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import tqdm

from ..field import ARFieldModel
from ..io import read_model, write_image, write_stack
from ..io.zarr_store import ZARR_SUFFIXES
from ._common import OK, common, positive_float, positive_int, say

#: what `simulate` makes: kind → (help, registration of its options); a new kind is one entry
KINDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None]]] = {}


def _model_options(p: argparse.ArgumentParser, rho: list[float], order: list[int]) -> None:
    p.add_argument(
        "--model",
        type=Path,
        help="a model JSON file (written by `identify`); replaces --rho, --order and --sigma",
    )
    p.add_argument(
        "--rho",
        type=float,
        nargs="+",
        default=rho,
        help=f"ρ per axis, each in (-1, 1) (default {' '.join(map(str, rho))})",
    )
    p.add_argument(
        "--order",
        type=positive_int,
        nargs="+",
        default=order,
        help=f"root multiplicity per axis (default {' '.join(map(str, order))})",
    )
    p.add_argument("--sigma", type=positive_float, default=1.0, help="field std (default 1)")
    p.add_argument("--mean", type=float, default=0.0, help="field mean (default 0)")
    p.add_argument("--dtype", choices=["float64", "float32"], default="float64")


def _field_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--shape",
        type=positive_int,
        nargs="+",
        default=[512, 512],
        help="grid shape, one length per axis (default 512 512)",
    )
    _model_options(p, [0.9, 0.9], [2, 2])
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output: .npy, .tif or .zarr keep the values; .png is 8-bit, for "
        "viewing; a .zarr is written row by row (a field larger than memory)",
    )


def _sequence_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--frames", type=positive_int, default=100, help="frames (default 100)")
    p.add_argument(
        "--shape",
        type=positive_int,
        nargs="+",
        default=[256, 256],
        help="frame shape (default 256 256)",
    )
    _model_options(p, [0.95, 0.9, 0.9], [1, 2, 2])
    p.add_argument(
        "--noise-std",
        type=float,
        default=0.0,
        help="std of white noise added to every frame (default 0: none)",
    )
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output: .zarr or .tif (written frame by frame), .npy, a folder of "
        "PNG frames (a path without suffix), .gif or .mp4 (for viewing)",
    )


KINDS["field"] = ("one realisation of a random field", _field_options)
KINDS["sequence"] = (
    "frames of a space–time field (axis 0 of the model is time)",
    _sequence_options,
)


def _scene_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--frames", type=positive_int, default=50, help="frames (default 50)")
    p.add_argument(
        "--shape", type=positive_int, nargs=2, default=[64, 64], help="frame shape (default 64 64)"
    )
    p.add_argument(
        "--targets", type=positive_int, default=1, help="targets, 10-px rhombi (default 1)"
    )
    p.add_argument(
        "--snr", type=positive_float, default=3.0, help="target amplitude / noise std (default 3)"
    )
    p.add_argument(
        "--p-false",
        type=float,
        default=0.1,
        help="probability that a frame holds clutter spots (default 0.1)",
    )
    p.add_argument("--dt", type=positive_float, default=0.1, help="time between frames (0.1)")
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        help="frames: .npy, .tif, .zarr, a folder of PNG frames (no suffix), .gif or .mp4; "
        "the truth (frame, target, x, y, vx, vy) goes to <out>.truth.csv",
    )
    p.set_defaults(run=_scene)


KINDS["scene"] = (
    "a scene with moving targets, clutter spots, foreign objects and noise "
    "(kalmanfield.simulate_scene); frames + truth CSV",
    _scene_options,
)


def register(commands: argparse._SubParsersAction) -> None:
    p = commands.add_parser(
        "simulate",
        help="simulate a field, a frame sequence or a scene with targets into files",
        description="Simulates an exactly stationary AR field (ARFieldModel.sample), a "
        "sequence of frames (FieldStream) or a scene with moving targets and its truth "
        "(simulate_scene) and writes it.",
    )
    kinds = p.add_subparsers(dest="kind", metavar="KIND", required=True)
    for kind, (text, options) in KINDS.items():
        q = kinds.add_parser(kind, help=text, description=f"Simulates {text}.")
        options(q)
        common(q, seed=0)
        if q.get_default("run") is None:  # a kind may bring its own
            q.set_defaults(run=run)


def _model(args: argparse.Namespace) -> ARFieldModel:
    if args.model is not None:
        return read_model(args.model)
    if len(args.rho) != len(args.order):
        raise ValueError(f"--rho has {len(args.rho)} values, --order {len(args.order)}")
    return ARFieldModel(args.rho, args.order, args.sigma)


def run(args: argparse.Namespace) -> int:
    model = _model(args)
    if args.kind == "field":
        _field(args, model)
    else:
        _sequence(args, model)
    say(args, f"wrote {args.out} ({model!r}, seed {args.seed})")
    return OK


def _field(args: argparse.Namespace, model: ARFieldModel) -> None:
    shape = tuple(args.shape)
    if len(shape) != model.ndim:
        raise ValueError(f"--shape has {len(shape)} lengths for a model of {model.ndim} axes")
    if args.out.suffix.lower() in ZARR_SUFFIXES and model.ndim >= 2:
        # slab by slab along axis 0: the same values as model.sample, never all in memory
        stream = model.stream(shape[1:], seed=args.seed, dtype=args.dtype)
        write_stack(args.out, _frames(stream, shape[0], args.mean, args, "rows"))
        return
    field = model.sample(shape, seed=args.seed, dtype=args.dtype, mean=args.mean)
    if args.out.suffix.lower() in ZARR_SUFFIXES:
        write_stack(args.out, field)
    else:
        write_image(args.out, field)


def _frames(
    stream,
    count: int,
    mean: float,
    args: argparse.Namespace,
    unit: str,
    noise: np.random.Generator | None = None,
    noise_std: float = 0.0,
) -> Iterator:
    for _ in tqdm.tqdm(range(count), desc="simulate", unit=unit, disable=args.quiet):
        frame = stream.next_frame() + mean
        if noise is not None:
            frame = frame + noise.normal(0.0, noise_std, frame.shape).astype(frame.dtype)
        yield frame


def _sequence(args: argparse.Namespace, model: ARFieldModel) -> None:
    if len(args.shape) != model.ndim - 1:
        raise ValueError(
            f"--shape has {len(args.shape)} lengths; a model of {model.ndim} axes has frames "
            f"of {model.ndim - 1}"
        )
    if args.noise_std < 0:
        raise ValueError(f"--noise-std must be non-negative, got {args.noise_std}")
    stream = model.stream(tuple(args.shape), seed=args.seed, dtype=args.dtype)
    # the noise has its own stream, derived from the seed (the field is model.sample's)
    noise = np.random.default_rng([args.seed, 1]) if args.noise_std > 0 else None
    write_stack(
        args.out, _frames(stream, args.frames, args.mean, args, "frame", noise, args.noise_std)
    )


def _scene(args: argparse.Namespace) -> int:
    from ..extended import simulate_scene

    if not 0.0 <= args.p_false <= 1.0:
        raise ValueError(f"--p-false must lie in [0, 1], got {args.p_false}")
    scene = simulate_scene(
        tuple(args.shape),
        args.frames,
        targets=args.targets,
        snr=args.snr,
        p_false=args.p_false,
        dt=args.dt,
        seed=args.seed,
    )
    write_stack(args.out, scene.frames)
    truth = args.out.with_name(args.out.name + ".truth.csv")
    scene.truth.to_csv(truth, index=False)
    say(args, f"wrote {args.out} and {truth} (seed {args.seed})")
    return OK
