"""Branch-following IK along the line: the one IK call (``solve_ik``), tolerance and branch test
(``follows``, ``same_branch``) of every Cartesian method, and the knot methods' point on the start's
branch (``solve_on_line``), continuation along the whole line (``continuation``) and goal
configuration on the start's branch (``goal_configuration``). The ``sampled`` walk
(``core.cartesian.walk``) and its batched solve use the same call, tolerance and test.

Robots with configuration labels (``Kinematics.configuration``, issue 14) follow their start's
label exactly: a solution on another label is never taken, and a pose where IK fails is decided
from every solution of it (``on_label``): none at all is ``unreachable``, some only outside the
joint limits ``joint_limit``, some only on other labels ``branch_flip`` (``label_change`` names a
label change found on returned points). Robots without labels keep the jump-ratio tests above.
"""

from __future__ import annotations

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.knot_path import Knots
from core.errors import (
    BranchFlip,
    JointLimit,
    PlanningError,
    Singularity,
    Unreachable,
)
from core.geometry import so3
from core.kinematics import SINGULAR_VALUE_THRESHOLD, IKResult, Kinematics, jacobians, task_rows
from core.path.base import Path

IK_TOLERANCE = 1e-6
"""Largest IK residual [m] and [rad] of a point accepted as on the line (every method)."""
IK_SOLVE_TOLERANCE = 1e-9
"""Residual the IK is asked for (one more Newton step than ``IK_TOLERANCE`` from a good seed)."""
STRICT_BRANCH = (0.5, 1e-3)
"""A short step is on the branch when its solution is within ``0.5 max |step| + 1e-3`` [rad]
(max-abs) of where the Jacobian predicts, ``q0 + step`` (the walk, the continuation, the batched
solve of ``sampled``)."""
LOOSE_BRANCH = (3.0, 0.05)
"""A knot solved far from its seed is on the branch when it moved at most ``3 max |step| + 0.05``
[rad] (max-abs) from the seed, ``step`` the Jacobian's least-squares prediction (Taylor's knots)."""
GOAL_BRANCH_TOLERANCE = 0.1
"""[rad] a requested goal configuration is used when it is this close (max-abs) to the one reached by
IK continuation along the line from the start, i.e. on the same branch."""
CONTINUATION_STEP = (0.05, 0.25)
"""Largest step [m], [rad] of tool motion of the IK continuation that finds the goal configuration
on the start's branch."""
CONTINUATION_JOINT_STEP = 0.1
"""Largest predicted joint step [rad] of one continuation step."""
LABEL_BOUNDARY = 1e-6
"""Smallest task-Jacobian singular value below which a solution lies on the singular set where
labels change: it is the limit of every adjacent label's branch (``on_label``). Below
``core.kinematics.SINGULAR_VALUE_THRESHOLD`` a pose without a solution in the start's label is a
``singularity`` (next to the singular set, IK may return representatives only), not a
``branch_flip``."""
MIN_CONTINUATION_STEP = 1e-5
"""Shortest continuation step [share of s]; a failure there is the line's failure."""


def task_error(task_space: str, T_a: np.ndarray, T_b: np.ndarray) -> tuple[float, float]:
    """Position [m] and orientation [rad] difference of two poses (4, 4), task components only."""
    rows = 2 if task_space == "position_xy" else 3
    position = float(np.linalg.norm(T_a[:rows, 3] - T_b[:rows, 3]))
    if task_space == "position_xy":
        return position, 0.0
    return position, float(so3.rotation_angle(T_a[:3, :3].T @ T_b[:3, :3]))


def predicted_step(kin: Kinematics, q: np.ndarray, T_target: np.ndarray) -> np.ndarray:
    """Least-squares joint step (dof,) the Jacobian at ``q`` predicts toward the pose ``T_target``."""
    T = kin.fk(q)
    twist = np.zeros(6)
    twist[:3] = T_target[:3, 3] - T[:3, 3]
    twist[3:] = so3.log(T_target[:3, :3] @ T[:3, :3].T)
    rows = task_rows(kin.task_space)
    step, *_ = np.linalg.lstsq(kin.jacobian(q)[rows], twist[rows], rcond=1e-6)
    return step


