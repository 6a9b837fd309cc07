"""Cartesian straight-line planning: task -> validate -> ``METHODS[m]`` -> check -> finish.

Entry point: ``core.cartesian.plan.plan(task, method)``. See docs/architecture.md for the layout.
"""
