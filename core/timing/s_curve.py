"""Jerk-limited (S-curve) profiles on Ruckig: the phase table every jerk-limited plan samples, and
the path-parameter law ``SCurveTiming`` s(t) on [0, 1].

Ruckig (pip ``ruckig``; Berscheid and Kroeger, "Jerk-limited real-time trajectory generation with
arbitrary target states", RSS 2021) returns, per degree of freedom, seven phases of constant jerk.
``ConstantJerkPhases`` reads them (``Trajectory.profiles``) once and evaluates positions and their
derivatives vectorized over many times (the same arithmetic as Ruckig's ``at_time``, without one
Python call per sample), with the exact peaks of every phase. ``calculate`` runs Ruckig and turns
every failure (an unreachable state, Ruckig's 7,600 s cap, a brake phase) into ``Infeasible``.

``SCurveTiming`` has the call shape of ``core.timing.quintic.QuinticTiming`` (``duration``,
``__call__(t, order)``, ``time_at(s)``): s goes from 0 to 1 at rest at both ends, with continuous
s'' and |s'''| bounded. Units: [s]; s' in [1/s], s'' in [1/s^2], s''' in [1/s^3].
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import ruckig

from core.errors import Infeasible, InputError
from core.trajectory import Peaks

RUCKIG_MAX_DURATION = 7600.0
"""[s] Ruckig refuses longer trajectories (numerical stability; its ``ErrorTrajectoryDuration``)."""
DURATION_TOLERANCE = 1e-9
"""Relative: a Ruckig duration this close to the requested one is the requested one."""
PHASES = 7
RUCKIG_CODES = {
    "-100": "invalid input",
    "-101": f"the trajectory would take more than Ruckig's {RUCKIG_MAX_DURATION:g} s",
    "-102": "the position limits cannot be kept",
    "-104": "a limit is zero",
    "-110": "no time-optimal profile was found (numerical failure for these magnitudes)",
    "-111": "the joints could not be synchronized (numerical failure for these magnitudes)",
}
"""Ruckig's ``Result`` codes that its Python enum does not name (it raises ``ValueError``)."""
INVERSE_GRID = 4001
"""Points of the table that seeds ``SCurveTiming.time_at`` before its Newton steps."""


def calculate(inp: ruckig.InputParameter, names: Sequence[str]) -> ruckig.Trajectory:
    """Ruckig's trajectory for ``inp`` (``len(names)`` degrees of freedom); every Ruckig failure
    as ``Infeasible`` with its reason, Ruckig's ``DoF k`` replaced by the joint's name."""
    dof = len(names)
    trajectory = ruckig.Trajectory(dof)
    try:
        result = ruckig.Ruckig(dof).calculate(inp, trajectory)
    except ruckig.RuckigError as e:  # unreachable target state, the duration cap...
        reason = str(e).replace("[ruckig]", "").strip().split("\n")[0].split(" input:")[0]
        if reason.startswith("error in step"):  # "error in step 1, dof: 0" + a dump of inputs
            step, _, where = reason.removeprefix("error in ").partition(", dof: ")
            reason = (
                f"Ruckig's {step} failed numerically for DoF {where or '?'} (limits and boundary "
                "states of very different magnitudes)"
            )
        for j in range(dof - 1, -1, -1):
            reason = reason.replace(f"DoF {j}", f"joint {names[j]}")
        raise Infeasible(f"no jerk-limited profile within the limits: {reason}") from e
    except ValueError as e:  # a result code the Python enum lacks, e.g. "-101 is not a valid"
        code = str(e).split()[0]
        reason = RUCKIG_CODES.get(code, f"Ruckig result {code}")
        raise Infeasible(f"no jerk-limited profile within the limits: {reason}") from e
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise Infeasible(f"no jerk-limited profile within the limits (Ruckig: {result.name})")
    if trajectory.duration > RUCKIG_MAX_DURATION:
        raise Infeasible(f"the jerk-limited profile would take more than {RUCKIG_MAX_DURATION:g} s")
    if any(p.brake.duration > 0.0 for p in trajectory.profiles[0]):
        raise Infeasible(
            "the start state carries a joint over its velocity or acceleration limit before "
            "the jerk limit lets it brake: no jerk-limited profile stays within the limits"
        )
    return trajectory


