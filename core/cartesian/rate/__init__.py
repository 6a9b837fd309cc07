"""Resolved-rate control: the simulation (control.py), its QP (qp.py), the result (output.py)."""
