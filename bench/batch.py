"""B1/B2: 100 UR5 plans against one 10-obstacle environment, one ``POST /v1/batch`` against 100
requests one by one (same service, same machine, one keep-alive connection each way).

B1 plans 100 Cartesian lines (``sampled``) from the UR5's home to tool positions up to 12 cm away
in each axis (seeded); B2 100 quintic joint moves from home to goals up to 0.3 rad away per joint.
Every plan is checked continuously against ``ENVIRONMENT`` (a table, a wall, four pillars and four
balls, 1 cm clearance). One by one, each request builds its own collision model; in a batch the
items share one (``service.memo``). Every answer must be 200 (a failed plan is an error of the
bench, not a timing). ``--quick`` (CI) plans ``QUICK_PLANS`` per row. ``lines`` and ``joint_moves``
are also the workload of the batch tests.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from bench.harness import LiveServer, Row, Table, cpu_seconds

UR5_HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
UR5_TOOL_AT_HOME = [-0.6468484646344461, -0.10914999999999998, 0.17879479660838637]
"""FK of ``UR5_HOME`` [m] (tool0 in base_link)."""
UR5_TOOL_DOWN = [0.7071067811865475, 0.7071067811865476, 0.0, 0.0]
"""The tool's orientation at ``UR5_HOME`` (x, y, z, w)."""
PLANS = 100


def _obstacle(name: str, shape: dict[str, Any], position: list[float]) -> dict[str, Any]:
    return {
        "name": name,
        "shape": shape,
        "pose": {"position": position, "orientation": [0, 0, 0, 1]},
    }


def _pillar(name: str, x: float, y: float) -> dict[str, Any]:
    return _obstacle(name, {"type": "cylinder", "radius": 0.05, "length": 0.6}, [x, y, 0.3])


def _ball(name: str, position: list[float]) -> dict[str, Any]:
    return _obstacle(name, {"type": "sphere", "radius": 0.08}, position)


ENVIRONMENT: dict[str, Any] = {
    "obstacles": [
        _obstacle("table", {"type": "box", "size": [0.6, 0.8, 0.2]}, [-0.6, 0.0, -0.3]),
        _obstacle("wall", {"type": "box", "size": [0.05, 1.0, 0.8]}, [-1.1, 0.0, 0.3]),
        _pillar("pillar_1", 0.6, 0.6),
        _pillar("pillar_2", 0.6, -0.6),
        _pillar("pillar_3", -0.6, 0.6),
        _pillar("pillar_4", -0.6, -0.6),
        _ball("ball_1", [0.4, 0.0, 0.3]),
        _ball("ball_2", [0.0, 0.6, 0.6]),
        _ball("ball_3", [0.0, -0.6, 0.6]),
        _ball("ball_4", [0.5, 0.3, 0.8]),
    ],
    "clearance": 0.01,
}
"""Ten obstacles around the UR5 at home, none on the way of the plans below."""


def lines(n: int = PLANS, seed: int = 0) -> list[dict[str, Any]]:
    """``n`` Cartesian line requests (bodies of ``/v1/trajectories/cartesian``)."""
    rng = np.random.default_rng(seed)
    goals = np.array(UR5_TOOL_AT_HOME) + rng.uniform(-0.12, 0.12, (n, 3))
    return [
        {
            "robot": "ur5",
            "method": "sampled",
            "environment": ENVIRONMENT,
            "start": {"positions": UR5_HOME},
            "goal": {"pose": {"position": g.tolist(), "orientation": UR5_TOOL_DOWN}},
            "max_linear_speed": 0.25,
            "max_angular_speed": 1.0,
        }
        for g in goals
    ]


def joint_moves(n: int = PLANS, seed: int = 0) -> list[dict[str, Any]]:
    """``n`` quintic joint move requests (bodies of ``/v1/trajectories/joint``)."""
    rng = np.random.default_rng(seed)
    goals = np.array(UR5_HOME) + rng.uniform(-0.3, 0.3, (n, 6))
    return [
        {
            "robot": "ur5",
            "profile": "quintic",
            "environment": ENVIRONMENT,
            "start": {"positions": UR5_HOME},
            "goal": {"positions": g.tolist()},
        }
        for g in goals
    ]


def _one_by_one(
    client: Any, url: str, path: str, bodies: list[dict[str, Any]]
) -> Callable[[], int]:
    import orjson

    contents = [orjson.dumps(b) for b in bodies]
    headers = {"content-type": "application/json"}

    def call() -> int:
        for content in contents:
            r = client.post(f"{url}{path}", content=content, headers=headers)
            if r.status_code != 200:
                raise RuntimeError(f"HTTP {r.status_code}: {r.text[:300]}")
            orjson.loads(r.content)
        return len(contents)

    return call


def _batched(
    client: Any, url: str, endpoint: str, bodies: list[dict[str, Any]]
) -> Callable[[], int]:
    import orjson

    content = orjson.dumps({"items": [{"endpoint": endpoint, "body": b} for b in bodies]})
    headers = {"content-type": "application/json"}

    def call() -> int:
        r = client.post(f"{url}/v1/batch", content=content, headers=headers)
        if r.status_code != 200:
            raise RuntimeError(f"HTTP {r.status_code}: {r.text[:300]}")
        answer = orjson.loads(r.content)
        failed = [x for x in answer["results"] if x["status"] != 200]
        if failed:
            raise RuntimeError(f"{len(failed)} items failed, first: {failed[0]['body']}")
        return len(answer["results"])

    return call


CPU = "service CPU [ms]"


def _with_cpu(row: Row, pid: int) -> Row:
    """``row`` whose every call also measures the service's CPU time (user + system, all its
    threads): less sensitive than wall time to other load on the machine. The column shows the
    median over the calls."""
    fn, samples = row.fn, []
    assert fn is not None

    def call() -> object:
        before = cpu_seconds(pid)
        out = fn()
        samples.append(cpu_seconds(pid) - before)
        row.extra[CPU] = f"{np.median(samples) * 1e3:.0f}"
        return out

    row.fn = call
    return row


def _table(
    key: str, what: str, endpoint: str, bodies: list[dict[str, Any]], client: Any, live: LiveServer
) -> Table:
    single = f"ours: HTTP one by one, {len(bodies)} requests"
    url = live.url
    rows = [
        Row(single, _one_by_one(client, url, f"/v1/{endpoint}", bodies),
            note="keep-alive httpx, each answer decoded"),
        Row(f"ours: HTTP POST /v1/batch, {len(bodies)} items", _batched(client, url, endpoint, bodies),
            note="one request; one collision model shared by the items"),
    ]  # fmt: skip
    return Table(
        key,
        f"{len(bodies)} UR5 {what} against one 10-obstacle environment, batched vs one by one",
        single,
        [_with_cpu(row, live.pid) for row in rows],
        columns=(CPU,),
        unit="ms",
        notes=["Wall time of all the plans; ratio < 1: the batch is faster."],
    )


QUICK_PLANS = 20
"""Plans per row in ``--quick`` runs (CI): the rows run, the numbers are not the table's."""


def b1_lines(client: Any, live: LiveServer, quick: bool = False) -> Table:
    bodies = lines(QUICK_PLANS if quick else PLANS)
    return _table("B1", "Cartesian lines", "trajectories/cartesian", bodies, client, live)


def b2_joint_moves(client: Any, live: LiveServer, quick: bool = False) -> Table:
    bodies = joint_moves(QUICK_PLANS if quick else PLANS)
    return _table("B2", "quintic joint moves", "trajectories/joint", bodies, client, live)
