"""FastSLAM's facing gate (``FastSLAMParams.facing_gate``, applied in ``FastSLAM._model``): the two
face corners of a wall end lie at one spot but face opposite ways, and an observation that says
which way it faces is associated only with the landmark facing that way.

The state is built by hand: two particles at different poses, each holding the two landmarks of one
wall end at the spot the observation puts them, in opposite slot orders. The landmark facing the
wrong way has the wider covariance, so that by distance alone (no facing, or the gate off) it is the
nearer one: only the gate can make the association right.
"""

import dataclasses
import math

import numpy as np
import pytest
from conftest import EXACT

from mazeslam.fastslam.filter import FastSLAM, FastSLAMParams

PARAMS = dataclasses.replace(EXACT, NPARTICLES=2, seed=3)
#: Particle poses (x, y, theta); the observation (range 1.02 m, bearing 0) puts the wall end 1 m
#: straight ahead of each: at (1, 0) and at (2, 0).
POSES = np.array([[0.0, 0.0, 0.0], [2.0, -1.0, math.pi / 2]])
SPOTS = np.array([[1.0, 0.0], [2.0, 0.0]])
OBSERVATION = np.array([[1.02, 0.0]])
#: Per particle, the slot of the landmark facing back at the robot (world facing heading + pi) and
#: the slot of the one facing away (heading + 0): opposite orders, so a slot order cannot pass the test.
TOWARDS, AWAY = np.array([0, 1]), np.array([1, 0])
TIGHT, WIDE = np.diag([1e-4, 1e-4]), np.diag([4e-4, 4e-4])  # m^2: the facing-away one is the nearer by distance
SEEN = 5


def wall_end(params: FastSLAMParams) -> FastSLAM:
    """The filter with both particles holding the wall end's two landmarks (``TOWARDS``, ``AWAY``)."""
    slam = FastSLAM(params)
    slam.poses[:] = POSES
    rows = np.arange(2)
    for slots, facing, covariance in ((TOWARDS, math.pi, TIGHT), (AWAY, 0.0, WIDE)):
        slam.means[rows, slots] = SPOTS
        slam.covariances[rows, slots] = covariance
        slam.exists[rows, slots] = True
        slam.seen[rows, slots] = SEEN
        slam.facings[rows, slots] = POSES[:, 2] + facing
    slam.reindex()
    return slam


def matched_slots(slam: FastSLAM) -> list[list[int]]:
    """Per particle, the slots the scan updated (their count of sightings went up by one)."""
    return [np.flatnonzero(row == SEEN + 1).tolist() for row in slam.seen]


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize(
    "facing, expected",
    [
        (math.pi, TOWARDS),  # seen from the front: the face towards the robot
        (0.0, AWAY),  # its other face (the wall end seen from behind, as the observation says)
        (math.pi - math.radians(60), TOWARDS),  # 60 degrees off: within the 67.5-degree gate
        (math.radians(60), AWAY),
    ],
)
def test_an_observation_matches_only_the_landmark_facing_its_way(version, facing, expected):
    slam = wall_end(dataclasses.replace(PARAMS, version=version))
    report = slam.update(OBSERVATION, facings=np.array([facing]))
    assert matched_slots(slam) == [[expected[0]], [expected[1]]]
    assert (report.matched, report.new, report.ambiguous) == (2, 0, 0)


@pytest.mark.parametrize("version", [1, 2])
def test_an_observation_facing_neither_way_starts_a_landmark(version):
    # 90 degrees from both faces: both pairs ruled out, so it is beyond every landmark's gate.
    slam = wall_end(dataclasses.replace(PARAMS, version=version))
    report = slam.update(OBSERVATION, facings=np.array([math.pi / 2]))
    assert matched_slots(slam) == [[], []]
    assert (report.matched, report.new) == (0, 2)
    started = slam.exists & (slam.seen == 1)
    np.testing.assert_allclose(slam.facings[started], POSES[:, 2] + math.pi / 2)


@pytest.mark.parametrize(
    "facing, gate, landmarks_facing",
    [(math.nan, 67.5, True), (None, 67.5, True), (math.pi, 180.0, True), (math.pi, 67.5, False)],
    ids=["unknown facing", "no facings", "gate off", "landmarks of unknown facing"],
)
def test_without_the_gate_the_nearer_landmark_by_distance_is_matched(facing, gate, landmarks_facing):
    # The setting the tests above rely on: by Mahalanobis distance alone the facing-away landmark wins.
    slam = wall_end(dataclasses.replace(PARAMS, facing_gate=gate))
    if not landmarks_facing:
        slam.facings[:] = math.nan
    slam.update(OBSERVATION, facings=None if facing is None else np.array([facing]))
    assert matched_slots(slam) == [[AWAY[0]], [AWAY[1]]]
