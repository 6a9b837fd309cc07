"""The playground in headless Chromium, against a live server on loopback.

Starts ``python -m service`` on a free port, loads ``/`` in Chromium (Debian's ``chromium`` and
``chromium-driver``, driven by selenium) and does what a person would: plans a UR5 ``sampled``
line, a planar line through the unreachable hole, a spline and a compare run. It asserts what the
person would see: traces with one point per returned trajectory point, the limit lines, the failure
detail and where on the line it happened, a compare table row per method. A screenshot of each
view goes to ``artifacts/`` (gitignored). ``.ci/run`` installs the browser; without it the tests
skip and say why.
"""

from __future__ import annotations

import json
import os
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.browser.chromium import NEEDS_CHROMIUM

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "artifacts"
DOCS = ROOT / "docs"
try:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait
except ImportError:  # pragma: no cover - the test extra installs selenium (conftest skips)
    pass

pytestmark = [pytest.mark.browser, NEEDS_CHROMIUM]
PLAN_TIMEOUT_S = 45.0
FK_SUBSAMPLE = 100
"""The page computes the tool path from at most this many returned points (app.js MAX_FK_POINTS)."""


_STATE = "return document.body.dataset.state"
_RUNS = "return Number(document.body.dataset.run || 0)"


def _post(server: str, path: str, body: dict[str, Any]) -> tuple[int, dict[str, Any]]:
    """The same request as the page's, sent directly: what the plots must show."""
    req = urllib.request.Request(
        f"{server}{path}",
        data=json.dumps(body).encode(),
        headers={"content-type": "application/json"},
    )
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def _preset(driver: Any, preset: str) -> None:
    Select(driver.find_element(By.ID, "c-preset")).select_by_value(preset)
    WebDriverWait(driver, 15).until(
        lambda d: d.execute_script("return document.getElementById('c-start-0') !== null")
    )
    time.sleep(0.3)  # the preset may switch robots (GET /v1/robots/{name}) before filling fields


def _click_and_wait(driver: Any, element_id: str) -> None:
    runs = driver.execute_script(_RUNS)
    driver.find_element(By.ID, element_id).click()
    WebDriverWait(driver, PLAN_TIMEOUT_S).until(
        lambda d: d.execute_script(_RUNS) > runs and d.execute_script(_STATE) == "done"
    )


def _last_request(driver: Any) -> tuple[str, dict[str, Any]]:
    """The request the page sent (shown under "Last request"): path and body."""
    text = driver.execute_script("return document.getElementById('request-json').textContent")
    head, _, body = text.partition("\n")
    return head.split()[1], json.loads(body)


def _traces(driver: Any, plot: str) -> list[dict[str, Any]]:
    """name, type, point count, meta and axes of every trace drawn in ``plot``."""
    return driver.execute_script(
        """const gd = document.getElementById(arguments[0]);
        return (gd.data || []).map((t) => ({name: t.name, type: t.type || 'scatter',
          n: (t.x || []).length, meta: t.meta || null, yaxis: t.yaxis || 'y',
          x: Array.from(t.x || []).slice(0, 12), y: (t.y || []).slice(0, 5)}));""",
        plot,
    )


def _arm(driver: Any, plot: str, which: str) -> dict[str, Any]:
    """The arm trace drawn at ``which`` (start, goal, contact): name, point count, meta, x."""
    found = driver.execute_script(
        """const gd = document.getElementById(arguments[0]);
        return (gd.data || []).filter((t) => t.meta && t.meta.role === 'arm'
          && t.meta.which === arguments[1]).map((t) => ({name: t.name, n: t.x.length,
          meta: t.meta, x: t.x}));""",
        plot,
        which,
    )
    assert found, f"no arm at {which} in {plot}"
    return found[0]


def _slide_arm(driver: Any, plot: str, k: int) -> None:
    driver.execute_script(
        """const s = document.querySelector(`.arm-bar[data-plot="${arguments[0]}"] .arm-slider`);
        s.value = String(arguments[1]); s.dispatchEvent(new Event('input'));""",
        plot,
        k,
    )
    time.sleep(0.3)


def _layout(driver: Any, plot: str) -> dict[str, Any]:
    return driver.execute_script(
        """const gd = document.getElementById(arguments[0]);
        const l = gd.layout || {};
        return {shapes: (l.shapes || []).map((s) => ({x0: s.x0, type: s.type})),
                annotations: (l.annotations || []).map((a) => ({x: a.x, text: a.text}))};""",
        plot,
    )


def _rendered_lines(driver: Any, plot: str) -> int:
    """SVG line traces Plotly actually drew (what is on screen, not only in the data)."""
    return len(driver.find_elements(By.CSS_SELECTOR, f"#{plot} .scatterlayer .trace path.js-line"))


