"""``speed_profile`` / ``max_linear_jerk`` / ``max_angular_jerk`` on Cartesian requests over HTTP.

s(t) is recovered from the forward kinematics of the returned joints (the tool point projected on
the line) and differenced: its third differences stay within the path jerk limit and its second
differences change continuously; the joint velocity and acceleration caps still hold.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots import registry
from tests.ros_rules import check_ros_trajectory
from tests.service.conftest import pose_body

URL = "/v1/trajectories/cartesian"
UR5 = registry.get("ur5")
UR5_HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
H = 0.02  # [s] the differencing step: every 5th returned point


def _request(**kw) -> tuple[dict, np.ndarray, np.ndarray]:
    T0 = UR5.fk(np.array(UR5_HOME))
    Tg = T0.copy()
    Tg[:3, 3] += np.array([0.15, -0.1, 0.05])
    body = {
        "robot": "ur5",
        "start": {"positions": UR5_HOME},
        "goal": {"pose": pose_body(Tg)},
        "method": "sampled",
        "sample_period": 0.004,
        **kw,
    }
    return body, T0, Tg


def _differences(client, body, T0, Tg):
    response = client.post(URL, json=body)
    assert response.status_code == 200, response.text
    parsed = check_ros_trajectory(response.json(), rest_to_rest=True)
    d = Tg[:3, 3] - T0[:3, 3]
    s = (UR5.fk_many(parsed.positions)[:, :3, 3] - T0[:3, 3]) @ d / (d @ d)
    s = s[:-1:5]
    length = float(np.linalg.norm(d))
    third = length * np.diff(s, 3) / H**3
    acc_steps = length * np.abs(np.diff(np.diff(s, 2) / H**2))
    return parsed, third, acc_steps


@pytest.mark.parametrize("jerk", [1.0, 4.0])
def test_s_curve_keeps_the_path_jerk_and_the_joint_caps(client, jerk: float) -> None:
    body, T0, Tg = _request(speed_profile="s_curve", max_linear_jerk=jerk)
    parsed, third, acc_steps = _differences(client, body, T0, Tg)
    assert np.abs(third).max() <= jerk * (1 + 2e-3)
    assert np.abs(third).max() >= 0.9 * jerk  # the jerk limit shapes the profile
    assert acc_steps.max() <= jerk * H * (1 + 2e-3)  # s'' continuous
    assert np.all(np.abs(parsed.velocities) <= UR5.velocity_limits * (1 + 1e-6))
    assert np.all(np.abs(parsed.accelerations) <= UR5.acceleration_limits * (1 + 1e-6))


def test_trapezoidal_default_has_acceleration_jumps(client) -> None:
    body, T0, Tg = _request()
    _, _, steps_default = _differences(client, body, T0, Tg)
    body, T0, Tg = _request(speed_profile="trapezoidal")
    _, _, steps_explicit = _differences(client, body, T0, Tg)
    np.testing.assert_array_equal(steps_default, steps_explicit)
    assert steps_default.max() > 5.0 * 4.0 * H  # a jump far beyond a 4 m/s^3 s-curve's


def test_s_curve_on_an_arc(client) -> None:
    body, T0, Tg = _request(speed_profile="s_curve", max_linear_jerk=2.0)
    side = np.cross(Tg[:3, 3] - T0[:3, 3], [0.0, 0.0, 1.0])
    c = 0.5 * (T0[:3, 3] + Tg[:3, 3]) + 0.1 * side / np.linalg.norm(side)  # equidistant
    body["path"] = {"type": "circ", "center": c.tolist()}
    response = client.post(URL, json=body)
    assert response.status_code == 200, response.text
    parsed = check_ros_trajectory(response.json(), rest_to_rest=True)
    p = UR5.fk_many(parsed.positions)[:, :3, 3]
    r = np.linalg.norm(T0[:3, 3] - c)
    assert np.abs(np.linalg.norm(p - c, axis=1) - r).max() <= 1e-3
    # Arc length travelled from the angle about the centre: its jerk within the limit.
    u = (T0[:3, 3] - c) / r
    n = np.cross(T0[:3, 3] - c, Tg[:3, 3] - c)
    v = np.cross(n / np.linalg.norm(n), u)
    arc = r * np.arctan2((p - c) @ v, (p - c) @ u)[:-1:5]
    assert np.abs(np.diff(arc, 3) / H**3).max() <= 2.0 * (1 + 5e-3)


@pytest.mark.parametrize(
    ("change", "loc"),
    [
        ({"speed_profile": "bang_bang"}, ["body", "speed_profile"]),
        ({"max_linear_jerk": 0.0}, ["body", "max_linear_jerk"]),
        ({"max_linear_jerk": -1.0}, ["body", "max_linear_jerk"]),
        ({"max_linear_jerk": 1e5}, ["body", "max_linear_jerk"]),
        ({"max_angular_jerk": 1e6}, ["body", "max_angular_jerk"]),
        ({"max_angular_jerk": "fast"}, ["body", "max_angular_jerk"]),
    ],
)
def test_bad_profile_fields_are_validation(client, change: dict, loc: list) -> None:
    body, _, _ = _request(**{"speed_profile": "s_curve", **change})
    response = client.post(URL, json=body)
    assert response.status_code == 422, response.text
    problem = response.json()
    assert problem["code"] == "validation"
    assert any(e["loc"][: len(loc)] == loc for e in problem["errors"]), problem["errors"]


def test_s_curve_with_a_duration_lasts_exactly_that(client) -> None:
    body, _, _ = _request(speed_profile="s_curve", duration=2.0)
    response = client.post(URL, json=body)
    assert response.status_code == 200, response.text
    assert check_ros_trajectory(response.json(), rest_to_rest=True).times[-1] == 2.0
