"""The playground's collision-free mode (issue 27), in headless Chromium against a live server: the
joint move form sends ``POST /v1/trajectories/collision_free`` with the work cell, and the page
draws what came back: the found waypoints (at the tool, with a faint arm at each), the motion's tool
path among the obstacles, the arm moving along it, every joint with the waypoints marked, the
clearance and the planner's figures. A program PTP with ``"planner": "collision_free"`` is tested
when the service's schema has that option (API.md round 3: another branch adds it). Skips, saying
why, when the service does not serve the endpoint.
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
    _arm,
    _click_and_wait,
    _last_request,
    _post,
    _severe_console_errors,
    _shot,
    _slide_arm,
    _traces,
)

try:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait
except ImportError:  # pragma: no cover - the test extra installs selenium (conftest skips)
    pass

pytestmark = [pytest.mark.browser, NEEDS_CHROMIUM]
PATH = "/v1/trajectories/collision_free"


def _openapi(server: str) -> dict[str, Any]:
    with urllib.request.urlopen(f"{server}/openapi.json", timeout=30) as r:
        return json.loads(r.read())


@pytest.fixture
def served(server: str) -> dict[str, Any]:
    doc = _openapi(server)
    if PATH not in doc["paths"]:
        pytest.skip(f"this service has no POST {PATH} (issue 27): the page hides the mode")
    return doc


def _joint_preset(driver: Any) -> None:
    driver.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='joint']").click()
    Select(driver.find_element(By.ID, "j-preset")).select_by_value("ur5-around-ball")
    WebDriverWait(driver, 15).until(lambda d: d.find_elements(By.ID, "env-pos-0-0"))
    time.sleep(0.3)


def test_the_joint_move_goes_around_the_ball(server: str, served: Any, page: Any) -> None:
    _joint_preset(page)
    assert page.find_element(By.ID, "j-collision-free").is_selected()
    _click_and_wait(page, "j-plan")
    path, request = _last_request(page)
    assert path == PATH
    ball = request["environment"]["obstacles"][0]
    assert ball["shape"] == {"type": "sphere", "radius": 0.05}
    assert request["environment"]["clearance"] == 0.02
    status, body = _post(server, path, request)
    assert status == 200, body
    waypoints = body["waypoints"]
    assert len(waypoints) >= 3  # not the straight segment: the ball is in its way
    assert "200" in page.find_element(By.ID, "status").text
    summary = page.find_element(By.ID, "summary").text
    assert "certified\nyes" in summary and body["diagnostics"]["planner"]["name"] in summary

    # The waypoints at the tool: one marker each, where the service's FK puts them.
    traces = _traces(page, "plot-path")
    drawn = [t for t in traces if (t["meta"] or {}).get("role") == "waypoints"]
    assert len(drawn) == 1 and drawn[0]["n"] == len(waypoints)
    _, fk = _post(server, "/v1/robots/ur5/fk", {"positions": waypoints, "frames": True})
    got = page.execute_script(
        """const t = document.getElementById('plot-path').data.find((d) => d.meta && d.meta.role === 'waypoints');
        return t.x.map((x, i) => [x, t.y[i], t.z[i]]);"""
    )
    expected = [r["pose"]["position"] for r in fk["results"]]
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    ghosts = [t for t in traces if (t["meta"] or {}).get("role") == "waypoint-arm"]
    assert len(ghosts) == len(waypoints) - 2
    assert [t["n"] for t in ghosts] == [len(r["frames"]) for r in fk["results"][1:-1]]
    assert [t["meta"]["name"] for t in traces if (t["meta"] or {}).get("role") == "obstacle"] == [
        ball["name"]
    ]

    # The arm moves along the motion: at the slider's start it is the start arm, and ▶ play ends
    # at the goal arm.
    moving = lambda: next(  # noqa: E731
        t for t in _traces(page, "plot-path") if (t["meta"] or {}).get("role") == "arm-moving"
    )
    _slide_arm(page, "plot-path", 0)
    assert moving()["x"] == pytest.approx(_arm(page, "plot-path", "start")["x"], abs=1e-12)
    page.find_element(By.CSS_SELECTOR, ".arm-bar[data-plot='plot-path'] .arm-play").click()
    WebDriverWait(page, 30).until(
        lambda d: d.execute_script(
            """const s = document.querySelector('.arm-bar[data-plot="plot-path"] .arm-slider');
            return s.value === s.max;"""
        )
    )
    time.sleep(0.3)
    assert moving()["x"] == pytest.approx(_arm(page, "plot-path", "goal")["x"], abs=1e-12)
    _shot(page, "collision-free-cartesian")

    # Every joint against time, the waypoints marked where the motion passes them.
    page.find_element(By.CSS_SELECTOR, "#view-tabs button[data-view='joints']").click()
    time.sleep(0.4)
    knots = [t for t in _traces(page, "plot-joints") if (t["meta"] or {}).get("role") == "knots"]
    assert len(knots) == 1 and knots[0]["n"] == len(waypoints) * 6
    marked = page.execute_script(
        """const t = document.getElementById('plot-joints').data.find((d) => d.meta && d.meta.role === 'knots');
        return {x: Array.from(t.x), y: Array.from(t.y)};"""
    )
    np.testing.assert_allclose(np.reshape(marked["y"], (-1, 6)), waypoints, atol=1e-12)
    times = np.array([p["time_from_start"] for p in body["points"]])
    assert set(np.round(marked["x"], 12)) <= set(np.round(times, 12))
    assert page.find_element(By.ID, "card-joint-clearance").is_displayed()
    prof = body["diagnostics"]["clearance_profile"]
    clearance = {(t["meta"] or {}).get("role"): t for t in _traces(page, "plot-joint-clearance")}
    assert clearance["clearance-profile"]["n"] == len(prof["value"])
    assert min(prof["value"]) >= 0.02 - 1e-9
    _shot(page, "collision-free-joints")
    assert _severe_console_errors(page) == []


def test_without_the_mode_the_straight_move_hits_the_ball(
    server: str, served: Any, page: Any
) -> None:
    """The same preset as a plain joint move: the service answers 422 collision, and the page
    marks the contact (what the collision-free mode avoids)."""
    _joint_preset(page)
    page.find_element(By.ID, "j-collision-free").click()
    assert page.find_element(By.ID, "j-profile").is_displayed()
    _click_and_wait(page, "j-plan")
    path, request = _last_request(page)
    assert path == "/v1/trajectories/joint"
    status, problem = _post(server, path, request)
    assert status == 422 and problem["code"] == "collision", problem
    assert page.find_element(By.ID, "problem-code").text == "collision"
    contact = [
        t for t in _traces(page, "plot-path") if (t["meta"] or {}).get("role") == "collision"
    ]
    assert len(contact) == 1 and contact[0]["meta"]["links"] == problem["links"]


def test_a_goal_in_collision_is_drawn_in_red(server: str, served: Any, page: Any) -> None:
    _joint_preset(page)
    # The ball moved onto the goal's tool point: the goal is in collision, nothing is planned.
    goal = [float(page.find_element(By.ID, f"j-goal-{j}").get_attribute("value")) for j in range(6)]
    _, fk = _post(server, "/v1/robots/ur5/fk", {"positions": goal})
    for c in range(3):
        field = page.find_element(By.ID, f"env-pos-0-{c}")
        field.clear()
        field.send_keys(str(fk["pose"]["position"][c]))
    page.find_element(By.ID, "env-clearance").click()  # blur: the change event
    _click_and_wait(page, "j-plan")
    path, request = _last_request(page)
    status, problem = _post(server, path, request)
    assert status == 422 and problem["code"] == "collision" and problem["at"] == "goal", problem
    assert page.find_element(By.ID, "problem-code").text == "collision"
    goal_arm = _arm(page, "plot-path", "goal")
    assert goal_arm["meta"]["collides"] is True
    assert _arm(page, "plot-path", "start")["meta"]["collides"] is False


def _ptp_has_planner(doc: dict[str, Any]) -> bool:
    schemas = doc["components"]["schemas"]
    return "planner" in schemas.get("PtpSegment", {}).get("properties", {})


def test_a_program_ptp_can_be_collision_free(server: str, served: Any, page: Any) -> None:
    if not _ptp_has_planner(served):
        pytest.skip('this service\'s program PTP has no "planner" yet (API.md round 3)')
    _joint_preset(page)  # the work cell: the ball
    page.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='program']").click()
    goal = [1.2, -1.3, 1.9, -2.2, -1.4, 0.4]
    page.find_element(By.ID, "p-add-ptp").click()
    WebDriverWait(page, 15).until(lambda d: d.find_elements(By.ID, "p-seg-0-q-0"))
    for j, v in enumerate(goal):
        field = page.find_element(By.ID, f"p-seg-0-q-{j}")
        field.clear()
        field.send_keys(str(v))
    Select(page.find_element(By.ID, "p-seg-0-planner")).select_by_value("collision_free")
    page.find_element(By.ID, "p-period").click()  # blur: the change event
    _click_and_wait(page, "p-plan")
    path, request = _last_request(page)
    assert request["segments"][0]["planner"] == "collision_free"
    assert request["segments"][0]["goal"]["positions"] == pytest.approx(goal)
    status, body = _post(server, path, request)
    assert status == 200, body
    assert "200" in page.find_element(By.ID, "status").text
    segment = body["segments"][0]
    found = segment.get("waypoints") or (segment.get("diagnostics") or {}).get("waypoints")
    if found:
        drawn = [
            t
            for t in _traces(page, "plot-program-path")
            if (t["meta"] or {}).get("role") == "waypoints"
        ]
        assert len(drawn) == 1 and drawn[0]["n"] == len(found)
    assert _severe_console_errors(page) == []


_INJECT_PLANNER = """
(() => {
  const orig = window.fetch;
  window.fetch = async (url, init) => {
    const res = await orig(url, init);
    if (!String(url).endsWith('/openapi.json')) return res;
    const doc = await res.json();
    const s = doc.components.schemas;
    s.PtpSegment.properties.planner = s.PtpSegment.properties.planner ||
      {anyOf: [{type: 'string', enum: ['collision_free']}, {type: 'null'}], default: null};
    s.ProgramRequest.properties.seed = s.ProgramRequest.properties.seed ||
      {type: 'integer', minimum: 0, default: 0};
    return new Response(JSON.stringify(doc), {status: 200,
      headers: {'content-type': 'application/json'}});
  };
})();
"""


def test_the_ptp_planner_option_follows_the_schema(server: str, browser: Any) -> None:
    """A PTP ``planner`` and a program ``seed`` in the schema (as API.md's contract has them) are
    offered and sent; a service without them names the field (422), one with them plans."""
    script = browser.execute_cdp_cmd(
        "Page.addScriptToEvaluateOnNewDocument", {"source": _INJECT_PLANNER}
    )
    try:
        browser.get(f"{server}/")
        WebDriverWait(browser, 30).until(
            lambda d: d.execute_script("return document.body.dataset.state") == "ready"
        )
        browser.find_element(By.CSS_SELECTOR, "#form-tabs button[data-tab='program']").click()
        assert browser.find_element(By.ID, "p-seed-box").is_displayed()
        browser.find_element(By.ID, "p-add-ptp").click()
        WebDriverWait(browser, 15).until(lambda d: d.find_elements(By.ID, "p-seg-0-planner"))
        Select(browser.find_element(By.ID, "p-seg-0-planner")).select_by_value("collision_free")
        seed = browser.find_element(By.ID, "p-seed")
        seed.send_keys("3")
        browser.find_element(By.ID, "p-period").click()  # blur: the change event
        _click_and_wait(browser, "p-plan")
        path, request = _last_request(browser)
        assert request["segments"][0]["planner"] == "collision_free" and request["seed"] == 3
        status, answer = _post(server, path, request)
        if _ptp_has_planner(_openapi(server)):
            assert status == 200, answer
        else:
            assert status == 422 and answer["code"] == "validation", answer
            locs = [
                e.text for e in browser.find_elements(By.CSS_SELECTOR, "#problem ul.errors code")
            ]
            assert "body.segments.0.planner" in locs or "body.seed" in locs, locs
    finally:
        browser.execute_cdp_cmd(
            "Page.removeScriptToEvaluateOnNewDocument", {"identifier": script["identifier"]}
        )
