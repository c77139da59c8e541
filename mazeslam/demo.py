"""The main job on built-in defaults: simulate a maze run, estimate the path, print the ATE table, plot.

As the filter lands, its rows join dead reckoning's in the same table and figure.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam import log, sidecars
from mazeslam.envs.simulator import SimulationConfig, simulate
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.evaluation.plots import plot_run
from mazeslam.filters.motion import dead_reckoning


def run_demo(out_dir: str | Path = "runs/demo", seed: int = 0, config: SimulationConfig | None = None,
             progress: bool = True) -> tuple[pd.DataFrame, Path]:
    """Simulate, evaluate every estimator against the truth; return the ATE table and the figure's path."""
    out_dir = Path(out_dir)
    result = simulate(out_dir / "run.log", config=config, seed=seed, progress=progress)
    course_log = log.read(result.log_path)
    _, truth = sidecars.read_truth(result.truth_path)
    world = sidecars.read_map(result.map_path)
    estimates = {"dead reckoning": dead_reckoning(course_log, world["start_pose"])}
    table = pd.DataFrame(
        [{"estimator": name, **absolute_trajectory_error(poses, truth)} for name, poses in estimates.items()]
    ).set_index("estimator")
    last_scan = np.flatnonzero(course_log.is_scan)[-1]
    geometry = sidecars.beam_geometry(world["sensor"])
    scan = (truth[last_scan], course_log.values[last_scan], geometry.bearings(course_log.width))
    figure = plot_run(out_dir / "run.png", world["walls"], world["corners"], truth, estimates, scan,
                      title=f"{result.maze.name}, seed {seed}: {len(course_log)} records, "
                            f"{course_log.duration:.0f} s")
    table.to_csv(out_dir / "ate.csv")
    return table, figure
