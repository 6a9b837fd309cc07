"""The playground as ES modules, in headless Chromium against a live server (round 3, issues 23 and
28): the requests a program preset costs (counted with the Performance API), the lists read from
``/openapi.json`` (a schema entry the page was never told about appears in it), "zoom to the path"
with the collision geometry shown, the planar preset's elbow label against the service's IK, and a
``circ`` path drawn on its circle.
"""

from __future__ import annotations

import json
import time
import urllib.request
from typing import Any

import numpy as np
import pytest

from tests.browser.chromium import NEEDS_CHROMIUM
from tests.browser.test_playground_browser import (
    _STATE,
    _arm,
    _click_and_wait,
    _last_request,
    _post,
    _preset,
    _severe_console_errors,
    _traces,
)

try:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait
except ImportError:  # pragma: no cover - the test extra installs selenium (conftest skips)
    pass

pytestmark = [pytest.mark.browser, NEEDS_CHROMIUM]

_RESOURCES = """return performance.getEntriesByType('resource')
  .map((e) => new URL(e.name).pathname)
  .filter((p) => p.startsWith('/v1/') || p === '/openapi.json');"""


def _openapi(server: str) -> dict[str, Any]:
    with urllib.request.urlopen(f"{server}/openapi.json", timeout=30) as r:
        return json.loads(r.read())


def _request_schema(doc: dict[str, Any], path: str) -> str:
    """The component name of ``POST path``'s request body."""
    ref = doc["paths"][path]["post"]["requestBody"]["content"]["application/json"]["schema"]
    return ref["$ref"].rsplit("/", 1)[-1]


def _options(driver: Any, select_id: str) -> list[str]:
    return driver.execute_script(
        "return Array.from(document.getElementById(arguments[0]).options).map((o) => o.value)",
        select_id,
    )


def _program_preset(driver: Any, preset: str) -> None:
    driver.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='program']").click()
    Select(driver.find_element(By.ID, "p-preset")).select_by_value(preset)
    WebDriverWait(driver, 15).until(
        lambda d: len(d.find_elements(By.CSS_SELECTOR, "#p-segments .segment")) >= 3
    )


@pytest.mark.parametrize(("preset", "robot"), [("ur5-weld", "ur5"), ("panda-pick", "panda")])
def test_a_program_preset_costs_at_most_three_requests_besides_the_plan(
    server: str, page: Any, preset: str, robot: str
) -> None:
    """Picking the preset and running it: the plan, and at most 3 other requests (the robot's
    description when it changes, one FK request for the preset's start and the form, one for every
    drawn tool point, joint goal and waypoint). Before the modules: 207 for the weld seam."""
    page.execute_script(
        "performance.setResourceTimingBufferSize(10000); performance.clearResourceTimings();"
    )
    _program_preset(page, preset)
    _click_and_wait(page, "p-plan")
    requests = page.execute_script(_RESOURCES)
    plans = [p for p in requests if p == "/v1/trajectories/program"]
    others = [p for p in requests if p != "/v1/trajectories/program"]
    assert len(plans) == 1, requests
    assert len(others) <= 3, others
    assert sum(p == f"/v1/robots/{robot}/fk" for p in others) <= 2, others
    # ... and the whole picture is there: every segment drawn, the arm at the start.
    path, request = _last_request(page)
    status, body = _post(server, path, request)
    assert status == 200, body
    traces = _traces(page, "plot-program-path")
    drawn = [t["meta"]["index"] for t in traces if (t["meta"] or {}).get("role") == "segment"]
    assert drawn == [s["index"] for s in body["segments"]]
    _, a = _post(server, f"/v1/robots/{robot}/fk", {"positions": request["start"]["positions"]})
    start = _arm(page, "plot-program-path", "start")
    assert start["meta"]["configuration"] == a["configuration"]
    assert _severe_console_errors(page) == []


