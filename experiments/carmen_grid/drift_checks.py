"""Where the grid filter's remaining error on the CARMEN logs comes from: a uniform scale, or a bend?
(docs/grid.md, "Known limits": edmonton's slow drift.)

Per (log, seed) of ``results/table.csv``, from the trajectory run.py wrote (``results/<log>_seed<k>/
trajectory.csv``, best particle at every record), at the scans against the reference poses:
the aligned ATE after the best rigid motion (as the table) and after the best similarity (rigid
motion and scale, Umeyama 1991), and that scale (reference over estimate); the 95th percentile of
the heading error after the rigid alignment; the steps between consecutive scans more than
``WRONG_STEP`` (0.3 m or 0.1 rad) off the reference's, and which (numbered from 1, step ``k`` from
scan ``k - 1`` to scan ``k``, as orebro_checks numbers intervals) where there are few. A filter whose path is
right but uniformly too long or too short (a laser odometry or a range scale off by a fraction)
loses most of its error under the similarity; a bend does not.

Per log, how far the seeds' paths are apart (rigid ATE of every pair of seeds, one against the
other: the part of the error that changes from run to run) beside their ATE against the reference
(what they share is either the filter's bias or the reference's own error). Per log, the laser
odometry (configs/carmen.toml's ``[scan_matching]``) against the reference:
its path length over the reference's, and the median over the accepted intervals longer than
0.2 m of its error along the reference's motion as a share of the distance (positive: longer). Per
log, the laser's maximum range and the share of its beams with no return within it (the importer
writes them as 0; the grid filter clears the map along them up to that range).

Run: ``python -m experiments.carmen_grid.drift_checks`` after run.py (a few CPU minutes: the
laser odometry of every log); writes ``results/drift_checks.md``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from experiments.carmen_grid.run import CONFIG, RESULTS, imported_run
from mazeslam.core.geometry import relative, wrap_angle
from mazeslam.evaluation.metrics import align_se2, apply_se2
from mazeslam.pipeline import load_slam_config
from mazeslam.registration.scan_matching import laser_odometry

#: A step between consecutive scans this far off the reference's (m, rad) is wrong; up to
#: ``LISTED`` wrong steps of a run are listed.
WRONG_STEP, LISTED = (0.3, 0.1), 15


def similarity_fit(estimate: np.ndarray, reference: np.ndarray) -> tuple[float, float, float]:
    """RMSE (m) of positions ``estimate`` (S, 2) against ``reference`` (S, 2) after the best rigid
    motion and after the best similarity, and the similarity's scale (Umeyama 1991)."""
    centred_e, centred_r = estimate - estimate.mean(axis=0), reference - reference.mean(axis=0)
    u, singular, vt = np.linalg.svd(centred_r.T @ centred_e / len(estimate))
    sign = np.diag([1.0, np.sign(np.linalg.det(u @ vt))])
    rotation = u @ sign @ vt
    scale = float(np.trace(np.diag(singular) @ sign) / np.mean(np.sum(centred_e**2, axis=1)))

    def rmse(factor: float) -> float:
        return float(np.sqrt(np.mean(np.sum((centred_r - factor * centred_e @ rotation.T) ** 2, axis=1))))

    return rmse(1.0), rmse(scale), scale


