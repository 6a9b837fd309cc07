"""The sampling search of a collision-free motion, behind a small interface; OMPL's RRT-Connect.

``Sampler`` is what ``core.motion.plan`` needs of a sampling planner: from a start to any of a few
goals within joint limits, given two questions it may ask (is this configuration clear, is this
straight joint segment clear), a seed and a time limit, a list of configurations whose straight
segments all passed ``edge_ok``. ``RRTConnect`` answers it with OMPL's RRT-Connect (Kuffner and
LaValle 2000; the ``ompl`` wheel on PyPI, BSD-3): the tree edges are checked by ``edge_ok`` through
a Python ``MotionValidator``, so OMPL never judges a motion by its own resolution.

Determinism. OMPL draws every random number from generators that take their seeds from one
process-wide seed generator when they are constructed. The wheel's bindings offer neither
``setStateSamplerAllocator`` nor an overridable ``allocDefaultStateSampler`` (so neither a seeded
nor a Halton sampler can be installed), but ``RNG.setSeed`` re-seeds that seed generator: under one
process-wide lock, each search re-seeds it from the request's seed, then builds its space, planner
and nearest-neighbour structure and lets the planner allocate its state sampler (a first ``solve``
that stops at once), so every generator of the search is seeded the same way in any worker,
whatever ran before. The search itself runs outside the lock.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

ou.setLogLevel(ou.LOG_NONE)  # OMPL logs to stderr; failures are reported through the result

_SEED_LOCK = threading.Lock()
"""Held while a search seeds OMPL's process-wide seed generator and draws its generators."""
SEED_OFFSET = 1
"""OMPL seeds must be > 0: the request's seed (>= 0) plus this."""


@dataclass(frozen=True)
class SearchProblem:
    """What a sampling search gets.

    Attributes:
        q_start: ``(dof,)`` [rad or m], clear.
        q_goals: ``(k, dof)`` candidate goals, clear, in order of preference.
        lower, upper: ``(dof,)`` joint position limits of the search space.
        state_ok: Is this configuration clear?
        edge_ok: Is the straight joint segment between these two configurations clear
            (certified)? None: the sampler checks segments itself, at ``resolution``.
        seed: Integer >= 0; the same problem and seed give the same answer.
        time_limit: [s] of search.
        max_states: Most questions (``state_ok`` and ``edge_ok``): bounds the tree, so the
            memory, of one search.
        resolution: [rad] Longest step between the configurations ``state_ok`` is asked about
            along a segment, when ``edge_ok`` is None (a lazy search: its path is certified
            afterwards).
        max_edge: [rad] Longest tree edge (joint-space norm); None: the sampler's default.
    """

    q_start: np.ndarray
    q_goals: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    state_ok: Callable[[np.ndarray], bool]
    edge_ok: Callable[[np.ndarray, np.ndarray], bool] | None
    seed: int
    time_limit: float
    max_states: int
    resolution: float = 0.1
    max_edge: float | None = None


@dataclass(frozen=True)
class SearchResult:
    """What a sampling search found.

    Attributes:
        path: ``(n, dof)`` from the start to one of the goals, every segment passed ``edge_ok``;
            None when none was found in time.
        iterations: Questions the search asked (``state_ok`` and ``edge_ok`` calls).
        states: Configurations in the search trees at the end.
        time_ms: [ms] wall time of the search.
    """

    path: np.ndarray | None
    iterations: int
    states: int
    time_ms: float


class Sampler(Protocol):
    """A sampling planner: ``name`` (reported) and ``search``."""

    name: str

    def search(self, problem: SearchProblem) -> SearchResult: ...


class _Counts:
    """Questions asked by a search: ``states`` (configurations), ``edges`` (segments)."""

    def __init__(self) -> None:
        self.states = self.edges = 0

    def wrap(self, state_ok: Callable[[np.ndarray], bool], dof: int) -> Callable[[Any], bool]:
        def check(state: Any) -> bool:
            self.states += 1
            return bool(state_ok(_array(state, dof)))

        return check


class _EdgeValidator(ob.MotionValidator):
    """OMPL's motion check answered by ``edge_ok`` (no resolution of OMPL's own)."""

    def __init__(
        self, si: ob.SpaceInformation, dof: int, edge_ok: Callable[..., bool], counts: _Counts
    ) -> None:
        super().__init__(si)
        self.dof, self.edge_ok, self.counts = dof, edge_ok, counts

    def checkMotion(self, s1: Any, s2: Any) -> bool:
        self.counts.edges += 1
        return bool(self.edge_ok(_array(s1, self.dof), _array(s2, self.dof)))


def _array(state: Any, dof: int) -> np.ndarray:
    return np.array(state[0:dof], dtype=float)


def _state(si: ob.SpaceInformation, q: np.ndarray) -> Any:
    st = si.allocState()
    for j, v in enumerate(q):
        st[j] = float(v)
    return st


class RRTConnect:
    """OMPL's RRT-Connect over the joint box (tree edges of at most ``max_edge``; by default a
    fifth of the box's diagonal, OMPL's own choice)."""

    name = "rrt_connect"

    def search(self, problem: SearchProblem) -> SearchResult:
        started = time.perf_counter()
        dof = len(problem.q_start)
        end = started + max(float(problem.time_limit), 0.0)
        with _SEED_LOCK:
            ou.RNG.setSeed(int(problem.seed) + SEED_OFFSET)
            space = ob.RealVectorStateSpace(dof)
            bounds = ob.RealVectorBounds(dof)
            for j in range(dof):
                bounds.setLow(j, float(problem.lower[j]))
                bounds.setHigh(j, float(problem.upper[j]))
            space.setBounds(bounds)
            si = ob.SpaceInformation(space)
            counts = _Counts()
            si.setStateValidityChecker(counts.wrap(problem.state_ok, dof))
            if problem.edge_ok is not None:
                si.setMotionValidator(_EdgeValidator(si, dof, problem.edge_ok, counts))
            else:
                extent = float(np.linalg.norm(problem.upper - problem.lower))
                space.setLongestValidSegmentFraction(min(problem.resolution / extent, 1.0))
            si.setup()
            pdef = ob.ProblemDefinition(si)
            pdef.addStartState(_state(si, problem.q_start))
            goals = ob.GoalStates(si)
            for q in problem.q_goals:
                goals.addState(_state(si, q))
            pdef.setGoal(goals)
            planner = og.RRTConnect(si)
            if problem.max_edge is not None:
                planner.setRange(float(problem.max_edge))
            planner.setProblemDefinition(pdef)
            planner.setup()
            planner.solve(ob.PlannerTerminationCondition(lambda: True))  # allocates its sampler

        def stop() -> bool:
            return time.perf_counter() >= end or counts.states + counts.edges >= problem.max_states

        planner.solve(ob.PlannerTerminationCondition(stop))
        path = None
        if pdef.hasExactSolution():
            sol = pdef.getSolutionPath()
            path = np.array([_array(sol.getState(i), dof) for i in range(sol.getStateCount())])
        data = ob.PlannerData(si)
        planner.getPlannerData(data)
        states = int(data.numVertices())
        elapsed = (time.perf_counter() - started) * 1e3
        planner.clear()
        return SearchResult(path, counts.edges + counts.states, states, elapsed)
