"""mazeslam: particle-filter SLAM (FastSLAM) for a small differential-drive robot in a maze.

The stages (see DESIGN.md): simulate a maze run or record a real one -> a course log (+ truth and
map sidecars) -> corners -> FastSLAM -> metrics. Start with ``mazeslam.simulate`` and
``mazeslam.log.read``.
"""

import gymnasium

from mazeslam.envs.simulator import SimulationConfig, simulate

__all__ = ["SimulationConfig", "simulate"]

if "mazeslam/Maze-v0" not in gymnasium.registry:
    gymnasium.register(id="mazeslam/Maze-v0", entry_point="mazeslam.envs.maze_env:MazeEnv")
__version__ = "0.1.0"
