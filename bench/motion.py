"""M1: collision-free motions on the MotionBenchMaker Panda problems (issue 27), ours against an
in-run OMPL baseline: ``python -m bench --only M1`` (or ``python -m bench.motion``).

For every problem of ``bench/data/mbm_panda`` (15 per scenario; ``--quick``: 2):

- ours: ``POST /v1/trajectories/collision_free`` to a live service (the spherized Panda inline,
  seed 0, the default budget), timed from the client (the request's wall time); the answer's
  points are re-checked here with the continuous check (``CollisionChecker.check_path``: joints
  moving linearly between returned points), so "certified" is the bench's own finding;
- the baseline: OMPL 2.0.1 RRT-Connect with default settings (range, resolution) and a coal
  validity callback (``pin.computeCollisions`` through coal's broad phase on the same collision
  model: the per-state check ours uses in its search), ``solve`` then ``simplifySolution``, in this
  process, timed the same way; its simplified path re-checked as straight segments;
- roboplan's RRT-Connect + shortcut when ``roboplan`` is installed.

Per scenario and overall: valid problems (start and goal clear), solved, certified, the planners'
search time (median / p95), the request's wall time against the baseline's solve + simplify, path
length (sum of |dq|) against the straight segment and ours against the baseline's, and every invalid
problem answered 422 ``collision`` with ``at``. ``--write`` replaces the part of
``bench/RESULTS.md`` between the ``motion:begin`` and ``motion:end`` markers.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import itertools  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

from bench import mbm  # noqa: E402
from bench.harness import ROOT, cpu_seconds, optional, server  # noqa: E402
from core.collisions import checked  # noqa: E402
from core.trajectory import Trajectory  # noqa: E402
from robots import registry  # noqa: E402
from robots.collision import CollisionChecker  # noqa: E402
from robots.validity import GroupedClearance  # noqa: E402
from service.convert.environment import collision_check  # noqa: E402
from service.schemas.environment import Environment  # noqa: E402

RESULTS = ROOT / "bench" / "RESULTS.md"
BEGIN, END = "<!-- motion:begin -->", "<!-- motion:end -->"
BASELINE_TIME = 10.0
"""[s] The baseline's solve budget (ours: the request's default, the service's time budget)."""


@dataclass
class Outcome:
    """One planner on one problem."""

    solved: bool = False
    certified: bool = False
    search_ms: float = np.nan
    wall_ms: float = np.nan
    cpu_ms: float = np.nan
    check_cpu_ms: float = np.nan
    length: float = np.nan
    depth_mm: float = 0.0
    note: str = ""


@dataclass
class Case:
    problem: mbm.Problem
    valid: bool
    straight: float
    ours: Outcome = field(default_factory=Outcome)
    baseline: Outcome = field(default_factory=Outcome)
    invalid_answer: str = ""


def checker_of(problem: mbm.Problem) -> CollisionChecker:
    robot = registry.resolve(mbm.robot())
    env = Environment.model_validate(mbm.environment(problem))
    check = collision_check(robot, env, mbm.urdf())
    assert check is not None
    return check


SWEEP_STEP = 0.002
"""[rad] Spacing of the sweep that measures how deep an uncertified path goes (coal)."""


def recheck(check: CollisionChecker, qs: np.ndarray) -> tuple[bool, float]:
    """The continuous check of the straight joint segments through ``qs``: (clear, the deepest
    penetration [mm] below a pair's threshold found by a coal sweep every ``SWEEP_STEP`` along the
    segments of a path that is not)."""
    result = check.check_path(np.arange(len(qs), dtype=float), qs)
    if result.contact is None:
        return True, 0.0
    dense = [qs[:1]]
    for a, b in itertools.pairwise(qs):
        n = max(int(np.ceil(np.linalg.norm(b - a) / SWEEP_STEP)), 1)
        dense.append(a + np.arange(1, n + 1)[:, None] / n * (b - a))
    grouped = GroupedClearance(check)
    margin = grouped.distances(np.vstack(dense)) - grouped.threshold
    return False, float(max(-1e3 * margin.min(), 0.0))


def length(qs: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(qs, axis=0), axis=1).sum())


