"""``mazeslam sweep``: a grid of simulator and filter settings run over seeds (locally or on a Dask
cluster), into one table, its summary and the report (``mazeslam report``).

SIGTERM and Ctrl-C stop a sweep promptly and cleanly (``stop_on_signals``): its workers end, the
finished runs stay in ``runs.jsonl``, the folder's lock is released, one line says so, and the
command exits with 143 (SIGTERM) or 130 (SIGINT); the same command then resumes it.
"""

from __future__ import annotations

from pathlib import Path

import click

from mazeslam.cli.side_process import Interrupted, stop_on_signals
from mazeslam.core.outputs import prepare_output_folder


@click.command()
@click.argument("sweep_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Results folder; runs already in it are not run again (resume).",
)
@click.option("--workers", type=click.IntRange(min=1), help="Local worker processes [default: one per core].")
@click.option("--scheduler", help="Run on the Dask cluster at this address instead, e.g. tcp://host:8786.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
def sweep(sweep_file, out_dir, workers, scheduler, quiet):
    """Run a grid of simulator and filter settings over seeds; write one table and its summary."""
    from mazeslam.sweeps.report import make_report
    from mazeslam.sweeps.runner import RESULTS, load_sweep, run_sweep

    definition = load_sweep(sweep_file)
    prepare_output_folder(out_dir)
    try:
        with stop_on_signals():
            result = run_sweep(definition, out_dir, workers, scheduler, progress=not quiet)
    except Interrupted as stop:
        click.echo(
            ("" if quiet else "\n")  # after the progress bar's line
            + f"{definition.name}: interrupted ({stop.signal_name}); the finished runs are kept in "
            f"{out_dir / RESULTS}: the same command resumes the sweep",
            err=True,
        )
        raise
    for problem in result.skipped:
        click.echo(f"warning: {problem}", err=True)
    click.echo(
        f"{definition.name}: {len(result.table)} runs ({result.ran} run now in {result.seconds:.1f} s, "
        f"{result.reused} already in {out_dir})"
    )
    click.echo((out_dir / "summary.md").read_text())
    click.echo("wrote " + ", ".join(str(p) for p in [*result.paths.values(), *make_report(out_dir)[1:]]))
