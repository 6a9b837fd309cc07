"""deploy/ and Dockerfile agree with the app: probes name real routes, ports and users match."""

from __future__ import annotations

import ast
import functools
import importlib.metadata
import importlib.util
import json
import os
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
    assert not re.search(r"build-essential|gcc|\bpip install\b", final)
    # One system package and nothing else: the OpenMP runtime pinocchio's wheel links against.
    joined = re.sub(r"\\\n\s*", " ", final)
    installs = re.findall(r"apt-get install((?: -{1,2}[\w-]+)*)((?: [\w.+-]+)+)", joined)
    assert [packages.split() for _, packages in installs] == [["libgomp1"]], installs
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


def _project_version() -> str:
    match = re.search(r'^version = "([^"]+)"$', (REPO / "pyproject.toml").read_text(), re.M)
    assert match
    return match.group(1)


def test_compose_kubernetes_and_the_build_script_name_one_image() -> None:
    """deploy/build_and_run.sh tags trajectory-service:<pyproject version>; compose and the
    Deployment run exactly that image."""
    image = f"trajectory-service:{_project_version()}"
    script = (DEPLOY / "build_and_run.sh").read_text()
    assert 'IMAGE="${IMAGE:-trajectory-service:${VERSION}}"' in script
    assert "sed -n 's/^version = " in script  # VERSION is read from pyproject.toml
    assert COMPOSE["services"]["api"]["image"] == image
    assert _container()["image"] == image


def test_the_scripts_smoke_request_matches_the_robot() -> None:
    """The UR5 start the smoke check hard-codes is the registered home (it uses HTTP only)."""
    sys.path.insert(0, str(DEPLOY))
    try:
        import smoke_check
    finally:
        sys.path.remove(str(DEPLOY))
    from robots import registry

    assert smoke_check.UR5_HOME == pytest.approx(registry.get("ur5").home.tolist(), abs=1e-15)


