"""Figures of docs/course-robot.md: log1 and a simulated course-robot log mapped by dead reckoning,
corner FastSLAM and the grid filter (configs/course.toml, filter seed 0).

Each panel places the scans' 0.05-0.4 m returns along one path (as map sharpness counts them) and
draws the path; a simulated log adds the true walls and path.

    python -m experiments.course_robot.figures    # about 1 min

Writes docs/img/course_log1_maps.png and docs/img/course_sim_maps.png.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from mazeslam.core.config import with_settings  # noqa: E402
from mazeslam.data.beam_detection import loaded_with_convention  # noqa: E402
from mazeslam.data.loaded_run import LoadedRun, load_run  # noqa: E402
from mazeslam.data.scans import scan_points_world  # noqa: E402
from mazeslam.evaluation.metrics import absolute_trajectory_error  # noqa: E402
from mazeslam.evaluation.sharpness import TRUSTED_SPAN, dead_reckoning_without_glitches, paths_sharpness  # noqa: E402
from mazeslam.pipeline import MapKind, SlamConfig, load_slam_config, run_slam  # noqa: E402
from mazeslam.sim.simulator import load_config, simulate  # noqa: E402
from mazeslam.viz import plots  # noqa: E402

HERE = Path(__file__).resolve().parent
PROJECT = HERE.parents[1]
IMAGES = PROJECT / "docs" / "img"
LOG1 = PROJECT.parent / "shared" / "data" / "course" / "log1.txt"
SIMULATION = PROJECT / "configs" / "simulation_course_robot.toml"
COURSE = PROJECT / "configs" / "course.toml"
#: The simulated log shown (one of experiments/course_robot/filters.py's seeds).
SIMULATION_SEED = 201


def paths_of(run: LoadedRun, config: SlamConfig) -> dict:
    """Name -> (R, 3) path: dead reckoning (glitches left out), corner FastSLAM's and the grid filter's mean."""
    reckoned = dead_reckoning_without_glitches(run, config.odometry.jump_tolerance)
    corners, grid = (with_settings(config, {"map.kind": kind}) for kind in (MapKind.LANDMARKS, MapKind.GRID))
    return {
        "dead reckoning": reckoned,
        "corner FastSLAM (mean)": run_slam(run, corners, progress=False).mean_poses,
        "grid filter (mean)": run_slam(run, grid, progress=False).mean_poses,
    }


def draw(run: LoadedRun, config: SlamConfig, title: str, out: Path) -> Path:
    """One panel per path: the scan returns placed along it, the path, and the truth when there is one."""
    paths = paths_of(run, config)
    sharpness = paths_sharpness(run, paths, config.odometry.jump_tolerance)
    fig, axes = plt.subplots(
        1, len(paths), figsize=(5.2 * len(paths), 6.2), sharex=True, sharey=True, layout="constrained"
    )
    for ax, (name, poses) in zip(axes, paths.items()):
        sharp = sharpness[name]
        points = scan_points_world(run.log, poses, run.geometry, *TRUSTED_SPAN)
        ax.plot(*points.T, ".", color="black", ms=1.0, alpha=0.25, label="scan returns 0.05-0.4 m", rasterized=True)
        plots.draw_walls(ax, run.walls, colour="tab:brown", linewidth=1.2, label="true walls")  # over the points
        if run.truth is not None:
            ax.plot(run.truth[:, 0], run.truth[:, 1], color="tab:green", lw=1.2, label="true path")
        ax.plot(poses[:, 0], poses[:, 1], color="tab:blue", lw=1.2, label=f"{name} path")
        plots.mark_start(ax, poses, "tab:blue")
        plots.mark_end(ax, poses, "tab:blue")
        label = f"{name}\n{sharp.cells} cells (x{sharp.ratio:.2f} of dead reckoning), extent x{sharp.extent_ratio:.2f}"
        if run.truth is not None:
            label += f"\nATE {1000 * absolute_trajectory_error(poses, run.truth)['rmse']:.1f} mm"
        ax.set_title(label, fontsize=9)
        ax.set(xlabel="x [m]", aspect="equal")
        ax.grid(True, lw=0.3)
        legend = ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=7, ncol=2)  # below the data
        legend.legend_handles[0].set(markersize=5, alpha=1.0)  # the scan returns' dot, readable in the legend
    axes[0].set_ylabel("y [m]")
    fig.suptitle(title)
    fig.savefig(out, dpi=110, bbox_inches="tight")  # the legends below the panels included
    plt.close(fig)
    return out


def main() -> None:
    config = load_slam_config(COURSE)
    IMAGES.mkdir(parents=True, exist_ok=True)
    if LOG1.exists():
        run = loaded_with_convention(LOG1, config)
        print(
            draw(
                run,
                config,
                "log1 (the exercise's robot): scans placed along each path",
                IMAGES / "course_log1_maps.png",
            )
        )
    else:
        print(f"{LOG1} is absent: its figure is not redrawn", file=sys.stderr)
    folder = HERE / "simulated"
    folder.mkdir(exist_ok=True)
    path = folder / f"course_sim_{SIMULATION_SEED}.log"
    if not path.exists():
        simulate(path, load_config(SIMULATION), seed=SIMULATION_SEED, progress=False)
    title = f"Simulated course robot (seed {SIMULATION_SEED}): scans placed along each path"
    print(draw(load_run(path), config, title, IMAGES / "course_sim_maps.png"))


if __name__ == "__main__":
    main()