class ConstantJerkPhases:
    """Per degree of freedom, seven phases of constant jerk read from a Ruckig trajectory.

    Attributes:
        phase_durations, jerk: ``(dof, 7)`` [s], [unit/s^3].
        acc, vel, pos: ``(dof, 8)`` states at the phase boundaries.
        starts: ``(dof, 7)`` start time of each phase [s].
    """

    def __init__(self, trajectory: ruckig.Trajectory, duration: float) -> None:
        phases = trajectory.profiles[0]
        self.phase_durations = np.array([p.t for p in phases])
        self.jerk = np.array([p.j for p in phases])
        self.acc = np.array([p.a for p in phases])
        self.vel = np.array([p.v for p in phases])
        self.pos = np.array([p.p for p in phases])
        self.starts = np.concatenate(
            [np.zeros((len(phases), 1)), np.cumsum(self.phase_durations, axis=1)[:, :-1]], axis=1
        )
        self.duration = float(duration)

    def switch_times(self) -> np.ndarray:
        """Times [s] inside (0, duration) where the jerk steps: every phase boundary of every
        degree of freedom."""
        live = self.phase_durations > 0.0
        times = np.unique(self.starts[live])
        return times[(times > 0.0) & (times < self.duration)]

    def evaluate(self, t: np.ndarray, orders: Sequence[int]) -> list[np.ndarray]:
        """Derivatives ``orders`` (0-3) at times ``t`` ``(N,)`` [s], each ``(N, dof)``."""
        dof = self.jerk.shape[0]
        k = np.empty((t.size, dof), dtype=np.intp)
        for j in range(dof):  # the phase starts differ per degree of freedom
            k[:, j] = np.searchsorted(self.starts[j], t, side="right") - 1
        np.clip(k, 0, PHASES - 1, out=k)
        cols = np.arange(dof)
        tau = np.clip(t, 0.0, self.duration)[:, None] - self.starts[cols, k]
        jk, ak, vk, pk = (x[cols, k] for x in (self.jerk, self.acc, self.vel, self.pos))
        out = []
        for order in orders:
            if order == 0:
                out.append(pk + tau * (vk + tau * (ak / 2.0 + tau * jk / 6.0)))
            elif order == 1:
                out.append(vk + tau * (ak + tau * jk / 2.0))
            elif order == 2:
                out.append(ak + tau * jk)
            else:
                out.append(jk.copy())
        return out

    def peaks(self) -> Peaks:
        """Exact largest |velocity|, |acceleration|, |jerk| per degree of freedom ``(dof,)``: jerk
        over the phases of non-zero length, acceleration at the phase boundaries (linear in
        between), velocity at the boundaries and where the acceleration crosses zero in a phase."""
        live = self.phase_durations > 0.0
        jerk = np.where(live, np.abs(self.jerk), 0.0).max(axis=1)
        acc = np.abs(self.acc).max(axis=1)
        a, j, h = self.acc[:, :-1], self.jerk, self.phase_durations
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = -a / j
            inside = live & (j != 0.0) & (tau > 0.0) & (tau < h)
            v_turn = np.where(inside, np.abs(self.vel[:, :-1] - a * a / (2.0 * j)), 0.0)
        vel = np.maximum(np.abs(self.vel).max(axis=1), v_turn.max(axis=1))
        return Peaks(vel, acc, jerk)


