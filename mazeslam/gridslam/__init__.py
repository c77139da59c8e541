"""Grid-map SLAM: occupancy grids shared copy-on-write between particles, a likelihood-field scan
matcher and the improved-proposal Rao-Blackwellised particle filter (gmapping's method)."""

from mazeslam.gridslam.filter import GridSlam, GridSlamParams, GridSlamResult, run_grid_slam
from mazeslam.gridslam.matching import MatchParams
from mazeslam.gridslam.occupancy import GridParams, TiledGrid

__all__ = ["GridParams", "GridSlam", "GridSlamParams", "GridSlamResult", "MatchParams", "TiledGrid", "run_grid_slam"]
