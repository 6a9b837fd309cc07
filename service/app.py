"""create_app(): the FastAPI application with its routers, error handlers and limits."""

from __future__ import annotations

from fastapi import Depends, FastAPI

from service import __version__, admission, deps, errors, openapi
from service.allocator import tune_malloc
from service.media_type import require_json
from service.middleware import metrics
from service.middleware.body_limit import BodyLimitMiddleware
from service.middleware.catch_all import CatchAllMiddleware
from service.middleware.observability import ObservabilityMiddleware
from service.middleware.write_timeout import WriteTimeoutMiddleware
from service.routes import (
    api_docs,
    batch,
    cartesian,
    collision,
    collision_free,
    compare,
    health,
    playground,
    program,
    ready,
    retime,
    robots,
    trajectories,
)
from service.settings import Settings

TRAJECTORY_ROUTERS = (trajectories, retime, cartesian, compare, program, collision_free)
"""Routers whose answers are trajectories: each route gets a deadline and ``?layout=``."""
PLANNING_ROUTERS = (robots, collision)
"""Other routers that compute: each route gets a deadline."""


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings.from_env()
    tune_malloc(settings.malloc_retain_bytes)  # per process: each worker creates its app
    app = FastAPI(
        title="Trajectory Service",
        version=__version__,
        description=openapi.DESCRIPTION,
        docs_url=None,  # /docs and /redoc with local assets: service/routes/api_docs.py
        redoc_url=None,
        generate_unique_id_function=openapi.operation_id,
    )
    app.state.settings = settings
    errors.install(app)
    openapi.install(app)
    for module in (health, ready, metrics, playground, api_docs):
        app.include_router(module.router)
    for module in PLANNING_ROUTERS:
        app.include_router(
            module.router,
            dependencies=[
                Depends(require_json),
                Depends(admission.admit),
                Depends(deps.request_deadline),
            ],
        )
    for module in TRAJECTORY_ROUTERS:
        app.include_router(
            module.router,
            dependencies=[
                Depends(require_json),
                Depends(admission.admit),
                Depends(deps.response_policy),
            ],
        )
    # the batch's items get their routes' dependencies (admission, deadline) in process
    app.include_router(batch.router, dependencies=[Depends(require_json)])
    # Innermost first: the body limit and timeouts, then the catch-all 500 (so an error anywhere
    # inside is a whole answer), then request id, metrics and access line around everything.
    app.add_middleware(
        BodyLimitMiddleware,
        max_bytes=settings.max_body_bytes,
        timeout_s=settings.body_timeout_s,
        deadline_s=settings.body_deadline_s,
    )
    app.add_middleware(WriteTimeoutMiddleware, timeout_s=settings.write_timeout_s)
    app.add_middleware(CatchAllMiddleware)
    app.add_middleware(
        ObservabilityMiddleware, routes=app.router.routes, access_log=settings.access_log
    )
    return app
