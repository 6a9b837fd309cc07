"""Every registry reaches the API with no other edit (issue 23): a throwaway entry put into
``METHODS``, ``PATHS``, ``TIMING_LAWS`` or ``PROFILES`` (monkeypatched, so it is gone after the
test) is in ``/openapi.json``, accepted over HTTP, and actually used (a spy counts its calls) -
for Cartesian requests and, where programs take the registry's names, in program segments (a
Cartesian method added to METHODS plans a program LIN: was 422)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from core.cartesian.methods import METHODS
from core.cartesian.methods.sampled import plan_sampled
from core.joint.profiles import PROFILES
from core.joint.profiles.polynomial import Quintic
from core.path import PATHS, line
from core.timing import TIMING_LAWS, trapezoidal
from robots import registry
from service.app import create_app
from service.schemas.common import Pose

UR5 = registry.get("ur5")
HOME = UR5.home.tolist()


def goal(offset: Any) -> dict:
    T = UR5.fk(UR5.home)
    T[:3, 3] += offset
    return Pose.from_matrix(T).model_dump()


CARTESIAN = {"robot": "ur5", "start": {"positions": HOME}, "goal": {"pose": goal([0.1, 0.0, 0.0])},
             "method": "sampled"}  # fmt: skip


def spy(target: Callable[..., Any], calls: list[Any]) -> Callable[..., Any]:
    def wrapped(*args: Any, **kwargs: Any) -> Any:
        calls.append(args)
        return target(*args, **kwargs)

    return wrapped


def enum_of(schema: dict, model: str, field: str) -> list[str]:
    """The ``enum`` of ``model.field`` in an OpenAPI document (a plain or optional field)."""
    prop = schema["components"]["schemas"][model]["properties"][field]
    if "enum" in prop:
        return prop["enum"]
    return next(s["enum"] for s in prop.get("anyOf", []) if "enum" in s)


@pytest.fixture
def client() -> TestClient:
    return TestClient(create_app())  # a fresh app: its OpenAPI document is built anew


def test_a_method_added_to_methods_plans_lines_and_program_segments(client, monkeypatch):
    calls: list[Any] = []
    monkeypatch.setitem(METHODS, "sampled_twin", spy(plan_sampled, calls))
    assert "sampled_twin" in enum_of(
        client.get("/openapi.json").json(), "CartesianRequest", "method"
    )
    r = client.post("/v1/trajectories/cartesian", json={**CARTESIAN, "method": "sampled_twin"})
    assert r.status_code == 200, r.text
    assert r.json()["diagnostics"]["method"] == "sampled_twin" and len(calls) == 1
    segment = {"type": "lin", "goal": {"pose": goal([0.1, 0.0, 0.0])}, "method": "sampled_twin"}
    program = {"robot": "ur5", "start": {"positions": HOME}, "segments": [segment]}
    r = client.post("/v1/trajectories/program", json=program)
    assert r.status_code == 200, r.text
    assert r.json()["segments"][0]["diagnostics"]["method"] == "sampled_twin" and len(calls) == 2


def test_a_path_added_to_paths_is_accepted_and_built(client, monkeypatch):
    calls: list[Any] = []
    monkeypatch.setitem(PATHS, "line_twin", spy(line, calls))
    assert "line_twin" in enum_of(client.get("/openapi.json").json(), "PathShape", "type")
    r = client.post("/v1/trajectories/cartesian", json={**CARTESIAN, "path": {"type": "line_twin"}})
    assert r.status_code == 200, r.text
    assert calls  # built through the registry
    assert r.json()["diagnostics"]["max_position_deviation"] < 1e-3


def test_a_timing_law_added_to_timing_laws_times_lines_and_program_stretches(client, monkeypatch):
    calls: list[Any] = []
    monkeypatch.setitem(TIMING_LAWS, "trapezoidal_twin", spy(trapezoidal, calls))
    names = enum_of(client.get("/openapi.json").json(), "CartesianRequest", "speed_profile")
    assert "trapezoidal_twin" in names
    body = {**CARTESIAN, "speed_profile": "trapezoidal_twin"}
    r = client.post("/v1/trajectories/cartesian", json=body)
    assert r.status_code == 200, r.text
    assert calls and all(spec.path is None for (spec,) in calls)
    calls.clear()
    segment = {"type": "lin", "goal": {"pose": goal([0.1, 0.0, 0.0])},
               "speed_profile": "trapezoidal_twin"}  # fmt: skip
    program = {"robot": "ur5", "start": {"positions": HOME}, "segments": [segment]}
    r = client.post("/v1/trajectories/program", json=program)
    assert r.status_code == 200, r.text
    assert any(spec.path is not None for (spec,) in calls)  # the program's stretch, timed by it
    assert r.json()["segments"][0]["diagnostics"]["timing"] == "trapezoidal_twin"


class QuinticTwin(Quintic):
    name = "quintic_twin"


def test_a_profile_added_to_profiles_times_joint_moves_and_program_ptps(client, monkeypatch):
    twin = QuinticTwin()
    calls: list[Any] = []
    monkeypatch.setattr(twin, "timed", spy(twin.timed, calls))
    monkeypatch.setitem(PROFILES, "quintic_twin", twin)
    schema = client.get("/openapi.json").json()
    assert "quintic_twin" in enum_of(schema, "JointTrajectoryRequest", "profile")
    goal_q = (np.array(HOME) + 0.2).tolist()
    move = {"robot": "ur5", "profile": "quintic_twin", "start": {"positions": HOME},
            "goal": {"positions": goal_q}}  # fmt: skip
    r = client.post("/v1/trajectories/joint", json=move)
    assert r.status_code == 200, r.text
    assert r.json()["diagnostics"]["method"] == "quintic_twin" and len(calls) == 1
    ptp = {"type": "ptp", "goal": {"positions": goal_q}, "profile": "quintic_twin"}
    program = {"robot": "ur5", "start": {"positions": HOME}, "segments": [ptp]}
    r = client.post("/v1/trajectories/program", json=program)
    assert r.status_code == 200, r.text
    assert r.json()["segments"][0]["diagnostics"]["timing"] == "quintic_twin" and len(calls) == 2


def test_an_unknown_name_is_validation_naming_the_registry(client):
    r = client.post("/v1/trajectories/cartesian", json={**CARTESIAN, "method": "nope"})
    assert r.status_code == 422
    err = r.json()
    assert err["errors"][0]["loc"] == ["body", "method"]
    assert all(name in err["errors"][0]["msg"] for name in METHODS)
