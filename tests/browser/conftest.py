"""Headless Chromium for the browser tests (Debian's ``chromium`` and ``chromium-driver``, driven
by selenium) and the live service it opens (``tests/live_service.py``). Every module here sets
``pytestmark = [pytest.mark.browser, NEEDS_CHROMIUM]``: deselected by default, run by
``pytest -m browser`` and ``.ci/run``; without the browser the tests skip and say why."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.browser.chromium import CHROME_FLAGS, CHROMEDRIVER, CHROMIUM, webdriver
from tests.live_service import live_service

try:
    from selenium.webdriver.support.ui import WebDriverWait
except ImportError:  # pragma: no cover - the test extra installs selenium (NEEDS_CHROMIUM skips)
    pass


@pytest.fixture(scope="module")
def server() -> Iterator[str]:
    """``python -m service`` on a free loopback port; always terminated."""
    try:
        with live_service() as url:
            yield url
    except RuntimeError as e:  # pragma: no cover - a broken checkout
        pytest.fail(str(e))


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """Chromium with its own profile, downloads into ``driver.downloads``, console logs kept."""
    assert CHROMIUM is not None and CHROMEDRIVER is not None  # else NEEDS_CHROMIUM skipped
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in CHROME_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}")
    downloads = tmp_path_factory.mktemp("downloads")
    options.add_experimental_option(
        "prefs",
        {"download.default_directory": str(downloads), "download.prompt_for_download": False},
    )
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(
        service=webdriver.ChromeService(executable_path=CHROMEDRIVER), options=options
    )
    driver.set_page_load_timeout(30)
    driver.downloads = downloads  # type: ignore[attr-defined]
    try:
        yield driver
    finally:
        driver.quit()


@pytest.fixture
def page(server: str, browser: Any) -> Any:
    """The playground, freshly loaded: schema read, robots listed and forms built."""
    browser.get(f"{server}/")
    WebDriverWait(browser, 30).until(
        lambda d: d.execute_script("return document.body.dataset.state") == "ready"
    )
    return browser
