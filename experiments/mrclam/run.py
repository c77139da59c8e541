"""FastSLAM on UTIAS MRCLAM Dataset 6, robot 1 (Vicon truth) with configs/mrclam.toml: the table in
docs/fastslam.md.

    python -m experiments.mrclam.run [--data ../shared/data/mrclam/MRCLAM_Dataset6]   (about a minute)

Imports robot 1, runs `mazeslam slam` with unknown and with known association, and writes
results.md beside this script: ATE RMSE (as estimated and aligned), the map error within 0.5 m,
pose NEES (median over the records, consistent about 2.4) and NIS (mean, consistent 2), resampled updates;
and two figures: the unknown-association run, docs/img/mrclam_robot1_unknown.png, the estimate
drawn after the same rigid alignment the aligned ATE uses (``metrics.align_se2`` of the mean path
onto the truth), beside the truth and the surveyed landmarks; and docs/img/mrclam_robot1_nees.png,
the pose NEES of both runs along the log, where the stated uncertainty departs from the error.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
MAZESLAM = [sys.executable, "-m", "mazeslam.cli"]
FIGURE = ROOT / "docs" / "img" / "mrclam_robot1_unknown.png"
NEES_FIGURE = ROOT / "docs" / "img" / "mrclam_robot1_nees.png"


def plot_aligned(log: Path, out: Path, path: Path, title: str) -> Path:
    """The run in ``out`` (a ``mazeslam slam`` folder of ``log``) against the truth, both paths and
    the map moved by the rigid motion that best maps the mean path onto the truth, as the aligned
    ATE is computed; dead reckoning aligned alike (its own best motion)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    import pandas as pd

    from mazeslam.core.motion import dead_reckoning
    from mazeslam.data.loaded_run import load_run
    from mazeslam.evaluation.metrics import absolute_trajectory_error, align_se2, apply_se2
    from mazeslam.viz.plots import draw_ellipses, mark_end, mark_start, save_figure

    run = load_run(log)
    assert run.truth is not None
    mean = pd.read_csv(out / "trajectory.csv")[["x", "y", "theta"]].to_numpy()
    result = json.loads((out / "map.json").read_text())
    alignment = align_se2(mean, run.truth)
    rotation = np.array([[np.cos(alignment[2]), -np.sin(alignment[2])], [np.sin(alignment[2]), np.cos(alignment[2])]])
    landmarks = np.asarray(result["landmarks"], float).reshape(-1, 2)
    covariances = np.asarray(result["landmark_covariances"], float).reshape(-1, 2, 2)
    reckoning = dead_reckoning(run.log, run.start_pose)
    fig, ax = plt.subplots(figsize=(8, 7.5))
    ax.plot(*run.truth[:, :2].T, color="tab:green", linewidth=1.0, label="true path (Vicon)")
    reckoning_ate = absolute_trajectory_error(reckoning, run.truth, align=True)["rmse"]
    ax.plot(
        *apply_se2(align_se2(reckoning, run.truth), reckoning)[:, :2].T,
        "--",
        color="0.5",
        linewidth=0.8,
        label=f"dead reckoning, aligned (ATE {reckoning_ate:.2f} m)",
    )
    fastslam_ate = absolute_trajectory_error(mean, run.truth, align=True)["rmse"]
    ax.plot(
        *apply_se2(alignment, mean)[:, :2].T,
        color="tab:blue",
        linewidth=1.0,
        label=f"FastSLAM mean path, aligned (ATE {fastslam_ate:.2f} m)",
    )
    mark_start(ax, run.truth, "black")  # of the true path (black: the green circles are landmarks)
    mark_end(ax, run.truth, "black")
    if run.true_corners is not None:
        ax.plot(*run.true_corners.T, "o", color="tab:green", markerfacecolor="none", label="surveyed landmarks")
    if len(landmarks):
        moved = apply_se2(alignment, landmarks)
        draw_ellipses(ax, moved, rotation @ covariances @ rotation.T)
        ax.plot(*moved.T, "+", color="tab:purple", markersize=9, label="FastSLAM landmarks, aligned (2 sigma)")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return save_figure(fig, ax, path, title, legend_columns=2)


