"""``mazeslam report``: a sweep's results folder (``mazeslam sweep``) as Markdown tables and plots."""

from __future__ import annotations

from pathlib import Path

import click


@click.command()
@click.argument("out_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
def report(out_dir):
    """Turn a sweep's results folder into Markdown tables and plots."""
    from mazeslam.sweeps.report import make_report

    click.echo("wrote " + ", ".join(str(p) for p in make_report(out_dir)))
