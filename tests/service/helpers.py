"""Helpers shared by the HTTP tests: problem+json answers, seeded random request sweeps, and the
marker for tests that need the robot registry."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

needs_registry = pytest.mark.skipif(
    not (Path(__file__).resolve().parents[2] / "robots" / "registry.py").exists(),
    reason="robots/registry.py (another engineer's) is not there yet",
)
"""Marks the tests that need the robot registry: skipped until ``robots/registry.py`` exists."""


def problem(response: Any, status: int, code: str) -> dict[str, Any]:
    """Assert a problem+json answer with ``status`` and ``code``; return its body."""
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["code"] == code and body["status"] == status, body
    return body


def sweep(
    client: TestClient,
    url: str,
    generate: Callable[[np.random.Generator], tuple[dict[str, Any], bool]],
    recheck: Callable[[dict[str, Any], dict[str, Any]], None],
    *,
    seed: int,
    count: int,
    tolerated: tuple[str, ...] = (),
) -> dict[int, int]:
    """POST ``count`` seeded requests from ``generate`` (a request and whether it is well formed).

    Never a 5xx; a malformed request is 422; a well-formed one is 200 and passes ``recheck``, or a
    422 whose ``code`` is in ``tolerated``. A failure prints the request. Returns status counts.
    """
    rng = np.random.default_rng(seed)
    statuses: dict[int, int] = {}
    for i in range(count):
        request, valid = generate(rng)
        response = client.post(url, json=request)
        statuses[response.status_code] = statuses.get(response.status_code, 0) + 1
        where = f"request {i}: {json.dumps(request)}"
        assert response.status_code < 500, where
        if not valid:
            assert response.status_code == 422, where
            continue
        if response.status_code == 422 and response.json()["code"] in tolerated:
            continue
        assert response.status_code == 200, f"{where}\n{response.text}"
        try:
            recheck(request, response.json())
        except AssertionError as err:
            raise AssertionError(f"{where}\n{err}") from err
    return statuses
