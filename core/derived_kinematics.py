"""``DerivedKinematics``: the whole ``core.kinematics.Kinematics`` interface of a small robot model
(a test's toy, a closed-form arm) that has only ``fk`` and ``jacobian``, built from them one
configuration at a time."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from core.kinematics import PathSolutions, PathSolutionSet, Solutions, SolutionSet


class DerivedKinematics:
    """Mixin for a small robot model (tests, toys) that has only ``fk`` and ``jacobian``: the batched
    and combined members of ``Kinematics`` built from them, one configuration at a time."""

    dof: int

    def fk(self, q: np.ndarray) -> np.ndarray:  # pragma: no cover - provided by the model
        raise NotImplementedError

    def jacobian(self, q: np.ndarray) -> np.ndarray:  # pragma: no cover - provided by the model
        raise NotImplementedError

    def fk_many(self, qs: np.ndarray) -> np.ndarray:
        return np.stack([self.fk(q) for q in np.atleast_2d(qs)])

    def jacobian_many(self, qs: np.ndarray) -> np.ndarray:
        return np.stack([self.jacobian(q) for q in np.atleast_2d(qs)])

    def fk_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.fk(q), self.jacobian(q)

    def fk_jacobian_many(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.fk_many(qs), self.jacobian_many(qs)

    def fk_jacobian_loop(self) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
        return self.fk_jacobian

    jerk_limits: np.ndarray | None = None
    """No jerk limits known."""
    configuration_labels: tuple[str, ...] = ()
    """No labels."""
    redundant_joints: tuple[str, ...] = ()
    """None held: ``ik_all`` gives what ``ik`` finds from the seed."""

    def configuration(self, q: np.ndarray) -> str | None:
        """No labels: core keeps its jump-ratio branch test for such a model."""
        return None

    def configurations(self, qs: np.ndarray) -> list[str | None]:
        return [None] * len(np.atleast_2d(qs))

    def ik_all(self, T_base_tool: np.ndarray, seed: np.ndarray | None = None) -> Solutions:
        """The one solution ``ik`` finds from ``seed`` (unlabelled; none when it does not converge)."""
        start = np.zeros(self.dof) if seed is None else np.asarray(seed, dtype=float)
        r = self.ik(T_base_tool, start)  # type: ignore[attr-defined]
        if not r.success:
            outside = int(not r.within_limits and max(r.position_error, r.orientation_error) < 1e-6)
            return SolutionSet(np.zeros((0, len(start))), (), outside)
        return SolutionSet(np.asarray(r.positions, dtype=float)[None], (None,), 0)

    def ik_many(
        self, Ts: np.ndarray, seed: np.ndarray, configuration: str | None = None
    ) -> PathSolutions:
        """``ik`` pose by pose, each from the previous solution (the label is not checked)."""
        Ts = np.asarray(Ts, dtype=float)
        positions = np.zeros((len(Ts), self.dof))
        found, within = np.zeros(len(Ts), dtype=bool), np.zeros(len(Ts), dtype=bool)
        previous = np.asarray(seed, dtype=float)
        for i, T in enumerate(Ts):
            r = self.ik(T, previous)  # type: ignore[attr-defined]
            found[i] = max(r.position_error, r.orientation_error) <= 1e-9
            within[i] = found[i] and r.within_limits
            previous = np.asarray(r.positions, dtype=float) if found[i] else previous
            positions[i] = previous
        return PathSolutionSet(positions, found, within)
