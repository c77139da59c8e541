"""Beam geometry of a range sensor: which bearing each range in a scan was measured along.

This is the one place that turns a range index into a bearing. The course logs come in more than
one convention (docs/formats.md, "Beam geometry"): the exercise's code puts beam k of N at
``-pi + k * 2pi/N``; the real log ``course/log1.txt`` puts it at ``k * 2pi/N``. So the convention
is a per-log setting, stored in the log's sidecar, never a constant.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from mazeslam.core.geometry import TWO_PI, wrap_angle


@dataclass(frozen=True)
class BeamGeometry:
    """Where the beams of a scan point, in the robot frame (0 = forward, counter-clockwise positive).

    Attributes:
        first_beam_angle: bearing of beam 0, radians.
        direction: +1 if the bearing grows with the beam index (counter-clockwise), -1 if it falls.
        field_of_view: angle the N beams span, radians. A full circle (2 pi, the course logs) puts
            beam k at ``k * 2pi/N``; a narrower fan (a front laser) spreads the N beams from the
            first to the last inclusive, ``k * fov/(N-1)``.
        mount_x, mount_y: position of the sensor in the robot frame, metres (the exercise's
            CAMERA_POS_DX is ``mount_x``: the camera sits ahead of the wheel axle).
    """

    first_beam_angle: float = -np.pi
    direction: int = 1
    field_of_view: float = TWO_PI
    mount_x: float = 0.0
    mount_y: float = 0.0

    def __post_init__(self):
        if self.direction not in (1, -1):
            raise ValueError(f"beam direction must be +1 or -1, got {self.direction!r}")
        if not 0.0 < self.field_of_view <= TWO_PI + 1e-9:
            raise ValueError(f"field_of_view must be in (0, 2pi] radians, got {self.field_of_view!r}")
        _check_placement(self.first_beam_angle, self.mount_x, self.mount_y)

    @property
    def is_full_circle(self) -> bool:
        return abs(self.field_of_view - TWO_PI) < 1e-9

    def angle_step(self, n_beams: int) -> float:
        """Angle between neighbouring beams, radians (positive)."""
        if n_beams < 1:
            raise ValueError(f"a scan needs at least one beam, got {n_beams}")
        if self.is_full_circle:
            return TWO_PI / n_beams
        return self.field_of_view / max(n_beams - 1, 1)

    def bearings(self, n_beams: int) -> np.ndarray:
        """Bearing of each of ``n_beams`` beams in the robot frame, radians in (-pi, pi]; shape (N,)."""
        k = np.arange(n_beams)
        return wrap_angle(self.first_beam_angle + self.direction * k * self.angle_step(n_beams))

    def returns(self, ranges: np.ndarray, min_range: float = 0.0, max_range: float = np.inf) -> np.ndarray:
        """A scan's returns within [min_range, max_range] (0 = no return is always left out) as
        points (K, 2) in the robot frame, metres: the sensor's mounting offset included."""
        ranges = np.asarray(ranges, dtype=float)
        valid = (ranges > 0) & (ranges >= min_range) & (ranges <= max_range)
        bearings = self.bearings(len(ranges))[valid]
        return np.column_stack(
            [self.mount_x + ranges[valid] * np.cos(bearings), self.mount_y + ranges[valid] * np.sin(bearings)]
        )

    def to_dict(self) -> dict:
        return {
            "first_beam_angle": self.first_beam_angle,
            "direction": self.direction,
            "field_of_view": self.field_of_view,
            "mount_x": self.mount_x,
            "mount_y": self.mount_y,
        }


#: Farthest a sensor can sit from the wheel axle, m (a robot is not bigger than this).
MAX_MOUNT = 10.0


def _check_placement(first_beam_angle, mount_x, mount_y) -> None:
    """Finite angles and a sensor on the robot (a sensor far off makes every observation absurd)."""
    if first_beam_angle is not None and not abs(first_beam_angle) <= 1000.0:
        raise ValueError(f"first_beam_angle must be a finite angle (radians), got {first_beam_angle!r}")
    for name, value in (("mount_x", mount_x), ("mount_y", mount_y)):
        if value is not None and not abs(value) <= MAX_MOUNT:
            raise ValueError(f"{name} must be within +-{MAX_MOUNT:g} m of the wheel axle, got {value!r}")


@dataclass(frozen=True)
class SensorOverrides:
    """Beam-geometry settings that replace a log's own (its sidecar or the exercise default); None
    keeps the log's. TOML section ``[sensor]`` and the command line's ``--first-beam-angle``,
    ``--beam-direction``, ``--mount-x``. Radians and metres, as in ``BeamGeometry``."""

    first_beam_angle: float | None = None
    direction: int | None = None
    mount_x: float | None = None
    mount_y: float | None = None

    def __post_init__(self):
        if self.direction is not None and self.direction not in (1, -1):
            raise ValueError(f"beam direction must be +1 or -1, got {self.direction!r}")
        _check_placement(self.first_beam_angle, self.mount_x, self.mount_y)

    def given(self) -> list[str]:
        """The names of the settings that are given (not None)."""
        return [name for name, value in dataclasses.asdict(self).items() if value is not None]

    def over(self, base: SensorOverrides) -> SensorOverrides:
        """``base`` (a config's ``[sensor]``) with the settings given here (the command line) replacing its own."""
        return dataclasses.replace(base, **{name: getattr(self, name) for name in self.given()})

    def apply(self, geometry: BeamGeometry) -> BeamGeometry:
        """``geometry`` with the given settings replaced."""
        return dataclasses.replace(geometry, **{name: getattr(self, name) for name in self.given()})

    def apply_described(self, geometry: BeamGeometry, origin: str) -> tuple[BeamGeometry, str]:
        """``apply`` and the geometry's ``origin`` (for messages) saying which settings replaced its own."""
        if not self.given():
            return geometry, origin
        return self.apply(geometry), f"{origin}, overridden by {', '.join(sorted(self.given()))}"


#: The exercise's MATLAB code: beam k at -pi + k 2pi/N, counter-clockwise. The simulator's default.
EXERCISE_CONVENTION = BeamGeometry(first_beam_angle=-np.pi, direction=1)
#: Beam 0 straight ahead, counter-clockwise: the convention of the real log ``course/log1.txt``.
FORWARD_FIRST_CONVENTION = BeamGeometry(first_beam_angle=0.0, direction=1)
