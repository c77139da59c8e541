"""``mazeslam relations``: a trajectory scored by the relation metric of Kümmerle et al. (2009)
against a relations file (``mazeslam.evaluation.relations``), beside a reference trajectory's score
when one is given (the benchmark's logs come with the reference poses of a mapping run: an
estimate within twice their error is the issue's goal on such logs)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mazeslam.config import InputError, read_text
from mazeslam.evaluation.relations import read_relations, relations_metric
from mazeslam.sidecars import TRUTH_HEADER, read_trajectory, read_truth


def read_poses(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Times (R,) s and poses (R, 3) (x m, y m, theta rad) of a trajectory: a ``mazeslam slam`` or
    ``smooth`` output folder (its trajectory.csv), a trajectory CSV, or a truth CSV (``t,x,y,theta``,
    e.g. the reference poses ``mazeslam import carmen`` writes beside the log)."""
    path = Path(path)
    if path.is_dir():
        path = path / "trajectory.csv"
        if not path.exists():
            raise InputError(f"{path.parent}: no trajectory.csv in the folder (give a run folder or a CSV)")
    header = read_text(path, "trajectory").partition("\n")[0].strip().replace(" ", "")
    if header == TRUTH_HEADER:
        return read_truth(path)
    times, poses, _ = read_trajectory(path)
    return times, poses


def relations_lines(
    trajectory: str | Path, relations_path: str | Path, reference: str | Path | None, max_gap: float
) -> list[str]:
    """The terminal report: the trajectory's relation errors, the reference's and their ratio."""
    relations = read_relations(relations_path)
    scored = {str(trajectory): relations_metric(*read_poses(trajectory), relations, max_gap)}
    if reference is not None:
        scored[str(reference)] = relations_metric(*read_poses(reference), relations, max_gap)
    lines = [f"{relations_path}: {len(relations.motions)} relations (Kümmerle et al. 2009: mean ± std of the errors)"]
    lines += [
        f"  {name}: translation {metric['trans_mean']:.4f} ± {metric['trans_std']:.4f} m, "
        f"rotation {math.degrees(metric['rot_mean']):.3f} ± {math.degrees(metric['rot_std']):.3f} deg"
        for name, metric in scored.items()
    ]
    if reference is not None:
        ours, theirs = scored.values()
        lines.append(
            f"  trajectory over reference: translation x{_ratio(ours['trans_mean'], theirs['trans_mean'])}, "
            f"rotation x{_ratio(ours['rot_mean'], theirs['rot_mean'])}"
        )
    return lines


def _ratio(ours: float, theirs: float) -> str:
    """``ours / theirs`` for the report; none where the reference scores 0 (the relations are its own)."""
    return f"{ours / theirs:.2f}" if theirs > 1e-9 else " n/a (the reference scores 0)"
