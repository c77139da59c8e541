"""A log's noise measured from the log itself, in the units of the filter's settings: the laser's,
the odometry's and the corners' (``noise``: ``calibrate``) and the odometry's against truth
(``odometry_noise``)."""
