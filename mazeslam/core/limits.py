"""Sane upper bounds on sizes a setting can ask for, with the memory or time they would take.

A setting far beyond these is a typo or a misunderstanding (``NPARTICLES = 1000000000``), and the
run would only end when the machine runs out of memory: it is refused up front, saying what it
would take. Each ``*_problem`` function returns the reason a value is refused, or None.
"""

from __future__ import annotations

#: Particles of a FastSLAM filter; each holds its landmark map.
MAX_PARTICLES = 100_000
#: About the bytes one particle takes with 100 landmarks: its map (means, covariances, counters,
#: ~75 bytes a landmark) and its share of an update's measurement model (~10 observations x 100
#: landmarks x 6 floats).
PARTICLE_BYTES = 100 * 75 + 10 * 100 * 6 * 8
#: Beams of one scan.
MAX_BEAMS = 10_000
#: Bytes a scan of one beam takes in memory and in a course log (8 in memory, ~10 as text).
BEAM_BYTES = 18
#: Cells of a maze (rows x cols).
MAX_MAZE_CELLS = 10_000
#: Bytes of one maze cell once simulated: its walls' boxes in the physics engine and their surfaces.
CELL_BYTES = 2_000
#: Seconds of one simulated or recorded run (11.6 days).
MAX_DURATION = 1e6
#: Cells of a grid filter's map (a float32 log-odds each when drawn or written whole: 1 GB).
MAX_GRID_CELLS = 250_000_000
#: Largest seed (numpy takes any non-negative integer; 64 bits are plenty).
MAX_SEED = 2**63 - 1


def human_bytes(count: float) -> str:
    """``count`` bytes as ``"4.8 GB"``."""
    for unit in ("bytes", "kB", "MB", "GB", "TB", "PB"):
        if abs(count) < 1000 or unit == "PB":
            return f"{count:.0f} {unit}" if unit == "bytes" else f"{count:.3g} {unit}"
        count /= 1000
    raise AssertionError("unreachable")


def particles_problem(count: int) -> str | None:
    if count > MAX_PARTICLES:
        return (
            f"{count} particles would take about {human_bytes(count * PARTICLE_BYTES)} "
            f"(~{human_bytes(PARTICLE_BYTES)} each with 100 landmarks); at most {MAX_PARTICLES}"
        )
    return None


def beams_problem(count: int) -> str | None:
    if count > MAX_BEAMS:
        return (
            f"{count} beams would take {human_bytes(count * BEAM_BYTES)} per scan, "
            f"{human_bytes(count * BEAM_BYTES * 10_000)} for 10000 scans; at most {MAX_BEAMS}"
        )
    return None


def maze_problem(rows: int, cols: int) -> str | None:
    cells = rows * cols
    if cells > MAX_MAZE_CELLS:
        return (
            f"a {rows} x {cols} maze has {cells} cells, which would take about "
            f"{human_bytes(cells * CELL_BYTES)} to simulate and days to explore; at most {MAX_MAZE_CELLS} cells"
        )
    return None


def grid_map_problem(width: float, height: float, resolution: float) -> str | None:
    """A grid map ``width`` x ``height`` metres at ``resolution`` metres a cell, if it is too big."""
    cells = (width / resolution) * (height / resolution)
    if cells > MAX_GRID_CELLS:
        return (
            f"a map of {width:.0f} m x {height:.0f} m at {resolution:g} m a cell has {cells:.3g} cells, which would "
            f"take about {human_bytes(4 * cells)}; at most {MAX_GRID_CELLS:.3g} cells"
        )
    return None


def duration_problem(seconds: float) -> str | None:
    if seconds > MAX_DURATION:
        return f"{seconds:g} s is {seconds / 86400:.3g} days of recording; at most {MAX_DURATION:g} s"
    return None
