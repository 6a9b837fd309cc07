"""Every ``examples/*.py`` script runs as a user runs it, against a live service, and exits 0: the
examples check their own promises (the straight-line cases of issue 4, the bounded-deviation ones,
the programs), so they never rot. This is the one place that runs them.

The service is ``python -m service`` on a free loopback port (``tests/live_service.py``), started
once for the module; each script is a subprocess given ``--url``, exactly as after the README's
start command (whose address is the scripts' default).
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.live_service import free_port, live_service

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(p for p in EXAMPLES.glob("*.py") if not p.name.startswith("_"))


@pytest.fixture(scope="module")
def service_url() -> Iterator[str]:
    with live_service() as url:
        yield url


def _run(script: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    return subprocess.run(
        [sys.executable, str(script), *args],
        cwd=EXAMPLES.parent,
        env=env,
        capture_output=True,
        text=True,
        timeout=180,
    )


def test_there_are_examples():
    assert {"ur5_line.py", "planar_through_hole.py", "puma_wrist_singularity.py",
            "duration_too_short.py", "panda_shelf_pick.py"} <= {p.name for p in SCRIPTS}  # fmt: skip


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_example_runs(script: Path, service_url: str):
    done = _run(script, "--url", service_url)
    assert done.returncode == 0, f"{script.name} failed:\n{done.stdout}\n{done.stderr}"
    assert done.stdout.rstrip().endswith("OK"), f"{script.name} did not finish:\n{done.stdout}"


def test_an_example_without_a_service_says_how_to_start_one():
    done = _run(EXAMPLES / "ur5_line.py", "--url", f"http://127.0.0.1:{free_port()}")
    assert done.returncode == 2, done.stdout + done.stderr
    assert "python -m service" in done.stdout and "--url" in done.stdout


def test_examples_import_nothing_the_service_install_lacks():
    """The scripts import the standard library, numpy, scipy, pinocchio, coal and the service's
    own packages: what ``pip install .`` installs (no httpx, no FastAPI test client, no
    requests)."""
    scripts = {p.stem for p in EXAMPLES.glob("*.py")}
    allowed = (
        set(sys.stdlib_module_names)
        | {"numpy", "scipy", "pinocchio", "coal", "core", "robots"}
        | scripts
    )
    for script in EXAMPLES.glob("*.py"):
        tree = ast.parse(script.read_text())
        imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        imported |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
        outside = {name for name in imported if name.split(".")[0] not in allowed}
        assert not outside, f"{script.name} imports {outside}"
