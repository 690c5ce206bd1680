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
    """Summarise a fabric (.fabric.h5), a cache (.usdc/.usda/.usd, .h5) or a batch manifest
    (.json: one line per job).

    Exit code 1 when the file is missing, not a clothtool file, truncated or invalid.

    \b
    Examples:
      clothtool inspect skirt.fabric.h5 --json
      clothtool inspect skirt.usdc
      clothtool inspect caches/manifest.json
    """
    if path.suffix.lower() == ".json":
        from clothtool.batch.manifest import load_manifest_document
        from clothtool.batch.table import format_manifest_table

        document = load_manifest_document(path)
        emit_json(document) if as_json else click.echo(format_manifest_table(document))
        return
    from clothtool.summary import summarize_file

    summary, text = summarize_file(path)
    if as_json:
        emit_json(summary)
    else:
        click.echo(text)
