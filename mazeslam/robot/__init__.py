"""The robot side: the interface a robot offers (real or simulated), the e-puck's serial driver, the
omnidirectional camera's "virtual laser", and the recorder that writes course logs from either."""
