"""Particle weights and resampling, as pure functions (filterpy's ``resampling`` style: they return
indexes, the caller reorders its own arrays)."""

from __future__ import annotations

import numpy as np


def normalized_weights(log_weights: np.ndarray) -> np.ndarray:
    """Weights (P,) summing to one from log weights (P,), computed in log space: never NaN, even
    when every likelihood underflows."""
    weights = np.exp(log_weights - log_weights.max())
    return weights / weights.sum()


def effective_sample_size(weights: np.ndarray) -> float:
    """Kish's effective sample size 1 / sum(w^2) of normalised weights (P,): P when uniform, 1
    when one particle holds all the weight."""
    return float(1.0 / np.sum(weights**2))


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Low-variance (systematic) resampling: indexes (P,) of the particles to keep, each drawn in
    proportion to its normalised weight (P,) with one uniform draw from ``rng``."""
    count = len(weights)
    positions = (rng.random() + np.arange(count)) / count
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0
    return np.searchsorted(cumulative, positions)


def changed_rows(index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Resampling ``index`` (P,) as row copies ``rows[targets] = rows[sources]`` (n,) each, with
    the result of ``rows[index]`` (same order, so the same random draws follow): only the rows
    whose particle changes are copied (the right-hand side is read before it is written)."""
    targets = np.flatnonzero(index != np.arange(len(index)))
    return targets, index[targets]
