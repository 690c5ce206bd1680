"""Bake progress on stderr: a rich bar on a terminal, plain timed lines in a log.

A farm job's stderr is a file: a bar there is either nothing or a pile of escape codes, so
with ``--progress`` and no terminal the bake prints one plain line every few seconds
(``CLOTHTOOL_PROGRESS_INTERVAL``, default 10 s), always including the first and the last frame:

    bake walk.toml: frame 24/48 (50%), 61.2 frames/s, ETA 0:00:01
"""

from __future__ import annotations

import contextlib
import datetime
import math
import os
import sys
import time
from typing import Callable, TextIO

import click

INTERVAL_ENV = "CLOTHTOOL_PROGRESS_INTERVAL"
DEFAULT_INTERVAL_S = 10.0

ProgressCallback = Callable[[int, int], None]


def progress_interval() -> float:
    """Seconds between plain progress lines: ``CLOTHTOOL_PROGRESS_INTERVAL`` or the default."""
    text = os.environ.get(INTERVAL_ENV, "").strip()
    if not text:
        return DEFAULT_INTERVAL_S
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not math.isfinite(seconds) or seconds < 0:
        raise click.UsageError(f"{INTERVAL_ENV}='{text}' is not a number of seconds >= 0; set it to e.g. 10")
    return seconds


def _clock_text(seconds: float) -> str:
    return str(datetime.timedelta(seconds=round(seconds)))


class LogProgress:
    """Writes ``LABEL: frame DONE/TOTAL (P%), R frames/s, ETA H:MM:SS`` lines to ``stream``.

    The rate is the mean since the first frame (the JIT warm-up is over by then), so the ETA
    does not jump with one slow frame. ``clock`` is injectable so tests need not sleep.
    """

    def __init__(self, label: str, interval_s: float, stream: TextIO, clock: Callable[[], float] = time.monotonic):
        self.label = label
        self.interval_s = interval_s
        self.stream = stream
        self.clock = clock
        self._first: tuple[int, float] | None = None  # (frames done, time) at the first report
        self._last_line = -math.inf

    def __call__(self, done: int, total: int) -> None:
        now = self.clock()
        if self._first is None:
            self._first = (done, now)
        elif done < total and now - self._last_line < self.interval_s:
            return
        self._last_line = now
        self.stream.write(self.line(done, total, now) + "\n")
        self.stream.flush()  # a log tailed by a farm monitor must see each line as it comes

    def line(self, done: int, total: int, now: float) -> str:
        percent = 100 * done // total if total else 100
        text = f"{self.label}: frame {done}/{total} ({percent}%)"
        first_done, first_time = self._first
        elapsed = now - first_time
        if done > first_done and elapsed > 0:
            rate = (done - first_done) / elapsed
            text += f", {rate:.1f} frames/s"
            text += f", done in {_clock_text(elapsed)}" if done >= total else f", ETA {_clock_text((total - done) / rate)}"
        return text


@contextlib.contextmanager
def progress_bar(enabled: bool):
    """A rich progress bar on stderr when ``enabled``; yields a progress callback (or None)."""
    if not enabled:
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    with Progress(
        "[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
        console=Console(file=sys.stderr), transient=True,
    ) as progress:
        task = progress.add_task("baking", total=None)

        def update(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        yield update


@contextlib.contextmanager
def bake_progress(requested: bool | None, label: str):
    """Yield the bake's progress callback, or None for no progress.

    ``requested`` is ``--progress/--no-progress`` (None when not given): by default a bar
    when stderr is a terminal and nothing otherwise; ``--progress`` without a terminal
    gives plain timed lines.
    """
    terminal = sys.stderr.isatty()
    if requested is False or (requested is None and not terminal):
        yield None
    elif terminal:
        with progress_bar(True) as update:
            yield update
    else:
        yield LogProgress(label, progress_interval(), sys.stderr)
