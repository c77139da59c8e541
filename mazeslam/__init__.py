"""mazeslam: particle-filter SLAM (FastSLAM) for a small differential-drive robot in a maze.

The stages (see DESIGN.md): simulate a maze run or record a real one -> a course log (+ truth and
map sidecars) -> corners -> FastSLAM -> metrics. Start with ``mazeslam.simulate`` and
``mazeslam.log.read``.
"""

from mazeslam.envs.simulator import SimulationConfig, simulate

__all__ = ["SimulationConfig", "simulate"]
__version__ = "0.1.0"
