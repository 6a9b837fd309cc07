"""Every public problem body carries only keys docs/api.md documents (issue 23: an internal
``s_reached`` rode in error data into public 422 bodies, shown by a bounded_deviation PUMA line).

The documented keys are read from docs/api.md's "Errors" section (the field table and its list of
"other keys"); a sweep of failing requests over every route collects the keys actually answered.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from robots import registry
from service.app import create_app
from service.schemas.common import Pose

DOCS = Path(__file__).resolve().parents[2] / "docs" / "api.md"
UR5 = registry.get("ur5")
PUMA = registry.get("puma560")
HOME = UR5.home.tolist()


def documented_keys() -> set[str]:
    """Backticked names of the rows of the field table in docs/api.md's "## Errors" section."""
    text = DOCS.read_text()
    section = text[text.index("## Errors") :]
    section = section[: section.index("### Error codes")]
    keys: set[str] = set()
    for line in section.splitlines():
        if line.startswith("| ") and not line.startswith("| Field") and "---" not in line:
            first, rest = line.split("|")[1], "|".join(line.split("|")[2:])
            keys.update(re.findall(r"`([a-z_]+)`", first))
            if "other keys" in first:
                keys.update(re.findall(r"`([a-z_]+)`", rest))
    return keys


def pose(robot: Any, q: Any, offset: Any) -> dict:
    T = robot.fk(np.asarray(q, dtype=float))
    T[:3, 3] += offset
    return Pose.from_matrix(T).model_dump()


def line(method: str, offset: Any, robot: str = "ur5", q: Any = HOME, **extra: Any) -> dict:
    model = registry.get(robot)
    return {
        "robot": robot,
        "method": method,
        "start": {"positions": list(q)},
        "goal": {"pose": pose(model, q, offset)},
        **extra,
    }


PUMA_WRIST = [0.0, math.pi / 4, -math.pi, 0.0, 0.3, 0.0]
BALL = {
    "name": "ball",
    "shape": {"type": "sphere", "radius": 0.05},
    "pose": {
        "position": (UR5.fk(UR5.home)[:3, 3] + [0.1, 0, 0]).tolist(),
        "orientation": [0, 0, 0, 1],
    },
}
FAILING: list[tuple[str, dict]] = [
    *[
        ("/v1/trajectories/cartesian", line(m, [3.0, 0, 0]))
        for m in ("sampled", "bounded_deviation", "resolved_rate")
    ],
    # the PUMA line through its wrist singularity (bounded_deviation leaked s_reached)
    *[
        ("/v1/trajectories/cartesian", line(m, [0.0, 0.0, 0.0], "puma560", PUMA_WRIST))
        for m in ("bounded_deviation", "sampled")
    ],
    ("/v1/trajectories/cartesian", line("sampled", [0.2, 0, 0], duration=0.01)),
    ("/v1/trajectories/cartesian", line("sampled", [0.2, 0, 0], environment={"obstacles": [BALL]})),
    ("/v1/trajectories/cartesian", line("nope", [0.1, 0, 0])),
    (
        "/v1/trajectories/program",
        {
            "robot": "ur5",
            "start": {"positions": HOME},
            "segments": [{"type": "lin", "goal": {"pose": pose(UR5, HOME, [3, 0, 0])}}],
        },
    ),
    (
        "/v1/trajectories/joint",
        {
            "robot": "ur5",
            "profile": "quintic",
            "start": {"positions": HOME},
            "goal": {"positions": [9.0] * 6},
        },
    ),
    (
        "/v1/trajectories/joint",
        {
            "profile": "quintic",
            "start": {"positions": [0.0]},
            "goal": {"positions": [1.0]},
            "duration": 0.01,
            "limits": {"velocity": [1.0], "acceleration": [1.0]},
        },
    ),
    ("/v1/robots/ur5/ik", {"pose": pose(UR5, HOME, [3, 0, 0])}),
    ("/v1/robots/ur5/fk", {"positions": [0.0] * 5}),
    ("/v1/robots/nobody/fk", {"positions": [0.0] * 6}),
]


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def test_the_docs_list_the_keys() -> None:
    keys = documented_keys()
    assert {"type", "title", "status", "detail", "code", "errors", "s", "links"} <= keys
    assert "s_reached" not in keys


@pytest.mark.parametrize(
    ("url", "body"), FAILING, ids=[f"{u}:{i}" for i, (u, _) in enumerate(FAILING)]
)
def test_every_problem_body_carries_only_documented_keys(client, url, body) -> None:
    r = client.post(url, json=body)
    assert r.status_code >= 400, r.text
    problem = r.json()
    extra = set(problem) - documented_keys()
    assert not extra, (url, sorted(extra), problem)
    for entry in problem.get("errors", []):
        assert set(entry) <= {"loc", "msg", "type"}
