"""Issue 26.9: a Panda (redundant) ``sampled`` or ``bounded_deviation`` line answers velocities and
accelerations that are the derivatives of its own positions between the returned points: the
trapezoid rule between consecutive points integrates the returned accelerations to the returned
velocities (switch times of s(t) held by a pair of points, as on the joint and collision-free
routes), and the returned velocities to the returned positions (IK seeded on the integral curve of
dq/ds = J^+ V(s), so the null-space motion does not drift off what the velocities describe). The
positions themselves are checked against the path by pinocchio, independently of the service."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from robots import registry
from service.app import create_app

PANDA = registry.get("panda")
URL = "/v1/trajectories/cartesian"


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def request(method: str) -> dict:
    T0 = PANDA.fk(PANDA.home)
    R = Rotation.from_rotvec([0.0, 0.0, 0.6]) * Rotation.from_matrix(T0[:3, :3])
    goal = {
        "position": (T0[:3, 3] + [0.1, 0.15, -0.1]).tolist(),
        "orientation": R.as_quat().tolist(),
    }
    return {
        "robot": "panda",
        "start": {"positions": PANDA.home.tolist()},
        "goal": {"pose": goal},
        "method": method,
    }


@pytest.mark.parametrize("method", ["sampled", "bounded_deviation"])
def test_returned_rates_integrate_to_the_returned_motion(client, method):
    """Was 2.1e-3 rad/s (velocities from accelerations) and 1.9e-5 rad (positions from
    velocities) on this line; the tool stays on the line (pinocchio FK) at every point."""
    r = client.post(URL, json=request(method))
    assert r.status_code == 200, r.text
    p = r.json()["points"]
    t = np.array([x["time_from_start"] for x in p])
    q, v, a = (np.array([x[k] for x in p]) for k in ("positions", "velocities", "accelerations"))
    h = np.diff(t)[:, None]
    assert np.abs(np.diff(v, axis=0) - 0.5 * (a[1:] + a[:-1]) * h).max() <= 1e-5
    assert np.abs(np.diff(q, axis=0) - 0.5 * (v[1:] + v[:-1]) * h).max() <= 2e-6
    model = PANDA.model
    data = model.createData()
    frame = model.getFrameId(PANDA.tip_frame)
    start, end = PANDA.fk(PANDA.home)[:3, 3], np.array(request(method)["goal"]["pose"]["position"])
    u = (end - start) / np.linalg.norm(end - start)
    for qi in q:
        pin.framesForwardKinematics(model, data, qi)
        x = data.oMf[frame].translation - start
        assert np.linalg.norm(x - (x @ u) * u) <= 1.1e-3  # default tolerance 1 mm
