"""The OMPL sampler is deterministic per seed whatever ran before it, in this process or a fresh
one (OMPL's generators are seeded per search, ``core.motion.sampler``)."""

from __future__ import annotations

import hashlib
import subprocess
import sys
from pathlib import Path

import numpy as np

from core.motion.certify import Certifier
from core.motion.sampler import RRTConnect, SearchProblem
from tests.core.motion.discs import Discs

ROOT = Path(__file__).resolve().parents[3]
DISCS = Discs([[0.0, 0.0], [0.0, 1.6]], [0.8, 0.5])


def search(seed: int, lazy: bool = True) -> np.ndarray:
    c = Certifier(DISCS)
    problem = SearchProblem(
        np.array([-2.0, 0.1]), np.array([[2.0, -0.1]]), np.full(2, -3.0), np.full(2, 3.0),
        c.state_clear if lazy else c.state_ok, None if lazy else c.edge_ok, seed, 5.0, 100_000,
        0.05, 0.5,
    )  # fmt: skip
    found = RRTConnect().search(problem)
    assert found.path is not None
    return found.path


def digest(path: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(path).tobytes()).hexdigest()


def test_same_seed_same_path_whatever_ran_before() -> None:
    first = search(5)
    search(9)
    search(1, lazy=False)
    np.testing.assert_array_equal(search(5), first)
    assert not np.array_equal(search(6), first)


def test_same_path_in_a_fresh_process() -> None:
    code = "from tests.core.motion.test_sampler import search, digest; print(digest(search(5)))"
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == digest(search(5))