def _view(driver: Any, name: str) -> None:
    driver.find_element(By.CSS_SELECTOR, f"#view-tabs button[data-view='{name}']").click()
    time.sleep(0.4)  # Plotly resizes the plots of the view just shown


def _shot(driver: Any, name: str) -> None:
    """A screenshot of the whole page (the window grown to its height) in ``artifacts/``."""
    ARTIFACTS.mkdir(exist_ok=True)
    size = driver.get_window_size()
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(size["width"], max(size["height"], height + 140))
    time.sleep(0.5)  # the plots follow the new size
    driver.save_screenshot(str(ARTIFACTS / f"playground-{name}.png"))
    driver.set_window_size(size["width"], size["height"])


def _severe_console_errors(driver: Any) -> list[str]:
    """Console errors other than the failed plan's own 4xx answer."""
    return [
        e["message"]
        for e in driver.get_log("browser")
        if e["level"] == "SEVERE" and "status of 422" not in e["message"]
    ]


def _download(driver: Any, css: str, suffix: str) -> Path:
    """Click ``css`` and wait for the browser to save a new ``*suffix`` file."""
    folder: Path = driver.downloads
    before = set(folder.glob(f"*{suffix}"))
    driver.find_element(By.CSS_SELECTOR, css).click()
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline:
        new = set(folder.glob(f"*{suffix}")) - before
        if new:
            path = new.pop()
            time.sleep(0.2)  # the file is renamed from .crdownload once complete
            return path
        time.sleep(0.1)
    raise AssertionError(f"no {suffix} file was downloaded by {css}")


def _check_joint_plot(driver: Any, n_points: int, dof: int, knots: int | None = None) -> None:
    traces = _traces(driver, "plot-joints")
    joints = [t for t in traces if (t["meta"] or {}).get("role") == "joint"]
    limits = [t for t in traces if (t["meta"] or {}).get("role") == "limit"]
    assert len(joints) == 4 * dof  # position, velocity, acceleration, jerk per joint
    assert all(t["n"] == n_points for t in joints), [(t["name"], t["n"]) for t in joints]
    jerk = [t for t in joints if t["meta"]["quantity"].startswith("jerk")]
    assert len(jerk) == dof and {t["yaxis"] for t in jerk} == {"y4"}
    # One dashed pair (upper, lower) per joint and quantity; jerk only where a limit is known.
    assert len(limits) in (3 * dof, 4 * dof)
    assert {"y", "y2", "y3"} <= {t["yaxis"] for t in limits}
    assert _rendered_lines(driver, "plot-joints") >= 7 * dof
    if knots is not None:
        marked = [t for t in traces if (t["meta"] or {}).get("role") == "knots"]
        assert len(marked) == 1 and marked[0]["n"] == knots * dof


