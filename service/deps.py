"""FastAPI dependencies: the settings, the request's deadline and response policy, robot lookup.

``service.app`` attaches ``request_deadline`` to every planning router and ``response_policy`` to
the routers that answer trajectories, so every such route has a deadline and every response passes
the admission in ``service.encoding`` without the route doing anything. A route that wants the
objects themselves declares them, and FastAPI hands it the same instances (dependencies are cached
per request)::

    def plan(body: Request, deadline: Deadline = Depends(deps.request_deadline)) -> Response: ...
    def fk(robot: Robot = Depends(deps.robot_by_name)) -> ...: ...

The two request dependencies are ``async`` on purpose: they run in the request's own task, so the
context variable they set is seen by the route, which FastAPI runs in a thread with a copy of it.
"""

from __future__ import annotations

from contextvars import ContextVar
from dataclasses import replace
from typing import Annotated

from fastapi import Path, Request

from core.budget import Deadline
from robots.model import Robot
from robots.registry import resolve
from service import memo
from service.encoding import RESPONSE_POLICY, ResponsePolicy, current_policy
from service.schemas.common import LAYOUT_QUERY, Layout
from service.settings import Settings


async def get_settings(request: Request) -> Settings:
    """The app's settings (``create_app(settings)``)."""
    settings: Settings = request.app.state.settings
    return settings


BATCH_DEADLINE: ContextVar[Deadline | None] = ContextVar("batch_deadline", default=None)
"""The deadline of the ``POST /v1/batch`` a request runs in as an item (None outside a batch)."""


async def request_deadline(request: Request) -> Deadline:
    """The request's ``Deadline``: ``TRAJ_TIME_BUDGET_S`` from its first use (one per request, kept
    in ``request.state.deadline``; a batch item's ends no later than its batch's), also checked
    before a trajectory response is encoded. Also activates the request's ``service.memo``."""
    deadline: Deadline | None = getattr(request.state, "deadline", None)
    if deadline is None:
        settings: Settings = request.app.state.settings
        seconds = settings.time_budget_s
        batch = BATCH_DEADLINE.get()
        if batch is not None:
            seconds = min(seconds, batch.remaining())
        deadline = request.state.deadline = Deadline(seconds)
        memo.activate()
        RESPONSE_POLICY.set(
            replace(
                current_policy(),
                deadline=deadline,
                max_bytes=settings.max_response_bytes,
                budget_bytes=settings.response_budget_bytes,
            )
        )
    return deadline


async def response_policy(request: Request, layout: Layout = LAYOUT_QUERY) -> ResponsePolicy:
    """The ``?layout=`` of a trajectory response, with the request's deadline and size limits.
    (No sub-dependencies: each costs FastAPI a few tens of microseconds per request.)"""
    await request_deadline(request)
    policy = replace(current_policy(), layout=layout)
    RESPONSE_POLICY.set(policy)
    return policy


def robot_by_name(
    name: Annotated[str, Path(description="A registered robot (GET /v1/robots lists them).")],
) -> Robot:
    """The registered robot ``name`` (404 ``unknown_robot`` listing the names otherwise)."""
    return resolve(name)