class SCurveTiming:
    """s(t) from 0 to 1, rest to rest, with continuous s'' and bounded s''' (an S-curve).

    Args:
        duration: ``T`` [s], > 0: exactly this long (``Infeasible`` naming the shortest when the
            limits need longer). Absent: the shortest s(t) within the limits.
        max_velocity, max_acceleration, max_jerk: Bounds on s' [1/s], |s''| [1/s^2] and |s'''|
            [1/s^3] (a tool speed limit divided by the path length, for example). Without a
            duration all three are needed; with one alone the missing ones default to those of the
            canonical S-curve lasting ``T`` (jerk phases of T/8, cruise over the middle half:
            s' <= 4/(3T), |s''| <= 32/(3T^2), |s'''| <= 256/(3T^3)).
    """

    def __init__(
        self,
        duration: float | None = None,
        *,
        max_velocity: float | None = None,
        max_acceleration: float | None = None,
        max_jerk: float | None = None,
    ) -> None:
        given = (("max_velocity", max_velocity), ("max_acceleration", max_acceleration),
                 ("max_jerk", max_jerk))  # fmt: skip
        for name, value in given:
            if value is not None and not (np.isfinite(value) and value > 0.0):
                raise InputError(f"{name} must be a finite number > 0", field=(name,))
        if duration is None:
            missing = [name for name, value in given if value is None]
            if missing:
                raise InputError(
                    f"an s-curve without a duration needs {missing[0]}", field=(missing[0],)
                )
        elif not (np.isfinite(duration) and 0.0 < duration <= RUCKIG_MAX_DURATION):
            raise InputError(
                f"duration must be > 0 s and at most {RUCKIG_MAX_DURATION:g} s", field=("duration",)
            )
        else:
            T = float(duration)
            canonical = (4.0 / (3.0 * T), 32.0 / (3.0 * T**2), 256.0 / (3.0 * T**3))
            max_velocity, max_acceleration, max_jerk = (
                c if v is None else v for c, (_, v) in zip(canonical, given, strict=True)
            )
        inp = ruckig.InputParameter(1)
        inp.current_position, inp.target_position = [0.0], [1.0]
        inp.max_velocity, inp.max_acceleration = [max_velocity], [max_acceleration]
        inp.max_jerk = [max_jerk]
        if duration is not None:
            inp.minimum_duration = float(duration)
        trajectory = calculate(inp, ("s",))
        found = trajectory.duration
        if duration is not None and abs(found - duration) > DURATION_TOLERANCE * duration:
            raise Infeasible(
                f"no s-curve lasts {duration:.6g} s within these path limits: the shortest lasts "
                f"{found:.6g} s",
                field=("duration",),
                extra={"min_duration": found},
            )
        self.duration = float(found if duration is None else duration)
        self._phases = ConstantJerkPhases(trajectory, self.duration)
        self.max_velocity, self.max_acceleration = float(max_velocity), float(max_acceleration)  # type: ignore[arg-type]
        self.max_jerk = float(max_jerk)  # type: ignore[arg-type]

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s (order 0), s' [1/s] (1), s'' [1/s^2] (2) or s''' [1/s^3] (3) at times ``t`` [s];
        exactly 0 and 1 (and rest) at the ends."""
        t = np.asarray(t, dtype=float)
        flat = np.clip(t.ravel(), 0.0, self.duration)
        value = self._phases.evaluate(flat, (order,))[0][:, 0]
        if order < 3:
            value[flat == 0.0] = 0.0
            value[flat == self.duration] = 1.0 if order == 0 else 0.0
        if order == 0:
            value = np.clip(value, 0.0, 1.0)
        return value.reshape(t.shape)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Times [s] at which the profile reaches path parameters ``s`` (the first, where s
        dwells): a table lookup refined by Newton steps on s(t) - s = 0."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        grid = np.linspace(0.0, self.duration, INVERSE_GRID)
        t = np.interp(s, self(grid), grid)
        for _ in range(4):
            rate = self(t, 1)
            step = np.divide(self(t) - s, rate, out=np.zeros_like(t), where=rate > 1e-12)
            t = np.clip(t - step, 0.0, self.duration)
        t[s == 0.0], t[s == 1.0] = 0.0, self.duration
        return t

    def peaks(self) -> Peaks:
        """Exact largest s' [1/s], |s''| [1/s^2], |s'''| [1/s^3], each ``(1,)``."""
        return self._phases.peaks()

    def switch_times(self) -> np.ndarray:
        """Times [s] inside (0, duration) where the third derivative of s steps: the boundaries
        of the phases."""
        return self._phases.switch_times()


DEFAULT_LINEAR_JERK = 10.0
"""Tool jerk [m/s^3] used with ``max_linear_speed`` when the request gives no ``max_linear_jerk``
(ten times ``core.timing.speed_limited.DEFAULT_LINEAR_ACCELERATION`` per second)."""
DEFAULT_ANGULAR_JERK = 20.0
"""Tool angular jerk [rad/s^3] used when the request gives no ``max_angular_jerk``."""


def s_curve_limited(
    length: float,
    angle: float,
    max_linear_speed: float | None,
    max_angular_speed: float | None,
    max_linear_acceleration: float,
    max_angular_acceleration: float,
    max_linear_jerk: float | None = None,
    max_angular_jerk: float | None = None,
    cap: np.ndarray | None = None,
    acceleration_cap: np.ndarray | None = None,
) -> SCurveTiming:
    """Shortest rest-to-rest S-curve s(t) for a line of ``length`` [m] turning ``angle`` [rad].

    The tool's linear speed, acceleration and jerk stay within ``max_linear_*`` [m/s, m/s^2,
    m/s^3], its angular ones within ``max_angular_*`` [rad/s, rad/s^2, rad/s^3] (each ignored when
    ``None`` or when the line has no such motion; jerks default to ``DEFAULT_*_JERK``). ``cap``
    (s' [1/s] per grid point, from the joint velocity limits) and ``acceleration_cap`` (|s''|
    [1/s^2] per interval, from the joint acceleration limits) bound the whole profile by their
    smallest value: an S-curve has one velocity, acceleration and jerk bound, so the joint caps of
    ``core.timing.speed_limited`` are held conservatively.
    """
    bounds = {"velocity": np.inf, "acceleration": np.inf, "jerk": np.inf}
    for extent, speed, acc, jerk, default_jerk in (
        (length, max_linear_speed, max_linear_acceleration, max_linear_jerk, DEFAULT_LINEAR_JERK),
        (angle, max_angular_speed, max_angular_acceleration, max_angular_jerk,
         DEFAULT_ANGULAR_JERK),
    ):  # fmt: skip
        if extent > 1e-12:
            if speed is not None:
                bounds["velocity"] = min(bounds["velocity"], speed / extent)
            bounds["acceleration"] = min(bounds["acceleration"], acc / extent)
            j = default_jerk if jerk is None else jerk
            bounds["jerk"] = min(bounds["jerk"], j / extent)
    if cap is not None:
        bounds["velocity"] = min(bounds["velocity"], float(np.min(cap)))
    if acceleration_cap is not None:
        bounds["acceleration"] = min(bounds["acceleration"], float(np.min(acceleration_cap)))
    if not np.isfinite(bounds["velocity"]):
        raise InputError(
            "give duration or max_linear_speed/max_angular_speed for a motion of this kind",
            field=("max_linear_speed",),
        )
    for name, default in (("acceleration", 1.0), ("jerk", 10.0)):  # no motion of either kind
        if not np.isfinite(bounds[name]):
            bounds[name] = default
    return SCurveTiming(
        max_velocity=bounds["velocity"],
        max_acceleration=bounds["acceleration"],
        max_jerk=bounds["jerk"],
    )