def test_ur5_sampled_line(server: str, page: Any) -> None:
    _preset(page, "ur5-line")
    assert Select(page.find_element(By.ID, "robot")).first_selected_option.text == "ur5"
    assert (
        Select(page.find_element(By.ID, "c-method")).first_selected_option.get_attribute("value")
        == "sampled"
    )
    _click_and_wait(page, "c-plan")
    path, request = _last_request(page)
    assert path == "/v1/trajectories/cartesian" and request["method"] == "sampled"
    status, body = _post(server, path, request)
    assert status == 200, body
    n = len(body["points"])
    diag = body["diagnostics"]

    status_text = page.find_element(By.ID, "status").text
    assert "200" in status_text and f"{n} points" in status_text
    assert not page.find_element(By.ID, "problem").is_displayed()

    # Cartesian view: tool path beside the ideal line, deviation with the tolerance, sigma(s).
    path_traces = {t["name"]: t for t in _traces(page, "plot-path")}
    assert path_traces["tool path"]["n"] == min(n, FK_SUBSAMPLE)
    assert path_traces["ideal line"]["n"] == 2
    assert path_traces["tool path"]["type"] in ("scatter3d", "scatter")  # 2D views without WebGL
    deviation = {t["name"]: t for t in _traces(page, "plot-deviation")}
    profile = diag["deviation_profile"]
    assert deviation["position deviation"]["n"] == len(profile["s"])
    assert deviation["orientation deviation"]["n"] == len(profile["s"])
    assert any(name.startswith("position tolerance 0.001") for name in deviation)
    assert any(name.startswith("orientation tolerance 0.01") for name in deviation)
    sigma = _traces(page, "plot-sigma")
    assert sigma[0]["n"] == len(diag["singular_value_profile"]["value"])
    assert sigma[0]["y"][0] == pytest.approx(diag["singular_value_profile"]["value"][0])
    _shot(page, "ur5-cartesian")

    # The arm: one polyline through every link frame of POST /fk with frames, at start and goal.
    assert "environment" not in request  # no obstacles, no environment
    for which, q in (
        ("start", request["start"]["positions"]),
        ("goal", request["goal"]["positions"]),
    ):
        _, a = _post(server, "/v1/robots/ur5/fk", {"positions": q, "frames": True})
        arm = _arm(page, "plot-path", which)
        assert arm["n"] == len(a["frames"]) >= 7
        assert arm["meta"]["configuration"] == a["configuration"]
        assert arm["name"] == f"arm at {which} ({a['configuration']})"
        assert arm["x"] == pytest.approx([f["position"][0] for f in a["frames"]], abs=1e-12)
    assert page.find_element(By.ID, "summary-config-start").text.endswith(a["configuration"])
    moving = [
        t for t in _traces(page, "plot-path") if (t["meta"] or {}).get("role") == "arm-moving"
    ]
    assert len(moving) >= 1 and moving[0]["n"] == len(a["frames"])
    _slide_arm(page, "plot-path", 0)
    moved = [t for t in _traces(page, "plot-path") if (t["meta"] or {}).get("role") == "arm-moving"]
    start_arm = _arm(page, "plot-path", "start")
    assert moved[0]["x"] == pytest.approx(start_arm["x"], abs=1e-12)  # slider at t = 0: the start

    # Joints view: one point per returned point, the limit lines, every joint.
    _view(page, "joints")
    _check_joint_plot(page, n, dof=6)
    _shot(page, "ur5-joints")

    # Downloads: a plot as PNG, the raw response as JSON.
    png = _download(page, "button.png[data-plot='plot-joints']", ".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    saved = _download(page, "#download-json", ".json")
    assert json.loads(saved.read_text())["joint_names"] == body["joint_names"]
    assert len(json.loads(saved.read_text())["points"]) == n
    assert _severe_console_errors(page) == []


def test_planar_line_through_the_hole_shows_the_failure(server: str, page: Any) -> None:
    _preset(page, "planar-hole")
    _click_and_wait(page, "c-plan")
    path, request = _last_request(page)
    status, problem = _post(server, path, request)
    assert status == 422 and problem["code"] == "unreachable", problem
    s = problem["s"]

    # The problem, as the service said it, and where on the line.
    box = page.find_element(By.ID, "problem")
    assert box.is_displayed()
    assert page.find_element(By.ID, "problem-code").text == "unreachable"
    assert page.find_element(By.ID, "problem-detail").text == problem["detail"]
    assert f"s = {s:.4g}" in page.find_element(By.ID, "problem-s").text
    assert "422" in page.find_element(By.ID, "status").text

    # Not a blank plot: the planned prefix (same request with allow_partial) and the failure at s.
    _, prefix = _post(server, path, {**request, "allow_partial": True})
    n = len(prefix["points"])
    assert prefix["diagnostics"]["fraction"] == pytest.approx(s, abs=0.02)
    path_traces = {t["name"]: t for t in _traces(page, "plot-path")}
    assert path_traces["tool path"]["type"] == "scatter"  # 2D for the planar arm
    assert path_traces["tool path"]["n"] == min(n, FK_SUBSAMPLE)
    assert any(name.startswith("✖ unreachable at s=") for name in path_traces)
    for plot in ("plot-deviation", "plot-sigma"):
        layout = _layout(page, plot)
        assert any(sh["x0"] == pytest.approx(s) for sh in layout["shapes"]), plot
        assert any(a["text"] == "✖ unreachable" for a in layout["annotations"]), plot
    deviation = {t["name"]: t for t in _traces(page, "plot-deviation")}
    assert deviation["position deviation"]["n"] == len(
        prefix["diagnostics"]["deviation_profile"]["s"]
    )
    assert "orientation deviation" not in deviation  # position_xy: x and y only
    _shot(page, "planar-hole-cartesian")
    _view(page, "joints")
    _check_joint_plot(page, n, dof=2)
    _shot(page, "planar-hole-joints")
    assert _severe_console_errors(page) == []


def test_spline_through_waypoints(server: str, page: Any) -> None:
    page.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='spline']").click()
    _click_and_wait(page, "s-plan")
    path, request = _last_request(page)
    assert path == "/v1/trajectories/spline"
    status, body = _post(server, path, request)
    assert status == 200, body
    dof = len(body["joint_names"])
    _check_joint_plot(page, len(body["points"]), dof, knots=len(request["waypoints"]))
    _shot(page, "spline-joints")


