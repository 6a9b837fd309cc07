"""The client's tests talk to a live service: ``python -m service`` on a free loopback port, started
once for the session (``bench.harness.server``). The client package lives in ``client/`` (its own
distribution); the tests import it from there, as ``pip install ./client`` would."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
if str(REPO / "client") not in sys.path:
    sys.path.insert(0, str(REPO / "client"))


@pytest.fixture(scope="session")
def service_url() -> Iterator[str]:
    from bench.harness import server

    with server(1) as live:
        yield live.url
