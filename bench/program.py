"""Motion programs against single lines: ``python -m bench.program`` (prints a markdown table).

The problem (issue 16): UR5, 10 LIN segments of 10-30 cm in a horizontal plane (seeded random
zig-zag kept inside a reachable box, turns of 30-150 degrees), blend radii of 2-5 cm. Rows:

- the blended program, planned by ``core.program.plan.plan_program`` with its default timing
  (``time_optimal``) and with ``timing="jerk_limited"`` (round 2's timing);
- the same ten lines planned alone by the single-line planner (``core.cartesian.plan.plan``,
  ``sampled``), each from where the previous one ended: the sum of their planning times;
- the same program with full stops (every blend radius 0);
- the blended program with ``speed_profile="s_curve"`` (default tool jerk 10 m/s^3).

P7b (issue 24): the blended program's cycle time against TOPP-RA (toppra 0.6.10,
``bench.program_topp``) on the program's own blended joint path under the same joint and tool
limits, toppra on its default grid and on a fine one (``FINE`` intervals plus the path's
breakpoints), each answer's largest limit excess between its grid points measured here; and the
same ten corners as blended PTP segments (only joint limits bind). Targets: <= 1.02x TOPP-RA,
and the PTP program <= 0.80x its round-2 cycle time (``PTP_BEFORE``).

Planning times are medians of ``ROUNDS`` alternating runs in one process (2 shared cores: read the
ratios, not the absolute numbers); cycle times are the trajectories' durations.
"""

from __future__ import annotations

import itertools
import math
import os
import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np

from core.cartesian.plan import plan
from core.cartesian.task import CartesianTask
from core.program.plan import plan_program
from core.program.segments import ProgramTask, Segment
from core.program.timed import timed_program
from robots import registry

ROUNDS = 7
FINE = 2000
"""Grid intervals of toppra's fine run (plus the path's breakpoints)."""
LIN_BEFORE, PTP_BEFORE = 8.212, 6.703
"""Cycle times [s] of the blended LIN and PTP programs with round 2's timing (measured here on
main before round 3: the P7 table of 2026-11-25 and issue 24)."""
HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])
BOX = (np.array([-0.8, -0.35]), np.array([-0.35, 0.3]))


def corners(seed: int = 0, count: int = 10) -> tuple[list[np.ndarray], list[float]]:
    """Tool positions of the corners (count + 1, from the home position) and blend radii."""
    rng = np.random.default_rng(seed)
    robot = registry.get("ur5")
    p = [robot.fk(HOME)[:3, 3]]
    heading = 0.0
    while len(p) <= count:
        turn = rng.uniform(np.radians(30), np.radians(150)) * rng.choice([-1, 1])
        length = rng.uniform(0.1, 0.3)
        h = heading + turn if len(p) > 1 else rng.uniform(0, 2 * np.pi)
        q = p[-1] + length * np.array([np.cos(h), np.sin(h), 0.0])
        if np.all(q[:2] >= BOX[0]) and np.all(q[:2] <= BOX[1]):
            p.append(q)
            heading = h
    radii = [*rng.uniform(0.02, 0.05, count - 1).tolist(), 0.0]
    return p, radii


def segments(
    points: list[np.ndarray], radii: list[float], blended: bool, speed_profile: str = "trapezoidal"
) -> tuple[Segment, ...]:
    T = registry.get("ur5").fk(HOME)
    out = []
    for p, r in zip(points[1:], radii, strict=True):
        goal = T.copy()
        goal[:3, 3] = p
        out.append(
            Segment(
                "lin",
                goal_pose=goal,
                blend_radius=r if blended else 0.0,
                speed_profile=speed_profile,
            )
        )
    return tuple(out)


def _ptp(segs: tuple[Segment, ...]) -> tuple[Segment, ...]:
    """The same corners (goal poses, blend radii) as PTP segments."""
    return tuple(replace(s, type="ptp") for s in segs)


def _median_ms(run: Callable[[], Any], rounds: int) -> tuple[float, Any]:
    times, out = [], None
    for _ in range(rounds):
        start = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times)), out


