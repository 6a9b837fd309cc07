"""The layout rules of docs/architecture.md, checked on the source: no import cycle in core/,
robots/ or service/ (imports inside functions count too), core/ imports neither robots/ nor
service/, the service reaches core only through its entry points and types (it plans nothing and
checks no collision itself), no module over 400 lines and no function over 80 in core/, robots/ and
service/ (known exceptions listed with who is splitting them), no probing of robots
(getattr/hasattr/inspect) in the Cartesian planners, and every registry name reaches the HTTP
schema."""

from __future__ import annotations

import ast
from pathlib import Path

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


MAX_LINES = 400
MAX_FUNCTION_LINES = 80
KNOWN_LARGE: dict[str, str] = {}
"""Modules over ``MAX_LINES`` allowed for now; the lead drops each entry once its split lands."""
KNOWN_LONG = {
    ("core/cartesian/rate/control.py", "_simulate"): "helper rate splits it (two controllers)",
    ("core/cartesian/knot_nlp_derivatives.py", "derivatives"): "one CasADi graph",
    ("robots/urdf_screen.py", "screen_urdf"): "robots/",
}
"""Functions over ``MAX_FUNCTION_LINES`` allowed for now."""
SERVICE_MAY_IMPORT = {
    # entry points: one call each
    "core.cartesian.plan", "core.program.plan", "core.joint.point_to_point", "core.joint.splines",
    "core.joint.retime", "core.motion.plan",
    # inputs, results and errors
    "core.cartesian.task", "core.program.segments", "core.joint.motion", "core.collisions",
    "core.errors", "core.budget", "core.trajectory", "core.limits", "core.kinematics",
    "core.joint.durations", "core.geometry.so3", "core.timing.path_constraints",
    "core.motion.clearance", "core.motion.goals",
    # registries (the schema's names)
    "core.cartesian.methods", "core.path", "core.timing", "core.joint.profiles",
    "core.motion.timing",
}  # fmt: skip
"""The core modules the service may import: no planning internal (a walk, a check, a timing law's
module, a program's stages) is the service's business."""


def _sources() -> list[Path]:
    return [p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")]


def test_modules_stay_small() -> None:
    big = {
        str(p.relative_to(ROOT)): n
        for p in _sources()
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    }
    assert set(big) <= set(KNOWN_LARGE), {k: v for k, v in big.items() if k not in KNOWN_LARGE}


def test_functions_stay_short() -> None:
    long = {}
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = (node.end_lineno or node.lineno) - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long[(str(path.relative_to(ROOT)), node.name)] = n
    assert set(long) <= set(KNOWN_LONG), {k: v for k, v in long.items() if k not in KNOWN_LONG}


def test_the_service_reaches_core_through_its_entry_points_only() -> None:
    graph = _graph()
    for mod, deps in graph.items():
        if mod.startswith("service"):
            used = {d for d in deps if d.startswith("core") and d.count(".") >= 1}
            modules = {d for d in used if d in graph}  # ``from core.x import name``: core.x
            bad = modules - SERVICE_MAY_IMPORT
            assert not bad, (mod, sorted(bad))


def test_the_service_checks_no_collision_itself() -> None:
    """The check is a core stage (``core.collisions``): the service builds the collision object
    and hands it to core; it never runs a check."""
    for path in (ROOT / "service").rglob("*.py"):
        text = path.read_text()
        for call in (".check_path(", "check_motion(", "check_ends("):
            assert call not in text, (path, call)


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
    """Every schema name is a registry key, read when used (service/schemas/registry.py)."""
    from core.cartesian.methods import METHODS
    from core.joint.profiles import PROFILES
    from core.path import PATHS
    from core.timing import JOINT_PATH_LAWS, TIMING_LAWS
    from service.schemas.cartesian import Method, PathType, SpeedProfile
    from service.schemas.program import ProgramTiming, PtpProfile, SegmentMethod
    from service.schemas.program import SpeedProfile as SegmentSpeedProfile
    from service.schemas.registry import names_of
    from service.schemas.trajectories import Profile

    assert names_of(Method) == names_of(SegmentMethod) == list(METHODS)
    assert names_of(PathType) == list(PATHS)
    # a speed_profile times a Cartesian path; a program's timing its joint path (round 3)
    cartesian = [k for k in TIMING_LAWS if k not in JOINT_PATH_LAWS]
    assert names_of(SpeedProfile) == names_of(SegmentSpeedProfile) == cartesian
    assert names_of(ProgramTiming) == [k for k in TIMING_LAWS if k in JOINT_PATH_LAWS]
    assert names_of(Profile) == list(PROFILES)
    assert set(names_of(PtpProfile)) == set(PROFILES) - {"linear"}


def test_core_never_branches_on_a_registry_name() -> None:
    """No ``speed_profile == "..."`` (issue 23: five such branches bypassed ``TIMING_LAWS``)."""
    for path in (ROOT / "core").rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Compare) and isinstance(node.left, ast.Attribute):
                if node.left.attr in ("speed_profile", "method", "kind"):
                    literal = [c for c in node.comparators if isinstance(c, ast.Constant)]
                    assert not literal, (path, node.lineno, ast.unparse(node))
