"""Typed results of the service's answers (frozen dataclasses; ``raw`` keeps the whole answer).

Trajectories come as columns (``time_from_start`` ``(n,)``, ``positions``/``velocities``/
``accelerations`` ``(n, dof)``): Python lists, or numpy float64 arrays with ``as_numpy=True``
(numpy is then needed: ``pip install "trajectory-client[numpy]"``). SI units: m, rad, s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Union

from trajectory_client.errors import ServiceError, error_for

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    Array = npt.NDArray[np.float64]

Vector = Union[list[float], "Array"]
"""``(n,)`` values: a list, or a numpy array with ``as_numpy=True``."""
Matrix = Union[list[list[float]], "Array"]
"""``(n, dof)`` values: a list of rows, or a numpy array with ``as_numpy=True``."""

COLUMNS = ("time_from_start", "positions", "velocities", "accelerations")


def _array(value: Any, as_numpy: bool) -> Any:
    if not as_numpy:
        return value
    import numpy as np

    return np.asarray(value, dtype=np.float64)


@dataclass(frozen=True)
class Pose:
    """The tool frame in the base frame: ``position`` [m], ``orientation`` quaternion (x, y, z, w)."""

    position: list[float]
    orientation: list[float]

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> Pose:
        return cls(list(doc["position"]), list(doc["orientation"]))

    def to_json(self) -> dict[str, list[float]]:
        return {"position": list(self.position), "orientation": list(self.orientation)}


@dataclass(frozen=True)
class Trajectory:
    """A timed joint trajectory (any trajectory endpoint's answer).

    Attributes:
        joint_names: One per joint.
        time_from_start: ``(n,)`` [s], from 0, strictly increasing.
        positions, velocities, accelerations: ``(n, dof)`` [rad or m, /s, /s^2].
        diagnostics: The answer's ``diagnostics`` (``duration``, peaks, ``warnings``, ...).
        raw: The whole answer (``segments`` of a program, ``knots``, ``waypoints`` ...), without
            the four columns.
    """

    joint_names: list[str]
    time_from_start: Vector
    positions: Matrix
    velocities: Matrix
    accelerations: Matrix
    diagnostics: dict[str, Any]
    raw: dict[str, Any] = field(repr=False)

    @property
    def duration(self) -> float:
        """[s]"""
        return float(self.diagnostics["duration"])

    @property
    def warnings(self) -> list[str]:
        return list(self.diagnostics.get("warnings", []))

    def points(self) -> list[dict[str, Any]]:
        """The samples as ROS ``JointTrajectoryPoint``-shaped dicts (times as float seconds)."""
        rows = zip(*(_tolist(getattr(self, c)) for c in COLUMNS), strict=True)
        return [dict(zip(COLUMNS, row, strict=True)) for row in rows]

    @classmethod
    def from_json(cls, doc: dict[str, Any], as_numpy: bool = False) -> Trajectory:
        """From either layout of the answer (``?layout=columns`` or ROS-shaped ``points``)."""
        rest = {k: v for k, v in doc.items() if k not in (*COLUMNS, "points", "layout")}
        if "points" in doc:
            points = doc["points"]
            columns = {c: [p[c] for p in points] for c in COLUMNS}
        else:
            columns = {c: doc[c] for c in COLUMNS}
        return cls(
            joint_names=list(doc["joint_names"]),
            **{c: _array(v, as_numpy) for c, v in columns.items()},
            diagnostics=dict(doc.get("diagnostics", {})),
            raw=rest,
        )


def _tolist(value: Any) -> list[Any]:
    return value.tolist() if hasattr(value, "tolist") else list(value)


@dataclass(frozen=True)
class FKResult:
    """``pose``, ``jacobian`` (6 x dof, base frame, linear rows first), ``min_singular_value``,
    ``manipulability``, the ``configuration`` label and, when asked, every link's ``frames``."""

    pose: Pose
    jacobian: list[list[float]]
    min_singular_value: float
    manipulability: float
    configuration: str | None
    frames: list[dict[str, Any]] | None
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, doc: dict[str, Any], as_numpy: bool = False) -> FKResult:
        return cls(
            Pose.from_json(doc["pose"]),
            doc["jacobian"],
            float(doc["min_singular_value"]),
            float(doc["manipulability"]),
            doc.get("configuration"),
            doc.get("frames"),
            doc,
        )


