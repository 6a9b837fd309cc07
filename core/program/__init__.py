"""Motion programs: PTP, LIN and CIRC segments planned as one trajectory, blended at corners."""
