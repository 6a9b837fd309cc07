"""``/openapi.json`` serves client generators: stable snake_case operation ids, a working example
for every request body, plain schema names, a description that names what the service does; and a
real generator (``openapi-python-client``, test extra) turns it into a client that imports and
plans against a live service.
"""

from __future__ import annotations

import importlib
import json
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from core.cartesian.methods import METHODS
from core.joint.profiles import PROFILES
from robots import registry
from service.app import create_app
from service.openapi import OPERATION_IDS
from tests.live_service import live_service

SNAKE = re.compile(r"^[a-z][a-z0-9]*(_[a-z0-9]+)*$")
SCHEMA_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")


@pytest.fixture(scope="module")
def schema() -> dict[str, Any]:
    return create_app().openapi()


def operations(schema: dict[str, Any]) -> Iterator[tuple[str, str, dict[str, Any]]]:
    for path, item in schema["paths"].items():
        for method, operation in item.items():
            yield method.upper(), path, operation


def test_operation_ids_are_stable_snake_case_and_unique(schema: dict[str, Any]) -> None:
    ids = [op["operationId"] for _, _, op in operations(schema)]
    assert len(ids) == len(set(ids)), ids
    for op_id in ids:  # FastAPI's default is name + path + method: plan_joint_v1_..._post
        assert SNAKE.match(op_id) and "v1" not in op_id.split("_"), op_id
        assert not op_id.endswith(("_get", "_post")), op_id
    served = {(method, path): op["operationId"] for method, path, op in operations(schema)}
    for key, op_id in OPERATION_IDS.items():  # every listed id names a served operation
        assert served.get(key) == op_id, (key, op_id)
    assert served[("POST", "/v1/trajectories/joint")] == "plan_joint_trajectory"


def test_every_request_body_has_examples_that_plan(schema: dict[str, Any]) -> None:
    client = TestClient(create_app())
    checked = 0
    for method, path, operation in operations(schema):
        body = operation.get("requestBody")
        if body is None:
            continue
        examples = body["content"]["application/json"].get("examples")
        assert examples, f"{method} {path} ({operation['operationId']}) has no request example"
        url = path.replace("{name}", "ur5")
        for name, example in examples.items():
            assert example["summary"], name
            response = client.request(method, url, json=example["value"])
            assert response.status_code == 200, (operation["operationId"], name, response.text)
            checked += 1
    assert checked >= 12


def test_schema_names_are_plain_class_names(schema: dict[str, Any]) -> None:
    names = list(schema["components"]["schemas"])
    bad = [n for n in names if not SCHEMA_NAME.match(n)]  # not service__schemas__x__Name
    assert not bad, bad


def test_the_description_names_what_the_service_does(schema: dict[str, Any]) -> None:
    description = schema["info"]["description"]
    words = [*PROFILES, *registry.names(), "program", "compare", "collision", "arc", "URDF"]
    missing = [w for w in words if w.lower() not in description.lower()]
    assert not missing, missing
    assert "resolved-rate" in description and "bounded deviation" in description
    assert len(METHODS) == 5  # sampled, bounded_deviation(_nlp), resolved_rate(_dls): all named


# --- a client generated from /openapi.json ---------------------------------------------------------


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """The package ``openapi-python-client`` generates from the live schema, imported."""
    generator = shutil.which("openapi-python-client") or str(
        Path(sys.executable).parent / "openapi-python-client"
    )
    if not Path(generator).exists():
        pytest.skip("openapi-python-client is not installed (the test extra brings it)")
    out = tmp_path_factory.mktemp("generated")
    spec = out / "openapi.json"
    spec.write_text(json.dumps(create_app().openapi()))
    env = {"PATH": f"{Path(sys.executable).parent}:/usr/bin:/bin"}  # its ruff post-hooks
    done = subprocess.run(
        [generator, "generate", "--path", str(spec), "--meta", "none",
         "--output-path", str(out / "generated_client")],
        capture_output=True, text=True, timeout=300, env=env, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Warning" not in done.stdout + done.stderr, done.stdout + done.stderr
    sys.path.insert(0, str(out))
    try:
        yield importlib.import_module("generated_client")  # not client/'s trajectory_client
    finally:
        sys.path.remove(str(out))
        for module in [m for m in sys.modules if m.split(".")[0] == "generated_client"]:
            del sys.modules[module]


@pytest.fixture(scope="module")
def service_url() -> Iterator[str]:
    with live_service() as url:
        yield url


def test_the_generated_client_has_one_function_per_operation(
    generated: Any, schema: dict[str, Any]
) -> None:
    api = Path(generated.__file__).parent / "api"
    functions = {p.stem for p in api.rglob("*.py") if p.stem != "__init__"}
    assert functions == {op["operationId"] for _, _, op in operations(schema)}


def test_the_generated_client_plans_against_a_live_service(
    generated: Any, service_url: str
) -> None:
    from generated_client.api.robots import get_robot, list_robots
    from generated_client.api.trajectories import plan_joint_trajectory
    from generated_client.models import JointTrajectoryRequest, Problem, TrajectoryResponse

    client = generated.Client(base_url=service_url, raise_on_unexpected_status=True)
    robots = list_robots.sync(client=client)
    assert sorted(r.name for r in robots) == registry.names()
    ur5 = get_robot.sync(name="ur5", client=client)
    assert ur5.dof == 6 and list(ur5.joint_names) == list(registry.get("ur5").joint_names)
    body = {
        "profile": "quintic",
        "start": {"positions": [0, 0]},
        "goal": {"positions": [1, -0.5]},
        "limits": {"velocity": [1, 1], "acceleration": [2, 2]},
        "samples": 3,
    }
    answer = plan_joint_trajectory.sync(client=client, body=JointTrajectoryRequest.from_dict(body))
    assert isinstance(answer, TrajectoryResponse), answer
    # a quintic rest-to-rest move of 1 rad under 1 rad/s takes 1.875 s (peak 1.875 delta/T)
    assert answer.diagnostics.duration == pytest.approx(1.875, rel=1e-12)
    assert [p.positions for p in answer.points][1] == pytest.approx([0.5, -0.25], abs=1e-12)
    too_fast = JointTrajectoryRequest.from_dict({**body, "duration": 0.1})
    problem = plan_joint_trajectory.sync(client=client, body=too_fast)
    assert isinstance(problem, Problem) and problem.code == "joint_rate_limit", problem