@dataclass(frozen=True)
class IKSolution:
    """One joint solution [rad or m] with its label and residuals [m], [rad]."""

    positions: list[float]
    configuration: str | None
    position_error: float
    orientation_error: float


@dataclass(frozen=True)
class IKResult:
    """The answer of ``/ik``: the ``solutions`` (one unless ``all``), the ``solver`` and warnings."""

    solutions: list[IKSolution]
    solver: str
    warnings: list[str]
    raw: dict[str, Any] = field(repr=False)

    @property
    def positions(self) -> list[float]:
        """The first solution's joint positions."""
        return self.solutions[0].positions

    @classmethod
    def from_json(cls, doc: dict[str, Any], as_numpy: bool = False) -> IKResult:
        rows = doc["solutions"] if "solutions" in doc else [doc]
        solutions = [
            IKSolution(
                list(r["positions"]),
                r.get("configuration"),
                float(r["position_error"]),
                float(r["orientation_error"]),
            )
            for r in rows
        ]
        return cls(solutions, str(doc.get("solver", "")), list(doc.get("warnings", [])), doc)


@dataclass(frozen=True)
class Distance:
    """``min_distance`` [m] (None: nothing checked) and the closest ``pairs`` (``links``,
    ``distance`` [m], negative: penetration; ``points`` in the base frame)."""

    min_distance: float | None
    pairs: list[dict[str, Any]]
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, doc: dict[str, Any], as_numpy: bool = False) -> Distance:
        return cls(doc.get("min_distance"), list(doc.get("pairs", [])), doc)


@dataclass(frozen=True)
class CompareRow:
    """One method's row: ``ok``, its ``diagnostics``, its ``error`` (the exception its failure
    would raise alone) or its ``trajectory`` (with ``include_trajectories``)."""

    method: str
    ok: bool
    diagnostics: dict[str, Any]
    error: ServiceError | None
    trajectory: Trajectory | None


@dataclass(frozen=True)
class Comparison:
    """``/v1/compare``: one row per method, in the order asked."""

    rows: list[CompareRow]
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, doc: dict[str, Any], as_numpy: bool = False) -> Comparison:
        rows = []
        for r in doc.get("results", []):
            error = r.get("error")
            traj = r.get("trajectory")
            rows.append(
                CompareRow(
                    r["method"],
                    bool(r["ok"]),
                    dict(r.get("diagnostics", {})),
                    None if error is None else error_for(int(error.get("status", 422)), error),
                    None if traj is None else Trajectory.from_json(traj, as_numpy),
                )
            )
        return cls(rows, doc)


@dataclass(frozen=True)
class Robot:
    """A robot's description (``GET /v1/robots`` rows carry the first six; ``GET /v1/robots/{name}``
    and ``describe`` add ``limits``, ``home`` and the rest, kept in ``raw``)."""

    name: str
    dof: int
    joint_names: list[str]
    base_frame: str
    tip_frame: str
    task_space: str
    limits: dict[str, Any] | None
    home: list[float] | None
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, doc: dict[str, Any], as_numpy: bool = False) -> Robot:
        return cls(
            doc["name"],
            int(doc["dof"]),
            list(doc["joint_names"]),
            doc["base_frame"],
            doc["tip_frame"],
            doc["task_space"],
            doc.get("limits"),
            doc.get("home"),
            doc,
        )


@dataclass(frozen=True)
class BatchResult:
    """One item of a batch: its ``index`` in the items sent, ``endpoint``, ``status`` and either
    ``value`` (the typed result its endpoint's method returns) or ``error`` (the exception that
    method would raise); ``body`` is the item's whole answer."""

    index: int
    endpoint: str
    status: int
    value: Any
    error: ServiceError | None
    body: dict[str, Any] = field(repr=False)

    @property
    def ok(self) -> bool:
        return self.error is None

    def result(self) -> Any:
        """``value``, or raise ``error``."""
        if self.error is not None:
            raise self.error
        return self.value


@dataclass(frozen=True)
class Health:
    """``GET /health``: ``status`` ("ok") and the service's ``version``."""

    status: str
    version: str


@dataclass(frozen=True)
class Ready:
    """``GET /ready``: ``status`` ("ready") and the ``robots`` that loaded and passed their checks."""

    status: str
    robots: list[str]
