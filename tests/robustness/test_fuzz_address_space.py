"""Address-space-limited probes (issue 49, "Done when"): small scripts in a fresh interpreter
under RLIMIT_AS = 4 GiB (as on HPC nodes and in cgroups, a limit below the machine's memory)
and a timeout. An oversize request must be a MemoryError or ValueError (the interpreter
exits normally), ordinary work under the limit must still succeed; never an abort
("memory allocation failed", exit 134), a PanicException or a hang.

Quick mode: one probe per entry point; KALMANFIELD_FUZZ=long adds sizes around the limit."""

from __future__ import annotations

import subprocess

import pytest
from fuzz_support import LONG, run_script

LIMIT = 4 * 2**30
SETUP = """
import numpy as np
import kalmanfield as kf
MODEL = kf.ARFieldModel([0.9, 0.8], [2, 1])
"""

#: (name, statement that must be refused)
OVERSIZE = [
    ("sample 7 GB", "MODEL.sample((30000, 30000), seed=1)"),
    ("sample float32 6.4 GB", "MODEL.sample((40000, 40000), seed=1, dtype=np.float32)"),
    ("product field 7 GB", "kf.sample_product_field(MODEL, (30000, 30000), seed=1)"),
    ("stream take 6 GB", "kf.ARFieldModel([0.9] * 3, 1).stream((512, 512), seed=1).take(3000)"),
    ("stream frame 8 GB", "next(kf.ARFieldModel([0.9] * 3, 1).stream((32000, 32000), seed=1))"),
    # (was a PanicException: faer's AllocError)
    ("wiener_error_map 6 GB", "kf.wiener_error_map(MODEL, 1.0, (20000, 20000))"),
    ("vector filter width 20000", "kf.VectorRowFilter(MODEL, 1.0, 20000)"),
    # (its map and the per-mode map: 7.7 GB)
    (
        "vector error_variance 3e7 rows",
        "kf.VectorRowFilter(MODEL, 1.0, 16).error_variance(3 * 10**7)",
    ),
    # (was an abort: memory allocation failed)
    ("scalar error_variance 1e8 rows", "kf.ScalarRowFilter(MODEL, 1.0, 16).error_variance(10**8)"),
    (
        "denoise 6 GB stack",
        "kf.denoise(np.zeros((1, 2, 2)) + np.zeros((6000, 360, 360)), noise_var=0.1)",
    ),
]
if LONG:
    OVERSIZE += [
        (f"sample {gib} GiB", f"MODEL.sample(({gib} * 2**27 // 1000, 1000), seed=1)")
        for gib in (5, 8, 12)  # (3 GiB fit under 4 GiB of address space)
    ] + [
        (f"take {gib} GiB", f"kf.ARFieldModel([0.9] * 3, 1).stream((1024, 1024)).take({gib} * 128)")
        for gib in (5, 8)
    ]

#: (name, statement that must succeed under the limit)
ORDINARY = [
    ("scalar filter 512 wide", "kf.ScalarRowFilter(MODEL, 0.5, 512).filter(np.ones((64, 512)))"),
    ("sample 100 MB", "MODEL.sample((3000, 4000), seed=1)"),
    ("denoise 512²", "kf.denoise(MODEL.sample((512, 512), seed=1), noise_var=0.1)"),
    # (aborted: faer's products reserved twice the L3 cache per thread, 960 MiB here)
    ("vector filter 64 wide", "kf.VectorRowFilter(MODEL, 0.5, 64).filter(np.ones((8, 64)))"),
    (
        "scalar filter 512² smoothed",
        "kf.ScalarRowFilter(MODEL, 0.5, 512, smooth=True).filter(np.ones((512, 512)))",
    ),
    ("vector filter stack", "kf.VectorRowFilter(MODEL, 0.5, 128).filter(np.ones((6, 128, 128)))"),
    ("wiener_bound 512²", "kf.wiener_bound(MODEL, 0.5, (512, 512))"),
]


_RESULTS: dict[str, tuple[str, str]] = {}


def _all_probes() -> list[tuple[str, str]]:
    return [tuple(p.values if hasattr(p, "values") else p) for p in OVERSIZE + ORDINARY]


def _probe(name: str) -> tuple[str, str]:
    """(outcome, detail) of a probe: REFUSED/RETURNED (with the exception's message), ERROR
    (another exception) or DIED (exit code, stderr). The probes run one after the other in
    an interpreter under the limit (start-up costs more than most probes); one that kills it
    is reported and the rest run in a fresh one."""
    if not _RESULTS:
        pending = _all_probes()
        while pending:
            pending = pending[_run(pending) :]
    return _RESULTS[name]


def _run(probes: list[tuple[str, str]]) -> int:
    """Runs `probes` in one interpreter; returns how many have a result (the one that
    killed it included)."""
    body = (
        SETUP
        + f"""
import gc
for name, statement in {probes!r}:
    print("PROBE", name, flush=True)
    try:
        result = eval(statement)
        del result
        print("RESULT RETURNED -", flush=True)
    except (MemoryError, ValueError) as err:
        print("RESULT REFUSED", type(err).__name__, str(err).replace(chr(10), " "), flush=True)
    except BaseException as err:
        print("RESULT ERROR", type(err).__module__, type(err).__name__, err, flush=True)
    gc.collect()
"""
    )
    try:
        done = run_script(body, timeout=120 * len(probes), address_space=LIMIT)
        out, died = done.stdout, f"DIED exit {done.returncode}: {done.stderr[-800:]}"
    except subprocess.TimeoutExpired as err:
        out = err.stdout.decode() if isinstance(err.stdout, bytes) else (err.stdout or "")
        died = "DIED: timed out"
    current = None
    for line in out.splitlines():
        if line.startswith("PROBE "):
            current = line[len("PROBE ") :]
        elif line.startswith("RESULT ") and current is not None:
            outcome, _, detail = line[len("RESULT ") :].partition(" ")
            _RESULTS[current] = (outcome, detail)
            current = None
    if current is not None:  # it killed the interpreter
        _RESULTS[current] = ("DIED", died)
    return max(1, sum(name in _RESULTS for name, _ in probes))


@pytest.mark.parametrize("name,statement", OVERSIZE)
def test_oversize_requests_are_refused_under_an_address_space_limit(name, statement):
    outcome, detail = _probe(name)
    assert outcome == "REFUSED" and len(detail.split(maxsplit=1)) == 2, f"{outcome} {detail}"


@pytest.mark.parametrize("name,statement", ORDINARY)
def test_ordinary_work_succeeds_under_an_address_space_limit(name, statement):
    outcome, detail = _probe(name)
    assert outcome == "RETURNED", f"{outcome} {detail}"
