"""Every Python example of ``client/README.md`` runs against a live service (its address put in
place of the README's ``http://127.0.0.1:8000``), so the client's documentation cannot rot."""

from __future__ import annotations

import contextlib
import io
import re

import pytest

from tests.client.conftest import REPO

README = REPO / "client" / "README.md"
EXAMPLES = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)


def test_the_readme_has_examples() -> None:
    assert len(EXAMPLES) >= 5


@pytest.mark.parametrize("index", range(len(EXAMPLES)))
def test_each_readme_example_runs(service_url: str, index: int) -> None:
    code = EXAMPLES[index].replace("http://127.0.0.1:8000", service_url)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, f"client/README.md example {index}", "exec"), {})
    assert out.getvalue().strip(), "every example prints what it shows"
