"""The project's own docs keep up with the code: docs/api.md documents every endpoint the live app
serves (``/openapi.json`` and the routes left out of it) and every error ``code`` the service can
answer, with its HTTP status; README.md and docs/ never point at files a user of the project does not
have (``../shared``), and their relative links resolve.

Built from the live app (``service.app.create_app``) and from ``service/errors.py``'s table, never
from a hard-coded list, so a new route or error class fails here until docs/api.md describes it. The
reverse is not checked: the contract may describe more than one branch serves.
"""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.routing import APIRoute
from fastapi.testclient import TestClient

from core import errors as core_errors
from robots import registry
from service import errors as service_errors
from service.app import create_app
from service.settings import Settings
from tests.doc_curls import CurlExample, curl_examples, mismatches, parse_answer

ROOT = Path(__file__).resolve().parents[2]
API_MD = ROOT / "docs" / "api.md"
HTTP_METHODS = ("GET", "POST", "PUT", "PATCH", "DELETE")
ENDPOINT = re.compile(r"\b(" + "|".join(HTTP_METHODS) + r")\s+(/[^\s`,;)]*)")
CODE_ROW = re.compile(r"^\|\s*`([a-z_]+)`\s*\|([^|]*)\|")
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
JSON = {"content-type": "application/json"}
PENDING_DOCS = {"docs/architecture.md"}
"""Docs another team writes in this same release: a README link to one of them may dangle until
the branches are merged; once the file exists, the link is checked like every other."""


@pytest.fixture(scope="module")
def app():
    return create_app(Settings(max_body_bytes=64))


@pytest.fixture(scope="module")
def client(app) -> TestClient:
    return TestClient(app)


def api_text() -> str:
    return API_MD.read_text(encoding="utf-8")


def documented_endpoints(text: str) -> set[tuple[str, str]]:
    """(METHOD, path) named in a heading of docs/api.md: every endpoint has its own section."""
    headings = (line for line in text.splitlines() if line.startswith("#"))
    return {(m, p) for line in headings for m, p in ENDPOINT.findall(line)}


def section(text: str, heading: str) -> str:
    """The text under the Markdown heading ``heading`` up to the next heading of its level or above."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == heading)
    level = len(heading) - len(heading.lstrip("#"))
    end = next(
        (
            i
            for i in range(start + 1, len(lines))
            if lines[i].startswith("#") and len(lines[i]) - len(lines[i].lstrip("#")) <= level
        ),
        len(lines),
    )
    return "\n".join(lines[start + 1 : end])


def documented_codes(text: str) -> dict[str, str]:
    """``code`` -> its HTTP status cell, from the table under "### Error codes"."""
    rows: dict[str, str] = {}
    for line in section(text, "### Error codes").splitlines():
        match = CODE_ROW.match(line)
        if match:
            assert match.group(1) not in rows, f"code {match.group(1)} has two rows"
            rows[match.group(1)] = match.group(2)
    return rows


def planning_error_classes() -> set[type[core_errors.PlanningError]]:
    """Every PlanningError subclass that is imported anywhere, plus the table's classes."""
    found: set[type[core_errors.PlanningError]] = set(service_errors.STATUS)
    stack = [core_errors.PlanningError]
    while stack:
        cls = stack.pop()
        found.add(cls)
        stack.extend(cls.__subclasses__())
    return found


def literal_service_codes() -> set[str]:
    """Codes the service writes directly, in service/**/*.py (parsed, not grepped): the code
    argument of every ``problem_body(...)``, ``problem_bytes(...)`` and ``raw_problem(...)`` call, every string a variable named ``code`` is given,
    and the codes of a module-level table named ``*CODES*`` (``{404: ("not_found", ...)}``)."""
    codes: set[str] = set()
    for path in (ROOT / "service").rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                name = getattr(node.func, "id", getattr(node.func, "attr", None))
                position = {"problem_body": 1, "problem_bytes": 1, "raw_problem": 2}.get(name)
                if position is not None and len(node.args) > position:
                    arg = node.args[position]
                    if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                        codes.add(arg.value)
            elif isinstance(node, ast.Assign | ast.AnnAssign) and node.value is not None:
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                names = [t.id for t in targets if isinstance(t, ast.Name)]
                if "code" in names:
                    codes.update(
                        n.value
                        for n in ast.walk(node.value)
                        if isinstance(n, ast.Constant) and isinstance(n.value, str)
                    )
                elif any("CODES" in n for n in names) and isinstance(node.value, ast.Dict):
                    codes.update(_first_string(v) for v in node.value.values)
    return {c for c in codes if c is not None and re.fullmatch(r"[a-z][a-z_]*", c)}


