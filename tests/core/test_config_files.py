"""Config files: one file extends another (``extends``), every shipped config loads, and a config
that serves one kind of log differs from its base only where it says why."""

import dataclasses

import pytest
from conftest import PROJECT_ROOT

from mazeslam.core.config import ConfigError, load_toml
from mazeslam.core.motion import OdometryNoise
from mazeslam.gridslam.filter import SearchMode
from mazeslam.pipeline import SlamConfig, load_slam_config

CONFIGS = PROJECT_ROOT / "configs"


def test_the_config_for_logs_without_odometry_is_carmens_but_for_the_grid_motion():
    base = load_slam_config(CONFIGS / "carmen.toml")
    blind = load_slam_config(CONFIGS / "carmen_without_odometry.toml")
    assert base.grid.search == SearchMode.FAILED_MATCH and blind.grid.search == SearchMode.EVERY_SCAN
    expected_grid = dataclasses.replace(
        base.grid,
        search=SearchMode.EVERY_SCAN,
        every_scan_sigma=(0.4, 0.7),
        motion_noise=OdometryNoise(0.1, 0.1, 0.05),
    )
    assert blind == dataclasses.replace(base, grid=expected_grid)


def test_a_table_of_the_extending_file_merges_key_by_key_into_the_base(tmp_path):
    (tmp_path / "base.toml").write_text('[map]\nkind = "grid"\n\n[grid]\nparticles = 7\nseed = 3\n')
    (tmp_path / "child.toml").write_text('extends = "base.toml"\n\n[grid]\nseed = 5\n')
    config = load_toml(SlamConfig, tmp_path / "child.toml")
    assert (config.map.kind, config.grid.particles, config.grid.seed) == ("grid", 7, 5)


def test_extends_errors_name_the_files(tmp_path):
    (tmp_path / "a.toml").write_text('extends = "b.toml"\n')
    (tmp_path / "b.toml").write_text('extends = "a.toml"\n')
    with pytest.raises(ConfigError, match="a.toml: extends itself"):
        load_toml(SlamConfig, tmp_path / "a.toml")
    (tmp_path / "c.toml").write_text('extends = "missing.toml"\n')
    with pytest.raises(ConfigError, match="missing.toml"):
        load_toml(SlamConfig, tmp_path / "c.toml")
    (tmp_path / "d.toml").write_text('extends = "e.toml"\n[grid]\nparticle = 3\n')
    (tmp_path / "e.toml").write_text("")
    with pytest.raises(ConfigError, match=r"d.toml \(extending .*e.toml\).*particle"):
        load_toml(SlamConfig, tmp_path / "d.toml")


@pytest.mark.parametrize(
    "name", ["carmen.toml", "carmen_without_odometry.toml", "course.toml", "fastslam.toml", "mrclam.toml"]
)
def test_every_slam_config_loads(name):
    assert isinstance(load_slam_config(CONFIGS / name), SlamConfig)


def test_a_section_of_a_slam_config_loads_alone_and_a_flat_file_too(tmp_path):
    from mazeslam.core.config import load_toml_section
    from mazeslam.features.corners import CornerParams

    assert (
        load_toml_section(CornerParams, CONFIGS / "course.toml", "corners")
        == load_slam_config(CONFIGS / "course.toml").corners
    )
    (tmp_path / "flat.toml").write_text("min_range = 0.1\n[lines]\nmin_points = 7\n")
    flat = load_toml_section(CornerParams, tmp_path / "flat.toml", "corners")
    assert (flat.min_range, flat.lines.min_points) == (0.1, 7)
    (tmp_path / "bad.toml").write_text("[corners]\nmin_rnage = 0.1\n")
    with pytest.raises(ConfigError, match=r"bad.toml \[corners\].*min_rnage"):
        load_toml_section(CornerParams, tmp_path / "bad.toml", "corners")
