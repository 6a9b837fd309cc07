"""The project's own files agree: the README shows the exact test command CI runs and the start
command; the Dockerfile installs the project with ``pip install .`` and starts ``python -m service``
on 0.0.0.0. Files are parsed, not grepped loosely."""

from __future__ import annotations

import ast
import importlib.metadata
import json
import re
import shlex
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def readme_sections() -> dict[str, list[str]]:
    """``## heading`` -> the lines of the fenced code blocks under it."""
    sections: dict[str, list[str]] = {}
    heading, fenced = "", False
    for line in (ROOT / "README.md").read_text().splitlines():
        if line.startswith("```"):
            fenced = not fenced
            continue
        if fenced:
            sections.setdefault(heading, []).append(line.strip())
        elif line.startswith("## "):
            heading = line[3:].strip()
    return sections


def ci_test_command() -> str:
    """The command ``.ci/run`` runs after its "tests (README command)" marker."""
    lines = (ROOT / ".ci" / "run").read_text().splitlines()
    marker = next(i for i, line in enumerate(lines) if "tests (README command)" in line)
    return next(line.strip() for line in lines[marker + 1 :] if line.strip())


def dockerfile_instructions() -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) with line continuations joined and comments dropped."""
    text = (ROOT / "Dockerfile").read_text()
    joined = re.sub(r"\\\n", " ", text)
    out = []
    for line in joined.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            word, _, rest = line.partition(" ")
            out.append((word.upper(), rest.strip()))
    return out


def test_readme_shows_the_exact_ci_test_command() -> None:
    command = ci_test_command()
    assert "pytest" in command
    run_tests = next(
        lines for heading, lines in readme_sections().items() if "test" in heading.lower()
    )
    assert command in run_tests, f"README's test section lacks: {command}"


def test_readme_shows_the_start_command() -> None:
    start = next(
        lines for heading, lines in readme_sections().items() if heading.lower().startswith("start")
    )
    commands = [c for line in start for c in line.split("&&")]
    service = [shlex.split(c) for c in commands if "-m service" in c]
    assert service, "README's start section has no `python -m service` command"
    argv = service[0]
    module = argv.index("-m")
    assert argv[module + 1] == "service" and "--host" in argv and "--port" in argv
    assert any("pip install ." in c for c in commands), "README start does not install the project"


def test_dockerfile_installs_the_project_and_starts_the_service() -> None:
    instructions = dockerfile_instructions()
    runs = [shlex.split(args) for word, args in instructions if word == "RUN"]
    installs = [argv for argv in runs if "pip" in argv and "install" in argv]
    assert any("." in argv[argv.index("install") + 1 :] for argv in installs), runs
    cmd = [args for word, args in instructions if word == "CMD"][-1]
    argv = json.loads(cmd)  # exec form
    assert argv[:5] == ["python", "-m", "service", "--host", "0.0.0.0"], argv
    port = argv[argv.index("--port") + 1]
    assert ("EXPOSE", port) in instructions


PROJECT_PACKAGES = {"core", "robots", "service"}


def _imported_top_level_modules() -> set[str]:
    """Top-level modules that core/, robots/ and service/ import (parsed with ast)."""
    modules: set[str] = set()
    for package in ("core", "robots", "service"):
        for path in (ROOT / package).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.Import):
                    modules.update(alias.name.split(".")[0] for alias in node.names)
                elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                    modules.add(node.module.split(".")[0])
    return modules


QP_BACKENDS = {"daqp"}
"""Runtime dependencies the service uses by name through qpsolvers, not by import: DAQP, the dense
QP solver of the DLS controller's exact step (``core/cartesian/rate/tick_qp.py``, first in its
order of solvers) when a tick has obstacle rows and OSQP stops short."""
IMPORT_NAMES = {"pin": "pinocchio"}
"""Distributions whose modules do not come with their own files (meta-distributions)."""


def _runtime_dependencies() -> set[str]:
    tomllib = pytest.importorskip("tomllib")
    dependencies = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    return {
        re.split(r"[<>=!~;\[ ]", d, maxsplit=1)[0].lower().replace("_", "-") for d in dependencies
    }


def _top_level(name: str) -> set[str]:
    """Top-level modules a distribution installs, from its file list (cmeel wheels such as
    libpinocchio install under cmeel.prefix/.../site-packages/)."""
    modules = set()
    for file in importlib.metadata.files(name) or []:
        parts = file.parts
        top = parts[parts.index("site-packages") + 1 :] if "site-packages" in parts else parts
        if top[0].endswith((".dist-info", ".data")) or top[0].startswith(".."):
            continue
        if len(top) > 1 or top[0].endswith((".py", ".so")):
            modules.add(top[0].split(".")[0])
    return modules


def _modules_of(name: str) -> set[str]:
    """A distribution's modules; a meta-distribution's (``pin``) are its requirements'."""
    modules = _top_level(name)
    if not modules:
        for requirement in importlib.metadata.requires(name) or []:
            if "extra ==" not in requirement:
                modules |= _top_level(re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0])
    return modules


def test_every_runtime_dependency_is_imported_by_the_service() -> None:
    """The image installs the runtime dependencies: each must be a module the service imports, or
    a QP backend it names (the playground's plotly.min.js is vendored, so the plotly package is
    not one)."""
    names = _runtime_dependencies()
    imported = _imported_top_level_modules()
    unused = {name for name in names - QP_BACKENDS if not _modules_of(name) & imported}
    assert not unused, f"runtime dependencies no module of the service imports: {unused}"
    assert "plotly" not in names


def test_every_module_the_service_imports_is_declared() -> None:
    """``pip install .`` alone must bring every module core/, robots/ and service/ import: each
    third-party import is a module of a distribution named in ``project.dependencies`` itself
    (not one that happens to come along with another, as coal comes with pin and starlette with
    fastapi)."""
    names = _runtime_dependencies()
    declared = set().union(*(_modules_of(name) for name in names))
    third_party = _imported_top_level_modules() - set(sys.stdlib_module_names) - PROJECT_PACKAGES
    undeclared = third_party - declared
    assert not undeclared, f"imported but not declared in pyproject.toml: {sorted(undeclared)}"
    assert {"coal", "starlette", "pinocchio", "eaik"} <= third_party  # the check sees them


def test_the_exact_step_qp_solver_is_declared_and_installed() -> None:
    """The DLS controller's exact step (tick_qp) needs a dense QP solver: DAQP is declared, and
    qpsolvers finds it."""
    qpsolvers = pytest.importorskip("qpsolvers")
    assert QP_BACKENDS <= _runtime_dependencies()
    assert QP_BACKENDS <= set(qpsolvers.available_solvers)
    source = (ROOT / "core" / "cartesian" / "rate" / "tick_qp.py").read_text()
    order = re.search(r"for solver in \(([^)]*)\)", source)
    assert order and order.group(1).split(",")[0].strip().strip('"') in QP_BACKENDS


def test_ci_type_checks_core_robots_and_service() -> None:
    """``.ci/run`` runs mypy with the project's own configuration, which covers the three packages
    at default strictness (issue 23: 0 errors in CI)."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
    assert set(config["files"]) == {"core", "robots", "service"}
    assert not {"strict", "disallow_untyped_defs", "ignore_errors"} & set(config)
    commands = [
        line.split(";")[-1].strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
    ]
    assert any(re.fullmatch(r"\S*/bin/mypy", c) for c in commands), commands
