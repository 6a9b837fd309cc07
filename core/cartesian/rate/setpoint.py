"""Setpoints of the rate controllers: pose, unit twist d(pose)/ds and s on the path at path-clock
time tau, with s(t) tabulated per control tick (``core.cartesian.rate.control``).

``LineSetpoint`` is the fast case of a straight line (scalar float arithmetic per tick, the unit
twist one constant); ``PathSetpoint`` serves any other ``Path`` (an arc) through its vectorized
``poses``/``derivative``. ``setpoint_for`` picks one.
"""

from __future__ import annotations

import math

import numpy as np

from core.geometry import so3
from core.path import Path
from core.path.line import StraightLine
from core.timing import PathLaw as Profile


def tick_table(timing: Profile, dt: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``s`` at ticks ``0..n+1`` of ``dt`` [s] and the feedforward path rate of each tick [1/s]:
    the mean rate ``(s(t + dt) - s(t)) / dt`` over the tick rather than ``s'(t)`` at its start, so
    the feedforward moves the setpoint exactly one tick on (on a line: position and slerp angle
    are linear in s). ``s'(t)`` lags by ``s'' dt / 2`` while the profile accelerates: the tool fell
    behind the setpoint and the feedback made the lag up at full speed, 0.6 % over the tool's
    speed limit. Never above the profile's peak ``s'`` (a mean of it)."""
    grid = np.arange(n + 3) * dt
    s = timing(grid)
    return s[:-1], np.diff(s) / dt


class LineSetpoint:
    """Pose, unit twist d(pose)/ds and s on a straight line at path-clock time tau (s(t) tabulated
    per tick), in Python floats: per tick this is scalar arithmetic, where numpy's per-call cost
    would dominate (the same IEEE operations in the same order as the array expressions in the
    comments). The unit twist of a line is one constant array (``unit``)."""

    def __init__(self, line: StraightLine, timing: Profile, dt: float, n: int):
        self.s_table, self.sd_table = tick_table(timing, dt, n)
        self.s, self.sd = self.s_table.tolist(), self.sd_table.tolist()
        self.dt, self.end, self.last = dt, n * dt, n  # (len(self.s) - 2)
        self.p0, self.delta_p, theta = line.p0.tolist(), line.delta_p.tolist(), line.angle
        K = so3.skew(line.rotvec / theta) if theta > 0.0 else np.zeros((3, 3))
        # R0 exp(s theta [k]) = R0 + sin(s theta) R0 [k] + (1 - cos(s theta)) R0 [k]^2.
        R0K, R0K2 = line.R0 @ K, line.R0 @ K @ K
        self.theta, self.R0K, self.R0K2, self.line = theta, R0K, R0K2, line
        R = (line.R0.ravel().tolist(), R0K.ravel().tolist(), R0K2.ravel().tolist())
        self.R = list(zip(*R, strict=True))
        self.unit = np.concatenate([line.delta_p, line.R0 @ line.rotvec])  # per unit s' [1/s]
        self.max_unit = self.unit

    def __call__(self, tau: float) -> tuple[float, float, list[float], list[float], np.ndarray]:
        """``(s, s' [1/s], p_d (3 floats), R_d (9 floats, row by row), d(pose)/ds (6,))`` at
        clock time ``tau`` [s] (held after the end)."""
        x = min(tau, self.end) / self.dt
        i = min(int(x), self.last)
        w = x - i
        s = (1.0 - w) * self.s[i] + w * self.s[i + 1]
        sd = (1.0 - w) * self.sd[i] + w * self.sd[i + 1]
        a = s * self.theta
        sn, cs = math.sin(a), 1.0 - math.cos(a)
        p_d = [p + s * d for p, d in zip(self.p0, self.delta_p, strict=False)]  # p0 + s delta_p
        return s, sd, p_d, [r + sn * k + cs * k2 for r, k, k2 in self.R], self.unit

    def block(self, tau: float, count: int) -> tuple[list, list, list, np.ndarray, list]:
        """The setpoints of the next ``count`` ticks from clock time ``tau`` if the clock keeps
        rate 1 (``tau`` advancing by ``dt`` a tick, summed one by one as the loop does), by the
        operations of ``__call__`` on arrays (the same bits): ``s``, ``s'`` and ``p_d`` (lists),
        ``R_d`` ``(count, 3, 3)`` and the unit twists (``count`` times ``unit``)."""
        steps = np.full(count, self.dt)
        steps[0] = tau
        x = np.minimum(np.cumsum(steps), self.end) / self.dt
        i = np.minimum(x.astype(np.int64), self.last)
        w = x - i
        s = (1.0 - w) * self.s_table[i] + w * self.s_table[i + 1]
        sd = (1.0 - w) * self.sd_table[i] + w * self.sd_table[i + 1]
        a = s * self.theta
        sn, cs = np.sin(a)[:, None, None], (1.0 - np.cos(a))[:, None, None]
        R_d = self.line.R0 + sn * self.R0K + cs * self.R0K2
        p_d = self.line.p0 + s[:, None] * self.line.delta_p
        return s.tolist(), sd.tolist(), p_d.tolist(), R_d, [self.unit] * count


class PathSetpoint:
    """``LineSetpoint`` for any ``Path`` (an arc): poses from ``Path.pose``/``Path.poses`` and the unit
    twist d(pose)/ds from ``Path.derivative`` at each tick's s (it turns along an arc)."""

    def __init__(self, path: Path, timing: Profile, dt: float, n: int):
        self.s_table, self.sd_table = tick_table(timing, dt, n)
        self.dt, self.end, self.last, self.path = dt, n * dt, n, path
        rates = path.derivative(np.linspace(0.0, 1.0, 1001))
        self.max_unit = rates[np.argmax(np.linalg.norm(rates, axis=1))]

    def _s(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        i = np.minimum(x.astype(np.int64), self.last)
        w = x - i
        s = (1.0 - w) * self.s_table[i] + w * self.s_table[i + 1]
        return s, (1.0 - w) * self.sd_table[i] + w * self.sd_table[i + 1]

    def __call__(self, tau: float) -> tuple[float, float, list[float], list[float], np.ndarray]:
        """As ``LineSetpoint.__call__``."""
        s, sd = self._s(np.array([min(tau, self.end) / self.dt]))
        T = self.path.pose(float(s[0]))
        unit = self.path.derivative(s)[0]
        return float(s[0]), float(sd[0]), T[:3, 3].tolist(), T[:3, :3].ravel().tolist(), unit

    def block(self, tau: float, count: int) -> tuple[list, list, list, np.ndarray, list]:
        """As ``LineSetpoint.block``; the unit twists differ from tick to tick."""
        steps = np.full(count, self.dt)
        steps[0] = tau
        s, sd = self._s(np.minimum(np.cumsum(steps), self.end) / self.dt)
        T = self.path.poses(s)
        return (
            s.tolist(),
            sd.tolist(),
            T[:, :3, 3].tolist(),
            T[:, :3, :3],
            list(self.path.derivative(s)),
        )


def setpoint_for(path: Path, timing: Profile, dt: float, n: int) -> LineSetpoint | PathSetpoint:
    """The setpoint table of ``path`` under ``timing`` for ``n`` ticks of ``dt`` [s]."""
    if isinstance(path, StraightLine):
        return LineSetpoint(path, timing, dt, n)
    return PathSetpoint(path, timing, dt, n)


FIRST_BLOCK, MAX_BLOCK = 16, 1024
"""Setpoints tabulated per block of ticks: the first after a slowed tick, and the most (doubling)."""


class SetpointClock:
    """The setpoint of each tick on the path clock ``tau`` [s]: tabulated a block of ticks at a
    time (``block``) while the clock runs at rate 1, one by one (``__call__``) after a slowed tick.

    Args:
        setpoint: The path's setpoint table (``setpoint_for``).
        n: Ticks of the run (no block reaches past them).
    """

    def __init__(self, setpoint: LineSetpoint | PathSetpoint, n: int) -> None:
        self.setpoint, self.n, self.tau = setpoint, n, 0.0
        self._nominal, self._at, self._end, self._size = True, 0, 0, FIRST_BLOCK
        self._block: tuple = ()

    def at(self, k: int) -> tuple[float, float, list[float], np.ndarray, np.ndarray]:
        """``(s, s' [1/s], p_d (3 floats), R_d (3, 3), d(pose)/ds (6,))`` at tick ``k``."""
        if self._nominal:
            if k >= self._end:
                count = min(self._size, self.n - k)
                self._block = self.setpoint.block(self.tau, count)
                self._at, self._end, self._size = k, k + count, min(2 * self._size, MAX_BLOCK)
            j = k - self._at
            s, sd, p, R, u = self._block
            return s[j], sd[j], p[j], R[j], u[j]
        s1, sd1, p_d, R_flat, u1 = self.setpoint(self.tau)
        return s1, sd1, p_d, np.array(R_flat).reshape(3, 3), u1

    def advance(self, kappa: float, dt: float) -> None:
        """The clock after a tick of ``dt`` [s] run at rate ``kappa``."""
        self.tau = self.tau + kappa * dt
        if kappa != 1.0:  # the tabulated setpoints no longer apply
            self._nominal, self._end, self._size = False, 0, FIRST_BLOCK
        elif not self._nominal:
            self._nominal = True
