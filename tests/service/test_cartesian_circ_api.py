"""``path`` on POST /v1/trajectories/cartesian and /v1/compare: the circle arc over HTTP.

The circle is the test's own (centre and radius chosen here); the tool points come from the robot's
forward kinematics of the returned joints (``fk_many``), never from the diagnostics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core.path import PATHS
from robots import registry
from service.schemas.cartesian import PathType
from service.schemas.registry import names_of
from tests.ros_rules import check_ros_trajectory
from tests.service.conftest import pose_body

URL = "/v1/trajectories/cartesian"
UR5 = registry.get("ur5")
UR5_HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
RADIUS = 0.08
SWEEP = 2.0 * math.pi / 3


def _case(sweep: float = SWEEP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    T0 = UR5.fk(np.array(UR5_HOME))
    c = T0[:3, 3] + np.array([0.0, RADIUS, 0.0])
    Tg = T0.copy()
    Tg[:3, 3] = c + Rotation.from_rotvec([0, 0, sweep]).as_matrix() @ (T0[:3, 3] - c)
    return T0, Tg, c


def _request(path: dict, **kw) -> dict:
    _, Tg, _ = _case()
    return {
        "robot": "ur5",
        "start": {"positions": UR5_HOME},
        "goal": {"pose": pose_body(Tg)},
        "path": path,
        "method": "sampled",
        **kw,
    }


def _problem(response, code: str = "validation") -> dict:
    assert response.status_code == 422, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["code"] == code, body
    return body


def test_schema_path_types_are_the_registry() -> None:
    assert set(names_of(PathType)) == set(PATHS) == {"line", "circ"}


@pytest.mark.parametrize("how", ["center", "interim"])
def test_circ_request_follows_the_circle(client, how: str) -> None:
    T0, Tg, c = _case()
    point = c if how == "center" else c + Rotation.from_rotvec([0, 0, 0.3]).apply(T0[:3, 3] - c)
    response = client.post(URL, json=_request({"type": "circ", how: point.tolist()}))
    assert response.status_code == 200, response.text
    parsed = check_ros_trajectory(response.json(), rest_to_rest=True)
    q = parsed.positions
    w = np.linspace(0.0, 1.0, 8, endpoint=False)[:, None, None]
    dense = ((1 - w) * q[:-1][None] + w * q[1:][None]).reshape(-1, q.shape[1])
    p = UR5.fk_many(np.vstack([dense, q[-1:]]))[:, :3, 3]
    off_circle = np.hypot(np.linalg.norm((p - c)[:, :2], axis=1) - RADIUS, (p - c)[:, 2])
    assert off_circle.max() <= 1e-3
    # Round the arc, not along the chord: the arc's middle is passed within 5 mm.
    mid = c + Rotation.from_rotvec([0, 0, SWEEP / 2]).apply(T0[:3, 3] - c)
    assert np.linalg.norm(p - mid, axis=1).min() < 5e-3
    np.testing.assert_allclose(UR5.fk(q[0]), T0, atol=1e-9)
    np.testing.assert_allclose(UR5.fk(q[-1])[:3, 3], Tg[:3, 3], atol=1e-6)  # 6-digit pose body
    assert response.json()["diagnostics"]["max_position_deviation"] <= 1e-3


def test_compare_runs_every_method_on_the_arc(client) -> None:
    _, _, c = _case()
    task = {k: v for k, v in _request({"type": "circ", "center": c.tolist()}).items()}
    task.pop("method")
    response = client.post("/v1/compare", json={"task": task, "include_trajectories": True})
    assert response.status_code == 200, response.text
    rows = response.json()["results"] if "results" in response.json() else response.json()["rows"]
    assert len(rows) == 5
    for row in rows:
        assert row.get("error") is None, row
        q = np.array([pt["positions"] for pt in row["trajectory"]["points"]])
        p = UR5.fk_many(q)[:, :3, 3]
        assert np.abs(np.linalg.norm((p - c)[:, :2], axis=1) - RADIUS).max() <= 1e-3, row["method"]


def test_line_is_the_default_and_explicit_line_is_the_same(client) -> None:
    body = _request({"type": "line"})
    explicit = client.post(URL, json=body).json()
    body.pop("path")
    default = client.post(URL, json=body).json()
    assert explicit["points"] == default["points"]


@pytest.mark.parametrize(
    ("path", "loc"),
    [
        ({"type": "circ"}, ["body", "path"]),
        ({"type": "circ", "interim": [0, 0, 0], "center": [0, 0, 0]}, ["body", "path"]),
        ({"type": "line", "center": [0, 0, 0]}, ["body", "path"]),
        ({"type": "spiral"}, ["body", "path", "type"]),
        ({"type": "circ", "center": [0, 0]}, ["body", "path", "center"]),
        ({"type": "circ", "center": [0, 0, 1e9]}, ["body", "path", "center", 2]),
        ({"type": "circ", "radius": 1.0, "center": [0, 0, 0]}, ["body", "path", "radius"]),
    ],
)
def test_malformed_path_is_validation(client, path: dict, loc: list) -> None:
    body = _problem(client.post(URL, json=_request(path)))
    assert any(e["loc"][: len(loc)] == loc for e in body["errors"]), body["errors"]


def test_bad_circle_geometry_is_validation_at_path(client) -> None:
    T0, Tg, c = _case()
    chord_mid = (0.5 * (T0[:3, 3] + Tg[:3, 3])).tolist()
    cases = [
        ({"type": "circ", "interim": chord_mid}, ["body", "path", "interim"]),  # collinear
        (
            {"type": "circ", "center": (c + np.array([3e-4, 0, 0])).tolist()},
            ["body", "path", "center"],
        ),
        ({"type": "circ", "interim": T0[:3, 3].tolist()}, ["body", "path", "interim"]),
    ]
    for path, loc in cases:
        for url, body in ((URL, _request(path)), ("/v1/compare", None)):
            where = loc
            if body is None:  # a compare body holds the Cartesian request at task
                task = _request(path)
                task.pop("method")
                body = {"task": task}
                where = ["body", "task", *loc[1:]]
            problem = _problem(client.post(url, json=body))
            assert problem["errors"][0]["loc"] == where, (url, path, problem)
