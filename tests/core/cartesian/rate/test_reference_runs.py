"""The controller's ticks equal the outputs recorded before the per-tick bookkeeping was cut
(``scenarios.REFERENCE``): positions, rates, s, singular values, damping, path-clock rate, tracking
errors to 1e-9; active-bound flags, QP iterations, tick counts, fallbacks and failures exactly."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.cartesian.rate.scenarios import REFERENCE, SCENARIOS, run, summary

pytest.importorskip("robots.registry")


@pytest.fixture(scope="module")
def reference():
    with np.load(REFERENCE) as data:
        return {key: data[key] for key in data.files}


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_run_equals_recorded_outputs(reference, name):
    now = summary(run(name))
    assert set(now) == {key.split("/", 1)[1] for key in reference if key.startswith(name + "/")}
    for key, value in now.items():
        recorded = reference[f"{name}/{key}"]
        assert value.shape == recorded.shape, key
        if value.dtype.kind == "f" and key != "failure_s":
            np.testing.assert_allclose(value, recorded, rtol=0, atol=1e-9, err_msg=key)
        elif key == "failure_s":
            np.testing.assert_allclose(value, recorded, rtol=0, atol=1e-9, equal_nan=True)
        else:
            np.testing.assert_array_equal(value, recorded, err_msg=key)
