"""PUMA 560: a straight line through the wrist singularity, by resolved-rate control.

On this line the wrist joint q5 goes from +0.25 to -0.25 rad, so the wrist passes through (next to)
its singularity q5 = 0, where joints 4 and 6 line up. The notes' pseudo-inverse resolved-rate
controller asks for joint rates far beyond the limits there and refuses (422 ``joint_rate_limit``
or ``singularity``, with the path parameter ``s``); with ``allow_partial`` it returns the prefix it
could plan, braked to rest. The damped least-squares QP completes the line with every joint rate and
position within its limits, and reports the deviation from the line it accepted near the
singularity; a deviation over the tolerance is a 422 ``infeasible`` unless the request says
``allow_violations`` (issue 19's rule), so the DLS request sets it. Run: ``python examples/puma_wrist_dls.py [--url URL]`` (exit status 0 when all of that holds).
"""

from __future__ import annotations

from _common import URL, client, expect, line_errors, points

from robots import registry

REQUEST = {
    "robot": "puma560",
    "start": {"positions": [0.0, 0.6, -2.6, 0.3, 0.25, 0.0]},
    "goal": {"positions": [0.2, 0.7, -2.4, 0.32, -0.25, 0.0]},
    "duration": 2.0,
}


def main() -> None:
    http = client()
    robot = registry.get("puma560")

    pinv = http.post(URL, json={**REQUEST, "method": "resolved_rate"})
    problem = pinv.json()
    print(f"resolved_rate: {pinv.status_code} {problem.get('code')} at s={problem.get('s')}: "
          f"{problem.get('detail')}")  # fmt: skip
    expect(pinv.status_code == 422, "the pseudo-inverse should refuse the wrist singularity")
    expect(problem["code"] in ("joint_rate_limit", "singularity"), "unexpected error code")

    partial = http.post(URL, json={**REQUEST, "method": "resolved_rate", "allow_partial": True})
    expect(partial.status_code == 200, f"allow_partial should give 200, got {partial.status_code}")
    times, q, v = points(partial.json())
    print(f"resolved_rate, allow_partial: fraction {partial.json()['diagnostics']['fraction']:.3f}, "
          f"{len(times)} points over {times[-1]:.3f} s, ends at rest: {not v[-1].any()}")  # fmt: skip

    strict = http.post(URL, json={**REQUEST, "method": "resolved_rate_dls"})
    print(f"resolved_rate_dls: {strict.status_code} {strict.json().get('code')}: "
          f"{strict.json().get('detail')}")  # fmt: skip
    expect(strict.status_code == 422, "a deviation over the tolerance must be asked for")
    dls = http.post(URL, json={**REQUEST, "method": "resolved_rate_dls", "allow_violations": True})
    expect(dls.status_code == 200, f"the DLS should complete, got {dls.status_code}: {dls.text}")
    body = dls.json()
    diag = body["diagnostics"]
    times, q, v = points(body)
    pos, ori = line_errors(REQUEST, q)
    print(
        f"resolved_rate_dls: fraction {diag['fraction']}, {len(times)} points over {times[-1]:.3f} s"
    )
    print(f"  smallest singular value met {diag['min_singular_value_met']:.2e}, "
          f"largest damping {diag['max_damping']:.3f}")  # fmt: skip
    print(f"  deviation accepted: {diag['max_position_deviation'] * 1e3:.2f} mm, "
          f"{diag['max_orientation_deviation']:.4f} rad near s={diag['max_deviation_s']:.3f} "
          f"(at the points: {pos.max() * 1e3:.2f} mm, {ori.max():.4f} rad)")  # fmt: skip
    print(f"  QP per tick: {diag['qp_iterations_median']:.0f} iterations (max "
          f"{diag['qp_iterations_max']}), {diag['qp_solve_time_us_median']:.0f} us median")  # fmt: skip
    for warning in diag["warnings"]:
        print(f"  warning: {warning}")
    lo, hi = robot.position_limits.T
    expect(bool((q >= lo).all() and (q <= hi).all()), "a joint leaves its position limits")
    expect(bool((abs(v) <= robot.velocity_limits).all()), "a joint exceeds its velocity limit")
    expect(q[:, 4].max() > 0.2 and q[:, 4].min() < -0.2, "the wrist did not pass q5 = 0")
    expect(diag["max_damping"] > 0.0, "the damping should have been active")
    expect(not v[-1].any(), "the last point is not at rest")
    print("OK")


if __name__ == "__main__":
    main()
