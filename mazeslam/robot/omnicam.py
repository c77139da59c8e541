"""The exercise's "virtual laser": ranges from an omnidirectional camera image (OpenCV).

The camera looks up into a curved mirror; the floor around the robot appears as a ring between an
inner radius (the robot itself) and an outer radius (the mirror's edge), centred on the mirror's
centre. Walls are dark on a white floor. Along each beam's direction the first dark pixel outward
is the foot of the wall; its pixel radius rho becomes a distance with the exercise's mirror model

    d = h tan(rho / alpha)          (h: camera height above the floor, m; alpha: pixels per radian)

or with a lookup table fitted to known distances. No dark pixel: 0 (no return).

Image axes: the robot's forward direction points up in the image (towards smaller row numbers)
and its left to the left, so a beam at bearing phi (counter-clockwise from forward) samples the
pixels at (cx - rho sin phi, cy - rho cos phi).
"""

from __future__ import annotations

import cv2
import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.mirror import CameraCalibration
from mazeslam.robot.interface import RobotDisconnected, RobotError

#: Radial sampling step of the polar unwarping, pixels.
RADIAL_STEP = 0.25


def image_to_ranges(
    image: np.ndarray, calibration: CameraCalibration, geometry: BeamGeometry, n_beams: int
) -> np.ndarray:
    """Ranges (N,) in metres in the beam order of ``geometry``, 0 where no wall is seen.

    The ring is unwarped into one row per beam (``cv2.remap``, bilinear, every ``RADIAL_STEP``
    pixels from just outside the inner radius to just inside the outer one); the first sample
    darker than the threshold is the wall's foot, placed between it and the sample before by
    linear interpolation of the grey level.
    """
    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    # One pixel inside the ring on each side, so the interpolation never reads the dark robot
    # body or the mirror's rim.
    radii = np.arange(calibration.inner_radius + 1, calibration.outer_radius - 1 + 1e-9, RADIAL_STEP)
    bearings = geometry.bearings(n_beams)
    map_x = (calibration.center_x - radii[None, :] * np.sin(bearings)[:, None]).astype(np.float32)
    map_y = (calibration.center_y - radii[None, :] * np.cos(bearings)[:, None]).astype(np.float32)
    polar = cv2.remap(
        grey.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=255.0
    )  # (N, R): one row per beam
    if calibration.threshold == "otsu":  # chosen from the ring alone, not the robot or the rim
        threshold, _ = cv2.threshold(
            np.clip(polar, 0, 255).astype(np.uint8), 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU
        )
    else:
        threshold = float(calibration.threshold)
    dark = polar < threshold
    found = dark.any(axis=1)
    first = dark.argmax(axis=1)
    previous = np.maximum(first - 1, 0)
    rows = np.arange(n_beams)
    above, below = polar[rows, previous], polar[rows, first]
    fraction = np.where((first > 0) & (above > below), (above - threshold) / np.maximum(above - below, 1e-9), 1.0)
    rho = radii[previous] + np.clip(fraction, 0.0, 1.0) * (radii[first] - radii[previous])
    return np.where(found, calibration.distance(rho), 0.0)


def detect_mirror(image: np.ndarray) -> tuple[float, float, float]:
    """The mirror's centre (x, y) and outer radius in pixels, found as the strongest circle
    (Hough transform); for calibrating without clicks."""
    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    smallest = min(grey.shape)
    circles = cv2.HoughCircles(
        cv2.GaussianBlur(grey, (5, 5), 1.5),
        cv2.HOUGH_GRADIENT,
        dp=1,
        minDist=smallest,
        param1=100,
        param2=30,
        minRadius=smallest // 4,
        maxRadius=smallest // 2,
    )
    if circles is None:
        raise RobotError("no mirror found in the image: give its centre and outer radius instead")
    x, y, radius = circles[0][0]
    return float(x), float(y), float(radius)


class OmniCamera:
    """Frames turned into scans. ``source``: a device index or a video/image file for
    ``cv2.VideoCapture``, or any object with VideoCapture's ``read() -> (ok, frame)``."""

    def __init__(self, source, calibration: CameraCalibration, geometry: BeamGeometry, n_beams: int):
        self.source, self.calibration, self.geometry, self.n_beams = source, calibration, geometry, n_beams
        self.capture = source if hasattr(source, "read") else cv2.VideoCapture(source)
        if hasattr(self.capture, "isOpened") and not self.capture.isOpened():
            raise RobotDisconnected(f"cannot open camera {source!r}")

    def __call__(self) -> np.ndarray:
        ok, frame = self.capture.read()
        if not ok or frame is None:
            raise RobotDisconnected(f"camera {self.source!r} returned no frame")
        return image_to_ranges(frame, self.calibration, self.geometry, self.n_beams)

    def close(self) -> None:
        release = getattr(self.capture, "release", None)
        if release is not None:
            release()


def render_view(ranges_by_angle, angles: np.ndarray, calibration: CameraCalibration, size: int) -> np.ndarray:
    """A synthetic omnidirectional image (size x size grey levels): white floor, dark walls from
    their foot outward, the robot's disc black inside ``inner_radius``, black outside the mirror.

    ``ranges_by_angle``: true wall distances (m, inf for none) along ``angles`` (radians, robot
    frame, increasing over a full circle); each pixel takes the nearest angle's distance.
    """
    rows, columns = np.mgrid[0:size, 0:size]
    dx, dy = calibration.center_x - columns, calibration.center_y - rows  # left, forward
    rho = np.hypot(dx, dy)
    bearing = np.arctan2(dx, dy)  # counter-clockwise from forward (up)
    step = angles[1] - angles[0]
    index = np.mod(np.rint((bearing - angles[0]) / step).astype(int), len(angles))
    wall = np.asarray(ranges_by_angle)[index]
    floor_distance = calibration.distance(np.minimum(rho, calibration.outer_radius))
    image = np.full((size, size), 235, dtype=np.uint8)
    image[floor_distance >= wall] = 40
    image[(rho < calibration.inner_radius) | (rho > calibration.outer_radius)] = 0
    return image
