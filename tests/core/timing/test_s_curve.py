"""The s-curve path timing law: rest-to-rest ends to 1e-9, continuous s'', bounded s''', exact
duration or time-optimal (closed form), the inverse time_at, errors, and QuinticTiming's call
shape (so it registers as TIMING_LAWS["s_curve"])."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import Infeasible, InputError
from core.timing.quintic import QuinticTiming
from core.timing.s_curve import SCurveTiming, s_curve_limited

DENSE = 20_001


def ends(law: SCurveTiming) -> None:
    T = law.duration
    for order, (first, last) in enumerate(((0.0, 1.0), (0.0, 0.0), (0.0, 0.0))):
        value = law(np.array([0.0, T]), order)
        np.testing.assert_allclose(value, [first, last], rtol=0, atol=1e-9)
    # The profile itself (not only the pinned end samples) reaches 1 at rest.
    near = law._phases.evaluate(np.array([T]), (0, 1, 2))
    np.testing.assert_allclose([v[0, 0] for v in near], [1.0, 0.0, 0.0], atol=1e-9)


@pytest.mark.parametrize("T", [0.05, 1.0, 7.3, 120.0])
def test_a_duration_alone_gives_the_canonical_s_curve(T: float) -> None:
    law = SCurveTiming(T)
    assert law.duration == T
    ends(law)
    peaks = law.peaks()
    canonical = (4 / (3 * T), 32 / (3 * T**2), 256 / (3 * T**3))
    for peak, bound in zip(peaks, canonical, strict=True):
        assert peak[0] == pytest.approx(bound, rel=1e-9)


def test_limits_hold_and_acceleration_is_continuous_over_a_dense_resampling() -> None:
    rng = np.random.default_rng(4242)
    for _ in range(30):
        v, a, j = rng.uniform(0.2, 3.0), rng.uniform(0.5, 20.0), rng.uniform(2.0, 500.0)
        law = SCurveTiming(max_velocity=v, max_acceleration=a, max_jerk=j)
        ends(law)
        t = np.linspace(0.0, law.duration, DENSE)
        sd, sdd, sddd = law(t, 1), law(t, 2), law(t, 3)
        case = (v, a, j)
        assert sd.min() >= -1e-12 and np.all(np.diff(law(t)) >= -1e-15), case  # monotone
        assert np.abs(sd).max() <= v * (1 + 1e-9), case
        assert np.abs(sdd).max() <= a * (1 + 1e-9), case
        assert np.abs(sddd).max() <= j * (1 + 1e-9), case
        # Continuous s'': no step between neighbours larger than the jerk bound allows.
        assert np.abs(np.diff(sdd)).max() <= j * (t[1] - t[0]) * (1 + 1e-9), case
        # s' is the derivative of s, s'' of s' (central differences).
        h = 1e-6
        mid = t[1:-1]
        for order in (0, 1):
            fd = (law(mid + h, order) - law(mid - h, order)) / (2 * h)
            np.testing.assert_allclose(fd, law(mid, order + 1), atol=1e-5 * max(1.0, j))


def test_time_optimal_equals_the_closed_form() -> None:
    # Cruise reached (1 >= v^2/a + v a/j): T = 1/v + v/a + a/j.
    law = SCurveTiming(max_velocity=1.0, max_acceleration=2.0, max_jerk=10.0)
    assert law.duration == pytest.approx(1.0 + 0.5 + 0.2, rel=1e-12)
    # Neither v nor a reached (a^3/j^2 > 1/2 ...): pure jerk, four phases: T = 4 (1/(2j))^(1/3).
    law = SCurveTiming(max_velocity=100.0, max_acceleration=100.0, max_jerk=4.0)
    assert law.duration == pytest.approx(4.0 * (1.0 / 8.0) ** (1.0 / 3.0), rel=1e-12)


def test_a_duration_with_limits_is_exact_or_infeasible() -> None:
    limits = {"max_velocity": 1.0, "max_acceleration": 2.0, "max_jerk": 10.0}
    law = SCurveTiming(3.0, **limits)
    assert law.duration == 3.0
    ends(law)
    t = np.linspace(0.0, 3.0, DENSE)
    assert law(t, 1).max() <= 1.0 + 1e-9
    with pytest.raises(Infeasible) as err:
        SCurveTiming(1.5, **limits)
    assert "1.7 s" in str(err.value) and err.value.field == ("duration",)


def test_time_at_inverts_s() -> None:
    law = SCurveTiming(max_velocity=1.0, max_acceleration=2.0, max_jerk=10.0)
    t = np.linspace(0.0, law.duration, 1001)
    np.testing.assert_allclose(law.time_at(law(t)), t, rtol=0, atol=1e-9)
    assert law.time_at(np.array([0.0, 1.0])).tolist() == [0.0, law.duration]


def test_bad_inputs_name_the_field() -> None:
    for kwargs, field in (
        ({}, ("max_velocity",)),
        ({"max_velocity": 1.0, "max_acceleration": 1.0}, ("max_jerk",)),
        ({"duration": 0.0}, ("duration",)),
        ({"duration": float("nan")}, ("duration",)),
        ({"duration": 1.0, "max_jerk": -1.0}, ("max_jerk",)),
        ({"duration": 1.0, "max_velocity": float("inf")}, ("max_velocity",)),
    ):
        with pytest.raises(InputError) as err:
            SCurveTiming(**kwargs)
        assert err.value.field == field, kwargs


def test_same_call_shape_as_the_quintic_law() -> None:
    s_curve, quintic = SCurveTiming(2.0), QuinticTiming(2.0)
    t = np.linspace(0.0, 2.0, 7)
    for order in (0, 1, 2):
        assert s_curve(t, order).shape == quintic(t, order).shape == t.shape
    assert s_curve.time_at(np.array([0.5])).shape == quintic.time_at(np.array([0.5])).shape
    # Symmetric rest-to-rest laws both pass s = 1/2 at T/2.
    assert s_curve(np.array([1.0]))[0] == pytest.approx(0.5, abs=1e-12)


def test_tool_limits_become_path_limits() -> None:
    # 0.5 m and 1 rad: linear 0.25 m/s, 1 m/s^2, 10 m/s^3 (default) -> s' 0.5, s'' 2, s''' 20;
    # angular 1 rad/s, 2 rad/s^2, 5 rad/s^3 -> s' 1, s'' 2, s''' 5: the binding ones win.
    law = s_curve_limited(0.5, 1.0, 0.25, 1.0, 1.0, 2.0, None, 5.0)
    assert (law.max_velocity, law.max_acceleration, law.max_jerk) == (0.5, 2.0, 5.0)
    t = np.linspace(0.0, law.duration, DENSE)
    assert np.abs(law(t, 1)).max() <= 0.5 * (1 + 1e-9)
    assert np.abs(law(t, 3)).max() <= 5.0 * (1 + 1e-9)
    # Joint caps bound the whole profile by their smallest value.
    capped = s_curve_limited(0.5, 0.0, 0.25, None, 1.0, 2.0, cap=np.array([0.4, 0.3, 0.45]),
                             acceleration_cap=np.array([1.5, 0.9]))  # fmt: skip
    assert (capped.max_velocity, capped.max_acceleration) == (0.3, 0.9)
    with pytest.raises(InputError) as err:
        s_curve_limited(0.5, 0.0, None, None, 1.0, 2.0)
    assert err.value.field == ("max_linear_speed",)
