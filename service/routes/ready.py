"""GET /ready: every registered robot loads and forward kinematics passes a self-test.

The first successful check is cached for the life of the app (per worker process); until then each
call retries. Not ready is 503 ``application/problem+json`` with ``code: "not_ready"`` and a
``Retry-After`` header, so a load balancer or a Kubernetes readiness probe keeps traffic away.

Self-test: FK at each robot's home configuration is a finite 4x4 homogeneous transform, and the
planar 2-link arm at ``q = [0, 0]`` puts its tool at x = 1.8 m, y = 0 (to 1e-9 m), a known answer.
``robots`` is imported inside the handler, so the app starts (and answers 503) without it.
"""

from __future__ import annotations

import importlib
import logging
import threading
from typing import Any, Literal

import numpy as np
from fastapi import APIRouter, Request
from pydantic import BaseModel, Field
from starlette.responses import Response

from service.errors import problem_body, problem_response

router = APIRouter(tags=["health"])
log = logging.getLogger("service.ready")

KNOWN_ANSWER_ROBOT = "planar_2r"
KNOWN_ANSWER_XY = (1.8, 0.0)
"""Tool position in [m] of the planar 2-link arm at q = [0, 0] (links of 1.0 m and 0.8 m)."""
TOLERANCE_M = 1e-9
RETRY_AFTER_S = 5

_lock = threading.Lock()


class Ready(BaseModel):
    status: Literal["ready"] = Field(description='Always "ready" on a 200 answer.')
    robots: list[str] = Field(
        description="Registered robot names that loaded and passed FK checks."
    )


class NotReady(Exception):
    """The readiness self-test failed; the message says which step and which robot."""


def self_test(registry: Any) -> list[str]:
    """Load every robot of ``registry`` (``names()``, ``get(name)``) and check its FK.

    Returns:
        The robot names, sorted.

    Raises:
        NotReady: a robot does not load, FK is not a finite homogeneous 4x4 transform at home, or the
            planar 2-link known answer is off by more than ``TOLERANCE_M``.
    """
    names = sorted(registry.names())
    if not names:
        raise NotReady("no robot is registered")
    for name in names:
        try:
            robot = registry.get(name)
            T_base_tool = np.asarray(robot.fk(np.asarray(robot.home, dtype=float)), dtype=float)
        except Exception as e:
            raise NotReady(f"robot {name!r} failed to load or evaluate FK at home: {e}") from e
        if T_base_tool.shape != (4, 4) or not np.all(np.isfinite(T_base_tool)):
            raise NotReady(f"FK of robot {name!r} at home is not a finite 4x4 transform")
        if not np.allclose(T_base_tool[3], (0.0, 0.0, 0.0, 1.0)):
            raise NotReady(f"FK of robot {name!r} at home is not a homogeneous transform")
    if KNOWN_ANSWER_ROBOT in names:
        robot = registry.get(KNOWN_ANSWER_ROBOT)
        T_base_tool = np.asarray(robot.fk(np.zeros(robot.dof)), dtype=float)
        error = np.abs(T_base_tool[:2, 3] - KNOWN_ANSWER_XY)
        if not np.all(error <= TOLERANCE_M):
            raise NotReady(
                f"FK self-test failed: {KNOWN_ANSWER_ROBOT} at q=0 is off the known tool position "
                f"by {float(error.max()):.3g} m"
            )
    return names


def _not_ready(detail: str) -> Response:
    body = problem_body(503, "not_ready", "Service not ready", detail[:500])
    response = problem_response(503, body)
    response.headers["Retry-After"] = str(RETRY_AFTER_S)
    return response


@router.get(
    "/ready",
    response_model=Ready,
    summary="Readiness: robot models loaded and a forward-kinematics self-test passed",
    responses={503: {"description": "Not ready (problem+json, code `not_ready`)."}},
)
def ready(request: Request) -> Any:
    state = request.app.state
    cached = getattr(state, "ready_robots", None)
    if cached is None:
        with _lock:
            cached = getattr(state, "ready_robots", None)
            if cached is None:
                try:
                    registry = importlib.import_module("robots.registry")
                    cached = self_test(registry)
                except NotReady as e:
                    log.warning("not ready: %s", e)
                    return _not_ready(str(e))
                except Exception as e:  # the registry module is missing or broken
                    log.warning("not ready: robot registry unavailable: %s", e)
                    return _not_ready(f"robot registry unavailable: {type(e).__name__}")
                state.ready_robots = cached
                log.info("ready", extra={"robots": cached})
    return Ready(status="ready", robots=cached)
