"""Pose-graph smoothing of laser logs: every scan a node, the laser odometry and scan-to-submap
matches (local and loop closures, kept unambiguous) as edges, solved by robust sparse least squares.

``laser_graph.laser_pose_graph(run, config)`` builds and solves a loaded log's graph; ``graph`` holds
the edges and their residuals, ``solve`` the robust solve, ``closures`` the matching and its
ambiguity test, ``sequential`` the laser odometry's edges.
"""
