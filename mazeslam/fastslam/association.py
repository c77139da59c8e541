"""Data association: which landmark slot of each particle an observation is, as pure functions.

Both return ``assigned`` (P, K): the slot (column of the particle's map) each of K observations is
matched to, or -1 for none.
"""

from __future__ import annotations

import numpy as np


def associate_greedy(distance2: np.ndarray, gate: float) -> np.ndarray:
    """Greedy one-to-one maximum-likelihood association per particle.

    Args:
        distance2: (P, K, M) squared Mahalanobis distance of every observation to every slot
            (inf for empty slots).
        gate: pairs at this squared distance or beyond are never matched.
    Repeatedly takes the closest observation-landmark pair within the gate, so two observations
    never update one landmark, and the second is not silently lost: it competes for the next
    closest landmark or stays unmatched.
    """
    p, k, m = distance2.shape
    assigned = np.full((p, k), -1)
    if m == 0:
        return assigned
    remaining = distance2.copy()
    rows = np.arange(p)
    for _ in range(min(k, m)):
        flat = remaining.reshape(p, -1).argmin(axis=1)
        obs, slot = np.divmod(flat, m)
        ok = remaining[rows, obs, slot] < gate
        if not ok.any():
            break
        assigned[rows[ok], obs[ok]] = slot[ok]
        remaining[rows[ok], obs[ok], :] = np.inf
        remaining[rows[ok], :, slot[ok]] = np.inf
    return assigned


def nearest_within(points: np.ndarray, landmarks: np.ndarray, radius: float) -> np.ndarray:
    """Index (K,) of the landmark (L, 2) nearest each of ``points`` (K, 2), or -1 where none lies
    within ``radius`` (same units, metres). For naming observations by a reference map."""
    if not len(landmarks):
        return np.full(len(points), -1)
    distance = np.linalg.norm(points[:, None, :] - landmarks[None], axis=2)  # (K, L)
    nearest = distance.argmin(axis=1)
    return np.where(distance[np.arange(len(points)), nearest] <= radius, nearest, -1)


def associate_known(observation_ids: np.ndarray, slot_ids: np.ndarray, exists: np.ndarray) -> np.ndarray:
    """The slot holding each observation's known identity.

    Args:
        observation_ids: (K,) landmark identities of the observations (-1: unknown, never matched).
        slot_ids: (P, M) identity of every slot; exists: (P, M) the slot holds a landmark.
    """
    if slot_ids.shape[1] == 0:
        return np.full((len(slot_ids), len(observation_ids)), -1)
    match = (
        (slot_ids[:, None, :] == observation_ids[None, :, None])
        & exists[:, None, :]
        & (observation_ids[None, :, None] >= 0)
    )
    return np.where(match.any(axis=2), match.argmax(axis=2), -1)