def _first_string(node: ast.expr) -> str | None:
    """``"x"`` of a table value ``"x"`` or ``("x", ...)`` (a status -> code table)."""
    if isinstance(node, ast.Tuple) and node.elts:
        node = node.elts[0]
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


# --- endpoints ---------------------------------------------------------------------------------


def test_every_openapi_endpoint_is_documented(client: TestClient) -> None:
    schema = client.get("/openapi.json").json()
    served = {
        (method.upper(), path)
        for path, operations in schema["paths"].items()
        for method in operations
        if method.upper() in HTTP_METHODS
    }
    assert len(served) >= 10, served  # the round-1 routes at least: the schema was read
    missing = sorted(served - documented_endpoints(api_text()))
    assert not missing, f"docs/api.md has no section for: {missing}"


def test_every_route_outside_openapi_is_documented(app) -> None:
    """/metrics, the playground page and its static files are not in /openapi.json; a user still
    reaches them, so they are documented too."""
    hidden = {
        (method, path)
        for path, route in api_routes(app.routes)
        if not route.include_in_schema
        for method in route.methods
        if method in HTTP_METHODS
    }
    assert ("GET", "/metrics") in hidden, hidden
    missing = sorted(hidden - documented_endpoints(api_text()))
    assert not missing, f"docs/api.md has no section for: {missing}"


def api_routes(routes: list, prefix: str = "") -> Iterator[tuple[str, APIRoute]]:
    """(full path, route) of every APIRoute, also inside included routers (FastAPI >= 0.16x keeps
    them as ``_IncludedRouter`` entries holding the ``original_router``)."""
    for route in routes:
        if isinstance(route, APIRoute):
            yield prefix + route.path, route
        elif hasattr(route, "original_router"):
            yield from api_routes(
                route.original_router.routes, prefix + route.include_context.prefix
            )


def schema_fields(schema: dict, components: dict, seen: set[str]) -> Iterator[str]:
    """Every property name in an OpenAPI schema, following ``$ref`` (each component once)."""
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        if name not in seen:
            seen.add(name)
            yield from schema_fields(components[name], components, seen)
        return
    for key in ("anyOf", "oneOf", "allOf"):
        for sub in schema.get(key, []):
            yield from schema_fields(sub, components, seen)
    for key in ("items", "additionalProperties"):
        if isinstance(schema.get(key), dict):
            yield from schema_fields(schema[key], components, seen)
    for name, sub in schema.get("properties", {}).items():
        yield name
        yield from schema_fields(sub, components, seen)


def test_every_request_field_and_query_parameter_is_documented(client: TestClient) -> None:
    """Each field of each request body (nested ones too) and each query parameter of the live app
    is named in docs/api.md as `field`."""
    schema = client.get("/openapi.json").json()
    components = schema.get("components", {}).get("schemas", {})
    text = api_text()
    missing = {}
    for path, operations in schema["paths"].items():
        for method, operation in operations.items():
            content = operation.get("requestBody", {}).get("content", {})
            body = content.get("application/json", {}).get("schema")
            names = set(schema_fields(body, components, set())) if body else set()
            names |= {p["name"] for p in operation.get("parameters", []) if p["in"] == "query"}
            absent = sorted(n for n in names if f"`{n}`" not in text)
            if absent:
                missing[f"{method.upper()} {path}"] = absent
    assert not missing, f"request fields not named in docs/api.md: {missing}"


