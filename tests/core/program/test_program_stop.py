"""The program's collision stage (``core.program.stop``): the stop before a contact is tried
earlier while its re-check finds a contact, and the moving cut is the answer when no stop is clear
or the time budget is spent. The clearance object is a stand-in whose contacts are scripted; the
stop itself is the program's own ``rest_at`` (checked against its path in test_program.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from core.collisions import MOVING_END, STOP_TRIES
from core.errors import Collision, TimeBudgetExceeded
from core.program import stop
from core.program.assemble import assemble, rest_at, sample
from core.program.segments import ProgramTask, Segment
from core.program.timed import timed_program
from robots import registry

UR5 = registry.get("ur5")
HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])


@dataclass(frozen=True)
class Found:
    time: float
    links: tuple[str, str]
    distance: float
    index: int


@dataclass(frozen=True)
class Checked:
    contact: Found | None
    min_clearance: float
    closest: tuple[tuple[str, str], float] | None


class Scripted:
    """A ``Clearance`` whose continuous checks answer from a script: the first ``contacts``
    checks find a contact at 60 % of the motion, the later ones none."""

    pair_names: ClassVar[list[tuple[str, str]]] = [("tool", "ball")]
    threshold = np.zeros(1)
    motion_weights = np.ones((1, 6))

    def __init__(self, contacts: int) -> None:
        self.left = contacts
        self.checked: list[float] = []

    def distances(self, qs: np.ndarray) -> np.ndarray:
        return np.ones((len(qs), 1))

    def check_path(self, times: np.ndarray, qs: np.ndarray) -> Checked:
        self.checked.append(float(times[-1]))
        if self.left > 0:
            self.left -= 1
            k = int(0.6 * (len(times) - 1))
            return Checked(Found(float(times[k]) + 1e-6, ("tool", "ball"), -1e-3, k), -1e-3, None)
        return Checked(None, 1.0, (("tool", "ball"), 0.0))

    def close_pairs(self, q, d_influence):  # pragma: no cover - not used by the check
        raise NotImplementedError


def timed(check: Scripted):
    goal = UR5.fk(HOME)
    goal[:3, 3] += [0.1, 0.0, 0.0]
    task = ProgramTask(
        UR5, HOME, (Segment("lin", goal_pose=goal),), allow_partial=True, collision_check=check
    )
    return timed_program(task)


def test_each_stop_whose_check_finds_a_contact_is_tried_earlier(monkeypatch):
    asked: list[float] = []

    def spy(program, t, failure):
        asked.append(t)
        return rest_at(program, t, failure)

    monkeypatch.setattr(stop, "rest_at", spy)
    check = Scripted(contacts=3)  # the plan and the first two stops
    program = timed(check)
    whole = assemble(program)
    out = stop.collide(program, whole)
    k = int(0.6 * (len(whole.trajectory.times) - 1))
    end = float(whole.trajectory.times[k])
    assert asked == pytest.approx([end, 0.9 * end, 0.81 * end], rel=1e-12)
    assert isinstance(out.failure, Collision) and out.failure.extra["segment"] == 0
    q_there = sample(program.timings, np.array([0.81 * end]))[0][0]
    np.testing.assert_allclose(out.trajectory.positions[-1], q_there, atol=1e-12)
    assert np.array_equal(out.trajectory.velocities[-1], np.zeros(6))
    assert MOVING_END not in out.warnings and out.clearance is not None


def test_no_clear_stop_or_no_time_left_keeps_the_moving_cut(monkeypatch):
    check = Scripted(contacts=1 + STOP_TRIES)  # the plan and every stop
    program = timed(check)
    whole = assemble(program)
    out = stop.collide(program, whole)
    k = int(0.6 * (len(whole.trajectory.times) - 1))
    assert len(out.trajectory.times) == k + 1 and MOVING_END in out.warnings
    assert np.any(out.trajectory.velocities[-1])
    assert len(check.checked) == 1 + STOP_TRIES + 1  # the plan, the stops, the cut

    def expired(program, t, failure):
        raise TimeBudgetExceeded("bringing the program to rest exceeded the budget")

    monkeypatch.setattr(stop, "rest_at", expired)
    again = timed(Scripted(contacts=1))
    out = stop.collide(again, assemble(again))
    assert MOVING_END in out.warnings
