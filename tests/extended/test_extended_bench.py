"""The extended-object benchmark runs in its quick mode (every table and the cost ratio are
reported; a quick run writes its page to bench_out/, never to docs/)."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_quick_mode_runs():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    run = subprocess.run(
        [sys.executable, str(ROOT / "benches" / "bench_extended.py"), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.count("| SNR | P_f | runs |") == 5
    assert (
        "| scene | p_vanish | scenes |" in run.stdout or "motmetrics is not installed" in run.stdout
    )
    assert "| scene | frames | segment alone" in run.stdout
