"""``mazeslam relations``: a trajectory scored by the relation metric of Kümmerle et al. (2009)
against a relations file (``mazeslam.evaluation.relations``), beside a reference trajectory's score
when one is given (the benchmark's logs come with the reference poses of a mapping run: an
estimate within twice their error is a fair goal on such logs)."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np

from mazeslam.cli.options import POSITIVE
from mazeslam.core.config import InputError, read_text
from mazeslam.data.sidecars import TRUTH_HEADER, read_trajectory, read_truth
from mazeslam.evaluation.relations import read_relations, relations_metric

#: In a run folder, the path scored: the best particle's (consistent with the map, and the path the
#: CARMEN tables score), else the folder's trajectory.csv (the mean, or a smoother's only path).
RUN_FOLDER_PATHS = ("best_trajectory.csv", "trajectory.csv")


@click.command()
@click.argument("trajectory", type=click.Path(exists=True, path_type=Path))
@click.argument("relations_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--reference",
    type=click.Path(exists=True, path_type=Path),
    help="A second trajectory scored the same way, e.g. the reference poses of `mazeslam import carmen` "
    "(<log>.truth.csv); the ratio of the two is printed.",
)
@click.option(
    "--max-time-gap",
    type=POSITIVE,
    default=0.05,
    show_default=True,
    help="A relation's time must lie this close to a pose's time [s].",
)
def relations(trajectory, relations_file, reference, max_time_gap):
    """Score a trajectory by the relation metric of Kümmerle et al. (2009) against RELATIONS_FILE.

    TRAJECTORY: a `mazeslam slam` output folder (its best_trajectory.csv, else trajectory.csv), a
    trajectory CSV, or a truth CSV (t,x,y,theta).
    RELATIONS_FILE: one relation a line, `t1 t2 x y z roll pitch yaw`: the reference motion from the
    pose at time t1 to the pose at t2, in the first pose's frame (the format of the benchmark's
    hand-verified relations). Each time takes the pose nearest it."""
    click.echo("\n".join(relations_lines(trajectory, relations_file, reference, max_time_gap)))


def trajectory_file(path: str | Path) -> Path:
    """The CSV a ``relations`` argument names: the file itself, or in a ``mazeslam slam`` or
    ``smooth`` output folder the first of ``RUN_FOLDER_PATHS`` that exists."""
    path = Path(path)
    if not path.is_dir():
        return path
    for name in RUN_FOLDER_PATHS:
        if (path / name).exists():
            return path / name
    raise InputError(f"{path}: none of {', '.join(RUN_FOLDER_PATHS)} in the folder (give a run folder or a CSV)")


def read_poses(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Times (R,) s and poses (R, 3) (x m, y m, theta rad) of a trajectory CSV or a truth CSV
    (``t,x,y,theta``, e.g. the reference poses ``mazeslam import carmen`` writes beside the log)."""
    if read_text(path, "trajectory").partition("\n")[0].strip().replace(" ", "") == TRUTH_HEADER:
        return read_truth(path)
    times, poses, _ = read_trajectory(path)
    return times, poses


def relations_lines(
    trajectory: str | Path, relations_path: str | Path, reference: str | Path | None, max_gap: float
) -> list[str]:
    """The terminal report: the trajectory's relation errors, the reference's and their ratio."""
    relations = read_relations(relations_path)
    files = [trajectory_file(trajectory)] + ([] if reference is None else [trajectory_file(reference)])
    scored = [(file, relations_metric(*read_poses(file), relations, max_gap, str(file))) for file in files]
    lines = [f"{relations_path}: {len(relations.motions)} relations (Kümmerle et al. 2009: mean ± std of the errors)"]
    lines += [
        f"  {file}: translation {metric['trans_mean']:.4f} ± {metric['trans_std']:.4f} m, "
        f"rotation {math.degrees(metric['rot_mean']):.3f} ± {math.degrees(metric['rot_std']):.3f} deg"
        for file, metric in scored
    ]
    if reference is not None:
        (_, ours), (_, theirs) = scored
        lines.append(
            f"  trajectory over reference: translation {_ratio(ours['trans_mean'], theirs['trans_mean'])}, "
            f"rotation {_ratio(ours['rot_mean'], theirs['rot_mean'])}"
        )
    return lines


def _ratio(ours: float, theirs: float) -> str:
    """``x(ours / theirs)`` for the report; none where the reference scores 0 (the relations are its own)."""
    return f"x{ours / theirs:.2f}" if theirs > 1e-9 else "none (the reference scores 0)"
