"""Measure a log's sensor noise from the log itself, in the units of the filter's settings.

Range noise of the laser: every extracted wall is straight, so the scatter of its points around the
fitted line is the range noise seen across the wall. A point at bearing b on a line with normal
angle alpha is off the line by ``d = e cos(b - alpha)`` for a range error e, so ``e = d / cos(b - alpha)``.
Pooled over all lines (each fit uses two degrees of freedom), with beams within 60 degrees of the
wall's normal so the division does not amplify the line's own fit error:

    sigma^2 = sum_i e_i^2 / sum_lines (n - 2)

It needs no truth and no motion: only straight walls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mazeslam.filters.corners import CornerExtractor

#: Beams hitting a wall farther than this from its normal are left out (their range errors are
#: poorly seen across the wall), radians.
MAX_INCIDENCE = math.radians(60.0)


@dataclass(frozen=True)
class RangeNoise:
    """The laser's range noise measured on straight walls.

    Attributes:
        std: standard deviation of a range, metres.
        points: how many returns it was measured on; lines: on how many lines.
    """

    std: float
    points: int
    lines: int


def laser_range_noise(scans: np.ndarray, extractor: CornerExtractor) -> RangeNoise:
    """The range noise (see the module docstring) of ``scans`` (S, N) ranges in metres (0: no
    return), taken with ``extractor``'s beam geometry and line settings."""
    squared, dof, points, lines = 0.0, 0, 0, 0
    for ranges in scans:
        features = extractor.extract(ranges)
        bearings = extractor.bearings[features.beams]
        for segment in features.segments:
            span = slice(segment.first, segment.last + 1)
            incidence = np.cos(bearings[span] - segment.alpha)
            offsets = features.points[span] @ segment.normal - segment.r
            facing = np.abs(incidence) >= math.cos(MAX_INCIDENCE)
            if facing.sum() < 3:
                continue
            errors = offsets[facing] / incidence[facing]
            squared += float(errors @ errors)
            dof += int(facing.sum()) - 2
            points += int(facing.sum())
            lines += 1
    if dof <= 0:
        raise ValueError("no straight walls in the scans: the range noise cannot be measured")
    return RangeNoise(math.sqrt(squared / dof), points, lines)
