"""A malformed number in an inline URDF's ``<collision>`` is 422 ``invalid_urdf`` naming the element,
on every endpoint that reads the collision geometry (it answered 500 for ``xyz="abc 0 0"``)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from tests.service.helpers import problem


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def urdf_with(collision: str) -> str:
    return f"""<robot name="arm"><link name="base"/>
      <link name="l1"><collision>{collision}</collision></link>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1"/></joint></robot>"""


BAD = [
    ('<origin xyz="abc 0 0"/><geometry><sphere radius="0.1"/></geometry>', "origin xyz"),
    ('<origin rpy="0 nan 0"/><geometry><sphere radius="0.1"/></geometry>', "origin rpy"),
    ('<origin xyz="1 2"/><geometry><sphere radius="0.1"/></geometry>', "origin xyz"),
    ('<origin xyz="1e999 0 0"/><geometry><sphere radius="0.1"/></geometry>', "origin xyz"),
    ('<origin xyz="2e4 0 0"/><geometry><sphere radius="0.1"/></geometry>', "origin"),
    ('<geometry><box size="a b c"/></geometry>', "box size"),
    ('<geometry><box size="0.1 0.1"/></geometry>', "box size"),
    ('<geometry><cylinder radius="x" length="0.1"/></geometry>', "cylinder radius"),
    ('<geometry><cylinder radius="0.1"/></geometry>', "cylinder length"),
    ('<geometry><sphere radius="1e999"/></geometry>', "sphere radius"),
    ('<geometry><sphere radius="-1"/></geometry>', "sphere"),
]


@pytest.mark.parametrize(("collision", "named"), BAD)
def test_malformed_collision_numbers_are_invalid_urdf(client, collision: str, named: str) -> None:
    robot = {"urdf": urdf_with(collision), "tip_frame": "l1", "base_frame": "base"}
    requests = [
        ("/v1/distance", {"robot": robot, "positions": [0.0]}),
        ("/v1/robots/describe", {"robot": robot}),
        (
            "/v1/trajectories/joint",
            {"robot": robot, "profile": "quintic", "start": {"positions": [0.0]},
             "goal": {"positions": [0.5]}},
        ),
    ]  # fmt: skip
    for path, body in requests:
        err = problem(client.post(path, json=body), 422, "invalid_urdf")
        assert named in err["detail"] and "link 'l1'" in err["detail"], (path, err["detail"])
        assert err["errors"][0]["loc"] == ["body", "robot", "urdf"]
