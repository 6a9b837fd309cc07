"""deploy/ and Dockerfile agree with the app: probes name real routes, ports and users match."""

from __future__ import annotations

import functools
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml
from fastapi.testclient import TestClient

from service.app import create_app
from service.settings import env_names

REPO = Path(__file__).resolve().parents[2]
DEPLOY = REPO / "deploy"
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
LOCAL_URL = re.compile(r"http://(?:127\.0\.0\.1|localhost):(\d+)(/[A-Za-z0-9_/{}-]*)")


@functools.cache
def get_routes() -> frozenset[str]:
    """Paths the app serves to GET, from ``create_app().routes`` (included routers flattened)."""
    app = create_app()
    routes: Any = app.routes
    try:  # FastAPI >= 0.13x keeps included routers lazily; this lists their routes
        from fastapi.routing import iter_route_contexts

        routes = iter_route_contexts(app.routes)
    except ImportError:
        pass
    paths = {r.path for r in routes if "GET" in (getattr(r, "methods", None) or ())}
    client = TestClient(app)
    for path in ("/health", "/ready", "/metrics"):  # and they answer (503 is an answer)
        if path in paths:
            assert client.get(path).status_code in (200, 503), path
    return frozenset(paths)


def _k8s() -> dict[str, dict[str, Any]]:
    docs: dict[str, dict[str, Any]] = {}
    for path in sorted((DEPLOY / "k8s").glob("*.yaml")):
        for doc in yaml.safe_load_all(path.read_text()):
            if doc:
                assert doc["kind"] not in docs, f"two {doc['kind']} manifests"
                docs[doc["kind"]] = doc
    return docs


K8S = _k8s()
COMPOSE = yaml.safe_load((DEPLOY / "compose.yaml").read_text())
DOCKERFILE = (REPO / "Dockerfile").read_text()


def _final_stage() -> str:
    return re.split(r"^FROM ", DOCKERFILE, flags=re.MULTILINE)[-1]


def _dockerfile_instruction(name: str) -> str:
    """The last ``name`` instruction of the final stage, continuation lines joined."""
    joined = re.sub(r"\\\n\s*", " ", _final_stage())
    lines = [line for line in joined.splitlines() if line.startswith(name + " ")]
    assert lines, f"no {name} in the final stage"
    return lines[-1][len(name) + 1 :].strip()


def _container() -> dict[str, Any]:
    (container,) = K8S["Deployment"]["spec"]["template"]["spec"]["containers"]
    return container


def _container_port(ref: int | str) -> int:
    for port in _container()["ports"]:
        if ref in (port["containerPort"], port.get("name")):
            return int(port["containerPort"])
    raise AssertionError(f"port {ref!r} is not a container port")


def _image_port() -> int:
    cmd = json.loads(_dockerfile_instruction("CMD"))
    return int(cmd[cmd.index("--port") + 1])


def test_manifests_are_the_expected_kinds() -> None:
    assert set(K8S) == {"Deployment", "Service", "HorizontalPodAutoscaler"}
    assert K8S["HorizontalPodAutoscaler"]["apiVersion"] == "autoscaling/v2"


@pytest.mark.parametrize(
    ("probe", "path"),
    [("readinessProbe", "/ready"), ("livenessProbe", "/health"), ("startupProbe", "/health")],
)
def test_probes_name_real_routes_on_the_served_port(probe: str, path: str) -> None:
    get = _container()[probe]["httpGet"]
    assert get["path"] == path
    assert get["path"] in get_routes(), f"{probe} asks {get['path']}, which the app does not serve"
    assert _container_port(get["port"]) == _image_port()


def test_ports_agree_everywhere() -> None:
    port = _image_port()
    assert f"EXPOSE {port}" in _final_stage()
    (service_port,) = K8S["Service"]["spec"]["ports"]
    assert _container_port(service_port["targetPort"]) == port
    annotations = K8S["Deployment"]["spec"]["template"]["metadata"]["annotations"]
    assert int(annotations["prometheus.io/port"]) == port
    assert annotations["prometheus.io/path"] in get_routes()
    assert f"{port}" in COMPOSE["services"]["api"]["expose"]
    nginx = (DEPLOY / "nginx.conf").read_text()
    assert f"http://api:{port}" in nginx
    lb_target = COMPOSE["services"]["lb"]["ports"][0].rsplit(":", 1)[1]
    assert re.search(rf"listen\s+{lb_target};", nginx)


