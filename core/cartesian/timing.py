"""The timing of a Cartesian path (line or arc, ``core.path``), shared by every Cartesian method:
s(t) under the task's limits. The path's ``length`` [m] and ``angle`` [rad] turn tool limits into
limits on s.

A Cartesian method decides the path: joint positions q(s) for s in [0, end] (``end`` = 1, or the
planned fraction of a partial plan) and their derivatives dq/ds, d2q/ds2. ``time_path`` decides, in
one place for every method, how fast s advances; the path itself never changes:

The law is ``TIMING_LAWS[task.speed_profile]`` (``core.timing``; the request's ``speed_profile``
names it), fed one ``TimingSpec`` (``task_spec``): with the default ``trapezoidal``,

- ``duration`` given: a quintic rest-to-rest s(t) over it (``core.timing.quintic``). Joint speeds
  |dq/ds| s' must hold at every given s; where they do not, ``JointRateLimit`` names the first such
  s and the shortest duration that would hold (``extra["min_duration"]``): a requested duration is
  never stretched. Joint accelerations over their limits only warn (with the duration that avoids it).
- otherwise: the shortest rest-to-rest s(t) (``core.timing.speed_limited``) under the tool's speed limits
  (``CartesianTask.speeds()``, defaults 0.25 m/s and 1 rad/s) and accelerations
  (``max_linear_acceleration``, ``max_angular_acceleration``; defaults 1 m/s^2 and 2 rad/s^2), and under
  the joints' limits: |dq/ds| s' <= v_max caps s'; with d2q/ds2, half of each joint's acceleration
  limit goes to the curvature term |d2q/ds2| s'^2 (another cap on s') and half to |dq/ds| |s''|
  (a bound on s'' per interval), so |q''| <= a_max at the grid points. The tool slows down only
  where a joint cap binds, and a warning says where and by how much. A cap below
  ``MIN_SPEED_FRACTION`` of the requested path speed is a Type II ``Singularity``: no reasonable
  slow-down keeps the joints within their limits.

``speed_profile="s_curve"`` is the jerk-limited S-curve (``TIMING_LAWS["s_curve"]``:
continuous s'', path jerk within the tool jerk limits): with ``duration`` the S-curve of exactly that
duration; otherwise the shortest S-curve under the tool limits and the smallest joint caps on s' and
|s''| along the path (one bound each, so it is slower than the trapezoid where a joint cap binds
only locally).

``sample_path`` then places the returned points (``samples``: equally spaced in s; else one every
``sample_period`` seconds) and ``timed_trajectory`` turns q(s) into velocities dq/ds s' and
accelerations d2q/ds2 s'^2 + dq/ds s'' by the chain rule, at rest at both ends.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from core.cartesian.task import CartesianTask
from core.errors import Infeasible, InputError, JointRateLimit, Singularity
from core.limits import LIMIT_SLACK
from core.path import Path
from core.timing import TIMING_LAWS, PathLaw, TimingLaw, TimingSpec
from core.timing.caps import joint_speed_cap
from core.timing.quintic import QUINTIC_PEAK_VELOCITY
from core.timing.switch_times import jumps_at, with_switches
from core.trajectory import MAX_DURATION, MAX_POINTS, Trajectory

MIN_SPEED_FRACTION = 1e-3
"""Slowest the joint limits may make the tool, as a share of the requested path speed; below it the
line is a Type II singularity ("no finite slow-down"): the tool would crawl at < 0.1 % of its speed."""
ACCELERATION_SHARE = 0.5
"""Share of each joint's acceleration limit given to the curvature term d2q/ds2 s'^2; the rest
bounds dq/ds s''."""
_CAP_MARGIN = 1.0 - 1e-6
"""Caps are applied slightly tightened so rounding never lands a sample over a limit."""


@dataclass(frozen=True)
class PathTiming:
    """The timing of a path.

    Attributes:
        profile: s(t), rest to rest, from s = 0 to ``end``.
        end: Path parameter reached at the end (the planned fraction of the line).
        warnings: Slow-downs and limits the client should know about.
        slowdown: Smallest ratio of the allowed path speed to the requested one (1.0: none).
    """

    profile: PathLaw
    end: float
    warnings: tuple[str, ...]
    slowdown: float = 1.0

    @property
    def duration(self) -> float:
        return float(self.profile.duration)


def nominal_path_speed(task: CartesianTask, line: Path) -> float:
    """The peak s' [1/s] the task asks for: 1.875 / duration, or the tool speed limits over the
    line's length and angle (``inf`` when no limit applies to this line's motion)."""
    if task.duration is not None:
        return QUINTIC_PEAK_VELOCITY / task.duration
    linear, angular = task.speeds()
    speed = np.inf
    for extent, limit in ((line.length, linear), (line.angle, angular)):
        if limit is not None and extent > 1e-12:
            speed = min(speed, limit / extent)
    return float(speed)


def time_path(
    task: CartesianTask,
    line: Path,
    s: np.ndarray,
    dq_ds: np.ndarray,
    d2q_ds2: np.ndarray | None = None,
    tool_rate: np.ndarray | None = None,
) -> PathTiming:
    """s(t) from 0 to ``s[-1]`` for a path q(s) known at ``s`` (see the module docstring).

    Args:
        task: Gives ``duration`` or the speed limits, and the robot's joint limits.
        line: The line (its length [m] and angle [rad] turn tool limits into s' limits).
        s: Increasing path parameters from 0 to the end, shape ``(K,)``, K >= 2.
        dq_ds: Joint path derivative at ``s`` [rad per unit s], ``(K, dof)``.
        d2q_ds2: Second derivative [rad per unit s^2], ``(K, dof)``, or None to ignore joint
            acceleration limits.
        tool_rate: The tool's actual linear [m] and angular [rad] rates per unit s at ``s``,
            ``(K, 2)``, for a joint path that leaves the line within its tolerance (knot
            splines): the tool speed limits cap s' there too (without ``duration``). None: the
            path is on the line (its length and angle give the rates).

    Raises:
        JointRateLimit: with a fixed duration, a joint speed over its limit (first s).
        Singularity: joints need a slow-down below ``MIN_SPEED_FRACTION``.
    """
    s = np.asarray(s, dtype=float)
    dq_ds = np.asarray(dq_ds, dtype=float)
    if s.ndim != 1 or len(s) < 2 or s[0] != 0.0 or np.any(np.diff(s) <= 0.0):
        raise InputError("the path grid must increase from s = 0 and hold at least 2 points")
    robot = task.robot
    vmax, amax = robot.velocity_limits, robot.acceleration_limits
    d2 = None if d2q_ds2 is None else np.asarray(d2q_ds2, dtype=float)
    if task.duration is not None:
        return _fixed_duration(task, line, float(task.duration), s, dq_ds, d2)
    nominal = nominal_path_speed(task, line)
    linear, angular = task.speeds()
    cap_v = joint_speed_cap(dq_ds, vmax)
    cap_a = np.full(len(s), np.inf)
    acc_cap = None
    if d2 is not None:
        cap_a = np.sqrt(joint_speed_cap(d2, ACCELERATION_SHARE * amax))
        bound = joint_speed_cap(dq_ds, (1.0 - ACCELERATION_SHARE) * amax)
        acc_cap = np.maximum(np.minimum(bound[:-1], bound[1:]), 1e-12)
    cap = np.minimum(cap_v, cap_a)
    if tool_rate is not None:
        cap = np.minimum(cap, _tool_cap(np.asarray(tool_rate, dtype=float), linear, angular))
    floor = MIN_SPEED_FRACTION * nominal if np.isfinite(nominal) else 0.0
    low = cap_v[1:-1] < floor
    if np.any(low):
        i = int(np.argmax(low)) + 1
        raise Singularity(
            f"joint limits would slow the tool below {MIN_SPEED_FRACTION:.1%} of its speed at "
            f"s={s[i]:.4f}: no finite slow-down keeps the joint rates within limits",
            s=float(s[i]),
            extra={"min_speed_fraction": MIN_SPEED_FRACTION},
        )
    spec = replace(
        task_spec(task, line),
        s=s,
        cap=cap * _CAP_MARGIN,
        acceleration_cap=acc_cap,
        end=float(s[-1]),
    )
    profile = law(task)(spec)
    sdot = np.asarray(profile(profile.time_at(s), 1), dtype=float)
    if not profile.duration <= MAX_DURATION:
        raise Infeasible(
            f"the timed line would last {profile.duration:.4g} s, over the {MAX_DURATION:g} s limit",
            s=float(s[-1]),
        )
    warnings, slowdown = _slowdowns(s, sdot, nominal, cap, cap_v, cap_a)
    return PathTiming(profile, float(s[-1]), warnings, slowdown)


def _slowdowns(
    s: np.ndarray,
    sdot: np.ndarray,
    nominal: float,
    cap: np.ndarray,
    cap_v: np.ndarray,
    cap_a: np.ndarray,
) -> tuple[tuple[str, ...], float]:
    """Where a joint cap sets the path speed (the profile rides on it) below the requested one:
    a warning per kind of limit, and the smallest ratio of the allowed speed to the requested."""
    active = (sdot >= cap * _CAP_MARGIN * (1.0 - 1e-3)) & (cap < nominal * (1.0 - 1e-6))
    active[0] = active[-1] = False
    if not (np.any(active) and np.isfinite(nominal)):
        return (), 1.0
    warnings = []
    for name, c in (("velocity", cap_v), ("acceleration", cap_a)):
        binds = active & (c <= cap)
        if np.any(binds):
            k = int(np.argmin(np.where(binds, c, np.inf)))
            warnings.append(
                f"joint {name} limits slow the tool between s={s[binds][0]:.3f} and "
                f"s={s[binds][-1]:.3f} (to {c[k] / nominal:.1%} of the requested speed at "
                f"s={s[k]:.3f}); the path is unchanged"
            )
    return tuple(warnings), float(cap[active].min() / nominal)


def _tool_cap(tool_rate: np.ndarray, linear: float | None, angular: float | None) -> np.ndarray:
    """Largest s' [1/s] at each row of ``tool_rate`` (K, 2) [m, rad per unit s] that keeps the
    tool within the linear and angular speed limits [m/s], [rad/s] (None: no limit)."""
    cap = np.full(len(tool_rate), np.inf)
    for col, limit in ((0, linear), (1, angular)):
        if limit is not None:
            rate = tool_rate[:, col]
            cap = np.minimum(cap, np.where(rate > 1e-12, limit / np.maximum(rate, 1e-12), np.inf))
    return cap


def law(task: CartesianTask) -> TimingLaw:
    """The task's timing law: ``TIMING_LAWS[task.speed_profile]`` (``InputError`` at
    ``speed_profile`` for any other name)."""
    found = TIMING_LAWS.get(task.speed_profile)
    if found is None:
        raise InputError(
            f"speed_profile must be one of {', '.join(TIMING_LAWS)}", field=("speed_profile",)
        )
    return found


def task_spec(task: CartesianTask, line: Path) -> TimingSpec:
    """The ``TimingSpec`` of the task's path: its extent, the tool's speed (defaults when nothing
    times the motion), acceleration and jerk limits, and the task's duration."""
    linear, angular = task.speeds()
    return TimingSpec(
        length=line.length,
        angle=line.angle,
        duration=task.duration,
        max_linear_speed=None if task.duration is not None else linear,
        max_angular_speed=None if task.duration is not None else angular,
        max_linear_jerk=task.max_linear_jerk,
        max_angular_jerk=task.max_angular_jerk,
        max_linear_acceleration=task.max_linear_acceleration,
        max_angular_acceleration=task.max_angular_acceleration,
    )


