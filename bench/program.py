"""Motion programs against single lines: ``python -m bench.program`` (prints a markdown table).

The problem (issue 16): UR5, 10 LIN segments of 10-30 cm in a horizontal plane (seeded random
zig-zag kept inside a reachable box, turns of 30-150 degrees), blend radii of 2-5 cm. Rows:

- the blended program, planned by ``core.program.plan.plan_program``;
- the same ten lines planned alone by the single-line planner (``core.cartesian.plan.plan``,
  ``sampled``), each from where the previous one ended: the sum of their planning times;
- the same program with full stops (every blend radius 0);
- the blended program with ``speed_profile="s_curve"`` (default tool jerk 10 m/s^3).

Planning times are medians of ``ROUNDS`` alternating runs in one process (2 shared cores: read the
ratios, not the absolute numbers); cycle times are the trajectories' durations.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np

from core.cartesian.plan import plan
from core.cartesian.task import CartesianTask
from core.program.plan import plan_program
from core.program.segments import ProgramTask, Segment
from robots import registry

ROUNDS = 7
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


def main() -> None:
    robot = registry.get("ur5")
    points, radii = corners()
    blended = ProgramTask(robot, HOME, segments(points, radii, True))
    stopped = ProgramTask(robot, HOME, segments(points, radii, False))
    s_curve = ProgramTask(robot, HOME, segments(points, radii, True, "s_curve"))
    ends = [seg.goal_pose for seg in blended.segments]

    def singles() -> float:
        q, total = HOME, 0.0
        for T in ends:
            result = plan(CartesianTask(robot=robot, q_start=q, T_goal=T), "sampled")
            q = result.trajectory.positions[-1]
            total += result.trajectory.duration
        return total

    times: dict[str, list[float]] = {"blended": [], "stops": [], "singles": [], "s_curve": []}
    results = {}
    for _ in range(ROUNDS):
        for name, run in (
            ("blended", lambda: plan_program(blended)),
            ("stops", lambda: plan_program(stopped)),
            ("s_curve", lambda: plan_program(s_curve)),
            ("singles", singles),
        ):
            start = time.perf_counter()
            results[name] = run()
            times[name].append(time.perf_counter() - start)
    med = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
    cycle = {
        "blended": results["blended"].trajectory.duration,
        "stops": results["stops"].trajectory.duration,
        "singles": results["singles"],
        "s_curve": results["s_curve"].trajectory.duration,
    }
    lengths = [np.linalg.norm(b - a) for a, b in itertools.pairwise(points)]
    print(
        f"### P7: motion program, UR5, 10 LIN segments of {min(lengths) * 100:.0f}-"
        f"{max(lengths) * 100:.0f} cm, blends {min(radii[:-1]) * 100:.1f}-"
        f"{max(radii[:-1]) * 100:.1f} cm (0.25 m/s)\n"
    )
    print("| P7 | planning median [ms] | ratio | cycle time [s] | note |")
    print("|---|---:|---:|---:|---|")
    base = med["singles"]
    notes = {
        "singles": "the ten lines planned alone (core sampled), sum",
        "blended": "one program, 9 blends",
        "stops": "one program, a stop at every corner",
        "s_curve": "blended, speed_profile s_curve (tool jerk <= 10 m/s^3), peak joint jerk "
        f"{results['s_curve'].trajectory.peak_jerk.max():.0f} rad/s^3 (blended: "
        f"{results['blended'].trajectory.peak_jerk.max():.0f})",
    }
    for name in ("singles", "blended", "stops", "s_curve"):
        label = {"singles": "**ten single lines**", "blended": "ours: program, blended",
                 "stops": "ours: program, full stops",
                 "s_curve": "ours: program, blended, s_curve"}[name]  # fmt: skip
        print(f"| {label} | {med[name]:.1f} | {med[name] / base:.2f}x | {cycle[name]:.3f} | "
              f"{notes[name]} |")  # fmt: skip
    saving = 1.0 - cycle["blended"] / cycle["stops"]
    print(f"\n- Blending saves {saving:.1%} of the cycle time against full stops "
          f"({cycle['blended']:.3f} s against {cycle['stops']:.3f} s).")  # fmt: skip


if __name__ == "__main__":
    main()
