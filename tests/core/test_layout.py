"""The layout rules of docs/architecture.md, checked on the source: no import cycle in core/,
robots/ or service/ (imports inside functions count too), core/ imports neither robots/ nor
service/, no core module over 400 lines, no probing of robots (getattr/hasattr/inspect) in the
Cartesian planners, and every registry name reaches the HTTP schema."""

from __future__ import annotations

import ast
from pathlib import Path
from typing import get_args

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("core", "robots", "service")


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _graph() -> dict[str, set[str]]:
    files = {_module(p): p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in files}
    for mod, path in files.items():
        for node in ast.walk(ast.parse(path.read_text())):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            for name in names:
                if name in files and name != mod:
                    graph[mod].add(name)
    return graph


def test_no_import_cycles() -> None:
    graph = _graph()
    state: dict[str, int] = {}

    def visit(m: str, stack: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                raise AssertionError("import cycle: " + " -> ".join([*stack, m, n]))
            if n not in state:
                visit(n, [*stack, m])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [])


def test_core_imports_neither_robots_nor_service() -> None:
    for mod, deps in _graph().items():
        if mod.startswith("core"):
            bad = {d for d in deps if d.startswith(("robots", "service"))}
            assert not bad, (mod, bad)


def test_core_modules_stay_small() -> None:
    sizes = {p: len(p.read_text().splitlines()) for p in (ROOT / "core").rglob("*.py")}
    assert max(sizes.values()) <= 400, max(sizes.items(), key=lambda kv: kv[1])


def test_core_does_not_probe_robots() -> None:
    for path in (ROOT / "core").rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id in ("hasattr", "getattr")
            ):
                target = ast.unparse(node.args[0])
                assert "robot" not in target and "kin" not in target, (path, node.lineno)
            if isinstance(node, ast.Import | ast.ImportFrom):
                names = [a.name for a in node.names] + [getattr(node, "module", None) or ""]
                assert "inspect" not in names, (path, node.lineno)


def test_registries_reach_the_schema() -> None:
    from core.cartesian.methods import METHODS
    from core.path import PATHS
    from core.timing import TIMING_LAWS
    from service.schemas.cartesian import Method

    assert set(get_args(Method)) == set(METHODS)
    assert "line" in PATHS and {"quintic", "speed_limited"} <= set(TIMING_LAWS)
