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
    """Summarise a fabric (.fabric.h5) or a cache (.usdc/.usda/.usd, .h5).

    Exit code 1 when the file is missing, not a clothtool file, truncated or invalid.

    \b
    Examples:
      clothtool inspect skirt.fabric.h5 --json
      clothtool inspect skirt.usdc
    """
    from clothtool.summary import summarize_file

    summary, text = summarize_file(path)
    if as_json:
        emit_json(summary)
    else:
        click.echo(text)
