"""The MotionBenchMaker Panda problems of ``bench/data/mbm_panda`` as API requests.

``problems()`` reads ``problems.json``; ``request(problem)`` is the body of
``POST /v1/trajectories/collision_free``: VAMP's spherized Panda inline (tip
``panda_grasptarget``), MBM's collision objects as ``environment.obstacles`` (box ``size`` = MBM's
full side lengths; sphere ``radius``; cylinder ``radius`` = dimensions[1] and ``length`` =
dimensions[0], MBM's height along the local z axis; poses as given, in the base frame
``panda_link0``), the SRDF's disabled pairs as ``environment.allowed_collisions``.
"""

from __future__ import annotations

import functools
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

DATA = Path(__file__).resolve().parent / "data" / "mbm_panda"
SCENARIOS = ("table_pick", "table_under_pick", "box", "bookshelf_small", "bookshelf_tall",
             "bookshelf_thin", "cage")  # fmt: skip
TIP = "panda_grasptarget"


@dataclass(frozen=True)
class Problem:
    """One MBM problem: ``scenario``, ``index`` (1-based, as in the MBM files), joints, objects."""

    scenario: str
    index: int
    start: list[float]
    goal: list[float]
    obstacles: list[dict[str, Any]]

    @property
    def name(self) -> str:
        return f"{self.scenario}/{self.index}"


def problems(
    per_scenario: int | None = None, scenarios: tuple[str, ...] = SCENARIOS
) -> list[Problem]:
    """The problems of ``scenarios``, the first ``per_scenario`` of each (default all 15)."""
    data = json.loads((DATA / "problems.json").read_text())
    return [
        Problem(s, p["index"], p["start"], p["goal"], p["obstacles"])
        for s in scenarios
        for p in data[s][:per_scenario]
    ]


@functools.cache
def urdf() -> str:
    return (DATA / "panda_spherized.urdf").read_text()


@functools.cache
def allowed_collisions() -> list[list[str]]:
    """The SRDF's ``disable_collisions`` pairs."""
    text = (DATA / "panda.srdf").read_text()
    return [[a, b] for a, b in re.findall(r'link1="([^"]+)" link2="([^"]+)"', text)]


def robot() -> dict[str, str]:
    return {"urdf": urdf(), "tip_frame": TIP}


def obstacle(o: dict[str, Any]) -> dict[str, Any]:
    """One MBM collision object as an API obstacle."""
    d = o["dimensions"]
    shape = {
        "box": lambda: {"type": "box", "size": list(d)},
        "sphere": lambda: {"type": "sphere", "radius": d[0]},
        "cylinder": lambda: {"type": "cylinder", "radius": d[1], "length": d[0]},
    }[o["type"]]()
    return {"name": o["id"], "shape": shape,
            "pose": {"position": o["position"], "orientation": o["orientation"]}}  # fmt: skip


def environment(problem: Problem) -> dict[str, Any]:
    return {
        "obstacles": [obstacle(o) for o in problem.obstacles],
        "allowed_collisions": allowed_collisions(),
    }


def request(problem: Problem, **extra: Any) -> dict[str, Any]:
    """The collision-free request of ``problem`` (``extra``: more fields, e.g. ``seed``)."""
    return {
        "robot": robot(),
        "start": {"positions": problem.start},
        "goal": {"positions": problem.goal},
        "environment": environment(problem),
        **extra,
    }
