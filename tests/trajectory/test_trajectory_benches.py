"""The benchmark and the study of the trajectory domain run in their quick modes (they check
that every implementation agrees and every detector reports; a quick run writes its page to
bench_out/, never to docs/)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("script", ["bench_trajectory.py", "study_change_detection.py"])
def test_quick_mode_runs(script):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    run = subprocess.run(
        [sys.executable, str(ROOT / "benches" / script), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "| implementation |" in run.stdout or "| scenario | method |" in run.stdout
