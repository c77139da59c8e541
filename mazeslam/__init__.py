"""mazeslam: particle-filter SLAM (FastSLAM) for a small differential-drive robot in a maze.

The stages (see docs/architecture.md): simulate a maze run or record a real one -> a course log (+
truth and map sidecars) -> corners -> FastSLAM -> metrics. Start with ``mazeslam.simulate`` and
``mazeslam.data.log.read``.

The package registers the Gymnasium environment ``mazeslam/Maze-v0`` (truncated after
``MAX_EPISODE_STEPS``; its vector entry point ``make_vector_env``: ``mazeslam.envs.vector_env.MazeVectorEnv``,
batched numpy physics) as soon as Gymnasium is imported, before or after mazeslam, and loads
nothing heavy itself: Gymnasium (which has no lazy plugin registration since 1.0) only when the
program imports it, the simulator (pymunk) on first use of ``mazeslam.simulate`` or
``mazeslam.SimulationConfig``, plotting, tables and the camera only in the modules that need them.
"""

import importlib.util
import sys

__all__ = ["SimulationConfig", "simulate"]
__version__ = "0.1.0"

#: Steps (0.1 s each) before ``mazeslam/Maze-v0`` truncates an episode (``env.spec.max_episode_steps``).
MAX_EPISODE_STEPS = 3000


def make_vector_env(num_envs: int = 1, max_episode_steps: int | None = None, max_steps: int | None = None, **kwargs):
    """The vector entry point: ``MazeVectorEnv`` truncating after ``max_steps`` if given, else after
    ``max_episode_steps`` (the registration's, which ``gym.make_vec`` passes)."""
    from mazeslam.envs.vector_env import MazeVectorEnv

    limit = max_steps if max_steps is not None else max_episode_steps or MAX_EPISODE_STEPS
    return MazeVectorEnv(num_envs=num_envs, max_steps=limit, **kwargs)


def _register() -> None:
    """Register ``mazeslam/Maze-v0`` with Gymnasium (once)."""
    import gymnasium

    if "mazeslam/Maze-v0" not in gymnasium.registry:
        gymnasium.register(
            id="mazeslam/Maze-v0",
            entry_point="mazeslam.envs.maze_env:MazeEnv",
            vector_entry_point="mazeslam:make_vector_env",
            max_episode_steps=MAX_EPISODE_STEPS,
        )


class _RegisterWithGymnasium:
    """An import hook (``sys.meta_path``) that registers the environment right after Gymnasium is
    imported, so that ``import mazeslam`` does not import Gymnasium (173 ms) itself."""

    def find_spec(self, name, path=None, target=None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            load = spec.loader.exec_module

            def exec_module(module):
                load(module)
                _register()

            spec.loader.exec_module = exec_module
        return spec


if "gymnasium" in sys.modules:
    _register()
elif not any(isinstance(finder, _RegisterWithGymnasium) for finder in sys.meta_path):
    sys.meta_path.insert(0, _RegisterWithGymnasium())


def __getattr__(name: str):
    """``simulate`` and ``SimulationConfig`` from ``mazeslam.sim.simulator``, imported on first use."""
    if name in __all__:
        from mazeslam.sim import simulator

        return getattr(simulator, name)
    raise AttributeError(f"module 'mazeslam' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
