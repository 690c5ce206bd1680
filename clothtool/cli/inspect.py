"""``clothtool inspect``: summarise a fabric or a cache file."""

from __future__ import annotations

from pathlib import Path

import click

from clothtool.cli.common import emit_json, handle_errors


@click.command()
@click.argument("path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@handle_errors
def inspect(path: Path, as_json: bool) -> None:
    """Summarise a fabric (.fabric.h5).

    Exit code 1 when the file is missing, not a clothtool file, truncated or invalid.

    \b
    Example:
      clothtool inspect skirt.fabric.h5 --json
    """
    from clothtool.io.fabric_file import read_fabric
    from clothtool.summary import fabric_summary, format_fabric_summary

    fabric = read_fabric(path)
    summary = fabric_summary(fabric)
    if as_json:
        emit_json(summary)
    else:
        click.echo(format_fabric_summary(summary, path.name))
