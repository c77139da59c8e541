"""Scan registration: scan-to-scan matching into laser odometry (``scan_matching``: ICP with the
wheel odometry as prior) and the exhaustive correlative search it and the grid filter fall back on
(``correlative``)."""
