"""``masonry`` CLI processes for the multi-process tests, started so that no outcome depends on machine speed.

A ``masonry`` process spends its first seconds importing (8-35 s measured on a loaded 2-core machine, load 9):
started at a step of a running mission (a handler restarted, a mission control resumed), that import raced the
mission's own windows (the rejoin window, the handlers' patience with a silent mission control), and lost under
load. :func:`spawn` imports first and then waits on stdin; :meth:`Cli.go` lets it run. So a process is started
ahead (with the others, before any clock runs) and let go at the step, which then costs only its connecting.

Every wait here ends on an event: the line looked for, or the process's exit (its stderr closing), whichever
comes first; a process that exits without the line fails at once, with its output. :data:`HANG_GUARD_S` only
bounds a process that hangs without exiting.
"""

from __future__ import annotations

import queue
import socket
import subprocess
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path

#: Imports, says so on stderr, then runs the CLI when a line comes on stdin (exits 3 on a closed stdin).
PRELOADED = (
    "import sys\n"
    "from masonry.cli import main\n"
    "print('imported: waiting for go', file=sys.stderr, flush=True)\n"
    "sys.exit(3) if not sys.stdin.readline() else main()\n"
)
#: Wall seconds after which a wait gives up on a process that neither printed the line nor exited: a hang guard
#: only, far beyond anything legitimate (every process here ends on its own timeouts: mission control's
#: --max-time, startup and heartbeat timeouts, a handler's --wait; a whole mission takes under 30 s unloaded).
HANG_GUARD_S = 900.0


@dataclass
class Cli:
    """A ``masonry`` process: its stderr lines as they come (``lines``, None at its end) and all of both streams."""

    popen: subprocess.Popen[str]
    lines: queue.Queue[str | None] = field(default_factory=queue.Queue)
    out: list[str] = field(default_factory=list)
    err: list[str] = field(default_factory=list)
    pumps: list[threading.Thread] = field(default_factory=list)

    @property
    def returncode(self) -> int | None:
        return self.popen.returncode

    def go(self) -> None:
        """Wait for the import to be done, then let the CLI run."""
        self.wait_line("imported: waiting for go", [])
        assert self.popen.stdin is not None
        self.popen.stdin.write("go\n")
        self.popen.stdin.close()

    def wait_line(self, text: str, seen: list[str]) -> str:
        """The next stderr line holding ``text`` (lines read on the way go to ``seen``); fails at once if the
        process ends first."""
        while True:
            try:
                line = self.lines.get(timeout=HANG_GUARD_S)
            except queue.Empty:
                raise AssertionError(
                    f"hung: no line with {text!r}, no exit in {HANG_GUARD_S:.0f} s"
                ) from None
            if line is None:
                self.popen.wait(timeout=HANG_GUARD_S)
                raise AssertionError(
                    f"exited ({self.popen.returncode}) before a line with {text!r}; its last lines:\n"
                    + "".join(self.err[-30:])
                )
            seen.append(line)
            if text in line:
                return line

    def finish(self) -> tuple[str, str]:
        """Wait for the process to end on its own (see :data:`HANG_GUARD_S`): its stdout and stderr."""
        self.popen.wait(timeout=HANG_GUARD_S)
        for t in self.pumps:
            t.join(timeout=HANG_GUARD_S)
        return "".join(self.out), "".join(self.err)

    def kill(self) -> None:
        if self.popen.poll() is None:
            self.popen.kill()
        self.popen.wait()


def spawn(*args: str) -> Cli:
    """``masonry ARGS`` imported and waiting for :meth:`Cli.go`; both streams read by threads (a pipe left
    unread would block its writer)."""
    p = subprocess.Popen(
        [sys.executable, "-c", PRELOADED, *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    cli = Cli(p)

    def pump_out() -> None:
        assert p.stdout is not None
        for line in p.stdout:
            cli.out.append(line)

    def pump_err() -> None:
        assert p.stderr is not None
        for line in p.stderr:
            cli.err.append(line)
            cli.lines.put(line)
        cli.lines.put(None)

    cli.pumps = [threading.Thread(target=f, daemon=True) for f in (pump_out, pump_err)]
    for t in cli.pumps:
        t.start()
    return cli


CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def free_port() -> int:
    """A TCP port on the loopback free now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def spawn_fly(role: str, name: str, endpoint: str, mission: str, *extra: str, wait_s: int = 30) -> Cli:
    """``masonry fly --mission`` of the case study's ``role`` UAV ``name`` (simulated, JSON out), imported and
    waiting for :meth:`Cli.go`; ``extra`` options after the common ones."""
    return spawn(
        "fly",
        "--uav",
        role,
        "--name",
        name,
        "--sim",
        "--blueprint",
        str(CASE_STUDY),
        "--mission",
        endpoint,
        "--listen",
        f"tcp/127.0.0.1:{free_port()}",
        "--mission-name",
        mission,
        "--wait",
        str(wait_s),
        "--format",
        "json",
        *extra,
    )
