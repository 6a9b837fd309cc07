"""Control runs whose ticks are pinned to recorded outputs (``reference_runs.npz``).

The outputs were recorded from ``core.cartesian.rate.control.simulate`` before the per-tick
bookkeeping was cut (issue 19, P5); ``test_reference_runs`` holds every later version to them.
Record again (only after a deliberate change of behaviour) with
``python -m tests.core.cartesian.rate.scenarios``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from core.cartesian.rate.control import RateRun, simulate
from core.cartesian.task import CartesianTask
from tests.core.conftest import xy
from tests.toy_kinematics import ToyPlanar2R

REFERENCE = Path(__file__).with_name("reference_runs.npz")
FIELDS = (
    "positions", "rates", "s", "sigma", "damping", "time_scale", "active", "iterations",
    "tracking_position", "tracking_orientation",
)  # fmt: skip
"""The arrays of a ``RateRun`` compared (``solve_time`` is a wall time)."""


def _line(name: str, duration: float) -> CartesianTask:
    """bench/rate.py's line: 15 cm and 0.4 rad from the robot's home."""
    from robots import registry

    robot = registry.get(name)
    T0 = robot.fk(robot.home)
    T_goal = T0.copy()
    T_goal[:3, 3] += [0.15, -0.1, 0.1]
    T_goal[:3, :3] = Rotation.from_rotvec([0.2, 0.1, -0.3]).as_matrix() @ T0[:3, :3]
    return CartesianTask(robot, robot.home, T_goal, duration=duration)


def _puma_wrist() -> CartesianTask:
    from robots import registry

    robot = registry.get("puma560")
    q_start = np.array([0.0, 0.6, -2.6, 0.3, 0.25, 0.0])
    T_goal = robot.fk(np.array([0.2, 0.7, -2.4, 0.32, -0.25, 0.0]))
    return CartesianTask(robot, q_start, T_goal, duration=2.0, allow_violations=True)


class _LimitedToy(ToyPlanar2R):
    def __init__(self) -> None:
        super().__init__()
        self.position_limits = np.array([[-np.pi, np.pi], [0.8, np.pi]])


def _toy(goal, duration: float, robot=None, q_start=(0.3, 1.2)) -> CartesianTask:
    robot = robot or ToyPlanar2R()
    T_goal = goal if isinstance(goal, np.ndarray) else xy(*goal)
    return CartesianTask(
        robot, np.array(q_start, dtype=float), T_goal, duration=duration, allow_violations=True
    )


SCENARIOS: dict[str, tuple[Callable[[], CartesianTask], str]] = {
    "ur5_1s_dls": (lambda: _line("ur5", 1.0), "resolved_rate_dls"),
    "ur5_1s_pinv": (lambda: _line("ur5", 1.0), "resolved_rate"),
    "panda_1s_dls": (lambda: _line("panda", 1.0), "resolved_rate_dls"),
    "panda_1s_pinv": (lambda: _line("panda", 1.0), "resolved_rate"),
    "puma_wrist_dls": (_puma_wrist, "resolved_rate_dls"),
    "puma_wrist_pinv": (_puma_wrist, "resolved_rate"),
    "toy_limit_dls": (
        lambda: _toy(_LimitedToy().fk(np.array([0.2, 0.4])), 2.0, robot=_LimitedToy()),
        "resolved_rate_dls",
    ),
    "toy_fast_dls": (lambda: _toy((-0.6, 1.0), 0.3), "resolved_rate_dls"),
    "toy_outside_dls": (lambda: _toy((1.5, 1.2), 2.0), "resolved_rate_dls"),
    "toy_outside_pinv": (lambda: _toy((1.5, 1.2), 2.0), "resolved_rate"),
    "toy_singular_dls": (lambda: _toy((1.2, 0.3), 1.0, q_start=(0.0, 0.0)), "resolved_rate_dls"),
}
"""Name -> (task builder, method): free tracking on the UR5 and the Panda, the PUMA's wrist
singularity, a joint pinned at its position limit, velocity limits slowing the path clock, a goal
outside the workspace, a singular start (2R toy: the ``position_xy`` task rows)."""


def run(name: str) -> RateRun:
    build, method = SCENARIOS[name]
    return simulate(build(), method)


STRIDE = 4
"""Every ``STRIDE``-th tick and the last one are recorded (Euler carries any change forward)."""


def _thin(a: np.ndarray) -> np.ndarray:
    if len(a) == 0:
        return a
    return np.concatenate([a[::STRIDE], a[-1:]])


def summary(r: RateRun) -> dict[str, np.ndarray]:
    """The compared arrays and scalars of a run (failure as its class name and s)."""
    out = {f: _thin(np.asarray(getattr(r, f))) for f in FIELDS}
    out["ticks"] = np.array(len(r.s))
    out["dt"] = np.array(r.dt)
    out["nominal_ticks"] = np.array(r.nominal_ticks)
    out["fallbacks"] = np.array(r.fallbacks)
    failure = r.failure
    out["failure"] = np.array("" if failure is None else type(failure).__name__)
    out["failure_s"] = np.array(np.nan if failure is None else float(failure.s))
    return out


def record() -> None:
    arrays = {}
    for name in SCENARIOS:
        for key, value in summary(run(name)).items():
            arrays[f"{name}/{key}"] = value
    np.savez_compressed(REFERENCE, **arrays)


if __name__ == "__main__":
    record()
