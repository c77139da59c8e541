"""Logs and what lies beside them: the course log, read with validation and written (``log``), its
sidecars (truth, map, sensor; ``sidecars``), a log read once with its geometry, start pose and
glitches (``loaded_run``), the scans of any log (``scans``), a log's beam convention found from its
own scans (``beam_detection``), imports of CARMEN and MRCLAM datasets (``carmen``, ``mrclam``), and
occupancy maps in ROS map_server's format (``map_io``, ``map_export``)."""
