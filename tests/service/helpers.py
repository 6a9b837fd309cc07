"""Helpers shared by the HTTP tests: problem+json answers, seeded random request sweeps, and the
marker for tests that need the robot registry."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel

from service.field_paths import valid_depth

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


LONG_NUMBER = re.compile(r"\d{21,}")
"""A run of more than 20 digits: a number written out in full (1e160 as 160 digits), not sensibly."""


OWN_LOCS = ("extra_forbidden", "json_invalid")
"""``errors[].type`` whose ``loc`` is the client's own text, not a field of the model."""


def documented_problem(
    status: int,
    content_type: str,
    body: Any,
    codes: dict[str, str],
    model: type[BaseModel] | None = None,
) -> None:
    """Assert an error answer keeps the contract of docs/api.md (``codes``: its "Error codes" table,
    code -> status cell): problem+json, a documented ``code`` with its documented status, ``errors``
    on every ``validation`` answer, each ``loc`` a path of the request ``model`` (when given; an
    unknown field where the client put it), and no
    number written out in more than 20 digits. A ``/v1/compare`` row's ``error`` is checked too."""
    where = json.dumps(body)[:2000]
    assert content_type.startswith("application/problem+json"), (status, content_type, where)
    assert body["status"] == status and body["type"].endswith("/" + body["code"]), where
    assert body["code"] in codes, f"undocumented code {body['code']!r}: {where}"
    assert str(status) in codes[body["code"]], f"{body['code']} is documented {codes[body['code']]}"
    _problem_fields(body, model, where)


def _problem_fields(body: dict[str, Any], model: type[BaseModel] | None, where: str) -> None:
    assert isinstance(body.get("detail"), str) and body["detail"], where
    own = {k: v for k, v in body.items() if k != "errors"}  # locs may hold the client's keys
    messages = [e.get("msg") for e in body.get("errors") or ()]
    assert not LONG_NUMBER.search(json.dumps([own, messages])), where
    if body["code"] == "validation":
        assert isinstance(body.get("errors"), list) and body["errors"], f"no errors: {where}"
    for error in body.get("errors") or ():
        loc = error["loc"]
        assert isinstance(error["msg"], str) and loc and loc[0] in ("body", "query", "path"), where
        # An unknown field is named where the client put it; a JSON syntax error at its offset.
        if model is not None and loc[0] == "body" and error.get("type") not in OWN_LOCS:
            depth = valid_depth(model, loc[1:])
            assert depth == len(loc) - 1, f"{loc} is not a field of {model.__name__}: {where}"


def documented_rows(body: Any, codes: dict[str, str], model: type[BaseModel] | None) -> None:
    """The ``error`` of every failed ``/v1/compare`` row keeps the same contract (status 422)."""
    for row in body.get("results", ()) if isinstance(body, dict) else ():
        if row.get("error") is not None:
            error = row["error"]
            assert error["code"] in codes, f"undocumented code in a row: {error}"
            _problem_fields(error, model, json.dumps(error)[:2000])
