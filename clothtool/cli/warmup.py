"""``clothtool warmup``: fill (or clear) the kernel cache."""

from __future__ import annotations

import time

import click

from clothtool.cli.common import handle_errors


@click.command()
@click.option("--clear", is_flag=True, help="Remove the kernel cache (every key's directory) instead of filling it.")
@handle_errors
def warmup(clear: bool) -> None:
    """Compile every kernel variant into the kernel cache, so later cooks and bakes load them.

    Run it once where compiled kernels should persist, e.g. when a CI image or render node is
    built. The cache is $CLOTHTOOL_CACHE_DIR, else the user cache directory
    (~/.cache/clothtool/numba on Linux), in a sub-directory keyed by numba, Python, the CPU
    and the contents of clothtool's sources: an edit or an upgrade starts a new one.

    \b
    Examples:
      clothtool warmup
      CLOTHTOOL_CACHE_DIR=/opt/ci/cache clothtool warmup
      clothtool warmup --clear
    """
    from clothtool import _kernel_cache

    if clear:
        click.echo(f"removed the kernel cache {_kernel_cache.clear_cache()}")
        return
    directory = _kernel_cache.usable_key_directory()
    if directory is None:
        raise click.ClickException(
            f"the kernel cache cannot be written, so warming it up would keep nothing; set {_kernel_cache.CACHE_DIR_ENV} "
            "to a writable directory"
        )
    from clothtool.warmup import warm_up_kernels

    cpu0 = time.process_time()
    count = 0

    def report(label: str, seconds: float) -> None:
        nonlocal count
        count += 1
        click.echo(f"  {label:<64} {seconds:7.2f} s")

    click.echo(f"kernel cache {directory}")
    total = warm_up_kernels(report)
    click.echo(f"warmed up {count} solver variants in {total:.2f} s ({time.process_time() - cpu0:.2f} s CPU)")