def ours(client: Any, live: Any, case: Case, check: CollisionChecker) -> None:
    body = mbm.request(case.problem, seed=0)
    cpu = cpu_seconds(live.pid)
    started = time.perf_counter()
    answer = client.post(f"{live.url}/v1/trajectories/collision_free?layout=columns", json=body)
    wall = (time.perf_counter() - started) * 1e3
    cpu = (cpu_seconds(live.pid) - cpu) * 1e3
    data = answer.json()
    if not case.valid:
        ok = answer.status_code == 422 and data.get("code") == "collision" and "at" in data
        case.invalid_answer = "422 collision" if ok else f"{answer.status_code} {data.get('code')}"
        return
    out = case.ours
    out.wall_ms, out.cpu_ms = wall, cpu
    if answer.status_code != 200:
        out.note = f"{answer.status_code} {data.get('code')}"
        return
    qs = np.asarray(data["positions"], dtype=float)
    out.solved = True
    out.search_ms = float(data["diagnostics"]["planner"]["plan_time_ms"])
    out.certified, out.depth_mm = recheck(check, qs)
    out.length = length(qs)
    out.check_cpu_ms = usual_check_cpu(check, data)


def usual_check_cpu(check: CollisionChecker, data: dict[str, Any]) -> float:
    """CPU time [ms] of the usual continuous check of the answer as the service runs it
    (``core.collisions.checked`` on the request's clearance), run again here: the part of the request's
    cost that is not the planner's."""
    traj = Trajectory(
        np.asarray(data["time_from_start"], dtype=float),
        np.asarray(data["positions"], dtype=float),
        np.asarray(data["velocities"], dtype=float),
        np.asarray(data["accelerations"], dtype=float),
        tuple(data["joint_names"]),
    )
    grouped = GroupedClearance(check)
    started = time.process_time()
    checked(traj, grouped)
    return (time.process_time() - started) * 1e3


