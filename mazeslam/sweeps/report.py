"""``mazeslam report``: a sweep's results as Markdown tables and plots (error bars are 95 % CIs)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam.core.config import InputError
from mazeslam.core.outputs import write_file
from mazeslam.core.outputs import written as written_whole
from mazeslam.sweeps.runner import MAPS, summarise
from mazeslam.viz.backends import file_figure
from mazeslam.viz.plots import draw_walls

#: The summary's columns: (metric, header). Metrics an older table lacks are left out.
REPORTED = [
    ("ate_rmse", "ATE [mm]"),
    ("ate_aligned_rmse", "ATE aligned [mm]"),
    ("optimum_ate_rmse", "optimum's ATE [mm]"),
    ("optimum_ratio", "ATE / optimum's"),
    ("optimum_aligned_ratio", "aligned ATE / optimum's"),
    ("reckoning_ate_rmse", "dead reckoning ATE [mm]"),
    ("map_aligned_rmse", "map aligned [mm]"),
    ("landmarks", "landmarks"),
    ("median_nees", "median NEES"),
    ("mean_nees", "mean NEES"),
    ("nees_inside_95", "NEES inside 95 %"),
    ("nis_mean", "NIS mean"),
    ("nis_inside_95", "NIS inside 95 %"),
    ("resampled_fraction", "resampled scans"),
    ("slam_seconds", "run time [s]"),
]

#: The plots' panels: (metric, axis label, reference lines {value: label}, log scale).
PLOTTED = [
    ("ate_rmse", "ATE RMSE [mm]", {}, False),
    ("ate_aligned_rmse", "ATE RMSE, SE(2)-aligned [mm]", {}, False),
    ("optimum_ratio", "ATE / batch optimum's ATE", {1.0: "optimum"}, False),
    ("optimum_aligned_ratio", "aligned ATE / optimum's aligned ATE", {1.0: "optimum"}, False),
    ("median_nees", "median pose NEES (log)", {3.0: "consistent (3)", 7.81: "95 % bound"}, True),
    ("nis_mean", "mean NIS", {2.0: "consistent (2)"}, False),
    ("map_aligned_rmse", "map RMSE, aligned [mm]", {}, False),
    ("slam_seconds", "FastSLAM run time [s]", {}, False),
]

#: Axis labels (with units) of the settings sweeps vary, by their short name.
SETTING_LABELS = {
    "NPARTICLES": "number of particles",
    "version": "FastSLAM version",
    "beams": "scan points N (beams over 360 deg)",
    "mode": "landmarks",
    "sigmaR+sigmaB": "assumed sensor noise sigmaR / sigmaB\n(m, rad)",
    "sigmaX+sigmaTH+sigmaTH_drive": "assumed odometry noise sigmaX / sigmaTH / sigmaTH_drive\n"
    "(m/sqrt(m), rad/sqrt(rad), rad/sqrt(m))",
    "observation_scale": "observation_scale\n(x the corners' calibrated covariance)",
    "inflation": "inflation (x every noise variance)",
    "likelihood_exponent": "likelihood exponent (weights use each scan's likelihood to this power)",
    "range_noise_std": "laser range noise [m]",
}


#: Units of the first setting of linked settings, whose axis is labelled by that one.
LINKED_UNITS = {"sigmaX": "m/sqrt(m)", "sigmaR": "m"}


def short_name(key: str) -> str:
    """A grid key without its place: ``slam.fastslam.sigmaR+slam.fastslam.sigmaB`` -> ``sigmaR+sigmaB``."""
    return "+".join(part.split(".")[-1] for part in key.split("+"))


def linked_values(values: list) -> np.ndarray | None:
    """(N, K) numbers of a linked setting's N grid values ``"a/b/c"`` (None when they are not all numbers)."""
    try:
        return np.array([[float(part) for part in str(v).split("/")] for v in values])
    except ValueError:
        return None


def scaled_together(values: list) -> bool:
    """Whether the grid values of a linked setting keep their parts in (about) the same ratios: the
    parts are scaled together, and the first one stands for all."""
    numbers = linked_values(values)
    if numbers is None or numbers.shape[1] < 2 or (numbers[:, 0] == 0).any():
        return False
    ratios = numbers[:, 1:] / numbers[:, :1]
    return bool(((ratios.max(axis=0) / ratios.min(axis=0) - 1) < 0.05).all())


