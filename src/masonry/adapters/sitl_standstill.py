"""A SITL on this computer that the machine left unrun is not a silent autopilot (issue 29).

The MAVLink link watchdog (:mod:`masonry.adapters.link_silence`) counts the autopilot's silence on the local
clock up to when the receiver last listened. ArduCopter's SITL on a loaded machine is left runnable but unrun for
0.4-2.7 s of wall at a time (docs/performance/autopilots.md, "the autopilot stood still": its clock moved one
telemetry period across each such gap, the receiver listening all along); its clock, its heartbeats and its
simulated vehicle stop together, so nothing of the flight happened in that gap, yet the watchdog found "no
message for 1 s" and the UAV landed ("flight controller link lost"). The project's own SITL in lock-step does not
count a gap in which it was unrun (:data:`masonry.adapters.sitl_lockstep.UNRUN_S`); this is the same rule on the
client's side for an autopilot that is a process of this computer: the time that process waited for a CPU is
taken out of the silence (:meth:`Standstill.heard_until`). The kernel says it in two readings: the process's
state (``/proc/PID/stat``: ``R``, runnable, whether running or waiting for a CPU) and its CPU time
(``/proc/PID/schedstat``'s first field, in ns). Between two readings that both find it runnable and its CPU time
the same, it was runnable and never ran: a task that ran would have advanced its CPU time, and one that slept
must have run to go to sleep. (The kernel's own count of the wait, schedstat's second field, is added only
when the wait ends, so it cannot tell of a wait still going on.)

The autopilot is known to be such a process only over TCP on this computer's loopback (``tcp:127.0.0.1:PORT``,
as ArduCopter's SITL serves its MAVLink): the process other than this one holding a socket on PORT, found once
from ``/proc/net/tcp`` and the processes' open files (:func:`server_pid`). Anything else (a serial port, UDP, a
remote autopilot, a SITL in this very process, a system without ``/proc`` or scheduler statistics) takes
nothing out: the watchdog counts as before. A local process that really fell silent is counted in full: one
that hangs or is stopped (asleep, not waiting for a CPU), or has gone (its statistics unreadable); so is a
silence longer than :data:`~masonry.adapters.link_silence.RECEIVER_HUNG_S`. Nothing is widened: a SITL that was
run and said nothing for ``heartbeat_timeout_s`` is lost after ``heartbeat_timeout_s`` as before.

The readings are taken when the watchdog asks (each tick and each command); what is taken out is the sum of the
intervals between two consecutive readings inside the silence (from the first at or after the last message to
the last at or before what the receiver read) that found the process runnable and unrun, so it never exceeds the
time it stood unrun in the silence (a coarse sampling, or a process that got a CPU now and then, only counts
more of the silence).
"""

from __future__ import annotations

import ipaddress
import logging
import math
import os
import threading
from collections import deque
from collections.abc import Callable
from pathlib import Path

from masonry.adapters.link_silence import RECEIVER_HUNG_S
from masonry.adapters.link_silence import heard_until as receiver_heard_until

__all__ = ["Standstill", "loopback_tcp_port", "run_state", "server_pid", "unrun_stretches_s"]

#: Samples kept (at the watchdog's 20-50 Hz, well over RECEIVER_HUNG_S of them).
SAMPLES = 2048
#: A stretch unrun shorter than this (s) is not counted (see :func:`unrun_stretches_s`).
MIN_UNRUN_S = 0.05
#: A silence with more than this much of the process's wait taken out is logged (once a silence).
LOG_UNRUN_S = 0.5
_PROC = Path("/proc")
_log = logging.getLogger(__name__)


def loopback_tcp_port(url: str) -> int | None:
    """The port of a MAVLink URL ``tcp:HOST:PORT`` whose HOST is this computer's loopback; else None."""
    scheme, _, rest = url.partition(":")
    host, _, port = rest.rpartition(":")
    if scheme != "tcp" or not port.isdigit():
        return None
    if host != "localhost":
        try:
            if not ipaddress.ip_address(host.strip("[]")).is_loopback:
                return None
        except ValueError:
            return None
    return int(port)


