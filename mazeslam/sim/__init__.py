"""The simulator, which knows nothing of SLAM: mazes (``maze``, ``walls``), the pymunk world
(``world``), the virtual laser and the omnidirectional camera's ranges (``laser``,
``omnicam_sensor``), wheel odometry (``odometry``), driving policies (``policies``), the whole run
written as a course log with truth (``simulator``: ``simulate``), batched numpy physics for the
vector env (``batched``) and a small building for the grid filter (``building``)."""