def tick_labels(values: list) -> list[str]:
    """Short tick labels: settings scaled together (``"a/b/c"``) by their first number alone
    (``axis_label`` says how the others follow), anything else as it is."""
    numbers = linked_values(values)
    if numbers is None or not scaled_together(values):
        return [str(v) for v in values]
    return [f"{n:.2g}" for n in numbers[:, 0]]


def axis_label(key: str, values: list) -> str:
    """The x axis label of a grid setting, with units; for settings scaled together, the first one's
    name and the others' ratio to it."""
    name = short_name(key)
    names = name.split("+")
    label = SETTING_LABELS.get(name, " / ".join(names))
    numbers = linked_values(values)
    if len(names) < 2 or numbers is None or not scaled_together(values):
        return label
    ratios = numbers[:, 1:] / numbers[:, :1]
    spread = ratios.max(axis=0) / ratios.min(axis=0) - 1
    follows = ", ".join(
        f"{other} {'=' if s < 0.001 else '≈'} {r:.3g} x"
        for other, r, s in zip(names[1:], np.median(ratios, axis=0), spread)
    )
    unit = LINKED_UNITS.get(names[0], "")
    return f"{'assumed ' if unit else ''}{names[0]}{f' [{unit}]' if unit else ''}\n({follows})"


def setting_text(key: str, value, values: list | None = None) -> str:
    """``name=value`` of a grid cell, short: settings scaled together by the first one's value."""
    names = short_name(key).split("+")
    if len(names) < 2:
        return f"{names[0]}={value}"
    if values is not None and scaled_together(values):
        return f"{names[0]}={float(str(value).split('/')[0]):.2g} (and {', '.join(names[1:])} with it)"
    return ", ".join(f"{n}={v}" for n, v in zip(names, str(value).split("/")))


def make_report(out_dir: str | Path) -> list[Path]:
    """Write summary.md, one plot per grid setting and the maps side by side; return the files."""
    out_dir = Path(out_dir)
    missing = [name for name in ("sweep.json", "results.csv") if not (out_dir / name).is_file()]
    if missing:
        raise InputError(
            f"{out_dir}: not a sweep's results folder (no {' or '.join(missing)}); "
            f"`mazeslam sweep configs/sweeps/smoke.toml --out {out_dir}` makes one"
        )
    meta = json.loads((out_dir / "sweep.json").read_text())
    table = in_millimetres(pd.read_csv(out_dir / "results.csv"))
    keys = list(meta["grid"])
    written = [out_dir / "summary.md"]
    write_file(written[0], summary_table(table, keys))
    for key in keys:
        written.append(_plot_against(table, key, [k for k in keys if k != key], out_dir, meta.get("name", "")))
    maps = _maps_side_by_side(table, keys, out_dir, name=meta.get("name", ""))
    if maps is not None:
        written.append(maps)
    return written


def in_millimetres(table: pd.DataFrame) -> pd.DataFrame:
    """The table with its RMSE columns (metres in results.csv) in millimetres, as the report shows them."""
    table = table.copy()
    for column in table.columns:
        if column.endswith("rmse"):
            table[column] = table[column] * 1000.0
    return table


def summary_table(table: pd.DataFrame, keys: list[str]) -> str:
    """Mean +- 95 % confidence half-width over the seeds of every ``REPORTED`` metric, per grid cell."""
    reported = [(metric, header) for metric, header in REPORTED if metric in table]
    summary = summarise(table, keys, [metric for metric, _ in reported])
    shown = summary[keys + ["runs"]].rename(columns={key: short_name(key) for key in keys})
    for metric, header in reported:
        shown[header] = [
            f"{m:.3g} ± {h:.2g}" if not math.isnan(h) else f"{m:.4g}"
            for m, h in zip(summary[metric], summary[f"{metric}_ci95"])
        ]
    return (
        "Mean ± 95 % confidence half-width over the seeds, per grid cell. ATE: the particles' mean path "
        "against the truth (aligned: after the best rigid motion); optimum: the batch least-squares "
        "solution of the same log with the filter's noise model and the true association (ratio 1: as good "
        "as any estimator); NEES: pose error normalised by the cloud's covariance, per record (consistent: "
        "3, 95 % of records under 7.81); NIS: innovation of each associated observation normalised by its "
        "predicted covariance (consistent: 2, 95 % under 5.99); resampled: share of scans.\n\n"
        + shown.to_markdown(index=False)
        + "\n"
    )


