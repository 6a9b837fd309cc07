"""The straight line: endpoints, slerp on the shorter arc, twist, and closest-point deviation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core.path.line import StraightLine, pose_error


def _pose(p, rotvec):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = p
    return T


@pytest.mark.parametrize("seed", range(20))
def test_endpoints_and_shorter_arc(seed):
    rng = np.random.default_rng(seed)
    T0 = _pose(rng.normal(size=3), rng.normal(size=3))
    T1 = _pose(rng.normal(size=3), rng.normal(size=3))
    line = StraightLine(T0, T1)
    P = line.poses(np.array([0.0, 1.0]))
    assert np.allclose(P[0], T0, atol=1e-12)
    assert np.allclose(P[1], T1, atol=1e-12)
    assert line.angle <= np.pi + 1e-12
    # Orientation at s=0.5 is halfway in angle from both ends.
    mid = line.pose(0.5)
    assert abs(pose_error(mid, T0)[1] - line.angle / 2) < 1e-9
    assert abs(pose_error(mid, T1)[1] - line.angle / 2) < 1e-9


def test_twist_is_the_derivative_of_the_pose():
    rng = np.random.default_rng(3)
    line = StraightLine(
        _pose([0.1, 0.2, 0.3], [0.2, 0.1, -0.3]), _pose([0.5, -0.1, 0.2], [1, 0.5, 0])
    )
    s, h, sdot = 0.37, 1e-6, 2.5
    T_a, T_b = line.pose(s - h), line.pose(s + h)
    v_fd = (T_b[:3, 3] - T_a[:3, 3]) / (2 * h) * sdot
    w_hat = (T_b[:3, :3] - T_a[:3, :3]) / (2 * h) @ line.pose(s)[:3, :3].T * sdot
    w_fd = np.array([w_hat[2, 1], w_hat[0, 2], w_hat[1, 0]])
    tw = line.twist(np.array([sdot]))[0]
    assert np.allclose(tw[:3], v_fd, atol=1e-6)
    assert np.allclose(tw[3:], w_fd, atol=1e-6)
    assert rng is not None


def test_deviation_zero_on_the_line_and_exact_off_it():
    line = StraightLine(_pose([0, 0, 0], [0, 0, 0]), _pose([1, 0, 0], [0, 0, 0.5]))
    s = np.linspace(0, 1, 11)
    dev = line.deviation(line.poses(s))
    assert np.allclose(dev.s, s, atol=1e-12)
    assert np.max(dev.position) < 1e-12 and np.max(dev.orientation) < 1e-12
    T = line.poses(np.array([0.3]))
    T[0, 1, 3] += 0.002  # 2 mm off to the side
    dev = line.deviation(T)
    assert dev.position[0] == pytest.approx(0.002, abs=1e-12)
    assert dev.s[0] == pytest.approx(0.3, abs=1e-12)


def test_pure_rotation_line_uses_orientation_to_find_s():
    line = StraightLine(_pose([0.4, 0, 0.2], [0, 0, 0]), _pose([0.4, 0, 0.2], [0, 0, 1.0]))
    T = line.poses(np.array([0.25]))
    dev = line.deviation(T)
    assert dev.s[0] == pytest.approx(0.25, abs=1e-12)
    assert dev.orientation[0] < 1e-12


def test_position_xy_ignores_z_and_orientation():
    line = StraightLine(_pose([1, 0, 0], [0, 0, 0]), _pose([0, 1, 0.7], [0, 0, 2.0]), "position_xy")
    assert line.T_goal[2, 3] == 0.0 and line.angle == 0.0
    T = line.poses(np.array([0.5]))
    T[0, 2, 3] = 5.0
    T[0, :3, :3] = Rotation.from_rotvec([0, 0, 1.0]).as_matrix()
    dev = line.deviation(T)
    assert dev.position[0] < 1e-12 and dev.orientation[0] == 0.0