def test_compare_has_a_row_per_method(server: str, page: Any) -> None:
    _preset(page, "ur5-line")
    _click_and_wait(page, "c-compare")
    path, request = _last_request(page)
    assert path == "/v1/compare"
    assert set(request["methods"]) == {
        "sampled",
        "bounded_deviation",
        "bounded_deviation_nlp",
        "resolved_rate",
        "resolved_rate_dls",
    }
    status, body = _post(server, path, request)
    assert status == 200, body
    results = body["results"]

    rows = page.find_elements(By.CSS_SELECTOR, "#compare-table tbody tr[data-method]")
    assert [r.get_attribute("data-method") for r in rows] == [r["method"] for r in results]
    assert len(rows) == len(request["methods"])
    for row, result in zip(rows, results, strict=True):
        cell = row.find_elements(By.TAG_NAME, "td")[1].text
        assert ("ok" in cell) == result["ok"], (result["method"], cell)

    curves = [
        t
        for t in _traces(page, "plot-compare")
        if (t["meta"] or {}).get("role") != "tolerance" and t["yaxis"] == "y"
    ]
    with_profile = [r for r in results if (r.get("diagnostics") or {}).get("deviation_profile")]
    assert [t["name"] for t in curves] == [r["method"] for r in with_profile]
    for trace, result in zip(curves, with_profile, strict=True):
        assert trace["n"] == len(result["diagnostics"]["deviation_profile"]["s"])
    _shot(page, "compare")
    assert _severe_console_errors(page) == []


def test_joint_move_plots_jerk_as_differences_of_the_accelerations(server: str, page: Any) -> None:
    page.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='joint']").click()
    Select(page.find_element(By.ID, "j-profile")).select_by_value("trapezoidal")
    _click_and_wait(page, "j-plan")
    path, request = _last_request(page)
    assert path == "/v1/trajectories/joint" and "jerk" not in request["limits"]
    status, body = _post(server, path, request)
    assert status == 200, body
    _check_joint_plot(page, len(body["points"]), dof=6)
    t = np.array([p["time_from_start"] for p in body["points"]])
    acc = np.array([p["accelerations"] for p in body["points"]])
    expected = np.gradient(acc, t, axis=0, edge_order=1)  # central differences inside
    jerk = page.execute_script(
        """const gd = document.getElementById('plot-joints');
        return gd.data.filter((t) => t.meta && t.meta.quantity && t.meta.quantity.startsWith('jerk'))
          .map((t) => Array.from(t.y));"""
    )
    assert len(jerk) == 6
    got = np.array(jerk).T
    # Interior points: (a[i+1] - a[i-1]) / (t[i+1] - t[i-1]), as np.gradient on a uniform grid.
    np.testing.assert_allclose(got[1:-1], expected[1:-1], rtol=1e-9, atol=1e-9)
    assert np.abs(got).max() > 10  # the trapezoid's acceleration steps show as jerk spikes
    # The joint move also draws the tool path and the arm (Cartesian view).
    assert _arm(page, "plot-path", "start")["n"] >= 7

    # jerk_limited adds the jerk column, and only then limits.jerk is sent.
    Select(page.find_element(By.ID, "j-profile")).select_by_value("jerk_limited")
    assert page.find_element(By.ID, "j-jmax-0").is_displayed()
    _click_and_wait(page, "j-plan")
    _, request = _last_request(page)
    assert request["profile"] == "jerk_limited"
    assert len(request["limits"]["jerk"]) == 6 and all(v > 0 for v in request["limits"]["jerk"])
    status, body = _post(server, "/v1/trajectories/joint", request)
    if status == 200:  # a service with jerk_limited (issue 17): the jerk limits are drawn too
        traces = _traces(page, "plot-joints")
        jerk_limits = [
            t
            for t in traces
            if (t["meta"] or {}).get("role") == "limit" and t["meta"]["quantity"].startswith("jerk")
        ]
        assert len(jerk_limits) == 6 and {t["yaxis"] for t in jerk_limits} == {"y4"}
        assert "200" in page.find_element(By.ID, "status").text
    else:  # not there yet: the page shows the service's own answer
        assert status == 422 and page.find_element(By.ID, "problem-code").text == body["code"]
    assert _severe_console_errors(page) == []


def test_ik_lists_every_solution_and_one_becomes_the_goal(server: str, page: Any) -> None:
    _preset(page, "ur5-line")
    page.find_element(By.ID, "c-goal-pose").click()
    page.find_element(By.ID, "c-pose-from-goal").click()
    time.sleep(0.5)
    page.find_element(By.ID, "c-ik-all").click()
    WebDriverWait(page, 30).until(
        lambda d: d.execute_script("return document.getElementById('c-ik-count') !== null")
    )
    path, request = _last_request(page)
    assert path == "/v1/robots/ur5/ik" and request["all"] is True
    status, body = _post(server, path, request)
    assert status == 200, body
    labels = [s["configuration"] for s in body["solutions"]]
    assert len(labels) >= 2
    rows = page.find_elements(By.CSS_SELECTOR, "#c-ik-list .ik-row")
    assert [r.get_attribute("data-configuration") for r in rows] == labels
    WebDriverWait(page, 30).until(
        lambda d: (
            len([t for t in _traces(d, "plot-path") if (t["meta"] or {}).get("role") == "ik-ghost"])
            == len(labels)
        )
    )
    page.find_element(By.ID, "c-ik-use-1").click()
    time.sleep(0.3)
    goal = [float(page.find_element(By.ID, f"c-goal-{j}").get_attribute("value")) for j in range(6)]
    assert goal == pytest.approx(body["solutions"][1]["positions"], abs=1e-6)
    assert page.find_element(By.ID, "c-goal-joints").is_selected()


