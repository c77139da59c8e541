"""Every figure the documentation shows has a maker in scripts/make_docs_figures.py, and the figure
functions and scripts produce non-empty images with labelled axes and nothing cut off (small inputs:
a 12 s simulated run, seeded)."""

import importlib.util
import json
import shutil
import sys
from pathlib import Path

import matplotlib
import matplotlib.figure
import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from conftest import PROJECT_ROOT
from PIL import Image

from mazeslam.cli.main import main

ROOT = PROJECT_ROOT


def load_script(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def figures():
    return load_script(ROOT / "scripts" / "make_docs_figures.py", "make_docs_figures")


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    """A 12 s simulated run and its `mazeslam slam` folder."""
    from mazeslam import simulate

    folder = tmp_path_factory.mktemp("figures")
    log = folder / "short.log"
    simulate(log, seed=5, duration=12.0, progress=False)
    result = CliRunner().invoke(main, ["slam", str(log), "--quiet", "--out", str(folder / "slam")])
    assert result.exit_code == 0, result.output
    return log, folder / "slam"


def non_empty_png(path: Path, smallest: int = 5_000) -> None:
    assert path.stat().st_size > smallest, path
    with Image.open(path) as image:
        assert image.size[0] > 300 and image.size[1] > 300
        assert len(np.unique(np.asarray(image.convert("L")))) > 10  # something is drawn


def test_every_image_the_docs_show_has_a_maker(figures):
    assert figures.uncovered() == []
    names = [entry[0] for entry in figures.FIGURES]
    assert len(names) == len(set(names))
    for name, outputs, commands, minutes in figures.FIGURES:
        assert outputs.split() and minutes > 0, name
        assert all(words for words in figures.commands_of(commands, Path("/tmp"))), name


def test_an_entry_runs_and_its_output_is_checked(figures, tmp_path):
    log = "{tmp}/a.log"
    entry = (
        f"mazeslam simulate --seed 1 --duration 6 --out {log} --quiet; "
        f"mazeslam corners {log} --scan 3 --plot {{tmp}}/scan.png; copy {{tmp}}/scan.png scan.png"
    )
    assert figures.make("scan", "scan.png", entry, root=tmp_path) == []
    non_empty_png(tmp_path / "scan.png")
    problems = figures.make("scan", "missing.png", "mazeslam --help", root=tmp_path)
    assert problems and "nothing matches" in problems[0]


def test_slam_figure_has_its_legend_and_labels_inside(short_run, monkeypatch):
    log, out = short_run
    non_empty_png(out / "slam.png", 20_000)
    from mazeslam.viz import plots

    seen = {}
    real_savefig = matplotlib.figure.Figure.savefig

    def savefig(fig, *args, **kwargs):
        real_savefig(fig, *args, **kwargs)
        renderer = fig.canvas.get_renderer()
        box = fig.bbox
        for artist in [*fig.legends, *[ax.yaxis.label for ax in fig.axes], *[ax.xaxis.label for ax in fig.axes]]:
            extent = artist.get_window_extent(renderer)
            seen[artist] = extent.x0 >= box.x0 - 1 and extent.x1 <= box.x1 + 1 and extent.y0 >= box.y0 - 1

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    import matplotlib.pyplot as plt  # plots.py draws without pyplot; a pyplot figure is checked here

    fig, ax = plt.subplots(figsize=(6, 5))
    ax.plot([0, 1], [0, 1], label="a line with a long legend entry that would stick out")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    plots.save_figure(fig, ax, out / "check.png", "title")
    assert seen and all(seen.values())


def test_scan_figure_and_animation(short_run, tmp_path):
    log, _ = short_run
    result = CliRunner().invoke(
        main,
        [
            "corners",
            str(log),
            "--scan",
            "2",
            "--plot",
            str(tmp_path / "scan.png"),
            "--animate",
            str(tmp_path / "s.gif"),
        ],
    )
    assert result.exit_code == 0, result.output
    non_empty_png(tmp_path / "scan.png")
    assert (tmp_path / "s.gif").stat().st_size > 5_000


def test_sweep_report_plots_and_maps(tmp_path):
    """A committed sweep's table, reported again: the plot, and maps.png from per-run maps made up here."""
    from mazeslam.sweeps.report import make_report, tick_labels

    results = tmp_path / "results"
    shutil.copytree(ROOT / "experiments" / "landmarks" / "results", results, ignore=shutil.ignore_patterns("maps*"))
    table = pd.read_csv(results / "results.csv")
    (results / "maps").mkdir()
    square = [[0, 0, 0.6, 0], [0.6, 0, 0.6, 0.6], [0.6, 0.6, 0, 0.6], [0, 0.6, 0, 0]]
    path = [[0.1 + 0.4 * t, 0.1 + 0.3 * t * t] for t in np.linspace(0, 1, 20)]
    for run_id in table.run_id:
        drawing = {"walls": square, "truth": path, "trajectory": path, "landmarks": [[0, 0], [0.6, 0.6]]}
        (results / "maps" / f"{run_id}.json").write_text(json.dumps(drawing))
    written = make_report(results)
    assert {p.name for p in written} >= {"summary.md", "plot_mode.png", "maps.png"}
    for png in (p for p in written if p.suffix == ".png"):
        non_empty_png(png, 20_000)
    # linked settings scaled together are labelled by their first value; others in full
    assert tick_labels(["0.001/0.006", "0.002/0.012"]) == ["0.001", "0.002"]
    assert tick_labels(["1/100", "2/1000"]) == ["1/100", "2/1000"]


def test_mrclam_figure_aligns_the_estimate(short_run, tmp_path):
    log, out = short_run
    mrclam = load_script(ROOT / "experiments" / "mrclam" / "run.py", "mrclam_run")
    path = mrclam.plot_aligned(log, out, tmp_path / "aligned.png", "short run, aligned")
    non_empty_png(path, 20_000)


def test_blind_cloud_growth_figure(tmp_path):
    blind_cloud = load_script(ROOT / "experiments" / "blind_cloud" / "run.py", "blind_cloud_run")
    travelled = np.linspace(0, 1.6, 50)
    spread = 0.01 + 0.02 * np.sqrt(travelled)
    blind = pd.DataFrame(
        {
            "travelled_blind_m": travelled,
            "std_major_m": spread,
            "std_minor_m": spread / 2,
            "std_theta_deg": 8 * np.sqrt(travelled),
            "predicted_std_major_m": spread * 1.05,
            "predicted_std_minor_m": spread / 2.1,
            "predicted_std_theta_deg": 8 * np.sqrt(travelled) + 0.1,
        }
    )
    for column, (a, b) in {
        "major_vs_model": ("std_major_m", "predicted_std_major_m"),
        "minor_vs_model": ("std_minor_m", "predicted_std_minor_m"),
        "theta_vs_model": ("std_theta_deg", "predicted_std_theta_deg"),
    }.items():
        blind[column] = blind[a] / blind[b]
    blind_cloud._plot_growth(blind, tmp_path / "growth.png", 1.0)
    non_empty_png(tmp_path / "growth.png", 20_000)
    summary = blind_cloud.vs_model(blind)
    assert summary["major_axis"]["max_ratio"] == pytest.approx(1 / 1.05)
    assert summary["minor_axis"]["share_within_10_percent"] == 1.0


def test_maze_env_figure(tmp_path):
    maze_env = load_script(ROOT / "scripts" / "figures" / "maze_env.py", "maze_env_figure")
    non_empty_png(maze_env.main(tmp_path / "maze_env.png", steps=20, seed=0), 20_000)


def test_slam_figure_is_a_few_artists_not_one_per_item(monkeypatch, tmp_path):
    """Issue 18: walls, ellipses and points each one artist, so the figure draws in well under a second."""
    import time

    from mazeslam import simulate
    from mazeslam.data.loaded_run import load_run
    from mazeslam.data.scans import scan_points_world
    from mazeslam.pipeline import run_slam
    from mazeslam.viz import slam_figure as slam_report

    run = load_run(simulate(tmp_path / "run.log", seed=6, duration=20.0, progress=False).log_path)
    result = run_slam(run, progress=False)
    points = scan_points_world(run.log, result.mean_poses, run.geometry)
    from mazeslam.viz import plots

    drawn = {}
    real_save = plots.save_figure

    def save(fig, ax, path, title=""):
        drawn.update(lines=len(ax.lines), patches=len(ax.patches), collections=len(ax.collections))
        return real_save(fig, ax, path, title)

    monkeypatch.setattr(plots, "save_figure", save)
    began = time.perf_counter()
    path = slam_report.plot_slam(tmp_path / "slam.png", result, points, run.truth, run.walls, "short", run.true_corners)
    seconds = time.perf_counter() - began
    non_empty_png(path, 20_000)
    assert len(run.walls) > 4 and len(result.landmarks) > 2
    assert drawn["patches"] == 0 and drawn["lines"] <= 8 and drawn["collections"] <= 2, drawn
    assert seconds < 5.0  # about 0.2 s on an idle core; generous for a loaded machine