def test_endpoint_parser_reads_headings_only() -> None:
    text = "## `POST /v1/x/{name}/fk`, `GET /v1/y`\nPOST /v1/not-a-heading\n### GET /\n"
    assert documented_endpoints(text) == {
        ("POST", "/v1/x/{name}/fk"),
        ("GET", "/v1/y"),
        ("GET", "/"),
    }


# --- error codes -------------------------------------------------------------------------------


def test_every_error_class_code_is_documented_with_its_status() -> None:
    rows = documented_codes(api_text())
    for cls in planning_error_classes():
        assert cls.code in rows, f"error code {cls.code!r} ({cls.__name__}) is not in docs/api.md"
    for cls, status in service_errors.STATUS.items():
        cell = rows[cls.code]
        assert re.search(rf"\b{status}\b", cell), (
            f"docs/api.md gives {cls.code!r} the status {cell.strip()!r}; service/errors.py: {status}"
        )


def test_every_code_the_service_writes_is_documented() -> None:
    literal = literal_service_codes()
    assert {"validation", "too_large", "not_ready", "bad_request"} <= literal, literal  # found
    missing = sorted(literal - documented_codes(api_text()).keys())
    assert not missing, f"docs/api.md has no row for the codes: {missing}"


@pytest.mark.parametrize(
    ("method", "url", "content"),
    [
        ("GET", "/no/such/route", None),
        ("DELETE", "/health", None),
        ("POST", "/v1/trajectories/joint", b"{not json"),
        ("POST", "/v1/trajectories/joint", b"[" + b"0," * 64 + b"0]"),
        ("GET", "/v1/robots/no_such_robot", None),
    ],
)
def test_live_error_answers_have_documented_codes(
    client: TestClient, method: str, url: str, content: bytes | None
) -> None:
    """Errors the HTTP layer makes (unknown route, method, malformed JSON, a body over the limit)
    carry a code of the table, whatever code the service chooses for them."""
    response = client.request(
        method, url, content=content, headers={"content-type": "application/json"}
    )
    assert 400 <= response.status_code < 500, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    code = response.json()["code"]
    assert code in documented_codes(api_text()), f"{method} {url} answered undocumented {code!r}"


def test_code_table_parser() -> None:
    text = "### Error codes\n\n| Code | HTTP | When |\n|---|---|---|\n| `a_b` | 422 | x |\n## Next\n| `c` | 1 | y |\n"
    assert documented_codes(text) == {"a_b": " 422 "}


# --- README and links --------------------------------------------------------------------------


def project_docs() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def test_docs_never_point_at_files_outside_the_project() -> None:
    for path in project_docs():
        text = path.read_text(encoding="utf-8")
        for outside in ("../shared", "/work/shared"):
            assert outside not in text, f"{path.relative_to(ROOT)} mentions {outside}"


def test_readme_links_the_project_docs() -> None:
    targets = set(LINK.findall((ROOT / "README.md").read_text(encoding="utf-8")))
    for doc in ("docs/api.md", "docs/architecture.md", "docs/robots.md"):
        assert doc in targets, f"README.md does not link {doc}"