@pytest.mark.parametrize(
    ("preset", "robot", "blends"), [("ur5-weld", "ur5", 4), ("panda-pick", "panda", 2)]
)
def test_program_preset_runs_and_shows_its_segments(
    server: str, page: Any, preset: str, robot: str, blends: int
) -> None:
    page.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='program']").click()
    Select(page.find_element(By.ID, "p-preset")).select_by_value(preset)
    WebDriverWait(page, 15).until(
        lambda d: len(d.find_elements(By.CSS_SELECTOR, "#p-segments .segment")) == 5
    )
    _click_and_wait(page, "p-plan")
    path, request = _last_request(page)
    assert path == "/v1/trajectories/program" and request["robot"] == robot
    assert len(request["segments"]) == 5
    status, body = _post(server, path, request)
    assert status == 200, body
    segs = body["segments"]
    assert "200" in page.find_element(By.ID, "status").text

    # 3D: one trace per segment in its colour, a trace per blend, a sphere per blend radius.
    traces = _traces(page, "plot-program-path")
    role = lambda r: [t for t in traces if (t["meta"] or {}).get("role") == r]  # noqa: E731
    assert [t["meta"]["index"] for t in role("segment")] == [s["index"] for s in segs]
    assert len(role("blend")) == blends == sum("blend_out" in s for s in segs)
    spheres = role("blend-sphere")
    assert [t["meta"]["radius"] for t in spheres] == [
        s["blend_radius"] for s in request["segments"] if s.get("blend_radius")
    ]
    _, a = _post(
        server,
        f"/v1/robots/{robot}/fk",
        {"positions": request["start"]["positions"], "frames": True},
    )
    assert _arm(page, "plot-program-path", "start")["n"] == len(a["frames"])

    # Speeds: |q'| of every joint at every returned point; segment and blend windows shaded.
    speed = _traces(page, "plot-program-speed")
    joint = [t for t in speed if (t["meta"] or {}).get("role") == "joint-speed"]
    assert len(joint) == len(body["joint_names"])
    assert all(t["n"] == len(body["points"]) for t in joint)
    assert joint[0]["y"] == pytest.approx([abs(p["velocities"][0]) for p in body["points"][:5]])
    shapes = page.execute_script(
        """return document.getElementById('plot-program-speed').layout.shapes
          .map((s) => ({name: s.name, x0: s.x0, x1: s.x1}));"""
    )
    windows = {s["name"]: s for s in shapes}
    for seg in segs:
        w = windows[f"segment {seg['index'] + 1}"]
        assert (w["x0"], w["x1"]) == pytest.approx((seg["start_time"], seg["end_time"]))
        if "blend_out" in seg:
            b = windows[f"blend {seg['index'] + 1}"]
            assert (b["x0"], b["x1"]) == pytest.approx(
                (seg["blend_out"]["start_time"], seg["blend_out"]["end_time"])
            )
    rows = page.find_elements(By.CSS_SELECTOR, "#program-table tbody tr[data-segment]")
    assert len(rows) == len(segs)
    _shot(page, f"program-{preset}")
    if preset == "ur5-weld" and os.environ.get("PLAYGROUND_DOCS_SCREENSHOT") == "1":
        # The README's picture (docs/playground.png), only when asked for: the program view,
        # page and form scrolled to the top.
        page.execute_script(
            "window.scrollTo(0, 0); document.querySelector('.forms').scrollTop = 0;"
        )
        time.sleep(0.3)
        page.save_screenshot(str(DOCS / "playground.png"))
    assert _severe_console_errors(page) == []


