"""Avoidance in the knot NLP: the linearized clearance rows (``core.clearance``) against central
finite differences of the checker's closed-form distances, and their place in the NLP's constraints."""

from __future__ import annotations

import numpy as np

from core.clearance import Clearance, clearance_ok, linearized_clearance_rows, stacked_rows
from robots import registry
from robots.collision import CollisionChecker, Obstacle, robot_setup

UR5 = registry.get("ur5")


def ball_checker(center, radius: float, clearance: float) -> CollisionChecker:
    geometry, allowed = robot_setup(UR5)
    T = np.eye(4)
    T[:3, 3] = center
    ball = Obstacle("ball", "sphere", radius=radius, T_base_obstacle=T)
    return CollisionChecker(
        UR5, geometry, [ball], clearance=clearance, self_collision=False, allowed_self=allowed
    )


def test_rows_are_the_distance_gradients() -> None:
    q = UR5.home
    tool = UR5.fk(q)[:3, 3]
    check = ball_checker(tool + np.array([-0.1, 0.0, -0.02]), 0.05, 0.01)
    assert isinstance(check, Clearance)
    qs = np.vstack([q, q + 0.01])
    index, G, lb = linearized_clearance_rows(check, qs, margin=0.002, influence=0.05)
    assert len(index) > 0 and set(index) <= {0, 1}
    d0 = check.distances(qs)
    for i, j in enumerate(index):
        # which pair: the one whose gradient this is (distance within the influence)
        eps = 1e-6
        fd = np.array(
            [
                (
                    check.distances((qs[j] + eps * e)[None])[0]
                    - check.distances((qs[j] - eps * e)[None])[0]
                )
                / (2 * eps)
                for e in np.eye(UR5.dof)
            ]
        )  # (dof, P)
        # the row is the unit gradient of one pair's distance
        norms = np.linalg.norm(fd, axis=0)
        match = [
            p
            for p in range(check.n_pairs)
            if norms[p] > 1e-9 and np.allclose(G[i], fd[:, p] / norms[p], atol=1e-5)
        ]
        assert match, (i, G[i])
        p = match[0]
        np.testing.assert_allclose(
            lb[i], (0.01 + 0.002 - d0[j, p]) / norms[p] + G[i] @ qs[j], atol=1e-6
        )


def test_rows_land_on_their_check_in_the_nlp() -> None:
    index = np.array([0, 2])
    G = np.array([[1.0, 2.0], [3.0, 4.0]])
    W, lb = stacked_rows((index, G, np.array([0.5, 0.6])), m=3, dof=2)
    qc = np.array([[1.0, 1.0], [5.0, 5.0], [-1.0, 2.0]])  # (M, dof), vec column-major of (dof, M)
    np.testing.assert_allclose(W @ qc.ravel(), [3.0, 5.0], atol=1e-12)
    np.testing.assert_allclose(lb, [0.5, 0.6])
    assert stacked_rows(None, 3, 2)[0] is None


def test_clearance_ok_uses_the_thresholds() -> None:
    tool = UR5.fk(UR5.home)[:3, 3]
    check = ball_checker(tool + np.array([-0.2, 0.0, 0.0]), 0.05, 0.01)
    d = check.distances(UR5.home[None])[0]
    assert d.min() > 0.01
    assert clearance_ok(check, UR5.home[None])
    assert not clearance_ok(check, UR5.home[None], margin=float(d.min()) - 0.01 + 1e-6)
