"""The benchmark script runs (``--quick``: small sizes, outputs cross-checked, no files)."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_filterbank_quick():
    run = subprocess.run(
        [sys.executable, str(ROOT / "benches" / "bench_filterbank.py"), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert run.returncode == 0, run.stderr
    assert "faster" in run.stdout and "k = 10" in run.stdout
