"""The robot side: one interface for the simulated and the real e-puck, its serial driver, the
omnidirectional camera's "virtual laser", and the recorder that writes course logs from either."""