@pytest.mark.parametrize("path", project_docs(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    anchors = {slug(line.lstrip("#")) for line in text.splitlines() if line.startswith("#")}
    for target in LINK.findall(text):
        if re.match(r"^[a-z]+:", target):
            continue  # http(s), mailto
        file, _, anchor = target.partition("#")
        if not file:
            assert anchor in anchors, f"{path.name}: no heading for #{anchor}"
            continue
        resolved = (path.parent / file).resolve()
        relative = resolved.relative_to(ROOT).as_posix() if resolved.is_relative_to(ROOT) else file
        if relative in PENDING_DOCS and not resolved.exists():
            continue
        assert resolved.exists(), f"{path.name} links {target}, which does not exist"


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def test_slug() -> None:
    assert slug(" `POST /v1/trajectories/joint`") == "post-v1trajectoriesjoint"
    assert slug(" Inline robots (URDF)") == "inline-robots-urdf"


# --- docs/robots.md against the registry ---------------------------------------------------------

ROBOTS_MD = ROOT / "docs" / "robots.md"
DH_ROW = re.compile(r"^\|\s*(\d+|flange)\s*\|([^|]+)\|([^|]+)\|([^|]+)\|\s*$")
LIMIT_ROW = re.compile(
    r"^\|\s*(\d+)\s*\|\s*`([^`]+)`\s*\|\s*\[([^,\]]+),([^\]]+)\]\s*\|[^|]*\|([^|]+)\|([^|]+)\|"
)


def number(text: str) -> float:
    """A table cell: a decimal number or a multiple of pi written ``pi/2``, ``-pi``, ``2 pi/3``."""
    text = text.strip()
    match = re.fullmatch(r"(-?)(\d*\.?\d*)\s*pi(?:/(\d+))?", text)
    if match is None:
        return float(text)
    sign, factor, divisor = match.groups()
    value = (float(factor) if factor else 1.0) * np.pi / (float(divisor) if divisor else 1.0)
    return -value if sign else value


def robot_section(name: str) -> str:
    """The text of docs/robots.md under the heading ``## `name`...`` (every registered robot has one)."""
    text = ROBOTS_MD.read_text(encoding="utf-8")
    heading = next((line for line in text.splitlines() if line.startswith(f"## `{name}`")), None)
    assert heading is not None, f"docs/robots.md has no section for the registered robot {name!r}"
    return section(text, heading)


def dh_table(text: str) -> tuple[str, list[tuple[str, float, float, float]]]:
    """Convention (``standard`` or ``modified``) and rows (i, a, d, alpha) of the DH table."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("DH parameters ("))
    convention = lines[start].split("(")[1].split(")")[0].split(";")[0].strip()
    rows = []
    for line in lines[start + 1 :]:
        if line.strip() and not line.startswith("|"):
            break
        match = DH_ROW.match(line)
        if match:
            rows.append((match.group(1), *(number(g) for g in match.groups()[1:])))
    return convention, rows


def dh_fk(convention: str, rows: list, q: np.ndarray) -> np.ndarray:
    """T_base_tool (4, 4) of DH ``rows`` at joint values ``q`` (theta_i = q_i; ``flange`` fixed)."""
    T = np.eye(4)
    joints = iter(q)
    for label, a, d, alpha in rows:
        theta = 0.0 if label == "flange" else next(joints)
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        if convention == "standard":  # Rz(theta) Tz(d) Tx(a) Rx(alpha)
            A = [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d]]
        else:  # modified: Rx(alpha) Tx(a) Rz(theta) Tz(d)
            A = [[ct, -st, 0, a], [st * ca, ct * ca, -sa, -d * sa], [st * sa, ct * sa, ca, d * ca]]
        T = T @ np.vstack([A, [0, 0, 0, 1]])
    return T


@pytest.mark.parametrize("name", registry.names())
def test_robots_md_dh_table_reproduces_the_model(name: str) -> None:
    robot = registry.get(name)
    convention, rows = dh_table(robot_section(name))
    assert convention in ("standard", "modified"), convention
    assert sum(label != "flange" for label, *_ in rows) == robot.dof, rows
    rng = np.random.default_rng(13)
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    for q in rng.uniform(lo, hi, size=(25, robot.dof)):
        np.testing.assert_allclose(
            dh_fk(convention, rows, q), robot.fk(q), atol=1e-9, err_msg=str(q)
        )


@pytest.mark.parametrize("name", registry.names())
def test_robots_md_limits_equal_the_registry(name: str) -> None:
    robot = registry.get(name)
    rows = [LIMIT_ROW.match(line) for line in robot_section(name).splitlines()]
    rows = [m for m in rows if m]
    assert [m.group(2) for m in rows] == list(robot.joint_names)
    table = np.array([[number(g) for g in m.groups()[2:6]] for m in rows])
    np.testing.assert_allclose(table[:, :2], robot.position_limits, atol=1e-4)
    np.testing.assert_allclose(table[:, 2], robot.velocity_limits, atol=1e-4)
    np.testing.assert_allclose(table[:, 3], robot.acceleration_limits, atol=1e-4)


def test_robots_md_number_cells() -> None:
    assert number("pi/2") == pytest.approx(np.pi / 2)
    assert number("-pi/2") == pytest.approx(-np.pi / 2)
    assert number("2 pi/3") == pytest.approx(2 * np.pi / 3)
    assert number(" -0.39225 ") == -0.39225


# --- the worked examples of docs/api.md run against the live app --------------------------------

EXAMPLES = curl_examples(API_MD.read_text(encoding="utf-8"))


def test_every_endpoint_section_has_an_example() -> None:
    paths = {re.sub(r"\?.*", "", example.url) for example in EXAMPLES}
    patterns = [
        re.compile("^" + re.sub(r"\{[^}]+\}", "[^/]+", p) + "$")
        for _, p in documented_endpoints(api_text())
        if not p.startswith("/static")
    ]
    missing = [p.pattern for p in patterns if not any(p.match(u) for u in paths)]
    assert not missing, f"endpoints without a worked example: {missing}"


def _served(app, method: str, path: str) -> bool:
    """The app has a route for ``method path`` (in /openapi.json or not)."""
    plain = [(r.path, r) for r in app.routes if isinstance(getattr(r, "path", None), str)]
    return any(
        method in (route.methods or ()) and re.fullmatch(re.sub(r"\{[^}]+\}", "[^/]+", full), path)
        for full, route in [*api_routes(app.routes), *plain]
    )


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: e.name)
def test_worked_example(example: CurlExample) -> None:
    """The example's status and ``code``, and its documented answer (the rules of
    ``tests/doc_curls.py``, stated at the top of docs/api.md) against the live answer."""
    if example.body is not None:
        json.loads(example.body)  # an example's body is valid JSON
    path = example.url.split("?")[0]
    assert any(
        re.fullmatch(re.sub(r"\{[^}]+\}", "[^/]+", p), path) and m == example.method
        for m, p in documented_endpoints(api_text())
    ), f"{example.method} {path} has no section"
    app = create_app()  # the module's app has a tiny body limit
    if not _served(app, example.method, path):
        pytest.skip(f"{example.method} {path}: not served by this branch (added in this release)")
    response = TestClient(app).request(
        example.method, example.url, content=example.body, headers=JSON
    )
    assert response.status_code == example.status, response.text[:500]
    if example.code is not None:
        assert response.json().get("code") == example.code, response.text[:500]
    if example.answer is not None and "stream=ndjson" in example.url:  # one JSON value per line
        lines = example.answer.strip().splitlines()
        live = [json.loads(line) for line in response.text.strip().splitlines()]
        assert len(live) == len(lines), response.text[:500]
        wrong = [
            w for d, v in zip(lines, live, strict=True) for w in mismatches(parse_answer(d), v)
        ]
        assert not wrong, "\n".join(wrong)
    elif example.answer is not None:
        wrong = mismatches(parse_answer(example.answer), response.json())
        assert not wrong, "\n".join(wrong)


def test_answer_rules_can_fail() -> None:
    """The comparison of documented and live answers rejects what it must."""
    doc = parse_answer('{"a":[1.25,...,"z"],"t":".../x","n":1.0e-12,"d":0.7118,"ms":5,"o":{...}}')
    live = {"a": [1.2504, 7, "z"], "t": "https://h/x", "n": -3e-10, "d": 0.71183, "o": {"k": 1}}
    assert mismatches(doc, {**live, "compute_time_ms": 9.0, "ms": 5}) == []
    assert mismatches(doc, {**live, "ms": 5, "d": 0.7119})  # past half a unit of 0.7118
    assert mismatches(doc, {**live, "ms": 5, "a": [1.256, "z"]})
    assert mismatches(doc, {**live, "ms": 5, "a": [1.25, "y"]})
    assert mismatches(doc, {**live, "ms": 5, "t": "x/y"})
    assert mismatches(doc, {**live, "ms": 5, "n": 2e-9})
    assert mismatches(doc, {**live, "ms": 5, "o": []})
    assert mismatches(doc, {k: v for k, v in live.items() if k != "d"} | {"ms": 5})
    assert mismatches(parse_answer("[1, 2]"), [1, 2, 3])
    assert mismatches(parse_answer("true"), 1)
