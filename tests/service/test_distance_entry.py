"""Issue 26.5: ``/v1/distance`` and ``/v1/robots/{name}/distance`` pass the entry checks and the
deadline of every planning route. Positions outside the joint limits were a 200; a fresh 64-joint
inline URDF with 128 spheres and 256 obstacles cost 2.1 CPU-s with no budget at all."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from core.limits import LIMIT_SLACK
from service.app import create_app
from service.settings import Settings
from tests.service.helpers import needs_registry, problem

UR5 = [0.0, -1.5, 1.5, -1.5, -1.5, 0.0]
UR5_LIMIT = 2 * math.pi
"""The UR5's position limit of every joint [rad] (the datasheet's +-2 pi)."""


def chain_urdf(joints: int = 64, spheres: int = 128) -> str:
    """A serial chain of ``joints`` revolute joints carrying ``spheres`` collision spheres."""
    links, chain = ['<link name="base_link"/>'], []
    for i in range(joints):
        geometry = "".join(
            f'<collision><origin xyz="0 0 {0.05 * k}"/><geometry><sphere radius="0.02"/>'
            "</geometry></collision>"
            for k in range(spheres // joints)
        )
        links.append(f'<link name="l{i}">{geometry}</link>')
        parent = "base_link" if i == 0 else f"l{i - 1}"
        chain.append(
            f'<joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="l{i}"/>'
            f'<origin xyz="0 0 0.1"/><axis xyz="0 {i % 2} {1 - i % 2}"/>'
            '<limit lower="-3" upper="3" velocity="1" effort="1"/></joint>'
        )
    return '<robot name="chain">' + "".join(links) + "".join(chain) + "</robot>"


OBSTACLES = [
    {
        "name": f"o{k}",
        "shape": {"type": "sphere", "radius": 0.01},
        "pose": {"position": [0.3 + 0.01 * k, 0.0, 0.0], "orientation": [0.0, 0.0, 0.0, 1.0]},
    }
    for k in range(256)
]


@needs_registry
@pytest.mark.parametrize("url", ["/v1/robots/ur5/distance", "/v1/distance"])
@pytest.mark.parametrize("excess", [0.5 * LIMIT_SLACK, 1e-6, 1.0])
def test_positions_outside_the_limits_as_every_planning_route(
    client: TestClient, url: str, excess: float
) -> None:
    """The same positions, the same verdict as a joint move starting there (one core check, one
    slack): within the slack a 200, past it 422 ``joint_limit`` naming ``positions.1``."""
    q = [*UR5]
    q[1] = -UR5_LIMIT - excess
    body = {"positions": q, **({"robot": "ur5"} if url == "/v1/distance" else {})}
    answer = client.post(url, json=body)
    move = {"robot": "ur5", "profile": "quintic", "start": {"positions": q},
            "goal": {"positions": UR5}, "duration": 10.0, "samples": 3}  # fmt: skip
    planned = client.post("/v1/trajectories/joint", json=move)
    assert answer.status_code == planned.status_code, (answer.text, planned.text)
    if excess > LIMIT_SLACK:
        err = problem(answer, 422, "joint_limit")
        assert err["joint"] == 1 and err["errors"][0]["loc"] == ["body", "positions", 1], err
        assert err["joint_name"] == "shoulder_lift_joint"
        assert err["limits"] == pytest.approx([-UR5_LIMIT, UR5_LIMIT])


@needs_registry
def test_wrong_length_is_validation(client: TestClient) -> None:
    err = problem(client.post("/v1/distance", json={"robot": "ur5", "positions": [0.0]}), 422,
                  "validation")  # fmt: skip
    assert err["errors"][0]["loc"] == ["body", "positions"]


@pytest.fixture
def hurried() -> Iterator[TestClient]:
    """A service whose time budget is spent before any stage of a distance query ends."""
    with TestClient(create_app(Settings(time_budget_s=1e-6, access_log=False))) as test_client:
        yield test_client


def test_a_costly_distance_query_has_the_planning_deadline(hurried: TestClient) -> None:
    """The 64-joint chain with 128 spheres among 256 obstacles: 422 ``time_budget_exceeded`` (was a
    200 after 2.1 CPU-s, whatever the budget)."""
    body = {"robot": {"urdf": chain_urdf()}, "positions": [0.1] * 64,
            "environment": {"obstacles": OBSTACLES}}  # fmt: skip
    err = problem(hurried.post("/v1/distance", json=body), 422, "time_budget_exceeded")
    assert err["budget_s"] == 1e-6