def wrong_steps(estimate: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Numbers (from 1) of the steps between consecutive poses of ``estimate`` (S, 3) whose motion
    is more than ``WRONG_STEP`` off ``reference``'s (S, 3)."""
    error = relative(relative(reference[:-1], reference[1:]), relative(estimate[:-1], estimate[1:]))
    off = (np.hypot(error[:, 0], error[:, 1]) > WRONG_STEP[0]) | (np.abs(wrap_angle(error[:, 2])) > WRONG_STEP[1])
    return np.flatnonzero(off) + 1


def main() -> None:
    table = pd.read_csv(RESULTS / "table.csv")
    scan_matching = load_slam_config(CONFIG).scan_matching
    seeds, logs = [], []
    for name, rows in table.groupby("log"):
        run = imported_run(name)
        records = np.flatnonzero(run.log.is_scan)
        reference = run.truth[records]
        paths = []
        for seed in rows["seed"]:
            path = RESULTS / f"{name}_seed{seed}" / "trajectory.csv"
            if not path.exists():
                continue
            estimate = pd.read_csv(path).iloc[records][["x", "y", "theta"]].to_numpy()
            paths.append(estimate[:, :2])
            rigid, similar, scale = similarity_fit(estimate[:, :2], reference[:, :2])
            aligned = apply_se2(align_se2(estimate, reference), estimate)
            heading = np.degrees(np.abs(wrap_angle(aligned[:, 2] - reference[:, 2])))
            wrong = wrong_steps(estimate, reference)
            seeds.append(
                {
                    "log": name,
                    "seed": seed,
                    "rigid ATE [m]": rigid,
                    "similarity ATE [m]": similar,
                    "scale": scale,
                    "heading error p95 [deg]": np.percentile(heading, 95),
                    "wrong steps": len(wrong),
                    "which": " ".join(map(str, wrong)) if len(wrong) <= LISTED else "",
                }
            )
        odometry = laser_odometry(run.log, run.geometry, scan_matching)
        truth_steps = relative(reference[:-1], reference[1:])
        steps = odometry.increments[1:]
        truth_length, length = np.hypot(*truth_steps[:, :2].T), np.hypot(*steps[:, :2].T)
        used = odometry.accepted[1:] & (truth_length > 0.2)
        along = np.einsum("ij,ij->i", steps[used, :2], truth_steps[used, :2]) / truth_length[used]
        apart = [similarity_fit(one, other)[0] for one, other in itertools.combinations(paths, 2)] or [np.nan]
        beams = run.log.values[records, : run.log.width]
        logs.append(
            {
                "log": name,
                "laser max range [m]": run.sensor_max_range,
                "beams with no return [%]": 100 * float(np.mean(beams == 0)),
                "seeds apart: median [m]": np.median(apart),
                "seeds apart: largest [m]": np.max(apart),
                "laser odometry / reference length": length.sum() / truth_length.sum(),
                "median error along the motion [%]": 100 * np.median(along / truth_length[used] - 1),
            }
        )
    per_seed = pd.DataFrame(seeds)
    grouped = per_seed.groupby("log")
    summary = pd.DataFrame(
        {
            "rigid ATE worst [m]": grouped["rigid ATE [m]"].max(),
            "similarity ATE worst [m]": grouped["similarity ATE [m]"].max(),
            "scale range": grouped["scale"].apply(lambda s: f"{s.min():.4f}-{s.max():.4f}"),
            "heading error p95, worst [deg]": grouped["heading error p95 [deg]"].max(),
            "wrong steps, most": grouped["wrong steps"].max(),
        }
    ).join(pd.DataFrame(logs).set_index("log"))
    text = (
        "# Scale or bend? (experiments/carmen_grid/drift_checks.py)\n\n"
        "Grid filter's best path at the scans against the reference poses, worst seed: aligned ATE after the best "
        "rigid motion and after the best similarity (the scale range over the seeds, reference over estimate), the "
        "95th percentile of the heading error after the rigid motion; the most steps between consecutive scans "
        "more than 0.3 m or 0.1 rad off the reference's in one seed (per seed: which, numbered as orebro_checks' "
        "intervals, where at most 15); the rigid ATE between every two seeds' "
        "paths (median and largest: how far the runs are apart, against their ATE to the reference); "
        "the laser's maximum range and the share of its beams with no return within it; "
        "the laser odometry's path length over the reference's and its median error along the reference's "
        "motion as a share of the distance over the accepted intervals.\n\n"
        + summary.to_markdown(floatfmt=".4g")
        + "\n\nPer seed:\n\n"
        + per_seed.to_markdown(index=False, floatfmt=".4g")
        + "\n"
    )
    (RESULTS / "drift_checks.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
