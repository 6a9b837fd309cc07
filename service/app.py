"""create_app(): the FastAPI application with its routers, error handlers and limits."""

from __future__ import annotations

from fastapi import FastAPI

from service import __version__, errors, metrics
from service.body_limit import BodyLimitMiddleware
from service.observability import ObservabilityMiddleware
from service.routes import (
    cartesian,
    collision,
    compare,
    health,
    playground,
    ready,
    robots,
    trajectories,
)
from service.settings import Settings


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings.from_env()
    app = FastAPI(
        title="Trajectory Service",
        version=__version__,
        description=(
            "Plans robot trajectories over HTTP: joint-space profiles, C2 splines, Cartesian straight "
            "lines (sampled IK, Taylor's bounded deviation, its optimization form, resolved-rate "
            "control). SI units throughout: meters, radians, seconds."
        ),
    )
    app.state.settings = settings
    errors.install(app)
    for module in (health, ready, metrics, robots, trajectories, cartesian, compare, playground):
        app.include_router(module.router)
    app.include_router(collision.router)
    app.add_middleware(BodyLimitMiddleware, max_bytes=settings.max_body_bytes)
    # Added last = outermost: request id, metrics and access line cover every answer, 413 included.
    app.add_middleware(
        ObservabilityMiddleware, routes=app.router.routes, access_log=settings.access_log
    )
    return app
