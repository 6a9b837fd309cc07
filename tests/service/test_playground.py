"""The playground page: served at /, Plotly vendored in service/static/vendor/, nothing from elsewhere.

The page itself is exercised in a real browser by ``tests/browser/test_playground_browser.py``;
these checks need no browser: what the routes serve, that the page names no other host (it must
work in a container without internet), and that its script calls only the public API.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from service.routes import playground
from service.settings import Settings

STATIC = Path(playground.__file__).resolve().parents[1] / "static"
PUBLIC_ENDPOINTS = {
    # shared/API.md: the routes any client may call.
    ("GET", "/v1/robots"),
    ("GET", "/v1/robots/{name}"),
    ("POST", "/v1/robots/{name}/fk"),
    ("POST", "/v1/robots/{name}/ik"),
    ("POST", "/v1/trajectories/joint"),
    ("POST", "/v1/trajectories/spline"),
    ("POST", "/v1/trajectories/cartesian"),
    ("POST", "/v1/compare"),
    ("POST", "/v1/trajectories/program"),
}


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(Settings()))


def test_index_is_the_page_with_a_same_origin_policy(client: TestClient) -> None:
    r = client.get("/")
    assert r.status_code == 200
    assert r.headers["content-type"].startswith("text/html")
    html = r.text
    assert '<script src="/static/plotly.min.js"' in html
    assert '<script src="/static/app.js"' in html
    assert '<link rel="stylesheet" href="/static/style.css">' in html
    csp = r.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "script-src 'self'" in csp
    assert "connect-src 'self'" in csp


def test_plotly_is_the_vendored_file_with_its_license_header(client: TestClient) -> None:
    path = STATIC / "vendor" / "plotly.min.js"
    assert playground.PLOTLY_JS == path
    r = client.get("/static/plotly.min.js")
    assert r.status_code == 200
    assert r.headers["content-type"].startswith("text/javascript")
    assert r.content == path.read_bytes()
    header = r.content[:200].decode()
    assert re.search(r"plotly\.js v\d+\.\d+\.\d+", header)
    assert "Licensed under the MIT license" in header and "Plotly, Inc." in header
    version = re.search(r"plotly\.js (v\d+\.\d+\.\d+)", header)
    assert version and version.group(1) in (STATIC / "vendor" / "README.md").read_text()


def test_the_package_data_ships_the_vendored_file() -> None:
    """A package-data glob of pyproject matches the file (setuptools globs like pathlib), so
    ``pip install .``, as in the image, installs it."""
    tomllib = pytest.importorskip("tomllib")
    pyproject = tomllib.loads((STATIC.parents[1] / "pyproject.toml").read_text())
    globs = pyproject["tool"]["setuptools"]["package-data"]["service"]
    assert any(STATIC / "vendor" / "plotly.min.js" in STATIC.parent.glob(g) for g in globs), globs


@pytest.mark.parametrize(
    ("name", "media"), [("app.js", "text/javascript"), ("style.css", "text/css")]
)
def test_static_files(client: TestClient, name: str, media: str) -> None:
    r = client.get(f"/static/{name}")
    assert r.status_code == 200
    assert r.headers["content-type"].startswith(media)
    assert r.content == (STATIC / name).read_bytes()


@pytest.mark.parametrize(
    "path", ["/static/nope.js", "/static/index.html", "/static/..%2Fapp.py", "/static/../app.py"]
)
def test_unknown_static_files_are_404_problems(client: TestClient, path: str) -> None:
    r = client.get(path)
    assert r.status_code == 404
    assert r.headers["content-type"].startswith("application/problem+json")
    assert "app.py" not in r.text and "nope" not in r.text  # the path is not echoed back


def test_the_page_is_not_in_the_openapi_document(client: TestClient) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    assert "/" not in paths
    assert not any(p.startswith("/static") for p in paths)


@pytest.mark.parametrize("name", ["index.html", "app.js", "style.css"])
def test_the_page_names_no_other_host(name: str) -> None:
    """No CDN, font service or any URL with a scheme: the page works with no internet."""
    text = (STATIC / name).read_text()
    assert not re.search(r"(https?:)?//[a-z0-9.-]+\.[a-z]{2,}", text, re.IGNORECASE), name
    for url in re.findall(r"""(?:src|href)\s*=\s*["']([^"']*)["']""", text):
        assert url.startswith(("/", "data:")), url


def _api_paths(script: str) -> set[str]:
    """Every string literal in app.js that starts with ``/v1/``, ``${...}`` read as ``{name}``."""
    return {
        re.sub(r"\$\{[^}]*\}", "{name}", path)
        for path in re.findall(r"""['`](/v1/[^'`]*)['`]""", script)
    }


def test_the_script_calls_only_the_public_api(client: TestClient) -> None:
    paths = _api_paths((STATIC / "app.js").read_text())
    assert paths == {p for _, p in PUBLIC_ENDPOINTS}
    served = client.get("/openapi.json").json()["paths"]
    assert paths <= set(served), paths - set(served)


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
def test_the_script_parses() -> None:
    """Plain ES2017+, no build step: the file is valid JavaScript as served."""
    result = subprocess.run(
        ["node", "--check", str(STATIC / "app.js")], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
