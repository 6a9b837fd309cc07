"""The benchmark suite's machinery (``bench.harness``, ``bench.__main__``): fast checks only. The
suite itself runs in CI as ``python -m bench --quick`` (``.ci/run``), which fails on errors only."""

from __future__ import annotations

import numpy as np
import pytest

from bench.__main__ import BEGIN, END, main, write_results
from bench.harness import Budget, Row, Table, measure, optional

TINY = Budget(rounds=2, batch_s=0.001, table_s=1.0, min_rounds=1)


def test_measure_alternates_rows_and_reports_ratios() -> None:
    calls: list[str] = []
    table = Table(
        "PX",
        "test",
        "a",
        [
            Row("a", lambda: calls.append("a")),
            Row("b", lambda: calls.append("b")),
            Row("missing", unavailable="unavailable (not installed)", peer=True),
        ],
    )
    measure(table, TINY)
    assert calls[0] == "a" and "b" in calls  # the warm-up calls, then the rounds
    assert all(r.times.size > 0 for r in table.rows[:2])
    text = "\n".join(table.markdown())
    assert "| **a** |" in text and "1.00x" in text and "unavailable (not installed)" in text
    assert table.errors == []


def test_a_peer_that_raises_is_reported_and_ours_raises() -> None:
    def boom() -> None:
        raise ValueError("broken")

    table = Table("PX", "test", "a", [Row("a", lambda: None), Row("peer", boom, peer=True)])
    measure(table, TINY)
    assert table.errors == ["PX peer: ValueError: broken"]
    with pytest.raises(ValueError):
        measure(Table("PX", "test", "ours", [Row("ours", boom)]), TINY)


def test_optional_names_a_missing_module() -> None:
    assert optional("numpy") == ""
    assert optional("no_such_module_here").startswith("unavailable (")


def test_results_keep_every_hand_written_section(tmp_path) -> None:
    path = tmp_path / "RESULTS.md"
    path.write_text("# Benchmark results\n\n## Analysis\ntext\n\n## Reliability\nkept\n")
    write_results(path, "first run")
    write_results(path, "second run")
    text = path.read_text()
    assert text.count(BEGIN) == 1 and text.count(END) == 1
    assert "second run" in text and "first run" not in text
    assert "## Analysis\ntext" in text and "## Reliability\nkept" in text


def test_cli_rejects_unknown_tasks() -> None:
    with pytest.raises(SystemExit):
        main(["--only", "P9", "--no-write"])


def test_p1_rows_agree_before_timing() -> None:
    from bench.joint import Q0, Q1, quintic_reference
    from core.joint.point_to_point import PointToPoint, plan_joint

    _, q, qd, qdd = quintic_reference(Q0, Q1, 2.0, 101)
    tr = plan_joint("quintic", PointToPoint.create(Q0, Q1), duration=2.0, samples=101).trajectory
    for got, want in ((tr.positions, q), (tr.velocities, qd), (tr.accelerations, qdd)):
        assert np.abs(got - want).max() <= 1e-12
