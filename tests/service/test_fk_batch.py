"""Forward kinematics of many rows in one request (``"positions": [[...], ...]``, docs/api.md
"Many configurations in one request").

References: pinocchio's own model of the shipped URDF text (pose, every link frame and the Jacobian
to 1e-9; singular values from numpy's SVD of pinocchio's Jacobian), and the single form of the same
endpoint, which every row must equal.
"""

from __future__ import annotations

from importlib import resources
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from core.geometry.so3 import quat_to_matrix
from robots import registry
from service.schemas.robots import MAX_FK_ROWS

ROWS = 40
TOOL = {"position": [0.01, -0.02, 0.1], "orientation": [0.0, 0.0, 0.3826834, 0.9238795]}


def _rows(name: str, n: int, seed: int) -> np.ndarray:
    robot = registry.get(name)
    lo, hi = robot.position_limits.T
    return np.random.default_rng(seed).uniform(lo, hi, size=(n, robot.dof))


def _matrix(pose: dict[str, list[float]]) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(np.array(pose["orientation"]))
    T[:3, 3] = pose["position"]
    return T


def _ok(client: TestClient, url: str, body: dict[str, Any]) -> Any:
    r = client.post(url, json=body)
    assert r.status_code == 200, r.text[:500]
    return r.json()


@pytest.mark.parametrize("name", registry.names())
def test_every_row_equals_pinocchio(client: TestClient, name: str) -> None:
    robot = registry.get(name)
    urdf = resources.files("robots").joinpath("urdf", f"{name}.urdf").read_text(encoding="utf-8")
    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    summary = _ok(client, f"/v1/robots/{name}/fk", {"positions": robot.home.tolist()})
    assert "pose" in summary  # the single form is unchanged
    qs = _rows(name, ROWS, seed=7)
    answer = _ok(client, f"/v1/robots/{name}/fk", {"positions": qs.tolist(), "frames": True})
    assert list(answer) == ["results"] and len(answer["results"]) == ROWS
    base_id = model.getFrameId(robot.base_frame, pin.FrameType.BODY)
    tip_id = model.getFrameId(robot.tip_frame, pin.FrameType.BODY)
    cols = [model.joints[model.getJointId(n)].idx_v for n in robot.joint_names]
    rows = [0, 1] if robot.task_space == "position_xy" else list(range(6))
    for q, row in zip(qs, answer["results"], strict=True):
        qf = pin.neutral(model)
        for joint_name, value in zip(robot.joint_names, q, strict=True):
            qf[model.joints[model.getJointId(joint_name)].idx_q] = value
        pin.framesForwardKinematics(model, data, qf)
        base = data.oMf[base_id]
        np.testing.assert_allclose(
            _matrix(row["pose"]), base.actInv(data.oMf[tip_id]).homogeneous, atol=1e-9
        )
        assert row["pose"]["orientation"][3] >= 0
        for frame in row["frames"]:
            expected = base.actInv(data.oMf[model.getFrameId(frame["name"], pin.FrameType.BODY)])
            np.testing.assert_allclose(_matrix(frame), expected.homogeneous, atol=1e-9)
        J = pin.computeFrameJacobian(model, data, qf, tip_id, pin.LOCAL_WORLD_ALIGNED)
        R = base.rotation.T
        J = np.vstack([R @ J[:3, cols], R @ J[3:, cols]])
        np.testing.assert_allclose(np.array(row["jacobian"]), J, atol=1e-9)
        s = np.linalg.svd(J[rows], compute_uv=False)
        s = np.concatenate([s, np.zeros(len(rows) - len(s))])
        assert row["min_singular_value"] == pytest.approx(s[-1], abs=1e-9)
        assert row["manipulability"] == pytest.approx(np.prod(s), abs=1e-9)