def test_a_cartesian_plan_draws_its_tool_path_from_one_fk_request(server: str, page: Any) -> None:
    _preset(page, "ur5-line")
    page.execute_script("performance.clearResourceTimings();")
    _click_and_wait(page, "c-plan")
    requests = page.execute_script(_RESOURCES)
    assert requests == ["/v1/trajectories/cartesian", "/v1/robots/ur5/fk"], requests
    path, request = _last_request(page)
    _, body = _post(server, path, request)
    tool = {t["name"]: t for t in _traces(page, "plot-path")}["tool path"]
    xs = page.execute_script(
        """const t = document.getElementById('plot-path').data.find((d) => d.name === 'tool path');
        return Array.from(t.x);"""
    )
    assert tool["n"] == len(xs) == min(len(body["points"]), 100)
    rows = [body["points"][0]["positions"], body["points"][-1]["positions"]]
    _, fk = _post(server, "/v1/robots/ur5/fk", {"positions": rows})
    assert xs[0] == pytest.approx(fk["results"][0]["pose"]["position"][0], abs=1e-12)
    assert xs[-1] == pytest.approx(fk["results"][1]["pose"]["position"][0], abs=1e-12)


def test_the_lists_are_the_services_own(server: str, page: Any) -> None:
    doc = _openapi(server)
    schemas = doc["components"]["schemas"]
    cartesian = schemas[_request_schema(doc, "/v1/trajectories/cartesian")]["properties"]
    joint = schemas[_request_schema(doc, "/v1/trajectories/joint")]["properties"]
    spline = schemas[_request_schema(doc, "/v1/trajectories/spline")]["properties"]
    assert _options(page, "c-method") == cartesian["method"]["enum"]
    boxes = page.find_elements(By.CSS_SELECTOR, "input[name='c-compare-method']")
    assert [b.get_attribute("value") for b in boxes] == cartesian["method"]["enum"]
    assert _options(page, "c-speed-profile") == cartesian["speed_profile"]["enum"]
    shape = schemas[cartesian["path"]["$ref"].rsplit("/", 1)[-1]]["properties"]["type"]
    assert _options(page, "c-path") == shape["enum"]
    assert _options(page, "j-profile") == joint["profile"]["enum"]
    assert _options(page, "s-boundary") == spline["boundary"]["enum"]
    types = page.execute_script(
        """return import('/static/js/program_form.js').then((m) => m.segmentTypes());"""
    )
    program = schemas[_request_schema(doc, "/v1/trajectories/program")]["properties"]
    assert sorted(types) == sorted(program["segments"]["items"]["discriminator"]["mapping"])


_INJECT = """
(() => {
  const orig = window.fetch;
  window.fetch = async (url, init) => {
    const res = await orig(url, init);
    if (!String(url).endsWith('/openapi.json')) return res;
    const doc = await res.json();
    const props = (name) => doc.components.schemas[name].properties;
    props(%(cartesian)s).method.enum.push('throwaway_method');
    props(%(joint)s).profile.enum.push('throwaway_profile');
    delete doc.paths['/v1/trajectories/collision_free'];
    return new Response(JSON.stringify(doc), {status: 200,
      headers: {'content-type': 'application/json'}});
  };
})();
"""


def test_a_new_schema_entry_appears_and_a_missing_endpoint_hides_its_mode(
    server: str, browser: Any
) -> None:
    """The page's lists follow ``/openapi.json``: a method and a profile it never saw are offered,
    and without ``POST /v1/trajectories/collision_free`` the collision-free mode is hidden."""
    doc = _openapi(server)
    names = {
        "cartesian": json.dumps(_request_schema(doc, "/v1/trajectories/cartesian")),
        "joint": json.dumps(_request_schema(doc, "/v1/trajectories/joint")),
    }
    script = browser.execute_cdp_cmd(
        "Page.addScriptToEvaluateOnNewDocument", {"source": _INJECT % names}
    )
    try:
        browser.get(f"{server}/")
        WebDriverWait(browser, 30).until(lambda d: d.execute_script(_STATE) == "ready")
        assert "throwaway_method" in _options(browser, "c-method")
        boxes = browser.find_elements(By.CSS_SELECTOR, "input[name='c-compare-method']")
        assert "throwaway_method" in [b.get_attribute("value") for b in boxes]
        assert "throwaway_profile" in _options(browser, "j-profile")
        browser.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='joint']").click()
        assert not browser.find_element(By.ID, "j-cf-row").is_displayed()
        # The page sends what it offers; the service (which has no such method) names the field.
        Select(browser.find_element(By.ID, "j-profile")).select_by_value("throwaway_profile")
        _click_and_wait(browser, "j-plan")
        assert browser.find_element(By.ID, "problem-code").text == "validation"
        assert "body.profile" in [
            e.text for e in browser.find_elements(By.CSS_SELECTOR, "#problem ul.errors code")
        ]
    finally:
        browser.execute_cdp_cmd(
            "Page.removeScriptToEvaluateOnNewDocument", {"identifier": script["identifier"]}
        )