def test_the_smoke_check_passes_against_the_app_and_fails_on_a_wrong_answer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """deploy/smoke_check.py, with its HTTP calls served by the app in-process: every check holds;
    with one joint position of the answer moved by 1e-6 rad, it fails."""
    sys.path.insert(0, str(DEPLOY))
    try:
        import smoke_check
    finally:
        sys.path.remove(str(DEPLOY))
    client = TestClient(create_app())

    def post(base: str, path: str, body: dict[str, Any]) -> tuple[int, dict[str, Any], float]:
        r = client.post(path, json=body)
        return r.status_code, r.json(), 0.0

    monkeypatch.setattr(smoke_check, "post", post)
    monkeypatch.setattr(smoke_check, "failures", [])
    assert smoke_check.main(["smoke_check.py", "http://testserver"]) == 0

    def post_off(base: str, path: str, body: dict[str, Any]) -> tuple[int, dict[str, Any], float]:
        status, answer, wall = post(base, path, body)
        answer["points"][len(answer["points"]) // 2]["positions"][0] += 1e-6
        return status, answer, wall

    monkeypatch.setattr(smoke_check, "post", post_off)
    monkeypatch.setattr(smoke_check, "failures", [])
    smoke_check.joint_plan("http://testserver")
    assert smoke_check.failures and "closed-form quintic" in smoke_check.failures[0]


def test_kubernetes_manifests_validate_against_the_kubernetes_schema() -> None:
    """Strict schemas (unknown fields rejected) shipped in the kubernetes-validate package."""
    kv = pytest.importorskip("kubernetes_validate")
    version = kv.utils.latest_version()
    for doc in K8S.values():
        kv.validate(doc, version, strict=True)
    broken = json.loads(json.dumps(K8S["Deployment"]))
    broken["spec"]["template"]["spec"]["containers"][0]["readinessProb"] = {}
    with pytest.raises(kv.ValidationError):
        kv.validate(broken, version, strict=True)


def test_compose_file_validates_against_the_compose_specification() -> None:
    """The compose-spec JSON schema that check-jsonschema ships (what `docker compose config`
    checks); podman 4.3 on Debian bookworm has no `podman compose`."""
    pytest.importorskip("check_jsonschema")
    jsonschema = pytest.importorskip("jsonschema")
    from importlib.resources import files

    schema = json.loads(
        files("check_jsonschema.builtin_schemas.vendor").joinpath("compose-spec.json").read_text()
    )
    validator = jsonschema.validators.validator_for(schema)(schema)
    assert not list(validator.iter_errors(COMPOSE))
    broken = json.loads(json.dumps(COMPOSE))
    broken["services"]["api"]["healthcheck"]["intervall"] = "10s"
    assert list(validator.iter_errors(broken))


def test_slim_venv_removes_build_files_and_links_identical_copies(tmp_path: Path) -> None:
    """deploy/slim_venv.py on a small tree: what goes, what stays, and every symlink reads the same
    bytes as the file it replaced."""
    site = tmp_path / "lib" / "python3.11" / "site-packages"
    lib = site / "pkg"
    (lib / "include").mkdir(parents=True)
    (lib / "include" / "pkg.h").write_text("int f(void);\n")
    (lib / "includes_python" / "include").mkdir(parents=True)
    (lib / "includes_python" / "include" / "__init__.py").write_text("X = 1\n")
    (lib / "tests").mkdir()
    (lib / "tests" / "test_x.py").write_text("def test(): pass\n")
    (lib / "__init__.py").write_text("")
    (lib / "libfoo.a").write_bytes(b"a" * 5000)
    payload = bytes(range(256)) * 64
    for name in ("libfoo.so", "libfoo.so.3", "libfoo.so.3.7"):
        (lib / name).write_bytes(payload)
    (lib / "other.so").write_bytes(payload[::-1])
    (tmp_path / "unrelated" / "tests").mkdir(parents=True)  # not inside a package: kept
    result = subprocess.run(
        [sys.executable, str(DEPLOY / "slim_venv.py"), str(tmp_path)],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    assert "MB ->" in result.stdout
    assert not (lib / "include").exists() and not (lib / "tests").exists()
    assert not (lib / "libfoo.a").exists()
    assert (lib / "includes_python" / "include" / "__init__.py").is_file()
    assert (tmp_path / "unrelated" / "tests").is_dir()
    links = [p for p in lib.glob("libfoo.so*") if p.is_symlink()]
    assert len(links) == 2
    for name in ("libfoo.so", "libfoo.so.3", "libfoo.so.3.7"):
        assert (lib / name).read_bytes() == payload
    assert not (lib / "other.so").is_symlink()


IMAGE_TARGET_BYTES = 700_000_000
"""The image's size target (on the stand-in base; python:3.11-slim is smaller)."""


@pytest.mark.container
@pytest.mark.skipif(shutil.which("podman") is None, reason="podman is not installed")
def test_the_image_builds_runs_and_plans(tmp_path: Path) -> None:
    """deploy/build_and_run.sh end to end: build (stand-in base without Docker Hub), HEALTHCHECK,
    the three plans, non-root; prints the build time and image size, which stays under 700 MB."""
    timing = tmp_path / "timing.txt"
    result = subprocess.run(
        ["bash", str(DEPLOY / "build_and_run.sh")],
        capture_output=True,
        text=True,
        timeout=1800,
        env={**os.environ, "TIMING_FILE": str(timing)},
        check=False,
    )
    tail = (result.stdout + result.stderr)[-4000:]
    assert result.returncode == 0, tail
    assert "smoke check: every plan checked" in result.stdout, tail
    print(timing.read_text())
    found = re.search(r"image_bytes=(\d+)", timing.read_text())
    assert found, timing.read_text()
    size = int(found.group(1))
    assert size < IMAGE_TARGET_BYTES, f"the image is {size / 1e6:.0f} MB"


def test_the_image_drops_only_what_eaik_brings_and_the_service_never_imports() -> None:
    """deploy/exclusive_requirements.py names urchin's mesh and graphics stack (what the Dockerfile
    uninstalls after `pip install .`): never a distribution whose modules the service imports,
    never one another installed distribution still requires."""
    sys.path.insert(0, str(DEPLOY))
    try:
        from exclusive_requirements import exclusive
    finally:
        sys.path.remove(str(DEPLOY))
    if not importlib.util.find_spec("urchin"):
        pytest.skip("urchin is not installed (EAIK without its requirements)")
    dropped = {name.lower() for name in exclusive(["urchin"])}
    assert {"urchin", "trimesh", "pyglet", "pyopengl", "pyribbit"} <= dropped
    imported = set()
    for package in ("core", "robots", "service"):
        for path in (REPO / package).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Import):
                    imported |= {a.name.split(".")[0] for a in node.names}
                elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                    imported.add(node.module.split(".")[0])
    providers = importlib.metadata.packages_distributions()
    used = {d.lower() for module in imported for d in providers.get(module, [])}
    assert not dropped & used, dropped & used
    assert not dropped & {"numpy", "scipy", "eaik"}
