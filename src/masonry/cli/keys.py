"""Operator keys in ``masonry sim --serve``'s terminal: the page's buttons without the page (docs/observe.md).

``p`` pause, ``r`` resume, ``h`` return-all (home), ``a`` abort, ``1``..``9`` recall the fleet's n-th UAV. Each
goes to mission control's operator desk (:meth:`masonry.mission.operator.Operator.submit`) and its answer is
printed on stderr. Only when stdin is a terminal: the terminal is put in cbreak mode (keys without Enter,
Ctrl-C still interrupts) and restored when the mission ends.
"""

from __future__ import annotations

import os
import select
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

#: Key -> the command it sends (recall: the digits).
KEYS = {"p": "pause", "r": "resume", "h": "return-all", "a": "abort"}


class TerminalKeys:
    """Reads operator keys from the terminal in a thread while a mission runs (a context manager).

    Args:
        operator: mission control's :class:`~masonry.mission.operator.Operator`.
        fleet: the UAV names, in order (``1`` recalls the first).
        echo: prints one line (the answer).
        fd: the terminal's file descriptor (default: stdin's).
    """

    def __init__(
        self, operator: Any, fleet: Sequence[str], echo: Callable[[str], None], fd: int | None = None
    ) -> None:
        self.operator = operator
        self.fleet = list(fleet)
        self.echo = echo
        self.fd = sys.stdin.fileno() if fd is None else fd
        self._saved: Any = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def command_for(self, key: str) -> dict[str, Any] | None:
        """The command a key sends (None: not a key of ours)."""
        if key in KEYS:
            return {"command": KEYS[key]}
        if key.isdigit() and 1 <= int(key) <= len(self.fleet):
            return {"command": "recall", "uav": self.fleet[int(key) - 1]}
        return None

    def __enter__(self) -> TerminalKeys:
        if not os.isatty(self.fd):
            return self
        import termios
        import tty

        self._saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd)
        recall = ", ".join(f"{i + 1} {n}" for i, n in enumerate(self.fleet[:9]))
        self.echo(f"keys: p pause, r resume, h return all, a abort, recall: {recall}")
        self._thread = threading.Thread(target=self._read, name="masonry-keys", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        if self._saved is not None:
            import termios

            termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)
            self._saved = None

    def _read(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self.fd], [], [], 0.2)
            if not ready:
                continue
            try:
                data = os.read(self.fd, 16)
            except OSError:
                return
            if not data:
                return
            for key in data.decode(errors="ignore"):
                command = self.command_for(key)
                if command is not None:
                    self.operator.submit(command, self._answer(command))

    def _answer(self, command: dict[str, Any]) -> Callable[[Any], None]:
        what = f"{command['command']}{' ' + command['uav'] if 'uav' in command else ''}"

        def answer(outcome: Any) -> None:
            self.echo(f"{what}: accepted" if outcome.accepted else f"{what}: refused ({outcome.reason})")

        return answer


__all__ = ["KEYS", "TerminalKeys"]