def _scene_ranges(driver: Any, plot: str) -> np.ndarray | None:
    ranges = driver.execute_script(
        """const s = (document.getElementById(arguments[0]).layout || {}).scene;
        return s ? [s.xaxis.range, s.yaxis.range, s.zaxis.range] : null;""",
        plot,
    )
    return None if ranges is None else np.array(ranges, dtype=float)


def _points(driver: Any, plot: str, roles: tuple[str, ...]) -> np.ndarray:
    pts = driver.execute_script(
        """const gd = document.getElementById(arguments[0]);
        const out = [];
        gd.data.filter((t) => t.meta && arguments[1].includes(t.meta.role)).forEach((t) => {
          for (let i = 0; i < t.x.length; i++) {
            if (t.x[i] !== null) out.push([t.x[i], t.y[i], t.z[i]]);
          }
        });
        return out;""",
        plot,
        list(roles),
    )
    return np.array(pts, dtype=float)


def test_zoom_to_the_path_leaves_the_collision_geometry_out(server: str, page: Any) -> None:
    """Issue 28: with the robot's collision geometry shown, "zoom to the path" still scales the
    view to the path (segments, blends, spheres, goals); unticked, the view holds the geometry."""
    _program_preset(page, "ur5-weld")
    _click_and_wait(page, "p-plan")
    if _scene_ranges(page, "plot-program-path") is None:
        pytest.skip("no WebGL: the program path is drawn as flat views")
    assert page.find_element(By.ID, "p-show-geometry").is_selected()
    geometry = _points(page, "plot-program-path", ("collision-geometry",))
    assert len(geometry) > 100, "the UR5's collision geometry is drawn"
    path = _points(page, "plot-program-path", ("segment", "blend", "blend-sphere", "goals"))
    zoomed = _scene_ranges(page, "plot-program-path")
    assert np.all(zoomed[:, 0] <= path.min(axis=0)) and np.all(zoomed[:, 1] >= path.max(axis=0))
    span = zoomed[:, 1] - zoomed[:, 0]
    assert span.max() < 0.6 * np.ptp(geometry, axis=0).max(), (span, np.ptp(geometry, axis=0))
    page.find_element(By.ID, "p-focus").click()
    time.sleep(0.5)
    whole = _scene_ranges(page, "plot-program-path")
    assert np.all(whole[:, 0] <= geometry.min(axis=0) + 1e-9)
    assert np.all(whole[:, 1] >= geometry.max(axis=0) - 1e-9)
    # Hiding the geometry does not change the zoomed view.
    page.find_element(By.ID, "p-focus").click()
    page.find_element(By.ID, "p-show-geometry").click()
    time.sleep(0.5)
    assert len(_points(page, "plot-program-path", ("collision-geometry",))) == 0
    np.testing.assert_allclose(_scene_ranges(page, "plot-program-path"), zoomed, atol=1e-12)


@pytest.mark.parametrize("label", ["down", "up"])
def test_the_planar_elbow_is_named_as_the_service_names_it(
    server: str, page: Any, label: str
) -> None:
    """The page's planar joints for a label equal the service's IK solution with that label."""
    q = page.execute_async_script(
        """const done = arguments[arguments.length - 1];
        import('/static/js/presets.js').then((m) => done(m.planarJoints(1.2, 0.5, arguments[0])));""",
        label,
    )
    body = {
        "pose": {"position": [1.2, 0.5, 0], "orientation": [0, 0, 0, 1]},
        "configuration": label,
    }
    status, ik = _post(server, "/v1/robots/planar_2r/ik", body)
    assert status == 200, ik
    assert q == pytest.approx(ik["positions"], abs=1e-12)


