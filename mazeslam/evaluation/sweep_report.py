"""``mazeslam report``: a sweep's results as Markdown tables and plots (error bars are 95 % CIs)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from mazeslam.evaluation.sweep import MAPS, summarise, summary_markdown  # noqa: E402

PLOTTED = [("ate_rmse", "ATE RMSE [m]"), ("ate_aligned_rmse", "ATE RMSE, aligned [m]"),
           ("optimum_ratio", "ATE / batch optimum's"), ("optimum_aligned_ratio", "ATE / batch optimum's, aligned"),
           ("map_aligned_rmse", "map RMSE, aligned [m]"), ("slam_seconds", "FastSLAM run time [s]")]


def short_name(key: str) -> str:
    """A grid key without its place: ``slam.fastslam.sigmaR+slam.fastslam.sigmaB`` -> ``sigmaR+sigmaB``."""
    return "+".join(part.split(".")[-1] for part in key.split("+"))


def make_report(out_dir: str | Path) -> list[Path]:
    """Write summary.md, one plot per grid setting and the maps side by side; return the files."""
    out_dir = Path(out_dir)
    meta = json.loads((out_dir / "sweep.json").read_text())
    table = pd.read_csv(out_dir / "results.csv")
    keys = list(meta["grid"])
    written = [out_dir / "summary.md"]
    written[0].write_text(summary_markdown(table, keys))
    for key in keys:
        written.append(_plot_against(table, key, [k for k in keys if k != key], out_dir))
    maps = _maps_side_by_side(table, keys, out_dir)
    if maps is not None:
        written.append(maps)
    return written


def _plot_against(table: pd.DataFrame, key: str, others: list[str], out_dir: Path) -> Path:
    """Each metric of ``PLOTTED`` the table has (older tables lack the optimum's) against one grid
    setting, a line per combination of the others."""
    plotted = [(metric, title) for metric, title in PLOTTED if table.get(metric, pd.Series()).notna().any()]
    summary = summarise(table, [key] + others)
    fig, axes = plt.subplots(1, len(plotted), figsize=(4.2 * len(plotted), 3.6))
    groups = summary.groupby(others) if others else [((), summary)]
    numeric = pd.api.types.is_numeric_dtype(summary[key])
    for label, group in groups:
        group = group.sort_values(key)
        name = ", ".join(f"{short_name(o)}={v}" for o, v in zip(others, label if isinstance(label, tuple) else (label,)))
        for ax, (metric, title) in zip(axes, plotted):
            x = group[key] if numeric else group[key].astype(str)
            ax.errorbar(x, group[metric], yerr=group[f"{metric}_ci95"].fillna(0), marker="o", capsize=3,
                        label=name or None)
    for ax, (metric, title) in zip(axes, plotted):
        if metric == "ate_rmse" and "reckoning_ate_rmse" in summary:
            ax.axhline(summary["reckoning_ate_rmse"].mean(), color="0.5", linestyle="--", label="dead reckoning")
        if metric.startswith("optimum"):
            ax.axhline(1.0, color="0.5", linestyle=":")  # as good as the batch optimum
        ax.set_title(title, fontsize=10)
        ax.set_xlabel(short_name(key))
        if numeric and summary[key].min() > 0 and summary[key].max() / summary[key].min() >= 20:
            ax.set_xscale("log")
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    if labels:
        fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=8)
    fig.tight_layout(rect=(0, 0.1 if labels else 0, 1, 1))
    path = out_dir / f"plot_{short_name(key)}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _maps_side_by_side(table: pd.DataFrame, keys: list[str], out_dir: Path, limit: int = 8) -> Path | None:
    """The first seed's final map (aligned) of each grid cell, up to ``limit`` cells."""
    first = table[table.seed == table.seed.min()].drop_duplicates(subset=keys)[: limit]
    files = [out_dir / MAPS / f"{run}.json" for run in first.run_id]
    if not files or not all(f.exists() for f in files):
        return None
    columns = min(len(files), 4)
    rows = math.ceil(len(files) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(3.6 * columns, 3.6 * rows), squeeze=False)
    for ax, file, (_, row) in zip(axes.flat, files, first.iterrows()):
        drawing = json.loads(file.read_text())
        for x1, y1, x2, y2 in drawing["walls"]:
            ax.plot([x1, x2], [y1, y2], color="0.6", linewidth=0.8)
        truth = pd.DataFrame(drawing["truth"])
        ax.plot(truth[0], truth[1], color="tab:green", linewidth=0.8)
        path = pd.DataFrame(drawing["trajectory"])
        ax.plot(path[0], path[1], color="tab:blue", linewidth=0.8)
        if drawing["landmarks"]:
            marks = pd.DataFrame(drawing["landmarks"])
            ax.plot(marks[0], marks[1], "+", color="tab:purple", markersize=6)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(", ".join(f"{short_name(k)}={row[k]}" for k in keys) + f"\nATE {row.ate_rmse:.3f} m", fontsize=8)
    for ax in list(axes.flat)[len(files):]:
        ax.axis("off")
    fig.tight_layout()
    path = out_dir / "maps.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
