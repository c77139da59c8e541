"""The physical world: maze walls and a differential-drive e-puck in a pymunk space.

The walls are static boxes (the solid blocks of ``mazeslam.sim.walls``); the robot is a dynamic
disc. Each physics step sets the disc's velocity from the two wheel speeds (differential-drive
kinematics), lets pymunk move it, and pushes it back out of any wall it entered, so the robot
slides along a wall it drives against and never passes through one. The robot's pose is that of
its wheel-axle centre: x, y in metres, theta in radians, world frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from mazeslam.core.config import require
from mazeslam.core.geometry import TWO_PI


@dataclass(frozen=True)
class RobotParams:
    """e-puck dimensions (GCtronic e-puck datasheet).

    Attributes:
        wheel_radius: metres (20.5 mm).
        wheelbase: distance between the wheels' contact points, metres (53 mm).
        body_radius: radius of the round body used for collisions, metres (about 37 mm).
        max_wheel_speed: fastest wheel surface speed, m/s (about 0.13 m/s: 1000 steps/s).
        encoder_steps_per_revolution: stepper-motor steps per wheel turn (1000).
        mass: kilograms (about 0.2 kg); only matters in contacts.
    """

    wheel_radius: float = 0.0205
    wheelbase: float = 0.053
    body_radius: float = 0.037
    max_wheel_speed: float = 0.13
    encoder_steps_per_revolution: int = 1000
    mass: float = 0.2

    def __post_init__(self):
        for name in ("wheel_radius", "wheelbase", "body_radius", "max_wheel_speed", "mass"):
            require(getattr(self, name) > 0, f"robot {name} must be positive, got {getattr(self, name)}")
        require(
            1 <= self.encoder_steps_per_revolution <= 10**7,
            f"robot encoder_steps_per_revolution must be in 1..10^7, got {self.encoder_steps_per_revolution}",
        )

    def wheel_speeds(self, speed: float, turn_rate: float) -> tuple[float, float]:
        """Left and right wheel surface speeds (m/s) for body ``speed`` (m/s) and ``turn_rate`` (rad/s).

        If a wheel would exceed ``max_wheel_speed``, both are scaled down together, which keeps the
        path's curvature.
        """
        half_difference = 0.5 * turn_rate * self.wheelbase
        left, right = speed - half_difference, speed + half_difference
        fastest = max(abs(left), abs(right))
        if fastest > self.max_wheel_speed:
            scale = self.max_wheel_speed / fastest
            left, right = left * scale, right * scale
        return left, right


class World:
    """A pymunk space holding the maze's wall boxes and the robot disc."""

    def __init__(self, boxes: np.ndarray, robot: RobotParams, start_pose):
        self.robot = robot
        self.space = pymunk.Space()
        for xmin, ymin, xmax, ymax in np.asarray(boxes, dtype=float):
            corners = [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]
            self.space.add(pymunk.Poly(self.space.static_body, corners))
        self.body = pymunk.Body(robot.mass, float("inf"))  # infinite moment: contacts never spin it
        self.body.position = (float(start_pose[0]), float(start_pose[1]))
        self.body.angle = float(start_pose[2])
        self.disc = pymunk.Circle(self.body, robot.body_radius)
        self.disc.friction = 0.0  # slide along walls rather than stick
        self.space.add(self.body, self.disc)

    @property
    def pose(self) -> np.ndarray:
        """True pose (x, y, theta) of the wheel-axle centre, world frame."""
        x, y = self.body.position
        return np.array([x, y, math.pi - (math.pi - self.body.angle) % TWO_PI])  # wrap_angle, for a float

    def step(self, left_travel: float, right_travel: float, dt: float) -> bool:
        """Advance ``dt`` seconds with each wheel's ground contact travelling the given metres.

        Returns whether the robot touched a wall during the step."""
        body = self.body
        speed = 0.5 * (left_travel + right_travel) / dt
        turn_rate = (right_travel - left_travel) / (self.robot.wheelbase * dt)
        heading = body.angle + 0.5 * turn_rate * dt  # midpoint heading over the step
        body.velocity = (speed * math.cos(heading), speed * math.sin(heading))
        body.angular_velocity = turn_rate
        self.space.step(dt)
        return self._push_out_of_walls()

    def _push_out_of_walls(self, iterations: int = 4) -> bool:
        """Move the disc out of any wall it overlaps after a step; return whether it touched one.

        pymunk corrects overlaps gradually, over many steps; since the wheels set the velocity anew
        every step, the disc would creep into a wall it drives against. Each contact's penetration
        depth is undone along its normal (a corner takes a second pass).
        """
        touched = False
        for _ in range(iterations):
            contacts = self.space.shape_query(self.disc)
            if not contacts:
                break
            touched = True
            for contact in contacts:
                normal = contact.contact_point_set.normal  # from the disc towards the wall
                depth = min((point.distance for point in contact.contact_point_set.points), default=0.0)
                self.body.position += normal * depth  # depth < 0: moves away from the wall
        return touched