def plot_nees_over_time(log: Path, outs: dict[str, Path], path: Path) -> Path:
    """Pose NEES along the log of each ``mazeslam slam`` folder in ``outs`` (association -> folder),
    from its trajectory.csv covariance columns against the truth, with the 95 % bound."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mazeslam.data.loaded_run import load_run
    from mazeslam.data.sidecars import read_trajectory
    from mazeslam.evaluation.consistency import POSE_BOUND_95
    from mazeslam.evaluation.metrics import normalized_estimation_error
    from mazeslam.viz.plots import save_figure

    run = load_run(log)
    assert run.truth is not None
    fig, ax = plt.subplots(figsize=(8, 4))
    for association, out in outs.items():
        times, poses, covariances = read_trajectory(out / "trajectory.csv")
        nees = normalized_estimation_error(poses, covariances, run.truth)
        ax.semilogy(times - times[0], nees, linewidth=0.6, label=f"FastSLAM, {association} association")
    ax.axhline(POSE_BOUND_95, color="black", linestyle="--", linewidth=0.8, label="95 % bound (3 dof)")
    ax.axhline(3.0, color="0.5", linestyle=":", linewidth=0.8, label="consistent mean (3)")
    ax.set_xlabel("time since the start [s]")
    ax.set_ylabel("pose NEES (log scale)")
    return save_figure(fig, ax, path, "MRCLAM Dataset 6, robot 1: pose NEES along the run, 100 particles")


def run(data: Path, figure: Path | None = FIGURE, nees_figure: Path | None = NEES_FIGURE) -> str:
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "mrclam1.log"
        subprocess.run(
            [*MAZESLAM, "import", "mrclam", str(data), "--robot", "1", "--out", str(log)],
            check=True,
            cwd=ROOT,
            capture_output=True,
        )
        for association in ("unknown", "known"):
            out = Path(folder) / association
            subprocess.run(
                [
                    *MAZESLAM,
                    "slam",
                    str(log),
                    "--config",
                    "configs/mrclam.toml",
                    "--association",
                    association,
                    "--out",
                    str(out),
                    "--quiet",
                ],
                check=True,
                cwd=ROOT,
                capture_output=True,
            )
            result = json.loads((out / "map.json").read_text())
            ate = {row["estimator"]: row for row in result["ate"]}
            if association == "unknown" and figure is not None:
                plot_aligned(
                    log,
                    out,
                    figure,
                    "MRCLAM Dataset 6, robot 1: FastSLAM, unknown association, 100 particles\n"
                    "estimate moved by the rigid alignment of the aligned ATE",
                )
            if not rows:
                reckoning = ate["dead reckoning"]
                rows.append(
                    f"| dead reckoning | {reckoning['ate_rmse']:.2f} m | {reckoning['aligned_rmse']:.2f} m | | | | |"
                )
            mean, aligned = ate["FastSLAM (mean)"], result["map_error"]["aligned"]
            rows.append(
                f"| FastSLAM, {association} association | {mean['ate_rmse']:.2f} m "
                f"| {mean['aligned_rmse']:.2f} m "
                f"| {aligned['rmse']:.2f} m, {aligned['matched']} of 15 landmarks "
                f"({len(result['landmarks'])} mapped) | {result['nees']['median']:.3g} "
                f"| {result['nis']['mean']:.2f} | {100 * result['resampled_fraction']:.1f} % |"
            )
        if nees_figure is not None:
            plot_nees_over_time(log, {a: Path(folder) / a for a in ("unknown", "known")}, nees_figure)
    return (
        "MRCLAM Dataset 6, robot 1, `configs/mrclam.toml`, 100 particles (`python -m experiments.mrclam.run`). "
        "Map: aligned landmarks within 0.5 m of a surveyed one; NEES: median over the records (consistent: about 2.4); "
        "NIS: mean over the associated observations (consistent: 2).\n\n"
        "| | ATE RMSE | aligned | map RMSE aligned | median NEES | NIS | resampled |\n"
        "|:--|--:|--:|--:|--:|--:|--:|\n" + "\n".join(rows) + "\n"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "mrclam" / "MRCLAM_Dataset6")
    parser.add_argument("--figure", type=Path, default=FIGURE, help="the unknown-association run's figure")
    parser.add_argument("--nees-figure", type=Path, default=NEES_FIGURE, help="both runs' NEES along the log")
    arguments = parser.parse_args()
    text = run(arguments.data.resolve(), arguments.figure.resolve(), arguments.nees_figure.resolve())
    (HERE / "results.md").write_text(text)
    print(text)