def solve_ik(kin: Kinematics, T: np.ndarray, start: np.ndarray) -> IKResult:
    """IK at the pose ``T`` (4, 4) from ``start`` (dof,), asked for ``IK_SOLVE_TOLERANCE``; the
    iterates may leave the joint limits, so a solution reachable only outside them is told apart
    (``within_limits``) from no solution at all, and no redundant arm is slid along a limit off the
    path its rates describe."""
    return kin.ik(
        T,
        start,
        position_tolerance=IK_SOLVE_TOLERANCE,
        orientation_tolerance=IK_SOLVE_TOLERANCE,
        respect_limits=False,
    )


def residual(result: IKResult) -> float:
    """The larger of an IK result's position [m] and orientation [rad] residuals."""
    return max(result.position_error, result.orientation_error)


def follows(
    q: np.ndarray, q0: np.ndarray, step: np.ndarray, branch: tuple[float, float] = STRICT_BRANCH
) -> bool | np.ndarray:
    """Whether ``q`` continues the branch from ``q0`` when the Jacobian predicts ``step``: max-abs
    distance to ``q0 + step`` within ``branch[0] max |step| + branch[1]`` [rad]. Arrays ``(..., dof)``
    give one answer per leading index."""
    off = np.abs(q - q0 - step).max(axis=-1)
    return off <= branch[0] * np.abs(step).max(axis=-1) + branch[1]


def same_branch(step: np.ndarray, predicted: np.ndarray) -> bool:
    """Whether a joint ``step`` (dof,) is within what the Jacobian's ``predicted`` step allows
    (``LOOSE_BRANCH``: a knot solved far from its seed)."""
    limit = LOOSE_BRANCH[0] * float(np.max(np.abs(predicted))) + LOOSE_BRANCH[1]
    return float(np.max(np.abs(step))) <= limit


def on_label(kin: Kinematics, T: np.ndarray, s: float, label: str, near: np.ndarray) -> np.ndarray:
    """The exact answer at the pose ``T`` (path parameter ``s``) for a robot with labels: the
    solution with the start's configuration ``label`` nearest ``near`` (``kin.ik_all``: every
    solution), else raises why there is none -- ``Unreachable`` when the pose has no solution at all (off
    the workspace), ``JointLimit`` when it has some only outside the joint limits, ``BranchFlip``
    when every solution carries another label -- unless one is singular: on the boundary between
    labels (``LABEL_BOUNDARY``) it is returned, next to it (``SINGULAR_VALUE_THRESHOLD``) ``Singularity``."""
    sols = kin.ik_all(T, np.asarray(near, dtype=float))
    same = [i for i, c in enumerate(sols.configurations) if c == label]
    if same:
        return np.asarray(sols.positions[same[0]], dtype=float)
    where = f"at s={s:.4f}"
    if len(sols.positions):
        J = jacobians(kin, np.asarray(sols.positions, dtype=float))[:, task_rows(kin.task_space)]
        sigma = np.linalg.svd(J, compute_uv=False)[:, -1]
        if sigma.min() < LABEL_BOUNDARY:  # on the singular set between labels: the limit of the
            return np.asarray(sols.positions[int(np.argmin(sigma))], dtype=float)  # start's too
        if sigma.min() < SINGULAR_VALUE_THRESHOLD:
            raise Singularity(
                f"the pose {where} is next to a singularity (smallest singular value "
                f"{sigma.min():.3g}) where IK finds no solution in the start's configuration "
                f"({label}): the line passes the singular set there",
                s=float(s),
                extra={"min_singular_value": float(sigma.min())},
            )
        others = ", ".join(sorted({str(c) for c in sols.configurations}))
        raise BranchFlip(
            f"the pose {where} has IK solutions only in other configurations ({others}) than the "
            f"start's ({label}): the line would flip the arm's branch there",
            s=float(s),
            extra={"configuration": label},
        )
    if sols.outside_limits:
        raise JointLimit(f"the pose {where} is reachable only outside the joint limits", s=float(s))
    raise Unreachable(
        f"no IK solution {where}: the pose is off the robot's workspace",
        s=float(s),
    )