def p7_programs(robot: object, points: list[np.ndarray], radii: list[float]) -> None:
    """The P7 table: planning times and cycle times of the program's variants."""
    blended = ProgramTask(robot, HOME, segments(points, radii, True))  # type: ignore[arg-type]
    jerk = replace(blended, timing="jerk_limited")
    stopped = ProgramTask(robot, HOME, segments(points, radii, False))  # type: ignore[arg-type]
    s_curve = ProgramTask(robot, HOME, segments(points, radii, True, "s_curve"))  # type: ignore[arg-type]
    ends = [seg.goal_pose for seg in blended.segments]

    def singles() -> float:
        q, total = HOME, 0.0
        for T in ends:
            result = plan(CartesianTask(robot=robot, q_start=q, T_goal=T), "sampled")  # type: ignore[arg-type]
            q = result.trajectory.positions[-1]
            total += result.trajectory.duration
        return total

    runs = {
        "singles": singles,
        "blended": lambda: plan_program(blended),
        "jerk": lambda: plan_program(jerk),
        "stops": lambda: plan_program(stopped),
        "s_curve": lambda: plan_program(s_curve),
    }
    times: dict[str, list[float]] = {k: [] for k in runs}
    results: dict[str, Any] = {}
    for _ in range(ROUNDS):
        for name, run in runs.items():
            start = time.perf_counter()
            results[name] = run()
            times[name].append(time.perf_counter() - start)
    med = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
    cycle = {k: float(v if k == "singles" else v.trajectory.duration) for k, v in results.items()}
    lengths = [np.linalg.norm(b - a) for a, b in itertools.pairwise(points)]
    print(
        f"### P7: motion program, UR5, 10 LIN segments of {min(lengths) * 100:.0f}-"
        f"{max(lengths) * 100:.0f} cm, blends {min(radii[:-1]) * 100:.1f}-"
        f"{max(radii[:-1]) * 100:.1f} cm (0.25 m/s)\n"
    )
    print("| P7 | planning median [ms] | ratio | cycle time [s] | note |")
    print("|---|---:|---:|---:|---|")
    peak = {k: results[k].trajectory.peak_jerk.max() for k in ("blended", "jerk", "s_curve")}  # type: ignore[attr-defined]
    rows = {
        "singles": ("**ten single lines**", "the ten lines planned alone (core sampled), sum"),
        "blended": ("ours: program, blended (time_optimal)", "one program, 9 blends; the default"),
        "jerk": ("ours: program, blended, jerk_limited", "round 2's timing, acceleration "
                 f"continuous (peak joint jerk {peak['jerk']:.0f} rad/s^3)"),
        "stops": ("ours: program, full stops", "one program, a stop at every corner"),
        "s_curve": ("ours: program, blended, s_curve", "speed_profile s_curve (tool jerk <= 10 "
                    f"m/s^3), peak joint jerk {peak['s_curve']:.0f} rad/s^3"),
    }  # fmt: skip
    for name, (label, note) in rows.items():
        print(f"| {label} | {med[name]:.1f} | {med[name] / med['singles']:.2f}x | "
              f"{cycle[name]:.3f} | {note} |")  # fmt: skip
    saving = 1.0 - cycle["blended"] / cycle["stops"]
    print(f"\n- Blending saves {saving:.1%} of the cycle time against full stops "
          f"({cycle['blended']:.3f} s against {cycle['stops']:.3f} s).")  # fmt: skip


def p7_optimum(robot: object, points: list[np.ndarray], radii: list[float]) -> None:
    """The P7b table: ours against toppra on each program's own blended joint path."""
    from bench.program_topp import excess, toppra_on_chunk

    print("\n### P7b: the blended programs against TOPP-RA on their own joint paths and limits\n")
    print("| P7b | compute median [ms] | cycle time [s] | ratio to toppra (fine) | excess | note |")
    print("|---|---:|---:|---:|---:|---|")
    for kind, segs, before in (
        ("10 LIN", segments(points, radii, True), LIN_BEFORE),
        ("10 PTP", _ptp(segments(points, radii, True)), PTP_BEFORE),
    ):
        task = ProgramTask(robot, HOME, segs)  # type: ignore[arg-type]
        ms, result = _median_ms(partial(plan_program, task), 3)
        timing: Any = timed_program(task).timings[0][1]
        path, rows, law = timing.path, timing.limits.rows, timing.law
        ours_excess = excess(path, rows, law, law.duration, len(law.profile.switch_times))
        answers: dict[str, tuple[float, float, float, int]] = {}
        fine = np.unique(np.concatenate([np.linspace(0, 1, FINE + 1), path.breakpoints()]))
        for grid, points_ in (("default", None), ("fine", fine)):
            t_ms, (trajectory, n) = _median_ms(partial(toppra_on_chunk, path, rows, points_), 3)

            def s_of_t(t, k, tr=trajectory):  # type: ignore[no-untyped-def]
                return tr._eval_params(np.asarray(t, dtype=float))[k]

            answers[grid] = (t_ms, trajectory.duration, excess(path, rows, s_of_t,
                                                              trajectory.duration, n), n)  # fmt: skip
        reference = answers["fine"][1]
        duration = result.trajectory.duration  # type: ignore[attr-defined]
        print(f"| ours: {kind}, time_optimal | {ms:.0f} | {duration:.3f} | "
              f"{duration / reference:.4f} | {ours_excess:.2g} | whole program (planning, timing, "
              f"sampling); {duration / before:.2f}x round 2's {before:.2f} s |")  # fmt: skip
        for grid, label in (("default", "its default grid"), ("fine", f"{FINE} intervals")):
            t_ms, d, ex, n = answers[grid]
            print(f"| toppra: {kind}, {label} | {t_ms:.0f} | {d:.3f} | {d / reference:.4f} | "
                  f"{ex:.2g} | {n} grid intervals; timing only |")  # fmt: skip


def main() -> None:
    robot = registry.get("ur5")
    points, radii = corners()
    print(f"Load average at the start: {os.getloadavg()[0]:.2f} (2 shared cores)\n")
    p7_programs(robot, points, radii)
    p7_optimum(robot, points, radii)
    print(f"\nLoad average at the end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
