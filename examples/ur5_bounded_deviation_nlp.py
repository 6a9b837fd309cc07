"""UR5: bounded deviation as constraints (CasADi + IPOPT) against Taylor's method, same line.

The line of ``ur5_bounded_deviation.py`` (0.3 m, 30 degrees, 1 mm / 0.01 rad). Taylor's method puts
its knots on the line until joint interpolation between them passes the midpoint test; the NLP makes
the knots decision variables, constrains the deviation of the returned joint path at dense check
points, and searches the smallest knot count that satisfies the bound: the knots need not lie on the
line, so fewer do. Both trajectories are checked here between every two returned points with the
robot's own FK. Run: ``python examples/ur5_bounded_deviation_nlp.py [--url URL]`` (exit status 0 when the NLP
needs fewer knots and both keep the bound).
"""

from __future__ import annotations

from _common import URL, client, expect
from ur5_bounded_deviation import check_plan, request


def main() -> None:
    c = client()
    counts = {}
    for method in ("bounded_deviation", "bounded_deviation_nlp"):
        req = request(method)
        response = c.post(URL, json=req)
        expect(response.status_code == 200, f"{method}: {response.status_code} {response.text}")
        body = response.json()
        diag = body["diagnostics"]
        print(f"{method}: compute {diag['compute_time_ms']:.0f} ms")
        if method == "bounded_deviation_nlp":
            print(f"  knot counts tried {diag['knot_counts_tried']} (Taylor: "
                  f"{diag['taylor_knot_count']}), {diag['ipopt_iterations']} IPOPT iterations "
                  f"in {diag['nlp_solve_time_ms']:.0f} ms")  # fmt: skip
        check_plan(req, body)
        counts[method] = diag["knot_count"]
    expect(
        counts["bounded_deviation_nlp"] < counts["bounded_deviation"],
        "the NLP should need fewer knots than Taylor's method",
    )
    print(f"knots: Taylor {counts['bounded_deviation']}, NLP {counts['bounded_deviation_nlp']}")
    print("OK")


if __name__ == "__main__":
    main()
