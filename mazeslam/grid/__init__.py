"""Grid-map SLAM: occupancy grids shared copy-on-write between particles, a likelihood-field scan
matcher and the improved-proposal Rao-Blackwellised particle filter (gmapping's method)."""

from mazeslam.grid.filter import GridSlam, GridSlamParams, GridSlamResult, run_grid_slam
from mazeslam.grid.matching import MatchParams
from mazeslam.grid.occupancy import GridParams, TiledGrid

__all__ = ["GridParams", "GridSlam", "GridSlamParams", "GridSlamResult", "MatchParams", "TiledGrid", "run_grid_slam"]
