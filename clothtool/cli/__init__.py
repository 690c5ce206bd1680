"""The ``clothtool`` command line: a thin layer over the library (parse, call, print)."""

from __future__ import annotations

import click

from clothtool import __version__
from clothtool.cli.bake import bake
from clothtool.cli.batch import batch
from clothtool.cli.common import OneLineErrorGroup, route_library_warnings
from clothtool.cli.cook import cook
from clothtool.cli.inspect import inspect
from clothtool.cli.study import study
from clothtool.cli.warmup import warmup


@click.group(cls=OneLineErrorGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="clothtool")
def main() -> None:
    """Cook garment meshes into fabrics and bake fabrics into HDF5/USD caches."""
    route_library_warnings()


main.add_command(cook)
main.add_command(bake)
main.add_command(inspect)
main.add_command(study)
main.add_command(batch)
main.add_command(warmup)