def fixed_profile(task: CartesianTask, line: Path, T: float, end: float = 1.0) -> PathLaw:
    """s(t) from 0 to ``end`` over exactly ``T`` [s] by the task's law (``trapezoidal``: the
    quintic; ``s_curve``: the canonical S-curve, its jerk within the task's jerk limits, else
    ``Infeasible`` naming the shortest duration)."""
    return law(task)(replace(task_spec(task, line), duration=T, end=end))


def nominal_profile(task: CartesianTask, line: Path) -> PathLaw:
    """s(t) from 0 to 1 under the task's duration or tool limits alone (no joint caps): what the
    rate controllers track (``TIMING_LAWS[task.speed_profile]``)."""
    return law(task)(task_spec(task, line))


def _fixed_duration(
    task: CartesianTask,
    line: Path,
    T: float,
    s: np.ndarray,
    dq_ds: np.ndarray,
    d2: np.ndarray | None,
) -> PathTiming:
    vmax, amax = task.robot.velocity_limits, task.robot.acceleration_limits
    names = task.robot.joint_names
    profile = fixed_profile(task, line, T, float(s[-1]))
    t = profile.time_at(s)
    sdot = profile(t, 1)
    ratio = np.abs(dq_ds) * sdot[:, None] / vmax
    acc = np.zeros_like(ratio)
    if d2 is not None:
        sddot = profile(t, 2)
        acc = np.abs(d2 * (sdot**2)[:, None] + dq_ds * sddot[:, None]) / amax
    # Speeds scale with 1/T, accelerations with 1/T^2: the shortest duration that keeps both.
    enforced_acc = 0.0 if task.allow_violations else float(acc.max())
    min_duration = T * max(float(ratio.max()), float(np.sqrt(enforced_acc)))
    over = ratio > 1.0 + LIMIT_SLACK
    if over.any():
        i = int(np.argmax(over.any(axis=1)))
        j = int(np.argmax(ratio[i]))
        raise JointRateLimit(
            f"with duration={T:g} s joint {names[j]} would move at {ratio[i, j] * vmax[j]:.4g} "
            f"(limit {vmax[j]:.4g}) at s={s[i]:.4f}; this line needs at least "
            f"{min_duration:.4g} s, or give speed limits instead of a duration",
            field=("duration",),
            s=float(s[i]),
            joint=j,
            extra={"min_duration": min_duration},
        )
    warnings = []
    fast = acc > 1.0 + LIMIT_SLACK
    if fast.any():
        i = int(np.argmax(fast.any(axis=1)))
        j = int(np.argmax(acc[i]))
        if not task.allow_violations:
            raise JointRateLimit(
                f"with duration={T:g} s joint {names[j]} would accelerate at "
                f"{acc[i, j]:.3g} times its limit at s={s[i]:.4f}; this line needs at least "
                f"{min_duration:.4g} s, or give speed limits instead of a duration (or set "
                "allow_violations to accept it)",
                field=("duration",),
                s=float(s[i]),
                joint=j,
                extra={"min_duration": min_duration, "limit": "acceleration"},
            )
        warnings.append(
            f"joint accelerations reach {acc.max():.3g} times their limits (first at "
            f"s={s[i]:.3f}); a duration of {T * np.sqrt(acc.max()):.4g} s would keep them"
        )
    return PathTiming(profile, float(s[-1]), tuple(warnings))