def label_change(s: float, label: str) -> BranchFlip:
    """The arm leaves the start's configuration ``label`` at ``s``."""
    return BranchFlip(
        f"the arm leaves the start's configuration ({label}) at s={s:.4f}: the line would flip "
        "its branch there",
        s=float(s),
        extra={"configuration": label},
    )


def solve_on_line(
    kin: Kinematics,
    line: Path,
    s: float,
    seed: np.ndarray,
    reference: np.ndarray | None = None,
    *,
    strict: bool = False,
    label: str | None = None,
) -> np.ndarray:
    """Joint positions (dof,) at the line's pose at ``s``, on the branch of ``seed``.

    IK from ``seed``, then from the seed moved by the Jacobian's predicted step, then from
    ``reference`` (a configuration on the start's branch near ``s``, from ``continuation``). A
    solution is on the branch when its distance to the seed, or to the reference, is within what the
    Jacobian predicts (``same_branch``); ``strict`` (small steps): when it is within
    ``STRICT_BRANCH`` of the predicted configuration. Raises ``BranchFlip`` when IK converges only on
    another branch, ``JointLimit`` when only outside the joint limits, ``Unreachable`` when not at
    all; each with ``s``. With the start's configuration ``label`` (robots with labels) a solution
    must also carry it (``strict`` callers check it afterwards, in a batch), and the failure is
    decided exactly by ``on_label``.
    """
    T = line.pose(s)
    seed = np.asarray(seed, dtype=float)
    anchors = [(seed, predicted_step(kin, seed, T))]
    starts = [seed + anchors[0][1], seed] if strict else [seed, seed + anchors[0][1]]
    if reference is not None:
        anchors.append((reference, predicted_step(kin, reference, T)))
        starts.append(reference)
    outcome = "unreachable"
    # IK roams outside the limits, so a solution reachable only outside them is told apart
    # (joint_limit) from no solution at all (unreachable).
    for start in starts:
        res = solve_ik(kin, T, start)
        if residual(res) > IK_TOLERANCE:
            continue
        if not res.within_limits:
            outcome = "joint_limit" if outcome == "unreachable" else outcome
            continue
        q = np.asarray(res.positions, dtype=float)
        # strict (short continuation steps): the label is checked in one batch at the end
        keeps = label is None or strict or kin.configuration(q) == label
        if keeps and _on_branch(q, anchors, strict):
            return q
        outcome = "branch_flip"
    where = f"at s={s:.4g}"
    if label is not None:
        exact = on_label(kin, T, s, label, seed)
        if _on_branch(exact, anchors, strict):
            return exact
        raise BranchFlip(
            f"the solution in the start's configuration ({label}) {where} is not where the "
            "Jacobian predicts the arm (it would jump there)",
            s=float(s),
        )
    if outcome == "branch_flip":
        raise BranchFlip(f"IK on the line {where} lands only on another branch", s=float(s))
    if outcome == "joint_limit":
        raise JointLimit(f"the line {where} is reachable only outside the joint limits", s=float(s))
    raise Unreachable(f"no IK solution within {IK_TOLERANCE:g} m on the line {where}", s=float(s))


def _on_branch(q: np.ndarray, anchors: list[tuple[np.ndarray, np.ndarray]], strict: bool) -> bool:
    """``solve_on_line``'s branch test: ``follows`` the first anchor's prediction (``strict``), or
    ``same_branch`` from any anchor."""
    if strict:
        seed, step = anchors[0]
        return bool(follows(q, seed, step))
    return any(same_branch(q - anchor, predicted) for anchor, predicted in anchors)


