"""Certification by the motion bound (``core.motion.certify``) against a dense sweep of a toy
clearance with closed-form distances (``discs.Discs``): a certified path is clear everywhere; a
refused one with ``contact`` has a configuration closer than the threshold where it says."""

from __future__ import annotations

import numpy as np
import pytest

from core.motion.certify import CERTIFY_MARGIN, Certifier, certify_polyline, margins
from tests.core.motion.discs import Discs, min_margin_dense

DISCS = Discs([[0.0, 0.0], [1.5, 0.4], [-1.0, 1.2]], [0.5, 0.3, 0.4], clearance=0.05)


def test_segment_around_and_through() -> None:
    clear = np.array([[-1.0, -1.0], [1.0, -1.0]])  # passes 1 m below the disc at the origin
    through = np.array([[-1.0, 0.1], [1.0, -0.1]])
    assert certify_polyline(DISCS, clear).ok
    cert = certify_polyline(DISCS, through)
    assert not cert.ok and cert.contact
    q = through[0] + cert.failed_at / np.linalg.norm(through[1] - through[0]) * (
        through[1] - through[0]
    )
    assert (margins(DISCS, q) < 0).any()  # the contact is real, where it is reported


def test_grazing_segment_within_the_margin_is_refused() -> None:
    # tangent to the first disc at the clearance plus half the certification margin
    y = -(0.5 + 0.05 + CERTIFY_MARGIN / 2)
    cert = certify_polyline(DISCS, np.array([[-1.0, y], [1.0, y]]))
    assert not cert.ok


@pytest.mark.parametrize("seed", range(6))
def test_random_paths_agree_with_a_dense_sweep(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(40):
        knots = rng.uniform(-2.0, 2.0, size=(rng.integers(2, 5), 2))
        cert = certify_polyline(DISCS, knots)
        dense = min_margin_dense(DISCS, knots)
        if cert.ok:
            assert dense >= CERTIFY_MARGIN - 1e-12, (seed, knots)
        elif cert.contact:
            assert dense < CERTIFY_MARGIN, (seed, knots)


def test_certifier_remembers_and_bounds_its_work() -> None:
    c = Certifier(DISCS)
    knots = np.array([[-1.0, -1.0], [1.0, -1.0], [1.2, -0.2]])
    first = c.path(knots)
    used = c.evaluations
    again = c.path(knots)
    assert first.ok and again.ok and again.evaluations <= first.evaluations
    assert c.evaluations - used == again.evaluations
    # a budget too small to prove a long segment near a disc: refused without a contact
    y = -(0.5 + 0.05 + 1e-4)
    short_budget = Certifier(DISCS, max_evaluations=3).path(np.array([[-1.0, y], [1.0, y]]))
    assert not short_budget.ok and not short_budget.contact


def test_probe_finds_deep_contacts() -> None:
    c = Certifier(DISCS)
    assert c.first_contact(np.array([[-1.0, 0.0], [1.0, 0.0]])) is not None
    assert c.first_contact(np.array([[-1.0, -1.0], [1.0, -1.0]])) is None
