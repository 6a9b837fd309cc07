"""Property-based fuzzing of every operation in the service's own ``/openapi.json`` (schemathesis).

Schemathesis reads the schema the app serves and generates requests for each operation: schema
examples, boundary values ("coverage" phase) and random positive and negative data ("fuzzing"
phase), plus undeclared methods. Every response is checked by schemathesis' built-in checks: no
5xx, a documented status code, a documented content type (``application/problem+json`` for errors),
a body that matches the documented schema, negative data rejected with a 4xx, ``Allow`` on a 405.
On top of those, every error body is checked against docs/api.md (``documented_problem``: a
documented code and status, ``errors`` on every ``validation``, each ``loc`` a field of the request).

One built-in check is left out, with reason: ``positive_data_acceptance`` expects every
schema-valid request to succeed, but JSON Schema cannot express the rules that make a valid request
here (a quaternion of norm 1 within 1e-3, ``samples`` or ``sample_period`` but not both, arrays as
long as the robot has joints), nor the planning outcomes that are a 422 by contract
(``unreachable``, ``joint_limit``, ...). The hand-written tests cover those rules, and
``test_hostile_bodies.py`` covers what schemathesis cannot generate (NaN, Infinity, 1e400, invalid
UTF-8, bodies over 2 MiB).

The app under test has a 1 s planning budget (and a 1 s batch budget) so that a generated
Cartesian, compare or batch request can never be slow. ``FUZZ_EXAMPLES`` (100) examples per
operation in the default run; the ``slow`` variant runs ``SLOW_FUZZ_EXAMPLES`` (1000). Operations
without parameters (``GET /health``, ``GET /ready``, ``GET /v1/robots``) have a finite input space:
schemathesis sends each distinct request once (3 requests plus 7 undeclared methods) and stops.
"""

from __future__ import annotations

import collections
import time
from typing import Any

import hypothesis
import pytest
import schemathesis

from service.app import create_app
from service.settings import Settings
from tests.service.helpers import documented_problem
from tests.service.test_docs import api_text, documented_codes
from tests.service.test_error_bodies import model_of

CODES = documented_codes(api_text())

FUZZ_BUDGET_S = 1.0
"""Planning budget [s] of the fuzzed app: a generated Cartesian request can never be slow."""
FUZZ_EXAMPLES = 100
SLOW_FUZZ_EXAMPLES = 1000
EXCLUDED_CHECKS = [schemathesis.checks.positive_data_acceptance]
PARAMETERLESS = {"GET /health", "GET /ready", "GET /v1/robots"}
"""Operations whose whole input space is a handful of requests (see the module docstring)."""

app = create_app(
    Settings(time_budget_s=FUZZ_BUDGET_S, batch_budget_s=FUZZ_BUDGET_S, access_log=False)
)
schema = schemathesis.openapi.from_asgi("/openapi.json", app)

REQUESTS: collections.Counter[str] = collections.Counter()
STATUSES: collections.Counter[tuple[str, int]] = collections.Counter()
SLOWEST: dict[str, float] = {}


def _settings(examples: int) -> hypothesis.settings:
    return hypothesis.settings(
        max_examples=examples,
        deadline=None,
        derandomize=True,  # the same requests on every run: a CI failure reproduces locally
        database=None,
        suppress_health_check=list(hypothesis.HealthCheck),
    )


def _call(case: Any, run: str) -> None:
    label = case.operation.label
    started = time.perf_counter()
    response = case.call()
    elapsed = time.perf_counter() - started
    REQUESTS[f"{run} {label}"] += 1
    STATUSES[(label, response.status_code)] += 1
    SLOWEST[label] = max(SLOWEST.get(label, 0.0), elapsed)
    case.validate_response(response, excluded_checks=EXCLUDED_CHECKS)
    if response.status_code >= 400:  # issue 26.10: every error body keeps docs/api.md's table
        content_type = response.headers.get("content-type") or [""]
        model = model_of(case.formatted_path) if case.method.upper() == "POST" else None
        documented_problem(response.status_code, content_type[0], response.json(), CODES, model)


@schema.parametrize()
@_settings(FUZZ_EXAMPLES)
def test_fuzz_operation(case: Any) -> None:
    _call(case, "default")


@pytest.mark.slow
@schema.parametrize()
@_settings(SLOW_FUZZ_EXAMPLES)
def test_fuzz_operation_slow(case: Any) -> None:
    _call(case, "slow")


def time_bound(label: str) -> float:
    """Longest a generated request may take [s]: the planning budget plus a second; compare runs
    up to five methods, each with its own budget; joint and spline plans are bounded by their
    sizes (the widest, 64 joints x 100,000 points, takes 2.5 s) and have no planning loop."""
    if label == "POST /v1/compare":
        return 5 * FUZZ_BUDGET_S + 1.0
    if label == "POST /v1/batch":  # items start within its budget; the last runs as if alone
        return FUZZ_BUDGET_S + Settings().time_budget_s + 1.0
    if label in ("POST /v1/trajectories/joint", "POST /v1/trajectories/spline"):
        return Settings().time_budget_s
    return FUZZ_BUDGET_S + 1.0


def _ran(request: pytest.FixtureRequest, prefix: str) -> set[str]:
    """Labels (``POST /v1/compare``) of the fuzz items of this session named ``prefix[...]``."""
    return {
        item.name[len(prefix) + 1 : -1]
        for item in request.session.items
        if item.name.startswith(prefix + "[")
    }


def test_zz_every_operation_was_fuzzed(request: pytest.FixtureRequest) -> None:
    """Runs after the fuzz items (file order): each selected operation got its requests, and no
    generated request took longer than its bound (``time_bound``)."""
    operations = {op.ok().label for op in schema.get_all_operations()}
    assert len(operations) >= 10, sorted(operations)
    for run, prefix, minimum in (
        ("default", "test_fuzz_operation", FUZZ_EXAMPLES),
        ("slow", "test_fuzz_operation_slow", SLOW_FUZZ_EXAMPLES),
    ):
        selected = _ran(request, prefix)
        if not selected:
            continue
        assert selected == operations, "every operation of /openapi.json is fuzzed"
        for label in sorted(selected):
            floor = 3 if label in PARAMETERLESS else minimum
            assert REQUESTS[f"{run} {label}"] >= floor, (run, label, REQUESTS)
    if not REQUESTS:
        pytest.skip("no fuzz item ran in this session")
    assert not [k for k in STATUSES if k[1] >= 500], STATUSES
    for label, seconds in SLOWEST.items():
        assert seconds <= time_bound(label), (label, seconds)
    print("\nschemathesis requests per operation:", dict(sorted(REQUESTS.items())))
    print("statuses:", dict(sorted(STATUSES.items())))