def test_the_planar_preset_says_which_elbow_it_starts_with(server: str, page: Any) -> None:
    _preset(page, "planar-hole")
    text = Select(page.find_element(By.ID, "c-preset")).first_selected_option.text
    _click_and_wait(page, "c-plan")
    _, request = _last_request(page)
    _, a = _post(server, "/v1/robots/planar_2r/fk", {"positions": request["start"]["positions"]})
    assert f"(elbow {a['configuration']})" in text
    assert _arm(page, "plot-path", "start")["meta"]["configuration"] == a["configuration"]


def test_an_arc_is_drawn_on_its_circle(server: str, page: Any) -> None:
    """Path shape ``circ`` through an interim point (docs/api.md's UR5 arc): the request carries
    it, the ideal arc passes through FK(start), the interim point and the goal, and every drawn
    tool point lies on that circle within the tolerance."""
    _preset(page, "ur5-line")
    page.find_element(By.ID, "c-goal-pose").click()
    goal = {"position": [-0.5775, 0.0109, 0.1785], "orientation": [0.7071, 0.7071, 0.0004, 0.0002]}
    interim = [-0.5775, -0.0691, 0.1785]
    page.execute_script(
        """const [p, q, via] = arguments;
        ['c-px', 'c-py', 'c-pz'].forEach((id, i) => { document.getElementById(id).value = p[i]; });
        ['c-qx', 'c-qy', 'c-qz', 'c-qw'].forEach((id, i) => { document.getElementById(id).value = q[i]; });
        const path = document.getElementById('c-path');
        path.value = 'circ'; path.dispatchEvent(new Event('change'));
        setTimeout(() => via.forEach((v, i) => { document.getElementById(`c-via-${i}`).value = v; }), 300);""",
        goal["position"],
        goal["orientation"],
        interim,
    )
    time.sleep(0.8)
    _click_and_wait(page, "c-plan")
    path, request = _last_request(page)
    assert request["path"] == {"type": "circ", "interim": interim}
    status, body = _post(server, path, request)
    assert status == 200, body
    traces = page.execute_script(
        """const t = document.getElementById('plot-path').data.filter((d) => d.name === arguments[0]);
        return t.map((d) => d.x.map((x, i) => [x, d.y[i], d.z[i]]));""",
        "ideal arc",
    )
    assert len(traces) == 1
    arc = np.array(traces[0])
    _, start = _post(server, "/v1/robots/ur5/fk", {"positions": request["start"]["positions"]})
    np.testing.assert_allclose(arc[0], start["pose"]["position"], atol=1e-9)
    np.testing.assert_allclose(arc[-1], goal["position"], atol=1e-9)
    assert np.min(np.linalg.norm(arc - interim, axis=1)) < 0.01  # 61 points on a 0.17 m arc
    # The circle through the three points: every drawn point and every tool point on it.
    p0, p1, p2 = np.array(start["pose"]["position"]), np.array(interim), np.array(goal["position"])
    a, b = p1 - p0, p2 - p0
    n = np.cross(a, b)
    centre = p0 + (np.dot(b, b) * np.cross(n, a) + np.dot(a, a) * np.cross(b, n)) / (2 * n @ n)
    radius = np.linalg.norm(p0 - centre)
    np.testing.assert_allclose(np.linalg.norm(arc - centre, axis=1), radius, atol=1e-9)
    tool = np.array(
        page.execute_script(
            """const t = document.getElementById('plot-path').data.find((d) => d.name === 'tool path');
            return t.x.map((x, i) => [x, t.y[i], t.z[i]]);"""
        )
    )
    assert np.abs(np.linalg.norm(tool - centre, axis=1) - radius).max() < 1e-3
    assert _severe_console_errors(page) == []