def test_obstacles_are_drawn_and_sent_as_the_environment(server: str, page: Any) -> None:
    _preset(page, "ur5-line")
    page.find_element(By.ID, "env-add-sphere").click()
    page.find_element(By.ID, "env-add-box").click()
    radius = page.find_element(By.ID, "env-radius-0")
    radius.clear()
    radius.send_keys("0.07")
    page.find_element(By.ID, "env-clearance").click()  # blur: the change event
    _click_and_wait(page, "c-plan")
    _, request = _last_request(page)
    env = request["environment"]
    assert [o["name"] for o in env["obstacles"]] == ["sphere1", "box2"]
    assert env["obstacles"][0]["shape"] == {"type": "sphere", "radius": 0.07}
    assert env["obstacles"][1]["shape"] == {"type": "box", "size": [0.1, 0.1, 0.1]}
    drawn = [t for t in _traces(page, "plot-path") if (t["meta"] or {}).get("role") == "obstacle"]
    assert [t["meta"]["name"] for t in drawn] == ["sphere1", "box2"]
    # Removing every obstacle removes the environment from the requests again.
    for _ in range(2):
        page.find_element(By.CSS_SELECTOR, "#env-table tr[data-obstacle] button").click()
    _click_and_wait(page, "c-plan")
    assert "environment" not in _last_request(page)[1]
    assert not page.find_element(By.ID, "card-clearance").is_displayed()  # no environment: no plot


def test_program_editor_reorders_and_a_bad_blend_is_named(server: str, page: Any) -> None:
    page.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='program']").click()
    Select(page.find_element(By.ID, "p-preset")).select_by_value("ur5-weld")
    WebDriverWait(page, 15).until(
        lambda d: len(d.find_elements(By.CSS_SELECTOR, "#p-segments .segment")) == 5
    )
    x0 = float(page.find_element(By.ID, "p-seg-0-p0").get_attribute("value"))
    x1 = float(page.find_element(By.ID, "p-seg-1-p0").get_attribute("value"))
    # Move segment 2 up, remove the last, add a PTP: the request follows the editor.
    page.find_element(
        By.CSS_SELECTOR, "#p-segments .segment[data-segment='1'] button[title='move up']"
    ).click()
    page.find_element(By.ID, "p-seg-4-remove").click()
    page.find_element(By.ID, "p-add-ptp").click()
    WebDriverWait(page, 15).until(
        lambda d: len(d.find_elements(By.CSS_SELECTOR, "#p-segments .segment")) == 5
    )
    blend = page.find_element(By.ID, "p-seg-1-blend")
    blend.clear()
    blend.send_keys("0.5")
    page.find_element(By.ID, "p-period").click()  # blur: the change event
    _click_and_wait(page, "p-plan")
    path, request = _last_request(page)
    segs = request["segments"]
    assert [s["type"] for s in segs] == ["lin", "lin", "lin", "lin", "ptp"]
    assert segs[0]["goal"]["pose"]["position"][0] == pytest.approx(x1)
    assert segs[1]["goal"]["pose"]["position"][0] == pytest.approx(x0)
    assert segs[1]["blend_radius"] == 0.5
    assert "positions" in segs[4]["goal"] and "blend_radius" not in segs[4]
    status, problem = _post(server, path, request)
    assert status == 422 and problem["code"] == "validation", problem
    assert page.find_element(By.ID, "problem-code").text == "validation"
    locs = [e.text for e in page.find_elements(By.CSS_SELECTOR, "#problem ul.errors code")]
    assert "body.segments.1.blend_radius" in locs
    assert _severe_console_errors(page) == []


def _accepts_environment(server: str, path: str) -> bool:
    """Whether the served OpenAPI request schema of ``path`` has ``environment`` (API.md round 2)."""
    with urllib.request.urlopen(f"{server}/openapi.json", timeout=30) as r:
        doc = json.loads(r.read())
    ref = doc["paths"][path]["post"]["requestBody"]["content"]["application/json"]["schema"]
    schema = doc["components"]["schemas"][ref["$ref"].rsplit("/", 1)[-1]] if "$ref" in ref else ref
    return "environment" in schema.get("properties", {})


