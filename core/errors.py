"""The PlanningError tree: every expected failure of planning, with the data that explains it.

Errors carry data (the request field at fault, the path parameter ``s`` where a Cartesian plan fails,
the joint, the sample index) and a stable machine-readable ``code``. They never carry HTTP status
codes: ``service/errors.py`` maps each class to a status and a problem+json body.
"""

from __future__ import annotations

from typing import Any, ClassVar


class PlanningError(Exception):
    """Base class. ``code`` names the failure; ``title`` is a short human summary.

    Args:
        detail: One sentence that says what went wrong and where, never echoing raw client input.
        field: Request field at fault, as a location tuple (for example ``("goal", "positions", 2)``).
        s: Path parameter in [0, 1] where a Cartesian plan failed.
        joint: Index of the joint at fault.
        sample: Index of the sample at fault.
        partial: A partial result (for example the reachable prefix of a line) the caller may return.
        extra: Further JSON-serializable facts for the problem body (public: every key is
            documented in docs/api.md).
        s_reached: Where a path was last reached before ``s`` (internal: how far a partial plan
            may go; never in a problem body).
    """

    code: ClassVar[str] = "infeasible"
    title: ClassVar[str] = "Planning failed"

    def __init__(
        self,
        detail: str,
        *,
        field: tuple[str | int, ...] | None = None,
        s: float | None = None,
        joint: int | None = None,
        sample: int | None = None,
        partial: Any = None,
        extra: dict[str, Any] | None = None,
        s_reached: float | None = None,
    ) -> None:
        super().__init__(detail)
        self.detail = detail
        self.field = field
        self.s = s
        self.joint = joint
        self.sample = sample
        self.partial = partial
        self.extra = dict(extra or {})
        self.s_reached = s_reached


class InputError(PlanningError):
    """A value is malformed or out of its documented range (checked at a core entry point)."""

    code = "validation"
    title = "Invalid request"


class UnknownRobot(PlanningError):
    """No robot is registered under the requested name; ``extra["available"]`` lists valid names."""

    code = "unknown_robot"
    title = "Unknown robot"


class UnknownFrame(PlanningError):
    """A frame name asked of a registered robot does not exist; ``extra["frames"]`` lists them."""

    code = "unknown_frame"
    title = "Unknown frame"


class InvalidURDF(PlanningError):
    """An inline URDF was rejected by screening or by the parser."""

    code = "invalid_urdf"
    title = "Invalid URDF"


class Unreachable(PlanningError):
    """Type I failure: no IK solution within tolerance (a pose outside the workspace)."""

    code = "unreachable"
    title = "Goal is unreachable"


class JointLimit(PlanningError):
    """The only solutions violate joint position limits."""

    code = "joint_limit"
    title = "Joint limit violated"


class BranchFlip(PlanningError):
    """IK jumped to another solution branch: a joint step far larger than the Jacobian predicts."""

    code = "branch_flip"
    title = "IK branch flip"


class Singularity(PlanningError):
    """Type II failure: the Jacobian loses rank along the path (smallest singular value too small)."""

    code = "singularity"
    title = "Singular configuration"


class JointRateLimit(PlanningError):
    """Joint rates exceed the velocity (or acceleration) limits and the timing cannot fix it."""

    code = "joint_rate_limit"
    title = "Joint rate limit exceeded"


class Infeasible(PlanningError):
    """The request is well formed but no plan satisfies its constraints."""

    code = "infeasible"
    title = "Infeasible request"


class NoConvergence(PlanningError):
    """An iterative solver (IK, IPOPT, OSQP) stopped at its iteration cap without converging."""

    code = "no_convergence"
    title = "Solver did not converge"


class TooLarge(PlanningError):
    """The request would exceed a size bound (points per response, joints, URDF bytes)."""

    code = "too_large"
    title = "Request too large"


class TimeBudgetExceeded(PlanningError):
    """Planning ran past its wall-time budget and was stopped."""

    code = "time_budget_exceeded"
    title = "Time budget exceeded"


ALL_ERRORS: tuple[type[PlanningError], ...] = (
    InputError,
    UnknownRobot,
    UnknownFrame,
    InvalidURDF,
    Unreachable,
    JointLimit,
    BranchFlip,
    Singularity,
    JointRateLimit,
    Infeasible,
    NoConvergence,
    TooLarge,
    TimeBudgetExceeded,
)


class Collision(PlanningError):
    """The motion brings the robot closer than the clearance to an obstacle, or two of its links into
    contact. ``extra``: ``time_from_start`` [s], ``links`` (robot link, obstacle or link), ``distance``
    [m] (negative: penetration); ``s`` for Cartesian plans; ``detail`` says when the start or the goal
    itself is in collision."""

    code = "collision"
    title = "Collision"


ALL_ERRORS = (*ALL_ERRORS, Collision)


class NoPathFound(PlanningError):
    """A collision-free motion search found no path within its time limit; ``extra`` carries the
    planner's figures (``planner``: name, seed, iterations, states, plan_time_ms)."""

    code = "no_path_found"
    title = "No path found"


ALL_ERRORS = (*ALL_ERRORS, NoPathFound)