def continuation(
    kin: Kinematics, line: Path, q_start: np.ndarray, deadline: Deadline = NO_DEADLINE
) -> Knots:
    """IK along the line from ``q_start``, each point seeded where the Jacobian predicts the arm
    will be and checked to be there (``strict`` branch test): the start's branch.

    Steps of at most ``CONTINUATION_STEP`` of tool motion, 1/256 of the line, and
    ``CONTINUATION_JOINT_STEP`` of predicted joint motion (short steps where joints move fast, near
    singularities), halved down to ``MIN_CONTINUATION_STEP`` where a step fails; the failure there is
    raised with ``s_reached`` (the last point reached).
    """
    steps = int(np.ceil(max(line.length / CONTINUATION_STEP[0], line.angle / CONTINUATION_STEP[1])))
    ds_max = 1.0 / min(max(steps, 1), 256)
    rows = task_rows(kin.task_space)
    s, q = 0.0, np.asarray(q_start, dtype=float)
    label = kin.configuration(q)
    s_list, q_list = [s], [q]
    halved = 1.0
    while s < 1.0:
        deadline.check("bounded deviation: IK continuation")
        twist = line.derivative(np.array([s]))[0][rows]  # tool twist per unit s at s
        dq_ds, *_ = np.linalg.lstsq(kin.jacobian(q)[rows], twist, rcond=1e-6)
        rate = float(np.max(np.abs(dq_ds)))
        ds = min(ds_max, CONTINUATION_JOINT_STEP / rate if rate > 0 else ds_max) * halved
        ds = max(ds, MIN_CONTINUATION_STEP)
        s_next = min(1.0, s + ds)
        try:
            q = solve_on_line(kin, line, s_next, q, strict=True, label=label)
        except (BranchFlip, Unreachable, JointLimit, Singularity) as err:
            if ds <= MIN_CONTINUATION_STEP:
                err.s_reached = s
                raise
            halved *= 0.5
            continue
        s, halved = s_next, min(1.0, 2.0 * halved)
        s_list.append(s)
        q_list.append(q)
    if label is not None:  # the start's label at every point, in one batch
        off = np.flatnonzero(np.array(kin.configurations(np.array(q_list))) != label)
        if len(off):
            i = int(off[0])
            pair = np.array(q_list[i - 1 : i + 1])
            J = jacobians(kin, pair)[:, task_rows(kin.task_space)]
            sigma = float(np.linalg.svd(J, compute_uv=False)[:, -1].min())
            change: PlanningError = label_change(s_list[i], label)
            if sigma < SINGULAR_VALUE_THRESHOLD:  # the label changed through the singular set
                change = Singularity(
                    f"the line passes a singularity at s={s_list[i]:.4g} (smallest singular "
                    f"value {sigma:.3g}) where the arm leaves the start's configuration ({label})",
                    s=float(s_list[i]),
                    extra={"min_singular_value": sigma},
                )
            change.s_reached = s_list[i - 1]
            raise change
    return Knots(np.array(s_list), np.array(q_list))


def reference_at(reference: Knots | None, s: float) -> np.ndarray | None:
    """The continuation's configuration at ``s`` (linear between its points), or None."""
    if reference is None:
        return None
    return np.array([np.interp(s, reference.s, col) for col in reference.positions.T])


def label_note(kin: Kinematics, q_start: np.ndarray, q_goal: np.ndarray) -> str:
    """``"; goal.positions are <label>, the line keeps the start's <label>"`` when the two labels
    differ (robots with labels), else ``""``: for the warning on a requested goal configuration."""
    start = kin.configuration(np.asarray(q_start, dtype=float))
    goal = kin.configuration(np.asarray(q_goal, dtype=float))
    if start is None or goal == start:
        return ""
    return f"; goal.positions are {goal}, the line keeps the start's {start}"


def goal_configuration(
    kin: Kinematics,
    line: Path,
    q_start: np.ndarray,
    q_hint: np.ndarray | None = None,
    deadline: Deadline = NO_DEADLINE,
) -> tuple[np.ndarray, list[str], Knots]:
    """The goal's joint positions on the start's branch, warnings, and the continuation.

    The end of ``continuation``; ``q_hint`` (the request's goal positions) is used instead when it
    lies within ``GOAL_BRANCH_TOLERANCE`` of it, otherwise a warning says so.
    """
    reference = continuation(kin, line, q_start, deadline)
    q = reference.positions[-1]
    if q_hint is not None:
        q_hint = np.asarray(q_hint, dtype=float)
        gap = float(np.max(np.abs(q_hint - q)))
        if gap <= GOAL_BRANCH_TOLERANCE:
            return q_hint, [], reference
        return (
            q,
            [
                f"the line ends at the goal pose in another joint configuration than goal.positions "
                f"(up to {gap:.3g} rad apart{label_note(kin, q_start, q_hint)}): the trajectory "
                "ends where the line leads, without a branch flip"
            ],
            reference,
        )
    return q, [], reference