def _socket_inodes(port: int, proc: Path) -> set[str]:
    """The inodes of the TCP sockets (IPv4 and IPv6) bound locally to ``port``: a server's listening and
    accepted sockets (a client's socket to it has ``port`` as its remote end, not its local one)."""
    inodes: set[str] = set()
    for table in ("tcp", "tcp6"):
        try:
            lines = (proc / "net" / table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 9 and int(fields[1].rsplit(":", 1)[1], 16) == port and fields[9] != "0":
                inodes.add(f"socket:[{fields[9]}]")
    return inodes


def server_pid(port: int, *, own_pid: int | None = None, proc: Path = _PROC) -> int | None:
    """The one process other than ``own_pid`` (this one) holding a TCP socket bound to ``port``; None if none,
    several, or no ``/proc`` to tell."""
    own = os.getpid() if own_pid is None else own_pid
    inodes = _socket_inodes(port, proc)
    if not inodes:
        return None
    found: set[int] = set()
    for entry in proc.iterdir() if proc.is_dir() else ():
        if not entry.name.isdigit() or int(entry.name) == own:
            continue
        try:
            for fd in (entry / "fd").iterdir():
                if os.readlink(fd) in inodes:
                    found.add(int(entry.name))
                    break
        except OSError:  # gone meanwhile, or not ours to read
            continue
    return found.pop() if len(found) == 1 else None


def run_state(pid: int, proc: Path = _PROC) -> tuple[bool, int] | None:
    """Process ``pid``'s main thread now: runnable (state ``R``: running or waiting for a CPU), and its CPU time
    (ns, ``/proc/PID/schedstat``'s first field); None when unreadable (gone, or no scheduler statistics)."""
    try:
        stat = (proc / str(pid) / "stat").read_text()
        cpu_ns = int((proc / str(pid) / "schedstat").read_text().split()[0])
        return stat[stat.rindex(")") + 2] == "R", cpu_ns  # the name, in parentheses, may hold anything
    except (OSError, ValueError, IndexError):
        return None


def unrun_stretches_s(samples: list[tuple[float, bool, int]]) -> float:
    """The seconds covered by stretches of consecutive readings ``(local s, runnable, CPU ns)`` that all find
    the process runnable with the same CPU time, each stretch counted if it lasts :data:`MIN_UNRUN_S` or more (a
    running process's CPU time is brought up to date at the scheduler's tick, 1-10 ms: a shorter flat stretch
    may have been run)."""
    total_s, start = 0.0, 0
    for i in range(1, len(samples) + 1):
        if i < len(samples) and samples[i][1] and samples[start][1] and samples[i][2] == samples[start][2]:
            continue
        span_s = samples[i - 1][0] - samples[start][0]
        total_s += span_s if span_s >= MIN_UNRUN_S else 0.0
        start = i
    return total_s


class Standstill:
    """The silence of a link's autopilot less the time its process (on this computer) waited for a CPU.

    Args:
        url: the link's MAVLink URL; only ``tcp:`` on the loopback names a local process.
        pid: the autopilot's process when known (a test); None: found from ``url`` at the first message heard.
        run_state: reads a process's state (runnable, CPU ns; None: unreadable), :func:`run_state` by default.
    """

    def __init__(
        self,
        url: str,
        *,
        pid: int | None = None,
        run_state: Callable[[int], tuple[bool, int] | None] = run_state,
    ) -> None:
        self.port = loopback_tcp_port(url)
        self.pid = pid
        self._looked = pid is not None or self.port is None
        self._run_state = run_state
        self.url = url
        self._samples: deque[tuple[float, bool, int]] = deque(maxlen=SAMPLES)  # (local s, runnable, CPU ns)
        self._lock = threading.Lock()  # the fly loop's and the commands' threads both ask
        self._logged_since = -math.inf  # the silence (its last message) last logged

    def heard_until(self, now_s: float, last_message_s: float, listened_s: float) -> float:
        """Up to when (local s) the autopilot could have spoken and the receiver has read all that arrived:
        :func:`masonry.adapters.link_silence.heard_until` less the time its process waited for a CPU since the
        last message (0 where it is no process of this computer)."""
        heard = receiver_heard_until(now_s, last_message_s, listened_s)
        return heard - self.unrun_s(now_s, last_message_s, heard)

    def unrun_s(self, now_s: float, since_s: float, until_s: float) -> float:
        """Seconds the autopilot's process stood runnable and unrun between ``since_s`` and ``until_s`` (local s),
        as far as the readings up to ``now_s`` tell (one is taken now); 0 when it cannot be told."""
        if not math.isfinite(since_s) or until_s - since_s > RECEIVER_HUNG_S:
            return 0.0
        with self._lock:
            pid = self._process()
            state = None if pid is None else self._run_state(pid)
            if pid is None or state is None:  # no local process, or it has gone: the silence counts in full
                self.pid = None
                self._samples.clear()
                return 0.0
            samples = self._samples
            if not samples or now_s > samples[-1][0]:
                samples.append((now_s, *state))
            while len(samples) > 1 and samples[0][0] < since_s:
                samples.popleft()  # the last message only moves on: what came before it is not needed
            inside = [x for x in samples if since_s <= x[0] <= until_s]
            unrun = unrun_stretches_s(inside)
            if unrun > LOG_UNRUN_S and since_s != self._logged_since:
                self._logged_since = since_s
                _log.warning(
                    "MAVLink watchdog on %s: the autopilot's process (pid %d) waited %.2f s for a CPU in the %.2f s "
                    "since its last message: not counted as its silence",
                    self.url, pid, unrun, now_s - since_s,
                )  # fmt: skip
            return unrun

    def _process(self) -> int | None:
        if not self._looked and self.port is not None:
            self._looked = True  # once, at the first message heard: the server is up and connected then
            self.pid = server_pid(self.port)
        return self.pid
