"""Progress of a long ``masonry sim`` on stderr: a rich bar with an ETA on a terminal, a plain line every few
seconds elsewhere (a log, CI, a pipe), so that a 20-minute simulation is never silent. Never on stdout."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

#: Wall seconds between two progress lines when stderr is not a terminal.
LINE_INTERVAL_S = 5.0

ProgressFn = Callable[[int, int, float], None]


def _duration(seconds: float) -> str:
    seconds = max(0.0, seconds)
    if seconds < 60.0:
        return f"{seconds:.0f} s"
    if seconds < 3600.0:
        return f"{seconds // 60:.0f} min {seconds % 60:02.0f} s"
    return f"{seconds // 3600:.0f} h {seconds % 3600 // 60:02.0f} min"


class ProgressLines:
    """``progress(done, total, sim_s)`` printing one line every ``interval_s`` wall seconds, with an ETA.

    The ETA is the wall time per completed task so far times the tasks left (none before the first completion).
    ``clock`` is injected (``time.monotonic`` by default) so that tests need no sleeps.
    """

    def __init__(
        self,
        stream: TextIO | None = None,
        *,
        interval_s: float = LINE_INTERVAL_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.stream = stream
        self.interval_s = interval_s
        self.clock = clock
        self._start = clock()
        self._last = self._start
        self._first_done: tuple[int, float] | None = None  # (done, wall) when the count first moved

    def line(self, done: int, total: int, sim_s: float) -> str:
        """The progress line for this state (wall time read from the clock)."""
        now = self.clock()
        elapsed = now - self._start
        eta = "ETA unknown"
        if done >= total:
            eta = "ETA 0 s"
        elif done > 0:
            eta = f"ETA {_duration(elapsed / done * (total - done))}"
        return (
            f"sim: {done}/{total} task{'' if total == 1 else 's'} done, simulated {sim_s:.0f} s, "
            f"{_duration(elapsed)} elapsed, {eta}"
        )

    def __call__(self, done: int, total: int, sim_s: float) -> None:
        now = self.clock()
        if now - self._last < self.interval_s:
            return
        self._last = now
        stream = self.stream if self.stream is not None else sys.stderr
        stream.write(self.line(done, total, sim_s) + "\n")
        stream.flush()


def progress_display(
    mode: bool | None, *, stderr_tty: bool | None = None, clock: Callable[[], float] = time.monotonic
) -> tuple[ProgressFn | None, Callable[[], None]]:
    """The progress callback and its finish function for ``masonry sim``.

    ``mode`` is ``--progress/--no-progress``: True prints the plain lines every few seconds (even on a terminal:
    for a log), False nothing, None (the default) the rich bar on a terminal and the lines when stderr is not
    one. Both go to stderr only, so stdout stays the report (``--format json``).
    """
    tty = sys.stderr.isatty() if stderr_tty is None else stderr_tty
    if mode is False:
        return None, lambda: None
    if tty and mode is None:
        return _progress_bar()
    return ProgressLines(clock=clock, interval_s=LINE_INTERVAL_S), lambda: None


def _progress_bar() -> tuple[ProgressFn, Callable[[], None]]:
    """A rich progress bar on stderr: tasks done out of total, simulated time, elapsed and remaining wall time."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    bar = Progress(
        TextColumn("mission"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("sim {task.fields[t]:.0f} s"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=True,
    )
    state: dict[str, Any] = {}

    def update(done: int, total: int, now_s: float) -> None:
        if "id" not in state:
            bar.start()
            state["id"] = bar.add_task("mission", total=total, t=now_s)
        bar.update(state["id"], completed=done, t=now_s)

    def finish() -> None:
        if "id" in state:
            bar.stop()

    return update, finish
