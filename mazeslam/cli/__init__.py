"""The ``mazeslam`` command line: the group and its error handling (``main``), one module per
command (``simulate``, ``info``, ``corners``, ``slam``, ``smooth``, ``record``, ``sweep``,
``calibrate``, ``odometry_noise``, ``report``, ``imports``, ``demo``, ``relations``), each imported
only when it runs (``lazy``), and what they share (``options``, ``run_folders``, ``side_process``).
Nothing in the library imports it."""
