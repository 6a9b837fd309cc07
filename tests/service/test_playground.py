"""The playground page: served at /, Plotly vendored in service/static/vendor/, nothing from elsewhere.

The page itself is exercised in a real browser by ``tests/browser/test_playground_browser.py``;
these checks need no browser: what the routes serve (the ES modules of ``service/static/js/`` as
JavaScript), that the page names no other host (it must work in a container without internet),
that its modules call only the public API, and that every name a module imports is exported by
the module it names (what a browser would otherwise refuse at load).
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
    ("GET", "/openapi.json"),
}
OPTIONAL_ENDPOINTS = {("POST", "/v1/trajectories/collision_free")}
"""Called only when ``/openapi.json`` lists it (the page hides the mode otherwise)."""
MODULES = sorted((STATIC / "js").glob("*.js"))


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(Settings()))


def test_index_is_the_page_with_a_same_origin_policy(client: TestClient) -> None:
    r = client.get("/")
    assert r.status_code == 200
    assert r.headers["content-type"].startswith("text/html")
    html = r.text
    assert '<script src="/static/plotly.min.js"' in html
    assert '<script type="module" src="/static/js/main.js"></script>' in html
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


@pytest.mark.parametrize(
    "path", [STATIC / "vendor" / "plotly.min.js", STATIC / "index.html", *MODULES]
)
def test_the_package_data_ships_the_page(path: Path) -> None:
    """A package-data glob of pyproject matches every file of the page (setuptools globs like
    pathlib), so ``pip install .``, as in the image, installs it."""
    tomllib = pytest.importorskip("tomllib")
    pyproject = tomllib.loads((STATIC.parents[1] / "pyproject.toml").read_text())
    globs = pyproject["tool"]["setuptools"]["package-data"]["service"]
    assert any(path in STATIC.parent.glob(g) for g in globs), globs


def test_static_files(client: TestClient) -> None:
    assert len(MODULES) >= 10 and STATIC / "js" / "main.js" in MODULES
    served = [("style.css", "/static/style.css", "text/css")]
    served += [(f"js/{m.name}", f"/static/js/{m.name}", "text/javascript") for m in MODULES]
    for name, url, media in served:
        r = client.get(url)
        assert r.status_code == 200, url
        assert r.headers["content-type"].startswith(media), url  # modules need a JS MIME type
        assert r.headers["x-content-type-options"] == "nosniff"
        assert r.content == (STATIC / name).read_bytes()


@pytest.mark.parametrize(
    "path",
    [
        "/static/nope.js",
        "/static/index.html",
        "/static/..%2Fapp.py",
        "/static/../app.py",
        "/static/js/nope.js",
        "/static/js/..%2Fstyle.css",
        "/static/js/style.css",
        "/static/js/../../app.py",
    ],
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


@pytest.mark.parametrize("name", ["index.html", "style.css", *(f"js/{m.name}" for m in MODULES)])
def test_the_page_names_no_other_host(name: str) -> None:
    """No CDN, font service or any URL with a scheme: the page works with no internet."""
    text = (STATIC / name).read_text()
    assert not re.search(r"(https?:)?//[a-z0-9.-]+\.[a-z]{2,}", text, re.IGNORECASE), name
    for url in re.findall(r"""(?:src|href)\s*=\s*["']([^"']*)["']""", text):
        assert url.startswith(("/", "data:")), url


def _api_paths(script: str) -> set[str]:
    """Every string literal of a module that starts with ``/v1/`` or is ``/openapi.json``,
    ``${...}`` read as ``{name}``."""
    return {
        re.sub(r"\$\{[^}]*\}", "{name}", path)
        for path in re.findall(r"""['`](/v1/[^'`]*|/openapi\.json)['`]""", script)
    }


def _code(module: Path) -> str:
    """The module without its comments (which may name paths as prose)."""
    text = re.sub(r"/\*.*?\*/", "", module.read_text(), flags=re.S)
    return re.sub(r"^\s*//.*$", "", text, flags=re.M)


def test_the_modules_call_only_the_public_api(client: TestClient) -> None:
    paths = set().union(*(_api_paths(_code(m)) for m in MODULES))
    assert paths == {p for _, p in PUBLIC_ENDPOINTS | OPTIONAL_ENDPOINTS}
    served = set(client.get("/openapi.json").json()["paths"]) | {"/openapi.json"}
    assert paths - {p for _, p in OPTIONAL_ENDPOINTS} <= served


IMPORT = re.compile(r"""import\s*\{([^}]*)\}\s*from\s*['"]\./([\w.]+)['"]""")
EXPORT = re.compile(r"^export\s+(?:async\s+)?(?:function|const|let|class)\s+([\w$]+)", re.M)


def test_every_import_is_exported_and_no_module_imports_in_a_cycle() -> None:
    """Each ``import {a} from './m.js'`` names an existing module that exports ``a``; the import
    graph has no cycle (a module is evaluated after all it imports); only relative imports."""
    exports = {m.name: set(EXPORT.findall(m.read_text())) for m in MODULES}
    graph: dict[str, set[str]] = {}
    for m in MODULES:
        text = m.read_text()
        # no bare or absolute import: only the page's own modules
        assert not re.search(r"""^(?:import|export)\b[^;]*?\bfrom\s*['"](?!\./)""", text, re.M), (
            m.name
        )
        graph[m.name] = set()
        for names, target in IMPORT.findall(text):
            assert target in exports, (m.name, target)
            graph[m.name].add(target)
            for name in filter(None, (n.strip() for n in names.split(","))):
                assert name in exports[target], f"{m.name} imports {name} from {target}"
    done: set[str] = set()

    def visit(name: str, path: tuple[str, ...]) -> None:
        assert name not in path, f"import cycle: {' -> '.join((*path, name))}"
        if name not in done:
            for target in graph[name]:
                visit(target, (*path, name))
            done.add(name)

    for name in graph:
        visit(name, ())
    reached: set[str] = set()
    stack = ["main.js"]
    while stack:
        name = stack.pop()
        if name not in reached:
            reached.add(name)
            stack.extend(graph[name])
    assert reached == set(graph), set(graph) - reached  # every module is part of the page


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.name)
def test_every_module_parses(module: Path) -> None:
    """Plain ES modules, no build step: each file is valid JavaScript as served."""
    result = subprocess.run(
        ["node", "--experimental-default-type=module", "--check", str(module)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
