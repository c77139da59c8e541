"""The sweep's summary table (``sweep.summarise``): per grid cell, the mean of each metric and its 95 %
confidence half-width, Student's t over the seeds."""

import dataclasses
import math

import pandas as pd
import pytest

from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.sweeps.runner import Sweep, configure, summarise


def test_summary_half_width_is_students_t_over_the_seeds():
    """Three seeds of 1, 2, 3: mean 2, sample standard deviation 1; Student's t with 2 degrees of
    freedom has the closed-form quantile (2p - 1) / sqrt(2p(1 - p)), 4.3027 at p = 0.975, so the
    95 % half-width is 4.3027 / sqrt(3). One seed: no half-width."""
    table = pd.DataFrame({"cell": ["a", "a", "a", "b"], "ate_rmse": [1.0, 2.0, 3.0, 5.0]})
    summary = summarise(table, ["cell"], ["ate_rmse"]).set_index("cell")
    quantile = (2 * 0.975 - 1) / math.sqrt(2 * 0.975 * 0.025)
    assert summary.loc["a", "ate_rmse"] == 2.0
    assert summary.loc["a", "ate_rmse_ci95"] == pytest.approx(quantile / math.sqrt(3), rel=1e-12)
    assert summary.loc["b", "ate_rmse"] == 5.0 and math.isnan(summary.loc["b", "ate_rmse_ci95"])


def test_summary_of_five_seeds_matches_the_t_table():
    """Five seeds: the half-width is t(0.975, 4) = 2.7764 (printed t tables) times s / sqrt(5)."""
    values = [0.1, 0.4, 0.2, 0.3, 0.5]
    summary = summarise(pd.DataFrame({"cell": ["a"] * 5, "ate_rmse": values}), ["cell"], ["ate_rmse"])
    s = pd.Series(values).std()
    assert summary.loc[0, "ate_rmse_ci95"] == pytest.approx(2.7764 * s / math.sqrt(5), rel=1e-4)


def test_a_sweep_reads_its_base_configs_once_and_a_changed_sweep_its_own(tmp_path):
    """The base configs are read once per Sweep; a Sweep made from it with another slam config
    (``dataclasses.replace``, as the benchmark's subset is made) reads that one."""
    sweep = Sweep(name="t", grid={"slam.fastslam.NPARTICLES": [5]}, seeds=[0])
    assert sweep.base_slam() is sweep.base_slam()
    assert sweep.base_slam().fastslam.NPARTICLES == FastSLAMParams().NPARTICLES
    config = tmp_path / "slam.toml"
    config.write_text("[fastslam]\nNPARTICLES = 7\n")
    other = dataclasses.replace(sweep, slam_config=str(config))
    assert other.base_slam().fastslam.NPARTICLES == 7
    assert sweep.base_slam().fastslam.NPARTICLES == FastSLAMParams().NPARTICLES
    assert configure(other, {"slam.fastslam.NPARTICLES": 5})[1].fastslam.NPARTICLES == 5
    assert other.base_slam().fastslam.NPARTICLES == 7  # configure changes a copy
