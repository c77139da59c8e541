"""The FastSLAM animation (GIF, or MP4 with ffmpeg) and its frames: axes in metres, legend, scan."""

import pytest
from PIL import Image

from mazeslam.data.loaded_run import load_run
from mazeslam.data.scans import scan_points_world
from mazeslam.features.corners import CornerExtractor
from mazeslam.pipeline import SlamConfig, run_slam
from mazeslam.viz import slam_figure as slam_report
from mazeslam.viz.slam_view import ffmpeg_path, scan_source


@pytest.fixture(scope="module")
def short_result(tmp_path_factory):
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("view") / "short.log"
    simulate(out, seed=3, duration=10.0, progress=False)
    run = load_run(out)
    config = SlamConfig()
    result = run_slam(run, config, progress=False, snapshot_every=2)
    extractor = CornerExtractor(run.geometry, run.log.width, config.corners)
    return run, result, scan_source(run.log, result.mean_poses, run.geometry, extractor)


def test_gif_has_one_frame_per_snapshot_and_the_scan(short_result, tmp_path):
    run, result, scan_at = short_result
    points = scan_points_world(run.log, result.mean_poses, run.geometry)
    path = slam_report.animate_slam(
        tmp_path / "slam.gif", result, points, run.truth, run.walls, scan_at=scan_at, title="short.log", video=False
    )
    assert path.suffix == ".gif"
    with Image.open(path) as image:
        assert image.n_frames == len(result.snapshots) > 3
    scan, corners = scan_at(result.snapshots[-1][0])
    assert len(scan) > 10 and corners.shape[1] == 2


def test_frames_have_labelled_axes_legend_and_time(short_result):
    from mazeslam.viz.slam_view import SlamView, view_extent

    run, result, scan_at = short_result
    view = SlamView(
        result.times, result.mean_poses, view_extent(result.mean_poses), "short.log", run.truth, run.walls, scan_at
    )
    index, particles, landmarks = result.snapshots[-1]
    view.show(index, particles, landmarks, result.landmark_covariances[: len(landmarks)])
    assert view.ax.get_xlabel() == "x [m]" and view.ax.get_ylabel() == "y [m]"
    labels = [text.get_text() for text in view.ax.get_legend().get_texts()]
    assert {"particles", "current scan", "its corners", "estimated path", "true path"} <= set(labels)
    assert f"record {index}" in view.ax.get_title() and "t = " in view.ax.get_title()
    assert len(view.scan_points.get_xdata()) > 10


def test_mp4_when_ffmpeg_is_there(short_result, tmp_path):
    if ffmpeg_path() is None:
        pytest.skip("no ffmpeg (pip install 'mazeslam[video]')")
    run, result, scan_at = short_result
    path = slam_report.animate_slam(tmp_path / "slam.gif", result, result.mean_poses[:, :2], scan_at=scan_at)
    assert path.name == "slam.mp4" and path.stat().st_size > 10_000