def sample_path(task: CartesianTask, timing: PathTiming) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and path parameters of the returned points, both ``(N,)``.

    ``samples`` N: N points equally spaced in s (the notes' N points on the line), timed by s(t);
    otherwise one point every ``sample_period`` [s] (default 0.01 s) and the last at the end, plus
    every time where s'' jumps held by a pair of points 1 us apart and every other switch of s(t)
    (``core.timing.switch_times.with_switches``), so that the trapezoid rule between consecutive
    points integrates the returned accelerations to the returned velocities (issue 26.9).
    """
    end = timing.end
    if task.samples is not None:
        s = np.linspace(0.0, end, int(task.samples))
        times = np.asarray(timing.profile.time_at(s), dtype=float)
    else:
        profile = timing.profile
        switches = np.concatenate([[0.0], profile.switch_times(), [timing.duration]])
        times = with_switches(jumps_at(profile, switches), task.sample_period, None, MAX_POINTS)
        s = np.clip(np.asarray(profile(times), dtype=float), 0.0, end)
    times[0], times[-1] = 0.0, timing.duration
    s[0], s[-1] = 0.0, end
    if np.any(np.diff(times) <= 0.0):
        raise Infeasible(
            "the returned points' times are not strictly increasing; give fewer samples"
        )
    return times, s


def timed_trajectory(
    times: np.ndarray,
    timing: PathTiming,
    positions: np.ndarray,
    dq_ds: np.ndarray,
    d2q_ds2: np.ndarray,
    joint_names: tuple[str, ...] = (),
) -> Trajectory:
    """The trajectory of q(s(t)) at ``times`` (N,): positions ``(N, dof)`` as given, velocities
    dq/ds s' and accelerations d2q/ds2 s'^2 + dq/ds s'' (chain rule); zero velocity at both ends."""
    sdot = np.asarray(timing.profile(times, 1), dtype=float)
    sddot = np.asarray(timing.profile(times, 2), dtype=float)
    sdot[0] = sdot[-1] = 0.0
    velocities = dq_ds * sdot[:, None]
    accelerations = d2q_ds2 * (sdot**2)[:, None] + dq_ds * sddot[:, None]
    return Trajectory(
        times=np.asarray(times, dtype=float),
        positions=np.asarray(positions, dtype=float),
        velocities=velocities,
        accelerations=accelerations,
        joint_names=tuple(joint_names),
    )
