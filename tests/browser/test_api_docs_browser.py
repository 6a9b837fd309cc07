"""``/docs`` (Swagger UI) and ``/redoc`` (ReDoc) render in headless Chromium with nothing but the
service: every operation of ``/openapi.json`` appears on the page, and every resource the page
loaded came from the service's own origin (the machines running this have no internet, so a CDN
asset would fail to load; the origin check says so even where one could). The playground's
"API docs" link leads to the rendered Swagger UI. Screenshots go to ``artifacts/``.
"""

from __future__ import annotations

import json
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from tests.browser.chromium import NEEDS_CHROMIUM

try:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait
except ImportError:  # pragma: no cover - the test extra installs selenium (skipped then)
    pass

pytestmark = [pytest.mark.browser, NEEDS_CHROMIUM]
ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts"
RENDER_TIMEOUT_S = 60.0
RESOURCES = "return performance.getEntriesByType('resource').map(e => e.name)"
KNOWN_BLOCKED = ("https://cdn.redoc.ly/redoc/logo-mini.svg",)
"""What a page asks of another host and the Content-Security-Policy blocks: ReDoc's footer logo
(ReDoc hides the image when it does not load)."""


def _operations(server: str) -> list[dict[str, Any]]:
    with urllib.request.urlopen(f"{server}/openapi.json", timeout=30) as r:
        schema = json.loads(r.read())
    return [op for ops in schema["paths"].values() for op in ops.values()]


def _same_origin_only(driver: Any, server: str) -> None:
    """Every resource loaded came from ``server``; the console reports no error (a script the
    policy refused, an asset that failed) beyond ``KNOWN_BLOCKED``."""
    loaded = driver.execute_script(RESOURCES)
    assert loaded, "the page loaded no resource at all"
    foreign = [url for url in loaded if not url.startswith(server + "/")]
    assert set(foreign) <= set(KNOWN_BLOCKED), f"resources from elsewhere: {foreign}"
    log = driver.get_log("browser")
    for url in foreign:  # asked for, and refused by the policy: never sent
        assert any("Content Security Policy" in e["message"] and url in e["message"] for e in log)
    errors = [
        e["message"]
        for e in log
        if e["level"] == "SEVERE" and not any(url in e["message"] for url in KNOWN_BLOCKED)
    ]
    assert not errors, errors


def test_swagger_ui_renders_every_operation_offline(server: str, browser: Any) -> None:
    operations = _operations(server)
    browser.get(f"{server}/docs")
    WebDriverWait(browser, RENDER_TIMEOUT_S).until(
        lambda d: len(d.find_elements(By.CSS_SELECTOR, ".opblock")) >= len(operations)
    )
    blocks = browser.find_elements(By.CSS_SELECTOR, ".opblock")
    shown = {b.get_attribute("id") for b in blocks}
    for op in operations:  # Swagger UI ids each block "operations-<tag>-<operationId>"
        assert any(i.endswith("-" + op["operationId"]) for i in shown), op["operationId"]
    title = browser.find_element(By.CSS_SELECTOR, ".info .title").text
    assert "Trajectory Service" in title
    _same_origin_only(browser, server)
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "api-docs-swagger.png"))


def test_redoc_renders_every_operation_offline(server: str, browser: Any) -> None:
    operations = _operations(server)
    browser.get(f"{server}/redoc")
    WebDriverWait(browser, RENDER_TIMEOUT_S).until(
        lambda d: (
            len(d.find_elements(By.CSS_SELECTOR, "[data-section-id^='operation/']"))
            >= len(operations)
        )
    )
    sections = browser.find_elements(By.CSS_SELECTOR, "[data-section-id^='operation/']")
    ids = {s.get_attribute("data-section-id") for s in sections}
    for op in operations:  # ReDoc's section of an operation: "operation/<operationId>"
        assert f"operation/{op['operationId']}" in ids, op["operationId"]
    _same_origin_only(browser, server)
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "api-docs-redoc.png"))


def test_the_playground_links_the_rendered_docs(server: str, browser: Any) -> None:
    browser.get(f"{server}/")
    link = browser.find_element(By.XPATH, "//a[contains(., 'API docs')]")
    assert link.get_attribute("href") == f"{server}/docs"
    browser.get(link.get_attribute("href"))
    WebDriverWait(browser, RENDER_TIMEOUT_S).until(
        lambda d: d.find_elements(By.CSS_SELECTOR, ".opblock")
    )
