"""Joint-space planning: point-to-point profiles (``profiles.PROFILES``), splines, durations."""
