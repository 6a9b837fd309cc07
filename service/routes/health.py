"""GET /health: a cheap liveness answer."""

from __future__ import annotations

from fastapi import APIRouter
from pydantic import BaseModel

from service import __version__

router = APIRouter(tags=["health"])


class Health(BaseModel):
    status: str
    version: str


@router.get("/health", response_model=Health, summary="Liveness: the process answers")
def health() -> Health:
    return Health(status="ok", version=__version__)
