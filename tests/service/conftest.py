"""Fixtures and request builders shared by the HTTP tests (one copy each)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from fastapi.testclient import TestClient

from core.geometry.so3 import matrix_to_quat
from service.app import create_app
from service.settings import Settings


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    """A client of the app with the default settings, one per test module (a module may define
    its own ``client`` for other settings)."""
    with TestClient(create_app(Settings())) as test_client:
        yield test_client


def pose_body(T: np.ndarray) -> dict[str, list[float]]:
    """The request's ``pose`` object of a transform ``T`` (4, 4): position [m], quaternion (x, y, z, w)."""
    return {"position": T[:3, 3].tolist(), "orientation": matrix_to_quat(T[:3, :3]).tolist()}