def test_a_collision_is_marked_where_it_happens(server: str, page: Any) -> None:
    if not _accepts_environment(server, "/v1/trajectories/cartesian"):
        pytest.skip("this service has no environment on /v1/trajectories/cartesian yet (issue 15)")
    _preset(page, "ur5-line")
    _click_and_wait(page, "c-plan")  # the new obstacle goes to the middle of this tool path
    page.find_element(By.ID, "env-add-sphere").click()
    _click_and_wait(page, "c-plan")
    path, request = _last_request(page)
    status, problem = _post(server, path, request)
    assert status == 422 and problem["code"] == "collision", problem
    assert page.find_element(By.ID, "problem-code").text == "collision"
    traces = _traces(page, "plot-path")
    contact = [t for t in traces if (t["meta"] or {}).get("role") == "collision"]
    assert len(contact) == 1
    assert contact[0]["meta"]["time_from_start"] == pytest.approx(problem["time_from_start"])
    assert contact[0]["meta"]["links"] == problem["links"]
    assert _arm(page, "plot-path", "contact")["n"] >= 7
    layout = _layout(page, "plot-deviation")
    assert any(sh["x0"] == pytest.approx(problem["s"]) for sh in layout["shapes"])

    # Lifted 1 m clear of the path: 200, and min_clearance in the summary.
    z = page.find_element(By.ID, "env-pos-0-2")
    lifted = float(z.get_attribute("value")) + 1.0
    z.clear()
    z.send_keys(str(lifted))
    page.find_element(By.ID, "env-clearance").click()
    _click_and_wait(page, "c-plan")
    path, request = _last_request(page)
    assert request["environment"]["obstacles"][0]["pose"]["position"][2] == pytest.approx(lifted)
    status, body = _post(server, path, request)
    assert status == 200, body
    clearance = body["diagnostics"]["min_clearance"]
    assert clearance > 0
    assert f"{clearance:.3g}"[:4] in page.find_element(By.ID, "summary").text
    # The clearance over time: the answer's clearance_profile, the requested clearance dashed.
    assert page.find_element(By.ID, "card-clearance").is_displayed()
    traces = {(t["meta"] or {}).get("role"): t for t in _traces(page, "plot-clearance")}
    prof = body["diagnostics"]["clearance_profile"]
    drawn = traces["clearance-profile"]
    assert drawn["n"] == len(prof["time_from_start"]) >= 2
    np.testing.assert_allclose(drawn["x"], prof["time_from_start"][:12], rtol=0, atol=1e-12)
    np.testing.assert_allclose(drawn["y"], prof["value"][:5], rtol=0, atol=1e-12)
    assert min(prof["value"]) >= clearance - 1e-9
    assert traces["clearance"]["y"] == [0, 0]
    assert (
        page.execute_script("return document.getElementById('plot-clearance').data[1].line.dash")
        == "dash"
    )


_GEOMETRY = [
    # API.md round 2: {"link", "shape", "origin": pose in the link frame}; injected below.
    {
        "link": "wrist_3_link",
        "shape": {"type": "sphere", "radius": 0.05},
        "origin": {"position": [0.0, 0.0, 0.02], "orientation": [0.0, 0.0, 0.0, 1.0]},
    },
    {
        "link": "forearm_link",
        "shape": {"type": "capsule", "radius": 0.04, "length": 0.3},
        "origin": {
            "position": [0.0, 0.0, 0.15],
            "orientation": [0.0, 0.7071067811865476, 0.0, 0.7071067811865476],
        },
    },
]


