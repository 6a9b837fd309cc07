"""POST /v1/compare: a row per method, failures isolated in their rows, bad tasks rejected whole."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from core.cartesian.methods import METHODS
from robots import registry
from service.app import create_app
from tests.service.conftest import pose_body


def _ur5_task(**extra):
    ur5 = registry.get("ur5")
    q0 = ur5.home
    T = ur5.fk(q0)
    T[:3, 3] += [0.05, 0.05, -0.03]
    task = {
        "robot": "ur5",
        "start": {"positions": q0.tolist()},
        "goal": {"pose": pose_body(T)},
        "duration": 1.0,
    }
    task.update(extra)
    return task


def test_compare_returns_a_row_per_method_in_order(client):
    r = client.post("/v1/compare", json={"task": _ur5_task(), "include_trajectories": True})
    assert r.status_code == 200, r.text
    rows = r.json()["results"]
    assert [row["method"] for row in rows] == list(METHODS)
    for row in rows:
        assert row["ok"], row
        diag = row["diagnostics"]
        assert diag["method"] == row["method"]
        assert diag["fraction"] == pytest.approx(1.0)
        assert diag["max_position_deviation"] <= 1e-3 + 1e-9
        traj = row["trajectory"]
        assert len(traj["points"]) >= 2
        assert np.allclose(traj["points"][-1]["velocities"], 0.0)


def test_one_failing_method_does_not_fail_the_others(client):
    # Planar arm straight through its inner hole (r < 0.2 m): sampled IK fails with unreachable,
    # the bounded-deviation method plans nothing through it either; each row keeps its own outcome.
    arm = registry.get("planar_2r")
    T = np.eye(4)
    T[:3, 3] = [0.6, 0.05, 0.0]
    q0 = arm.ik(T, arm.home).positions
    task = {
        "robot": "planar_2r",
        "start": {"positions": q0.tolist()},
        "goal": {"pose": {"position": [-0.6, -0.05, 0.0], "orientation": [0, 0, 0, 1]}},
        "duration": 4.0,
    }
    methods = ["sampled", "bounded_deviation", "resolved_rate_dls"]
    r = client.post("/v1/compare", json={"task": task, "methods": methods})
    assert r.status_code == 200, r.text
    rows = r.json()["results"]
    assert [row["method"] for row in rows] == methods
    sampled = rows[0]
    assert not sampled["ok"]
    assert sampled["error"]["code"] == "unreachable"
    assert sampled["error"]["s"] == pytest.approx(0.5 - np.sqrt(0.2**2 - 0.0) / 1.2, abs=0.03)
    for row in rows:
        if row["ok"]:
            assert row["diagnostics"]["max_position_deviation"] <= 1e-3 + 1e-9
        else:
            assert row["error"]["status"] == 422 and row["error"]["detail"]


def test_mixed_rows_keep_their_own_outcome(client):
    task = _ur5_task(solver="no_such_solver")
    r = client.post("/v1/compare", json={"task": task, "methods": ["sampled", "resolved_rate_dls"]})
    assert r.status_code == 200, r.text
    rows = {row["method"]: row for row in r.json()["results"]}
    assert rows["sampled"]["ok"]
    assert not rows["resolved_rate_dls"]["ok"]
    assert rows["resolved_rate_dls"]["error"]["code"] == "validation"


@pytest.mark.parametrize(
    ("body", "status", "code"),
    [
        ({"task": {}}, 422, "validation"),
        ({"task": _ur5_task(), "methods": ["sampled", "sampled"]}, 422, "validation"),
        ({"task": _ur5_task(), "methods": ["teleport"]}, 422, "validation"),
        ({"task": _ur5_task(), "surprise": 1}, 422, "validation"),
        ({"task": {**_ur5_task(), "robot": "r2d2"}}, 404, "unknown_robot"),
    ],
)
def test_bad_compare_requests(client, body, status, code):
    r = client.post("/v1/compare", json=body)
    assert r.status_code == status
    assert r.headers["content-type"].startswith("application/problem+json")
    assert r.json()["code"] == code


def test_the_whole_compare_request_shares_one_deadline(monkeypatch):
    """One budget for the request: once a slow first method has spent it, every later method
    answers time_budget_exceeded at once (with a budget per method each would plan in full)."""
    import time as _time

    from core.cartesian import methods
    from service.settings import Settings

    budget = 0.5

    def slow_sampled(task):
        _time.sleep(1.2 * budget)
        return methods.plan_sampled(task)

    monkeypatch.setitem(methods.METHODS, "sampled", slow_sampled)
    with TestClient(create_app(Settings(time_budget_s=budget))) as c:
        started = _time.perf_counter()
        r = c.post("/v1/compare", json={"task": _ur5_task()})
        elapsed = _time.perf_counter() - started
    assert r.status_code == 200, r.text
    rows = r.json()["results"]
    assert [row["method"] for row in rows] == list(METHODS)
    assert all(not row["ok"] for row in rows), rows
    assert {row["diagnostics"]["code"] for row in rows} == {"time_budget_exceeded"}
    assert elapsed < 1.2 * budget + 0.5  # the sleep, then nothing more than error rows