def test_service_and_autoscaler_select_the_deployment() -> None:
    deployment = K8S["Deployment"]
    pod_labels = deployment["spec"]["template"]["metadata"]["labels"]
    assert deployment["spec"]["selector"]["matchLabels"].items() <= pod_labels.items()
    assert K8S["Service"]["spec"]["selector"].items() <= pod_labels.items()
    hpa = K8S["HorizontalPodAutoscaler"]["spec"]
    assert hpa["scaleTargetRef"]["kind"] == "Deployment"
    assert hpa["scaleTargetRef"]["name"] == deployment["metadata"]["name"]
    assert 1 <= hpa["minReplicas"] <= hpa["maxReplicas"]
    (metric,) = hpa["metrics"]
    assert metric["resource"]["name"] == "cpu"


def test_pods_are_bounded_non_root_and_single_threaded() -> None:
    container = _container()
    for kind in ("requests", "limits"):
        assert {"cpu", "memory"} <= set(container["resources"][kind])
    pod_security = K8S["Deployment"]["spec"]["template"]["spec"]["securityContext"]
    assert pod_security["runAsNonRoot"] is True
    uid = _dockerfile_instruction("USER").split(":")[0]
    assert uid.isdigit() and int(uid) != 0 and pod_security["runAsUser"] == int(uid)
    env = {e["name"]: e["value"] for e in container["env"]}
    assert all(env[var] == "1" for var in THREAD_VARS)
    assert set(n for n in env if n.startswith("TRAJ_")) <= set(env_names())
    cpu = container["resources"]["limits"]["cpu"]
    assert int(env["TRAJ_WORKERS"]) == int(cpu), "one worker per CPU of the limit"


def test_compose_runs_replicas_with_a_healthcheck_on_a_real_route() -> None:
    api = COMPOSE["services"]["api"]
    assert api["deploy"]["replicas"] >= 2
    assert (DEPLOY / api["build"]["context"] / api["build"]["dockerfile"]).resolve() == (
        REPO / "Dockerfile"
    )
    (url,) = LOCAL_URL.findall(" ".join(api["healthcheck"]["test"]))
    assert int(url[0]) == _image_port() and url[1] in get_routes()
    env = {k: str(v) for k, v in api["environment"].items()}
    assert all(env[var] == "1" for var in THREAD_VARS)
    assert set(n for n in env if n.startswith("TRAJ_")) <= set(env_names())
    assert COMPOSE["services"]["lb"]["depends_on"]["api"]["condition"] == "service_healthy"
    for volume in COMPOSE["services"]["lb"]["volumes"]:
        assert (DEPLOY / volume.split(":")[0]).is_file()


def test_dockerfile_is_multi_stage_non_root_with_a_health_check() -> None:
    assert len(re.findall(r"^FROM ", DOCKERFILE, flags=re.MULTILINE)) >= 2
    final = _final_stage()
    assert "COPY --from=builder" in final
    assert not re.search(r"apt-get install|build-essential|gcc|\bpip install\b", final)
    (url,) = LOCAL_URL.findall(_dockerfile_instruction("HEALTHCHECK"))
    assert int(url[0]) == _image_port() and url[1] == "/health" and url[1] in get_routes()
    for var in THREAD_VARS:
        assert re.search(rf"\b{var}=1\b", final)
    cmd = json.loads(_dockerfile_instruction("CMD"))
    assert cmd[:3] == ["python", "-m", "service"] and cmd[cmd.index("--host") + 1] == "0.0.0.0"


def _hadolint() -> str | None:
    local = Path(sys.executable).with_name("hadolint")
    return str(local) if local.exists() else shutil.which("hadolint")


@pytest.mark.skipif(_hadolint() is None, reason="hadolint not installed")
def test_hadolint_is_clean() -> None:
    result = subprocess.run(
        [_hadolint(), str(REPO / "Dockerfile")], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stdout + result.stderr