@pytest.mark.parametrize(
    ("name", "extra"),
    [
        ("ur5", {"frames": True}),
        ("ur5", {"tool": TOOL, "frame": "forearm_link"}),
        ("puma560", {"tool": TOOL}),
        ("panda", {"frames": True, "tool": TOOL}),
        ("planar_2r", {}),
    ],
)
def test_every_row_is_the_single_answer(
    client: TestClient, name: str, extra: dict[str, Any]
) -> None:
    qs = _rows(name, 12, seed=3)
    many = _ok(client, f"/v1/robots/{name}/fk", {"positions": qs.tolist(), **extra})["results"]
    inline = _ok(client, "/v1/fk", {"robot": name, "positions": qs.tolist(), **extra})["results"]
    assert inline == many
    labels = set()
    for q, row in zip(qs, many, strict=True):
        one = _ok(client, f"/v1/robots/{name}/fk", {"positions": q.tolist(), **extra})
        assert list(row) == list(one)
        assert row["configuration"] == one["configuration"]
        labels.add(row["configuration"])
        assert (row["frames"] is None) == (one["frames"] is None)
        for a, b in zip(row["frames"] or [], one["frames"] or [], strict=True):
            assert a["name"] == b["name"]
            np.testing.assert_allclose(a["position"], b["position"], rtol=0, atol=1e-15)
            np.testing.assert_allclose(a["orientation"], b["orientation"], rtol=0, atol=1e-15)
        for key in ("min_singular_value", "manipulability"):
            assert row[key] == pytest.approx(one[key], rel=1e-15, abs=1e-15)
        np.testing.assert_allclose(row["pose"]["position"], one["pose"]["position"], atol=1e-15)
        np.testing.assert_allclose(
            row["pose"]["orientation"], one["pose"]["orientation"], atol=1e-15
        )
        np.testing.assert_allclose(row["jacobian"], one["jacobian"], rtol=0, atol=1e-15)
    if registry.get(name).configuration_labels:
        assert len(labels) > 1  # the rows are not all one configuration: labels follow each row


def _problem(client: TestClient, url: str, body: dict[str, Any], status: int) -> dict[str, Any]:
    r = client.post(url, json=body)
    assert r.status_code == status, r.text[:500]
    return r.json()


def test_a_bad_row_is_named(client: TestClient) -> None:
    q = registry.get("ur5").home.tolist()
    short = _problem(client, "/v1/robots/ur5/fk", {"positions": [q, q[:5]]}, 422)
    assert short["code"] == "validation"
    assert short["errors"][0]["loc"] == ["body", "positions", 1]
    outside = _problem(client, "/v1/robots/ur5/fk", {"positions": [q, q, [*q[:5], 7.0]]}, 422)
    assert outside["code"] == "joint_limit" and outside["joint_name"] == "wrist_3_joint"
    assert outside["errors"][0]["loc"] == ["body", "positions", 2, 5]
    typed = _problem(client, "/v1/fk", {"robot": "ur5", "positions": [q, [*q[:5], "1"]]}, 422)
    assert [e["loc"] for e in typed["errors"]] == [["body", "positions", 1, 5]]
    mixed = _problem(client, "/v1/robots/ur5/fk", {"positions": [q, 0.5]}, 422)
    assert all(e["loc"][:2] == ["body", "positions"] for e in mixed["errors"])
    empty = _problem(client, "/v1/robots/ur5/fk", {"positions": [[]]}, 422)
    assert empty["errors"][0]["loc"] == ["body", "positions", 0]
    frame = _problem(client, "/v1/robots/ur5/fk", {"positions": [q], "frame": "nope"}, 404)
    assert frame["code"] == "unknown_frame"


def test_the_row_bound(client: TestClient) -> None:
    q = registry.get("planar_2r").home.tolist()
    most = _ok(client, "/v1/robots/planar_2r/fk", {"positions": [q] * MAX_FK_ROWS})["results"]
    assert len(most) == MAX_FK_ROWS
    over = _problem(client, "/v1/robots/planar_2r/fk", {"positions": [q] * (MAX_FK_ROWS + 1)}, 422)
    assert over["code"] == "validation" and over["errors"][0]["loc"] == ["body", "positions"]
    assert str(MAX_FK_ROWS) in over["errors"][0]["msg"]


def test_openapi_documents_both_forms_with_an_example(client: TestClient) -> None:
    schema = client.get("/openapi.json").json()
    for path in ("/v1/robots/{name}/fk", "/v1/fk"):
        operation = schema["paths"][path]["post"]
        answer = operation["responses"]["200"]["content"]["application/json"]["schema"]
        refs = {s.get("$ref", "").rsplit("/", 1)[-1] for s in answer["anyOf"]}
        assert refs == {"FKResponse", "FKBatchResponse"}, answer
        example = operation["requestBody"]["content"]["application/json"]["examples"]["rows"]
        rows = example["value"]["positions"]
        url = path.replace("{name}", "ur5")
        assert len(_ok(client, url, example["value"])["results"]) == len(rows) >= 2
    props = schema["components"]["schemas"]["FKRequest"]["properties"]["positions"]
    assert any(s.get("maxItems") == MAX_FK_ROWS for s in props.get("oneOf", props.get("anyOf")))
