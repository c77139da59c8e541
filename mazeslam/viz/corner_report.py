"""``mazeslam corners``: lines and corners of every scan of a log, as a summary, figures and JSON."""

from __future__ import annotations

import dataclasses
import json
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image
from tqdm.auto import tqdm

from mazeslam.core.beams import SensorOverrides
from mazeslam.core.config import jsonable, load_toml_section, with_changes
from mazeslam.core.geometry import inverse, transform_points
from mazeslam.data.beam_detection import convention_warning
from mazeslam.data.scans import ScanSet, load_scans
from mazeslam.features.corners import CornerExtractor, CornerParams, ScanFeatures
from mazeslam.viz.corner_plots import ScanView, plot_scan


@dataclass
class CornerReport:
    """Features of every scan of one log."""

    scans: ScanSet
    params: CornerParams
    features: list[ScanFeatures]

    @classmethod
    def from_log(
        cls,
        path,
        config_path=None,
        mode: str | None = None,
        sensor: SensorOverrides | None = None,
        progress: bool = True,
        on_scan: Callable[[CornerReport, int], None] | None = None,
    ) -> CornerReport:
        """Extract every scan of the log at ``path``; ``on_scan(report so far, scan index)`` is
        called after each scan (``mazeslam corners --live`` draws it)."""
        params = load_toml_section(CornerParams, config_path, "corners") if config_path else CornerParams()
        params = with_changes(params, mode=mode)
        scans = load_scans(path, sensor)
        extractor = CornerExtractor(scans.geometry, scans.n_beams, params)
        report = cls(scans, params, [])
        for index, ranges in enumerate(tqdm(scans.ranges, desc="corners", unit="scan", disable=not progress)):
            report.features.append(extractor.extract(ranges))
            if on_scan is not None:
                on_scan(report, index)
        return report

    def summary(self) -> str:
        kinds = Counter(o.kind for f in self.features for o in f.observations)
        n = len(self.features)
        lines = sum(len(f.segments) for f in self.features)
        g = self.scans.geometry
        per_kind = ", ".join(f"{kind} {count / n:.2f}" for kind, count in sorted(kinds.items())) or "none"
        return "\n".join(
            [
                f"{self.scans.source}: {n} scans of {self.scans.n_beams} beams",
                f"  beam geometry    beam 0 at {g.first_beam_angle:+.4f} rad, direction {g.direction:+d}, "
                f"field of view {g.field_of_view:.4f} rad, sensor at ({g.mount_x:.3f}, {g.mount_y:.3f}) m "
                f"[{self.scans.geometry_origin}]",
                f"  mode             {self.params.mode}",
                f"  per scan         {lines / n:.2f} lines; observations: {per_kind}",
            ]
        )

    def convention_warning(self) -> str | None:
        """For a course log whose beam geometry is not from a sidecar: a warning when another
        convention makes its consecutive scans agree clearly better (``mazeslam.data.beam_detection``)."""
        run = self.scans.run
        if run is None or run.geometry_from_sidecar or len(self.features) < 2:
            return None
        return convention_warning(run.log, self.scans.geometry, self.params.min_range, self.params.max_range)

    def title(self, index: int) -> str:
        """What a figure of scan ``index`` shows; its time only when that tells it from the other scans
        (a log whose stamps are rounded, as CSAIL's to 1.13486e+09 s, gives many scans one time)."""
        times = np.asarray(self.scans.times)
        when = f", t = {times[index]:.2f} s" if np.count_nonzero(times == times[index]) == 1 else ""
        return (
            f"{Path(self.scans.source).name}: scan {index} (record {self.scans.records[index]}{when})"
            "\nits lines and corners, in the robot frame"
        )

    @property
    def mount(self) -> tuple[float, float]:
        return (self.scans.geometry.mount_x, self.scans.geometry.mount_y)

    def reach(self) -> float:
        """Half-width of a view that holds every scan's points (metres)."""
        return 1.05 * max((float(abs(f.points).max()) for f in self.features if len(f.points)), default=1.0)

    def plot(self, index: int, path) -> Path:
        if index >= len(self.features):
            raise ValueError(
                f"scan {index} does not exist: the log has {len(self.features)} scans (0..{len(self.features) - 1})"
            )
        return plot_scan(path, self.features[index], self.mount, self.title(index), self.true_corners(index))

    def true_corners(self, index: int):
        """The world's true corners in the robot frame at scan ``index``, when the log has truth."""
        if self.scans.true_poses is None or self.scans.true_corners is None:
            return None
        return transform_points(inverse(self.scans.true_poses[index]), self.scans.true_corners)

    def animate(self, path, frames_per_second: int = 4, most_frames: int = 200) -> Path:
        """The scans in turn (every scan, or evenly spaced ones up to ``most_frames``), in one GIF,
        with fixed axes so the view does not jump."""
        frames = np.unique(np.linspace(0, len(self.features) - 1, min(len(self.features), most_frames)).astype(int))
        fig = Figure(figsize=(7, 7.5), layout="constrained")
        canvas = FigureCanvasAgg(fig)  # off-screen whatever pyplot's backend: the frames are read from it
        ax = fig.add_subplot()
        view = ScanView(ax, self.mount, reach=self.reach(), truth=self.scans.true_corners is not None)
        handles, labels = ax.get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=7)
        view.show(self.features[frames[0]], self.title(frames[0]), self.true_corners(frames[0]))
        canvas.draw()
        fig.set_layout_engine("none")  # laid out once: the frames differ in data only

        # Blitting: what the frames share (axes, ticks, grid, legend) is drawn once; each frame restores
        # it and draws, in the order a full draw would, the artists from the first one a scan changes
        # on. The GIF is the one matplotlib's FuncAnimation and PillowWriter write, byte for byte, for
        # a fraction of the drawing (they draw the whole figure three times a frame).
        drawn = sorted((a for a in ax.get_children() if a is not ax.patch), key=lambda a: a.get_zorder())
        redrawn = drawn[min(drawn.index(a) for a in view.changing) :]
        for artist in redrawn:
            artist.set_animated(True)  # left out of the full draw
        canvas.draw()
        background = canvas.copy_from_bbox(fig.bbox)
        images = []
        for index in frames:
            view.show(self.features[index], self.title(index), self.true_corners(index))
            canvas.restore_region(background)
            for artist in redrawn:
                ax.draw_artist(artist)
            images.append(Image.fromarray(np.asarray(canvas.buffer_rgba())).convert("RGB"))  # opaque figure
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / frames_per_second), loop=0)
        return path

    def to_dict(self) -> dict:
        g = self.scans.geometry
        scans = []
        for index, features in enumerate(self.features):
            beams = features.beams
            scans.append(
                {
                    "scan": index,
                    "record": int(self.scans.records[index]),
                    "t": float(self.scans.times[index]),
                    "lines": [
                        {
                            "r": s.r,
                            "alpha": s.alpha,
                            "start": s.start.tolist(),
                            "end": s.end.tolist(),
                            "first_beam": int(beams[s.first]),
                            "last_beam": int(beams[s.last]),
                        }
                        for s in features.segments
                    ],
                    "observations": [
                        {
                            "range": o.range,
                            "bearing": o.bearing,
                            "x": o.x,
                            "y": o.y,
                            "kind": o.kind,
                            "covariance_xy": o.covariance_xy.tolist(),
                            "beam": o.beam,
                        }
                        for o in features.observations
                    ],
                }
            )
        return {
            "source": self.scans.source,
            "frame": "lines: sensor frame; observations: robot frame",
            "beam_geometry": g.to_dict(),
            "parameters": jsonable(dataclasses.asdict(self.params)),
            "scans": scans,
        }

    def write_json(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), allow_nan=False) + "\n")
        return path
