"""Shared command-line plumbing: error handling, output helpers, option parsers.

Library errors become one ``Error: ...`` line and exit code 1 here, at the CLI boundary,
and nowhere else.
"""

from __future__ import annotations

import functools
import json
import os
import sys
import warnings

import click

from clothtool.errors import ClothtoolError


def handle_errors(func):
    """Turn ClothtoolError (and unexpected failures) into one line and exit code 1."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except ClothtoolError as exc:
            raise click.ClickException(str(exc)) from None
        except KeyboardInterrupt:
            raise click.Abort() from None
        except click.exceptions.ClickException:
            raise
        except click.exceptions.Exit:
            raise
        except Exception as exc:
            if os.environ.get("CLOTHTOOL_DEBUG"):
                raise
            first = str(exc).splitlines()[0] if str(exc) else ""
            raise click.ClickException(
                f"internal error ({type(exc).__name__}: {first}); rerun with CLOTHTOOL_DEBUG=1 and report the traceback"
            ) from None

    return wrapper


def warn(line: str) -> None:
    click.echo(line if line.split(":", 1)[0] else f"warning: {line}", err=True)


def route_library_warnings() -> None:
    """Show warnings raised by clothtool's library code (e.g. the kernel cache being
    unusable) as one ``warning: ...`` line on stderr, like the CLI's own warnings, instead of
    Python's two-line ``file:line: Category`` form. Matched by the category's module so that
    nothing heavy (numba) is imported to know the classes; other warnings are left alone."""
    show_other = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if category.__module__.split(".", 1)[0] == "clothtool":
            warn(f"warning: {message}")
        else:
            show_other(message, category, filename, lineno, file, line)

    warnings.showwarning = show


def emit_json(data) -> None:
    click.echo(json.dumps(data, indent=2, sort_keys=True))


def float_list(count: int | None = None):
    """A click callback parsing 'a,b,c' into a tuple of floats (of ``count`` values)."""

    def parse(ctx, param, value):
        if value is None:
            return None
        try:
            numbers = tuple(float(v) for v in value.split(","))
        except ValueError:
            raise click.BadParameter(f"'{value}' is not a comma-separated list of numbers") from None
        if count is not None and len(numbers) != count:
            raise click.BadParameter(f"expected {count} comma-separated numbers, got {len(numbers)}")
        return numbers

    return parse


def stderr_is_terminal() -> bool:
    return sys.stderr.isatty()
