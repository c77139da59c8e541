"""The exercise's omnidirectional camera: where its mirror is in the image and how a pixel radius
becomes a floor distance (``d = h tan(rho / alpha)``, or a lookup table). Shared by the real camera
(``mazeslam.robot.omnicam``) and the simulated one (``mazeslam.sim.omnicam_sensor``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mazeslam.core.config import require

#: The exercise's mirror model: the camera's height above the floor (m) and its pixels per radian.
EXERCISE_HEIGHT, EXERCISE_ALPHA = 0.126, 107.0


@dataclass(frozen=True)
class CameraCalibration:
    """Where the mirror is in the image and how pixel radii become metres.

    Attributes:
        center_x, center_y: the mirror's centre, pixels.
        inner_radius, outer_radius: the ring searched for walls, pixels.
        height: h, the camera above the floor, m (the exercise: about 0.126).
        alpha: pixels per radian of the mirror model (the exercise: about 107).
        threshold: grey level below which a pixel is a wall (the exercise: 180 of 255), or
            "otsu" to choose it per image.
        table_radii, table_distances: instead of the mirror model, a lookup table (pixel radius ->
            metres, increasing), interpolated linearly.
    """

    center_x: float
    center_y: float
    inner_radius: float
    outer_radius: float
    height: float = EXERCISE_HEIGHT
    alpha: float = EXERCISE_ALPHA
    threshold: int | str = 180
    table_radii: tuple = ()
    table_distances: tuple = ()

    def __post_init__(self):
        require(0 <= self.inner_radius < self.outer_radius, "need 0 <= inner_radius < outer_radius (pixels)")
        require(self.height > 0 and self.alpha > 0, "height and alpha must be positive")
        require(
            self.threshold == "otsu" or (isinstance(self.threshold, int) and 0 < self.threshold < 256),
            f"threshold must be 1..255 or 'otsu', got {self.threshold!r}",
        )
        require(len(self.table_radii) == len(self.table_distances), "lookup table radii and distances differ in length")
        require(
            len(self.table_radii) > 0 or self.outer_radius < self.alpha * np.pi / 2,
            f"outer_radius {self.outer_radius} px reaches past the mirror model's horizon "
            f"(alpha pi / 2 = {self.alpha * np.pi / 2:.0f} px)",
        )

    def distance(self, rho: np.ndarray) -> np.ndarray:
        """Floor distance (m) seen at pixel radius ``rho``."""
        if len(self.table_radii):
            return np.interp(rho, self.table_radii, self.table_distances)
        return self.height * np.tan(np.asarray(rho, dtype=float) / self.alpha)

    def radius(self, distance: np.ndarray) -> np.ndarray:
        """Pixel radius at which the floor ``distance`` metres away appears (the model's inverse)."""
        if len(self.table_radii):
            return np.interp(distance, self.table_distances, self.table_radii)
        return self.alpha * np.arctan(np.asarray(distance, dtype=float) / self.height)