def _plot_against(table: pd.DataFrame, key: str, others: list[str], out_dir: Path, name: str = "") -> Path:
    """Each metric of ``PLOTTED`` the table has against one grid setting, a line per combination of
    the others: mean over the seeds with its 95 % confidence interval (clipped at zero; NEES: the
    median over seeds with the quartiles, on a log axis)."""
    plotted = [spec for spec in PLOTTED if table.get(spec[0], pd.Series(dtype=float)).notna().any()]
    summary = summarise(table, [key] + others, [spec[0] for spec in plotted] + ["reckoning_ate_rmse"])
    columns = 4
    rows = math.ceil(len(plotted) / columns)
    fig = file_figure(figsize=(4.3 * columns, 3.6 * rows + 1.2), layout="constrained")
    grid = fig.subplots(rows, columns, squeeze=False)
    axes = list(grid.flat)
    for ax in axes[len(plotted) :]:
        ax.axis("off")
    groups = list(summary.groupby(others)) if others else [((), summary)]
    numeric = pd.api.types.is_numeric_dtype(summary[key])
    values = sorted(summary[key].unique()) if numeric else list(dict.fromkeys(table[key].astype(str)))
    positions = {value: k for k, value in enumerate(values)}
    categorical = not numeric or any(isinstance(v, str) for v in values)
    linked = categorical and any("/" in str(v) for v in values)
    unordered = categorical and not linked  # linked settings keep the grid's order
    for index, (label, group) in enumerate(groups):
        group = (
            group.sort_values(key)
            if numeric
            else group.set_index(group[key].astype(str))
            .loc[[v for v in values if v in set(group[key].astype(str))]]
            .reset_index(drop=True)
        )
        label = label if isinstance(label, tuple) else (label,)
        legend = ", ".join(f"{short_name(o)}={v}" for o, v in zip(others, label))
        x = group[key].to_numpy() if not categorical else np.array([positions[str(v)] for v in group[key]], float)
        if categorical and len(groups) > 1:  # side by side, not on top of each other
            x = x + 0.08 * (index - (len(groups) - 1) / 2)
        for ax, (metric, _, _, log) in zip(axes, plotted):
            if log:
                cells = (
                    table
                    if not others
                    else table[np.logical_and.reduce([table[o] == v for o, v in zip(others, label)])]
                )
                grouped = cells.groupby(key)[metric]
                quartiles = grouped.quantile([0.25, 0.5, 0.75]).unstack()
                quartiles = quartiles.loc[[v for v in group[key]]]
                middle = quartiles[0.5].to_numpy()
                yerr = [middle - quartiles[0.25].to_numpy(), quartiles[0.75].to_numpy() - middle]
                ax.errorbar(
                    x,
                    middle,
                    yerr=yerr,
                    marker="o",
                    capsize=3,
                    label=legend or "FastSLAM",
                    linestyle="none" if unordered else "-",
                )
                continue
            mean = group[metric].to_numpy(dtype=float)
            half = group[f"{metric}_ci95"].fillna(0).to_numpy(dtype=float)
            lower = np.minimum(half, np.maximum(mean, 0))  # an RMSE, a ratio or a time is never below zero
            ax.errorbar(
                x,
                mean,
                yerr=[lower, half],
                marker="o",
                capsize=3,
                label=legend or "FastSLAM",
                linestyle="none" if unordered else "-",
            )  # no line between unordered categories
    for ax, (metric, title, lines, log) in zip(axes, plotted):
        if metric == "ate_rmse" and "reckoning_ate_rmse" in summary:
            ax.axhline(summary["reckoning_ate_rmse"].mean(), color="0.5", linestyle="--", label="dead reckoning")
        for value, text in lines.items():
            ax.axhline(value, color="0.4", linestyle=":", linewidth=1)
            ax.annotate(text, (0.01, value), xycoords=("axes fraction", "data"), fontsize=7, color="0.3", va="bottom")
        ax.set_ylabel(title, fontsize=9)
        ax.set_title(title.replace(" (log)", ""), fontsize=10)
        ax.set_xlabel(axis_label(key, values), fontsize=8)
        if log:
            ax.set_yscale("log")
        elif not metric.startswith("optimum"):
            ax.set_ylim(bottom=0)
        if categorical:
            labels = tick_labels(values)
            long = max(len(label) for label in labels) > 6
            ax.set_xticks(range(len(values)), labels, fontsize=8, rotation=30 if long else 0)
            ax.set_xlim(-0.5, len(values) - 0.5)
        elif summary[key].min() > 0 and summary[key].max() / summary[key].min() >= 20:
            ax.set_xscale("log")
            ax.set_xticks(values, [f"{v:g}" for v in values], fontsize=8)
            ax.minorticks_off()
        else:
            ax.set_xticks(values, [f"{v:g}" for v in values], fontsize=8)
        ax.grid(alpha=0.3)
    handles, labels = [], []
    for ax in axes[: len(plotted)]:
        for handle, text in zip(*ax.get_legend_handles_labels()):
            if text not in labels:
                handles.append(handle)
                labels.append(text)
    seeds = table.seed.nunique()
    fig.suptitle(
        f"{name or out_dir.name}: FastSLAM against {short_name(key)}, {seeds} seeds "
        f"(mean over seeds, bars: 95 % CI clipped at 0; NEES: median and quartiles)",
        fontsize=11,
    )
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5), fontsize=8)
    path = out_dir / f"plot_{short_name(key)}.png"
    with written_whole(path) as temporary:
        fig.savefig(temporary, dpi=100)
    return path