def _quat_matrix(q: list[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_collision_geometry_of_the_description_is_drawn_on_the_arm(server: str, page: Any) -> None:
    """A description with ``collision_geometry`` (injected into the page's GET, as the contract
    gives it) is drawn at the start: every wire point on its shape, placed by the /fk link frame."""
    page.execute_script(
        """const geo = arguments[0];
        const orig = window.fetch;
        window.fetch = async (url, init) => {
          const res = await orig(url, init);
          if (!String(url).endsWith('/v1/robots/ur5') || (init && init.method !== 'GET')) return res;
          const body = await res.json();
          body.collision_geometry = geo;
          return new Response(JSON.stringify(body), {status: 200,
            headers: {'content-type': 'application/json'}});
        };""",
        _GEOMETRY,
    )
    robot = Select(page.find_element(By.ID, "robot"))
    robot.select_by_value("panda")
    WebDriverWait(page, 15).until(lambda d: d.find_elements(By.ID, "c-start-6"))
    robot.select_by_value("ur5")
    WebDriverWait(page, 15).until(lambda d: not d.find_elements(By.ID, "c-start-6"))
    WebDriverWait(page, 15).until(lambda d: d.find_element(By.ID, "geometry-toggle").is_displayed())
    _click_and_wait(page, "c-plan")
    _, request = _last_request(page)
    _, a = _post(
        server, "/v1/robots/ur5/fk", {"positions": request["start"]["positions"], "frames": True}
    )
    frames = {f["name"]: f for f in a["frames"]}
    drawn = page.execute_script(
        """const gd = document.getElementById('plot-path');
        return gd.data.filter((t) => t.meta && t.meta.role === 'collision-geometry')
          .map((t) => ({shapes: t.meta.shapes, x: Array.from(t.x), y: Array.from(t.y),
            z: Array.from(t.z || t.y)}));"""
    )
    assert len(drawn) == 1 and drawn[0]["shapes"] == 2
    # Split at the null after each shape's wire: sphere first, then capsule.
    pts = [
        None if x is None else np.array([x, y, z])
        for x, y, z in zip(drawn[0]["x"], drawn[0]["y"], drawn[0]["z"], strict=True)
    ]
    placed = []
    for g in _GEOMETRY:
        f = frames[g["link"]]
        R = _quat_matrix(f["orientation"])
        centre = np.array(f["position"]) + R @ np.array(g["origin"]["position"])
        axis = R @ _quat_matrix(g["origin"]["orientation"]) @ np.array([0.0, 0.0, 1.0])
        placed.append((centre, axis))
    points = np.array([p for p in pts if p is not None])
    (c0, _), (c1, ax1) = placed
    on_sphere = np.abs(np.linalg.norm(points - c0, axis=1) - 0.05) < 1e-9
    # Distance of each point to the capsule's axis segment: 0.04 on its surface.
    t = np.clip((points - c1) @ ax1, -0.15, 0.15)
    on_capsule = np.abs(np.linalg.norm(points - (c1 + np.outer(t, ax1)), axis=1) - 0.04) < 1e-9
    assert np.all(on_sphere | on_capsule)
    assert on_sphere.sum() > 50 and on_capsule.sum() > 50


def _clearance_plot(page: Any, server: str, plot: str) -> None:
    """The last plan's clearance_profile is drawn in ``plot`` (times and values), with the requested
    clearance as a dashed line."""
    path, request = _last_request(page)
    status, body = _post(server, path, request)
    assert status == 200, body
    prof = body["diagnostics"]["clearance_profile"]
    times = [p["time_from_start"] for p in body["points"]]
    assert set(prof["time_from_start"]) <= set(times)
    traces = {(t["meta"] or {}).get("role"): t for t in _traces(page, plot)}
    assert traces["clearance-profile"]["n"] == len(prof["value"])
    np.testing.assert_allclose(traces["clearance-profile"]["x"], prof["time_from_start"][:12])
    np.testing.assert_allclose(traces["clearance-profile"]["y"], prof["value"][:5])
    c = request["environment"]["clearance"]
    assert traces["clearance"]["y"] == [c, c]


def test_joint_and_program_views_plot_the_clearance_over_time(server: str, page: Any) -> None:
    _preset(page, "ur5-line")
    _click_and_wait(page, "c-plan")
    page.find_element(By.ID, "env-add-sphere").click()
    z = page.find_element(By.ID, "env-pos-0-2")
    lifted = float(z.get_attribute("value")) + 1.0
    z.clear()
    z.send_keys(str(lifted))
    clearance = page.find_element(By.ID, "env-clearance")
    clearance.clear()
    clearance.send_keys("0.01")
    page.find_element(By.ID, "env-radius-0").click()  # blur: the change event
    page.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='joint']").click()
    _click_and_wait(page, "j-plan")
    assert page.find_element(By.ID, "card-joint-clearance").is_displayed()
    _clearance_plot(page, server, "plot-joint-clearance")
    page.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='program']").click()
    Select(page.find_element(By.ID, "p-preset")).select_by_value("ur5-weld")
    WebDriverWait(page, 15).until(
        lambda d: len(d.find_elements(By.CSS_SELECTOR, "#p-segments .segment")) == 5
    )
    _click_and_wait(page, "p-plan")
    assert page.find_element(By.ID, "card-program-clearance").is_displayed()
    _clearance_plot(page, server, "plot-program-clearance")
    assert _severe_console_errors(page) == []


def test_compare_plots_every_methods_clearance_over_time(server: str, page: Any) -> None:
    _preset(page, "ur5-line")
    page.find_element(By.ID, "env-add-sphere").click()
    z = page.find_element(By.ID, "env-pos-0-2")
    z.clear()
    z.send_keys(str(float(z.get_attribute("value") or 0.0) + 1.0))
    clearance = page.find_element(By.ID, "env-clearance")
    clearance.clear()
    clearance.send_keys("0.01")
    page.find_element(By.ID, "env-radius-0").click()  # blur: the change event
    _click_and_wait(page, "c-compare")
    path, request = _last_request(page)
    assert path == "/v1/compare" and request["task"]["environment"]["clearance"] == 0.01
    status, body = _post(server, path, request)
    assert status == 200, body
    assert page.find_element(By.ID, "card-compare-clearance").is_displayed()
    traces = _traces(page, "plot-compare-clearance")
    role = [(t["meta"] or {}).get("role") for t in traces]
    drawn = {
        t["meta"]["method"]: t
        for t, r in zip(traces, role, strict=True)
        if r == "clearance-profile"
    }
    planned = [r for r in body["results"] if r["ok"]]
    assert planned and sorted(drawn) == sorted(r["method"] for r in planned)
    for r in planned:
        prof = r["diagnostics"]["clearance_profile"]
        assert drawn[r["method"]]["n"] == len(prof["value"])
        np.testing.assert_allclose(drawn[r["method"]]["y"], prof["value"][:5])
    dashed = [t for t, r in zip(traces, role, strict=True) if r == "clearance"]
    assert len(dashed) == 1 and dashed[0]["y"] == [0.01, 0.01]
    assert _severe_console_errors(page) == []
