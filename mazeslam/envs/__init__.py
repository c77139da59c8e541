"""The Gymnasium API: the ``DriveEnv`` contract, the simulated maze (``MazeEnv``,
``mazeslam/Maze-v0``), its vector env on batched physics (``MazeVectorEnv``), the same actions and
observations on a real robot (``HardwareMazeEnv``), wrappers that record course logs
(``wrappers``) and run FastSLAM inside an episode (``online_slam``), and rendering."""
