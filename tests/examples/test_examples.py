"""Every ``examples/*.py`` script runs and exits 0: the examples check their own promises (the
straight-line cases of issue 4 and the bounded-deviation ones among them), so they never rot.
This is the one place that runs them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(p for p in EXAMPLES.glob("*.py") if not p.name.startswith("_"))


def test_there_are_examples():
    assert {"ur5_line.py", "planar_through_hole.py", "puma_wrist_singularity.py",
            "duration_too_short.py"} <= {p.name for p in SCRIPTS}  # fmt: skip


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_example_runs(script: Path):
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    done = subprocess.run(
        [sys.executable, str(script)],
        cwd=EXAMPLES.parent,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, f"{script.name} failed:\n{done.stdout}\n{done.stderr}"
    assert done.stdout.rstrip().endswith("OK"), f"{script.name} did not finish:\n{done.stdout}"
