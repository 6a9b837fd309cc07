"""Effort limits for joint plans that choose their own duration, and the peak effort of any motion.

A motion q(t) slowed uniformly by lambda, q(t / lambda), has the torque ``tau = b / lambda^2 + c``
where ``b = M q'' + C(q, q') q'`` (the torque without gravity of the unscaled motion) and ``c =
g(q)``: each sample and joint needs ``lambda^2 >= b / (tau_max - c)`` (``b > 0``) or ``b / (-tau_max -
c)`` (``b < 0``), and ``|c| <= tau_max`` (gravity alone, whatever the speed). ``shortest_for_effort``
takes the largest such lambda over a dense sampling, with each sampled peak near the limit found
exactly between samples (``core.timing.interval_peaks``), and rebuilds the plan at that duration
(``make(duration)``: a rest-to-rest profile slowed in time, ``TimeScaled``, exact; a plan that
cannot scale (non-zero end velocities) rebuilt for the duration and stretched further until it
keeps the limits). ``peak_effort`` measures |tau| per joint on a motion
at its samples and ``DENSE`` points between consecutive ones. A sampled trajectory (a Cartesian
plan, a collision-free motion) is held to the limits as the motion its points describe
(``HermiteMotion``: the quintic through q, q', q'' of consecutive points), slowed uniformly
(``held_trajectory``, ``slowed``). Units: [N m or N], [s].
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np
from scipy.interpolate import BPoly

from core.budget import NO_DEADLINE, Deadline
from core.errors import Infeasible
from core.joint.durations import MAX_DURATION
from core.kinematics import DEFAULT_GRAVITY, Dynamics
from core.timing.interval_peaks import refine_peaks, sampled_peaks
from core.timing.path_constraints import Effort
from core.trajectory import Peaks, Profile, Trajectory

CHUNK = 8
"""Dense check: chunks of this many sample intervals (peaks estimated per chunk)."""
CHUNKS = 512
"""Chunks over the whole duration."""
DENSE = 3
"""Points between consecutive returned samples where ``peak_effort`` is measured."""
STRETCHES = 20
"""Most rebuilds of a plan that does not scale in time."""
MARGIN = 1e-10
"""Relative room a stretched plan leaves below the effort limits."""
TOLERANCE = 1e-9
"""Relative excess of an effort limit a plan may have before it is slowed (the contract's)."""


class Sampled(Protocol):
    """A motion: ``duration`` [s] and ``sample(t) -> (q, q', q'')``, each ``(K, dof)``."""

    @property
    def duration(self) -> float: ...

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


class TimeScaled:
    """``profile`` (a ``core.trajectory.Profile`` from rest to rest) slowed uniformly to
    ``duration`` [s]: q(t / k), q'(t / k) / k, q''(t / k) / k^2 with k = duration / its own."""

    def __init__(self, profile: Profile, duration: float) -> None:
        self.base = profile
        self.duration = float(duration)
        self.k = self.duration / float(profile.duration)

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        return self.base(np.asarray(t, dtype=float) / self.k, order) / self.k**order

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, qdd = self.base.sample(np.asarray(t, dtype=float) / self.k)
        return q, qd / self.k, qdd / self.k**2

    def peaks(self) -> Peaks:
        p = self.base.peaks()
        return Peaks(p.velocity / self.k, p.acceleration / self.k**2, p.jerk / self.k**3)

    def switch_times(self) -> np.ndarray:
        """The profile's switch times [s], slowed."""
        return self.k * np.asarray(self.base.switch_times(), dtype=float)


def _torques(
    dynamics: Dynamics, motion: Sampled, t: np.ndarray, gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(b, c)`` at times ``t``: the torque without gravity and the gravity torque, ``(K, dof)``."""
    q, qd, qdd = motion.sample(t)
    b = dynamics.inverse_dynamics(q, qd, qdd, np.zeros(3))
    c = dynamics.inverse_dynamics(q, np.zeros_like(q), np.zeros_like(q), gravity)
    return b, c


def _needed(b: np.ndarray, c: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """lambda^2 each sample and joint needs (0 where nothing moves)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(b > 0, b / (limit - c), b / (-limit - c))
    return np.nan_to_num(need, nan=0.0, posinf=0.0, neginf=0.0)


def effort_peak_ratio(
    motion: Sampled,
    effort: Effort,
    names: Sequence[str],
    where: Callable[[float], float] | None = None,
) -> float:
    """The largest |tau| / limit over ``motion``, sampled densely and found exactly near the
    limit. ``Infeasible`` names the joint and ``s`` where gravity alone exceeds its limit: the
    share of the duration there, or ``where`` of it (a path parameter)."""
    n = CHUNK * CHUNKS
    t = np.linspace(0.0, motion.duration, n + 1)
    b, c = _torques(effort.dynamics, motion, t, effort.gravity)
    limit = np.asarray(effort.limits, dtype=float)
    over = np.abs(c) > limit
    if over.any():
        k, j = (int(v) for v in np.argwhere(over)[0])
        share = float(t[k] / motion.duration)
        share = share if where is None else float(where(share))
        raise Infeasible(
            f"gravity alone exceeds the effort limit of joint {names[j]} at s={share:.6g}",
            s=share,
            joint=j,
            extra={"limit": "effort"},
        )
    ratio = np.abs(b + c) / limit
    chunks = np.stack([ratio[i : i + CHUNK + 1] for i in range(0, n, CHUNK)])
    peak, inside = sampled_peaks(chunks)
    near = peak > 1.0 - 1e-6
    if near.any():
        i, r = np.nonzero(near)

        def evaluate(k: np.ndarray, frac: np.ndarray, row: np.ndarray) -> np.ndarray:
            at = (k + frac) * CHUNK * motion.duration / n
            bb, cc = _torques(effort.dynamics, motion, at, effort.gravity)
            pick = np.arange(len(k))
            return np.abs(bb[pick, row] + cc[pick, row]) / limit[row]

        peak[i, r] = np.maximum(peak[i, r], refine_peaks(evaluate, i, r, inside[i, r], CHUNK + 1))
    return float(peak.max())


def shortest_for_effort(
    make: Callable[[float], Sampled],
    duration: float,
    effort: Effort,
    names: Sequence[str],
    deadline: Deadline = NO_DEADLINE,
    where: Callable[[float], float] | None = None,
) -> Sampled:
    """The plan ``make(T)`` with the shortest ``T >= duration`` [s] (the plan's shortest within its
    kinematic limits) whose torque keeps ``effort`` (rules in the module docstring); ``where``
    as ``effort_peak_ratio``'s."""
    motion = make(duration)
    t = np.linspace(0.0, motion.duration, CHUNK * CHUNKS + 1)
    b, c = _torques(effort.dynamics, motion, t, effort.gravity)
    scale2 = max(1.0, float(_needed(b, c, np.asarray(effort.limits, float)).max()))
    last: tuple[float, float] | None = None  # the previous (scale2, worst): a secant step
    for _ in range(STRETCHES):
        stretched = duration * float(np.sqrt(scale2))
        if not stretched <= MAX_DURATION:
            raise Infeasible(
                f"keeping the effort limits needs more than {MAX_DURATION:g} s (gravity takes "
                "nearly all of a joint's effort limit)",
                field=("limits", "effort"),
            )
        candidate = motion if scale2 == 1.0 else make(stretched)
        worst = effort_peak_ratio(candidate, effort, names, where)
        if worst <= 1.0:
            return candidate
        step = scale2 * (4.0 * (worst - 1.0) + MARGIN)
        if last is not None and last[1] > worst:  # the peak falls this fast with scale2
            step = max(step, (scale2 - last[0]) * (worst - 1.0) / (last[1] - worst) * 1.5)
        last = (scale2, worst)
        scale2 += step
        deadline.check("effort limits")
    raise Infeasible("no duration found that keeps the effort limits", field=("limits", "effort"))


def peak_effort(
    dynamics: Dynamics | None, motion: Sampled, times: np.ndarray, gravity: np.ndarray | None
) -> np.ndarray | None:
    """Largest |tau| [N m or N] per joint ``(dof,)`` over ``motion`` at ``times`` ``(K,)`` and
    ``DENSE`` points between consecutive ones, under ``gravity`` [m/s^2] (base frame; default
    ``DEFAULT_GRAVITY``); None without ``dynamics``."""
    if dynamics is None:
        return None
    gravity = np.asarray(DEFAULT_GRAVITY if gravity is None else gravity, dtype=float)
    times = np.asarray(times, dtype=float)
    inner = times[:-1, None] + np.diff(times)[:, None] * np.arange(1, DENSE + 1) / (DENSE + 1)
    t = np.concatenate([times, inner.ravel()])
    q, qd, qdd = motion.sample(t)
    return np.abs(dynamics.inverse_dynamics(q, qd, qdd, gravity)).max(axis=0)


class HermiteMotion:
    """The motion a trajectory's points describe: between consecutive points the quintic through
    their q, q', q'' (``scipy.interpolate.BPoly.from_derivatives``: the returned values are its
    exact derivatives), run ``k`` times slower."""

    def __init__(self, trajectory: Trajectory, k: float = 1.0) -> None:
        tr = trajectory
        self.trajectory, self.k = tr, float(k)
        self.duration = float(tr.duration) * self.k
        data = np.stack([tr.positions, tr.velocities, tr.accelerations], axis=1)
        self._poly = BPoly.from_derivatives(tr.times, data)

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tau = np.clip(np.asarray(t, dtype=float) / self.k, 0.0, self.trajectory.duration)
        q, qd, qdd = (np.asarray(self._poly(tau, nu), dtype=float) for nu in (0, 1, 2))
        return q, qd / self.k, qdd / self.k**2


def slowed(trajectory: Trajectory, k: float) -> Trajectory:
    """``trajectory`` run ``k`` (>= 1) times slower: times by k, rates by 1/k^order."""
    tr = trajectory
    peaks = None
    if tr.peaks is not None:
        p = tr.peaks
        peaks = Peaks(p.velocity / k, p.acceleration / k**2, p.jerk / k**3)
    return Trajectory(
        tr.times * k, tr.positions, tr.velocities / k, tr.accelerations / k**2, tr.joint_names,
        peaks,
    )  # fmt: skip


def held_trajectory(
    trajectory: Trajectory,
    effort: Effort,
    names: Sequence[str],
    deadline: Deadline = NO_DEADLINE,
    where: Callable[[float], float] | None = None,
) -> float:
    """The factor k >= 1 by which ``trajectory`` (its ``HermiteMotion``) must run slower for its
    torque to keep ``effort`` (1.0: it does); ``where`` as ``effort_peak_ratio``'s."""
    motion = HermiteMotion(trajectory)
    duration = motion.duration
    if duration <= 0.0 or effort_peak_ratio(motion, effort, names, where) <= 1.0 + TOLERANCE:
        return 1.0
    held = shortest_for_effort(
        lambda T: HermiteMotion(trajectory, T / duration), duration, effort, names, deadline, where
    )
    return float(held.duration) / duration


def held_motion(
    trajectory: Trajectory,
    effort: Effort | None,
    dynamics: Dynamics | None,
    gravity: np.ndarray | None,
    names: Sequence[str],
    deadline: Deadline = NO_DEADLINE,
) -> tuple[Trajectory, np.ndarray | None]:
    """A joint motion's ``trajectory`` slowed until its torque keeps ``effort`` (a failure's
    ``s``: the share of the joint path's length there) and its peak effort (None without
    ``dynamics``)."""
    if effort is not None and trajectory.duration > 0.0:
        q, times = trajectory.positions, trajectory.times
        length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
        share = length / length[-1] if length[-1] > 0 else length

        def where(fraction: float) -> float:
            return float(np.interp(fraction * times[-1], times, share))

        k = held_trajectory(trajectory, effort, names, deadline, where)
        trajectory = slowed(trajectory, k) if k > 1.0 else trajectory
    between = peak_effort(dynamics, HermiteMotion(trajectory), trajectory.times, gravity)
    if dynamics is None or between is None:
        return trajectory, None
    g = np.asarray(DEFAULT_GRAVITY if gravity is None else gravity, dtype=float)
    at_points = dynamics.inverse_dynamics(  # the returned points' own values count too
        trajectory.positions, trajectory.velocities, trajectory.accelerations, g
    )
    return trajectory, np.maximum(between, np.abs(at_points).max(axis=0))


def effort_stretch(motion: Sampled, effort: Effort, times: np.ndarray) -> float:
    """The factor k >= 1 by which ``motion`` must run slower for its torque to keep ``effort`` at
    ``times`` ``(K,)`` and ``DENSE`` points between consecutive ones (1.0 when it does within
    ``TOLERANCE``): each sample needs k^2 >= b / (limit - g) (module docstring)."""
    times = np.asarray(times, dtype=float)
    inner = times[:-1, None] + np.diff(times)[:, None] * np.arange(1, DENSE + 1) / (DENSE + 1)
    b, c = _torques(effort.dynamics, motion, np.concatenate([times, inner.ravel()]), effort.gravity)
    k2 = float(_needed(b, c, np.asarray(effort.limits, dtype=float)).max(initial=0.0))
    return 1.0 if k2 <= 1.0 + TOLERANCE else float(np.sqrt(k2)) * (1.0 + MARGIN)