def _maps_side_by_side(
    table: pd.DataFrame, keys: list[str], out_dir: Path, limit: int = 8, name: str = ""
) -> Path | None:
    """The first seed's final map (aligned) of each grid cell, up to ``limit`` cells."""
    first = table[table.seed == table.seed.min()].drop_duplicates(subset=keys)[:limit]
    files = [out_dir / MAPS / f"{run}.json" for run in first.run_id]
    if not files or not all(f.exists() for f in files):
        return None
    columns = min(len(files), 4)
    rows = math.ceil(len(files) / columns)
    fig = file_figure(figsize=(3.6 * columns, 3.6 * rows + 0.9), layout="constrained")
    axes = fig.subplots(rows, columns, squeeze=False)
    for ax, file, (_, row) in zip(axes.flat, files, first.iterrows()):
        drawing = json.loads(file.read_text())
        draw_walls(ax, np.asarray(drawing["walls"], float), linewidth=0.8)
        truth = np.asarray(drawing["truth"], float)
        ax.plot(truth[:, 0], truth[:, 1], color="tab:green", linewidth=0.8, label="true path")
        mean_path = np.asarray(drawing["trajectory"], float)
        ax.plot(mean_path[:, 0], mean_path[:, 1], color="tab:blue", linewidth=0.8, label="FastSLAM mean path (aligned)")
        if drawing["landmarks"]:
            marks = np.asarray(drawing["landmarks"], float)
            ax.plot(marks[:, 0], marks[:, 1], "+", color="tab:purple", markersize=6, label="landmarks (aligned)")
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        setting = ", ".join(setting_text(k, row[k], list(table[k].unique())) for k in keys)
        ax.set_title(
            f"{setting}\nATE RMSE {row.ate_rmse:.1f} mm as estimated, {row.ate_aligned_rmse:.1f} mm aligned",
            fontsize=8,
        )
    for ax in axes[-1]:
        ax.set_xlabel("x [m]", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("y [m]", fontsize=8)
    for ax in list(axes.flat)[len(files) :]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=8)
    fig.suptitle(
        f"{name or out_dir.name}: final map of seed {table.seed.min()}, one per grid cell, "
        "drawn after the best rigid alignment to the truth",
        fontsize=10,
    )
    path = out_dir / "maps.png"
    with written_whole(path) as temporary:
        fig.savefig(temporary, dpi=110)
    return path