def baseline(case: Case, check: CollisionChecker) -> None:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    robot = check.robot
    gm, _ = check.geometry_model()
    data, gdata = pin.Data(robot.model), pin.GeometryData(gm)
    thr = {name: t for name, t in zip(check.pair_names, check.threshold, strict=True)}
    for k, name in enumerate(check.geometry_model()[1]):
        gdata.collisionRequests[k].security_margin = float(thr[name])
    manager = pin.BroadPhaseManager_NaiveCollisionManager(robot.model, gm, gdata)
    dof = robot.dof
    started, cpu = time.perf_counter(), time.process_time()
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    for j in range(dof):
        bounds.setLow(j, float(robot.position_limits[j, 0]))
        bounds.setHigh(j, float(robot.position_limits[j, 1]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    setup.setStateValidityChecker(
        lambda s: (
            not pin.computeCollisions(
                robot.model, data, manager, np.array(s[0:dof], dtype=float), True
            )
        )
    )
    si = setup.getSpaceInformation()
    start, goal = si.allocState(), si.allocState()
    for j in range(dof):
        start[j], goal[j] = case.problem.start[j], case.problem.goal[j]
    setup.setStartAndGoalStates(start, goal)
    setup.setPlanner(og.RRTConnect(si))
    solved = setup.solve(BASELINE_TIME)
    searched = time.perf_counter()
    out = case.baseline
    out.search_ms = (searched - started) * 1e3
    if not (solved and setup.haveExactSolutionPath()):
        out.wall_ms, out.note = out.search_ms, "not solved"
        return
    setup.simplifySolution()
    out.wall_ms = (time.perf_counter() - started) * 1e3
    out.cpu_ms = (time.process_time() - cpu) * 1e3
    path = setup.getSolutionPath()
    qs = np.array([path.getState(i)[0:dof] for i in range(path.getStateCount())], dtype=float)
    out.solved = True
    out.certified, out.depth_mm = recheck(check, qs)
    out.length = length(qs)


def run_cases(per_scenario: int | None) -> list[Case]:
    import httpx

    cases = []
    with server(1) as live, httpx.Client(timeout=120) as client:
        for problem in mbm.problems(per_scenario):
            check = checker_of(problem)
            ends = check.distances(np.array([problem.start, problem.goal])) - check.threshold
            start, goal = np.array(problem.start), np.array(problem.goal)
            case = Case(problem, bool((ends >= 0).all()), float(np.linalg.norm(goal - start)))
            ours(client, live, case, check)
            if case.valid:
                baseline(case, check)
            cases.append(case)
            print(f"  {problem.name}: {summary(case)}", flush=True)
    return cases


def summary(case: Case) -> str:
    if not case.valid:
        return f"invalid, answered {case.invalid_answer}"
    o, b = case.ours, case.baseline
    return (
        f"ours {'ok' if o.solved else o.note} {o.wall_ms:.0f} ms L={o.length:.2f} "
        f"cert={o.certified}; baseline {'ok' if b.solved else b.note} {b.wall_ms:.0f} ms "
        f"L={b.length:.2f} cert={b.certified} ({b.depth_mm:.1f} mm)"
    )


def _stat(values: list[float], q: float) -> str:
    v = np.asarray([x for x in values if np.isfinite(x)])
    return "-" if v.size == 0 else f"{np.percentile(v, q):.0f}"


def _ratio(values: list[float]) -> str:
    v = np.asarray([x for x in values if np.isfinite(x)])
    return "-" if v.size == 0 else f"{np.median(v):.2f}"


def rows(name: str, cases: list[Case]) -> list[str]:
    valid = [c for c in cases if c.valid]
    both = [c for c in valid if c.ours.solved and c.baseline.solved]
    invalid = [c for c in cases if not c.valid]
    good = sum(c.invalid_answer == "422 collision" for c in invalid)
    o = [c.ours for c in valid]
    b = [c.baseline for c in valid]

    def line(label: str, outs: list[Outcome], ratio: str, extra: str) -> str:
        solved = [x for x in outs if x.solved]
        certified = sum(x.certified for x in solved)
        planning = [x.cpu_ms - x.check_cpu_ms if np.isfinite(x.check_cpu_ms) else x.cpu_ms
                    for x in outs]  # fmt: skip
        return (
            f"| {name} | {label} | {len(valid)}/{len(cases)} | {len(solved)} | {certified} | "
            f"{_stat([x.search_ms for x in outs], 50)} / {_stat([x.search_ms for x in outs], 95)} | "
            f"{_stat([x.wall_ms for x in outs], 50)} / {_stat([x.wall_ms for x in outs], 95)} | "
            f"{_stat([x.cpu_ms for x in outs], 50)} | {_stat(planning, 50)} | "
            f"{_ratio([x.length / c.straight for x, c in zip(outs, valid, strict=True) if x.solved])} | "
            f"{ratio} | {extra} |"
        )

    wall = _ratio([c.ours.wall_ms / c.baseline.wall_ms for c in both])
    cpu = _ratio([c.ours.cpu_ms / c.baseline.cpu_ms for c in both])
    plan = _ratio([(c.ours.cpu_ms - c.ours.check_cpu_ms) / c.baseline.cpu_ms for c in both])
    length_ratio = _ratio([c.ours.length / c.baseline.length for c in both])
    worst = max((x.depth_mm for x in b if x.solved), default=0.0)
    return [
        line("**ours**", o, f"wall {wall}x, CPU {cpu}x (without the usual check {plan}x); "
             f"length {length_ratio}x", f"invalid answered 422 collision + at: {good}/{len(invalid)}"),
        line("OMPL+coal", b, "1.00x", f"deepest contact {worst:.1f} mm"),
    ]  # fmt: skip


def table(cases: list[Case]) -> list[str]:
    head = [
        "| scenario | planner | valid | solved | certified (re-checked) | search ms p50 / p95 | "
        "wall ms p50 / p95: request (ours), solve + simplify (OMPL) | CPU ms p50 | "
        "CPU ms p50 without the usual check | length / straight (median) | "
        "ours vs OMPL (medians of per-problem ratios) | notes |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    body = []
    for scenario in mbm.SCENARIOS:
        subset = [c for c in cases if c.problem.scenario == scenario]
        if subset:
            body += rows(scenario, subset)
    body += rows("**all**", cases)
    roboplan = optional("roboplan")
    note = f"roboplan: {roboplan or 'installed but not wired'}"
    return [*head, *body, "", note]


def m1_mbm(quick: bool) -> list[str]:
    """The M1 table (markdown lines)."""
    cases = run_cases(2 if quick else None)
    return [
        "### M1: collision-free motions, MotionBenchMaker Panda "
        f"({len(cases)} problems, spherized Panda inline)",
        "",
        *table(cases),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.motion", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="2 problems per scenario")
    parser.add_argument("--write", action="store_true", help="update bench/RESULTS.md")
    args = parser.parse_args()
    text = "\n".join(m1_mbm(args.quick))
    print(text)
    if args.write:
        current = RESULTS.read_text()
        block = f"{BEGIN}\n{text}\n{END}"
        if BEGIN in current and END in current:
            head, rest = current.split(BEGIN, 1)
            current = head + block + rest.split(END, 1)[1]
        else:
            current = current.rstrip("\n") + "\n\n" + block + "\n"
        RESULTS.write_text(current)


if __name__ == "__main__":
    main()
