"""Where Chromium and its driver are, and how the browser tests start it (``conftest.py``)."""

from __future__ import annotations

import shutil

import pytest

try:
    from selenium import webdriver
except ImportError:  # pragma: no cover - the test extra installs selenium
    webdriver = None  # type: ignore[assignment]

CHROMIUM = next(
    (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)),
    None,
)
CHROMEDRIVER = shutil.which("chromedriver")

NEEDS_CHROMIUM = pytest.mark.skipif(
    webdriver is None or CHROMIUM is None or CHROMEDRIVER is None,
    reason="needs selenium and Debian's chromium + chromium-driver "
    "(apt-get install chromium chromium-driver; .ci/run installs them)",
)
CHROME_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1600,1200",
    # Software WebGL for the 3D tool path (the page falls back to 2D views without WebGL).
    "--enable-unsafe-swiftshader",
]
