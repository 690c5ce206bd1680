"""Shared command-line plumbing: error handling, output helpers, option parsers.

Library errors become one ``Error: ...`` line and exit code 1 here, at the CLI boundary,
and nowhere else.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import signal
import sys
import threading
import warnings

import click

from clothtool.errors import ClothtoolError, UsageError


def one_line(text: str) -> str:
    """``text`` as one printable line: control characters from the input (a raw CR, a newline,
    escape sequences, undecodable bytes) are shown escaped instead of splitting or garbling it."""
    out = []
    for char in str(text):
        code = ord(char)
        if char == "\n":
            out.append("\\n")
        elif char == "\r":
            out.append("\\r")
        elif char == "\t":
            out.append("\\t")
        elif code < 0x20 or code == 0x7F or 0x80 <= code < 0xA0:
            out.append(f"\\x{code:02x}")
        elif 0xDC80 <= code <= 0xDCFF:  # an undecodable byte kept by the surrogateescape handler
            out.append(f"\\x{code - 0xDC00:02x}")
        else:
            out.append(char)
    return "".join(out)


class CommandError(click.ClickException):
    """One ``Error: ...`` line on stderr and exit code 1."""

    def __init__(self, message: str):
        super().__init__(one_line(message))


class CommandUsageError(CommandError):
    """One ``Error: ...`` line on stderr and exit code 2: the command was asked for something
    it cannot do."""

    exit_code = 2


class OneLineErrorGroup(click.Group):
    """A command group whose usage errors (bad option values, unknown options, missing
    arguments) are one ``Error:`` line and exit code 2, like every other error, instead of
    click's usage block: farm logs and CI parsers read one line."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except click.UsageError as exc:
            where = exc.ctx.command_path if exc.ctx is not None else ctx.command_path
            raise CommandUsageError(f"{exc.format_message()} (see '{where} --help')") from None


class Interrupted(KeyboardInterrupt):
    """A termination signal (SIGTERM, SIGINT) turned into Ctrl-C's control flow, so that the
    same cleanup runs: partial file of whole frames, no temporary file, exit code 1."""

    def __init__(self, signal_name: str):
        super().__init__(signal_name)
        self.signal_name = signal_name


_HANDLED_SIGNALS = ("SIGTERM", "SIGINT")
_received: list[str] = []  # signals received while the current command runs


@contextlib.contextmanager
def signals_interrupt():
    """While the command runs, SIGTERM (what timeout, schedulers and systemd send) and SIGINT
    raise Interrupted. Signals after the first are ignored so the cleanup it starts can finish."""
    if threading.current_thread() is not threading.main_thread():  # only the main thread may set handlers
        yield
        return

    def handler(number, frame):
        if _received:
            return
        _received.append(signal.Signals(number).name)
        raise Interrupted(_received[0])

    print_unraisable = sys.unraisablehook

    def unraisable(info):
        # The signal landed in a destructor: say nothing, raise_if_interrupted raises it again.
        if not isinstance(info.exc_value, Interrupted):
            print_unraisable(info)

    previous = {}
    for name in _HANDLED_SIGNALS:
        number = getattr(signal, name, None)
        if number is not None:
            previous[number] = signal.signal(number, handler)
    sys.unraisablehook = unraisable
    try:
        yield
    finally:
        for number, old in previous.items():
            signal.signal(number, signal.SIG_DFL if old is None else old)  # None: set outside Python
        sys.unraisablehook = print_unraisable
        _received.clear()


def raise_if_interrupted() -> None:
    """Raise Interrupted if a signal came. The handler raises at once, but where it lands in a
    destructor or a weakref callback Python only prints the exception: checked once per frame,
    such a signal still ends the bake a frame later."""
    if _received:
        raise Interrupted(_received[0])


def kept_note(exc: BaseException) -> str:
    """"; kept N frames in PATH" when the failed run kept a partial file, else ""."""
    kept = getattr(exc, "kept", None)
    if not kept:
        return ""
    path, frames = kept
    return f"; kept {frames} frame{'s' if frames != 1 else ''} in {path}"


def interrupted_message(exc: KeyboardInterrupt) -> str:
    """One line for an interrupted command, e.g. ``interrupted (SIGTERM) at frame 37; kept 36
    frames in out/x.partial.h5``."""
    name = exc.signal_name if isinstance(exc, Interrupted) else "SIGINT"
    frame = getattr(exc, "frame", None)
    where = f" at frame {frame}" if frame is not None else ""
    return f"interrupted ({name}){where}" + (kept_note(exc) or "; no output written")


def handle_errors(func):
    """Turn ClothtoolError (and unexpected failures) into one line and exit code 1 (2 for a
    UsageError); a termination signal (SIGTERM, SIGINT) ends the command the same way."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            with signals_interrupt():
                return func(*args, **kwargs)
        except UsageError as exc:
            raise CommandUsageError(str(exc)) from None
        except ClothtoolError as exc:
            raise CommandError(str(exc) + kept_note(exc)) from None
        except KeyboardInterrupt as exc:
            raise CommandError(interrupted_message(exc)) from None
        except click.exceptions.ClickException:
            raise
        except click.exceptions.Exit:
            raise
        except Exception as exc:
            if os.environ.get("CLOTHTOOL_DEBUG"):
                raise
            first = str(exc).splitlines()[0] if str(exc) else ""
            raise CommandError(
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
