"""CIRC geometry: the arc through an interim point or about a centre, against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from core.errors import InputError
from core.path.arc import Arc


def _pose(p, rotvec=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = p
    return T


def _circle_frame(rng):
    """A random circle: centre, radius, orthonormal in-plane axes u, v."""
    c = rng.uniform(-0.5, 0.5, 3)
    r = rng.uniform(0.05, 0.5)
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    v = np.cross(rng.normal(size=3), u)
    v /= np.linalg.norm(v)
    return c, r, u, v


@pytest.mark.parametrize("seed", range(20))
def test_arc_through_interim_is_the_circle_through_three_points(seed):
    rng = np.random.default_rng(seed)
    c, r, u, v = _circle_frame(rng)
    a0, ai, a1 = np.sort(rng.uniform(0.0, 2 * np.pi - 0.1, 3))
    a0, ai, a1 = 0.0, ai - a0, a1 - a0  # ordered angles: start, interim, goal

    def point(a):
        a = np.asarray(a, dtype=float)[..., None]
        return c + r * (np.cos(a) * u + np.sin(a) * v)

    arc = Arc(_pose(point(a0)), _pose(point(a1)), interim=point(ai))
    assert np.allclose(arc.center, c, atol=1e-9)
    assert arc.theta == pytest.approx(a1, abs=1e-9)
    s = np.linspace(0, 1, 101)
    p = arc.positions(s)
    assert np.allclose(np.linalg.norm(p - c, axis=1), r, atol=1e-12)
    assert np.allclose(p, point(s * a1), atol=1e-9)  # the arc that contains the interim point
    assert np.allclose(arc.positions(np.array([ai / a1]))[0], point(ai), atol=1e-9)
    assert arc.length == pytest.approx(r * a1, rel=1e-12)


def test_arc_about_center_takes_the_shorter_arc_and_hits_its_ends_exactly():
    c = np.array([0.4, 0.1, 0.3])
    p0, p1 = c + np.array([0.1, 0, 0]), c + np.array([0, 0, -0.1])
    arc = Arc(_pose(p0), _pose(p1, (0.3, 0.0, 0.0)), center=c)
    assert arc.theta == pytest.approx(np.pi / 2, abs=1e-12)
    assert np.array_equal(arc.positions(np.array([0.0, 1.0])), [p0, p1])
    mid = arc.positions(np.array([0.5]))[0]
    assert np.allclose(mid, c + 0.1 * np.array([1, 0, -1]) / np.sqrt(2), atol=1e-12)


def test_arc_orientation_is_slerp_and_tangent_matches_finite_differences():
    c = np.zeros(3)
    T0, T1 = _pose([0.2, 0, 0], (0, 0, 0.2)), _pose([0, 0.2, 0], (0.4, -0.1, 0.3))
    arc = Arc(T0, T1, center=c)
    s = np.linspace(0, 1, 11)
    key = Rotation.from_matrix(np.stack([T0[:3, :3], T1[:3, :3]]))
    ref = Slerp([0, 1], key)(s).as_matrix()
    assert np.allclose(arc.rotation_matrices(s), ref, atol=1e-12)
    h = 1e-6
    fd = (arc.positions(s + h) - arc.positions(s - h)) / (2 * h)
    assert np.allclose(arc.tangents(s), fd, atol=1e-7)


def test_deviation_of_points_on_and_off_the_arc():
    c = np.zeros(3)
    arc = Arc(_pose([0.2, 0, 0]), _pose([0, 0.2, 0]), center=c)
    T = arc.poses(np.linspace(0, 1, 7))
    assert np.allclose(arc.deviation(T).position, 0.0, atol=1e-15)
    T[:, 2, 3] += 0.003
    assert np.allclose(arc.deviation(T).position, 0.003, atol=1e-12)


def test_collinear_interim_and_unequal_center_are_validation_errors():
    T0, T1 = _pose([0, 0, 0]), _pose([0.2, 0, 0])
    with pytest.raises(InputError) as err:
        Arc(T0, T1, interim=np.array([0.1, 0.0, 0.0]), field=("segments", 2))
    assert err.value.field == ("segments", 2, "interim")
    with pytest.raises(InputError) as err:
        Arc(T0, T1, center=np.array([0.1005, 0.01, 0.0]))
    assert err.value.field == ("center",)
    with pytest.raises(InputError):  # a half turn: no unique plane
        Arc(T0, T1, center=np.array([0.1, 0.0, 0.0]))
