"""SLAM on a log, one pipeline for both filters: settings (``SlamConfig``, one TOML file), the
entry ``run_slam`` (corner FastSLAM or the grid filter, as ``[map] kind`` says), one result type
(``SlamResult``) and one writer of the outputs (``mazeslam.pipeline.outputs``)."""

from mazeslam.pipeline.config import MapKind, SlamConfig, load_slam_config
from mazeslam.pipeline.result import SlamResult
from mazeslam.pipeline.run import run_slam, slam_on_file

__all__ = ["MapKind", "SlamConfig", "SlamResult", "load_slam_config", "run_slam", "slam_on_file"]
