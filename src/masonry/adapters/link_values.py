"""Values around :class:`~masonry.adapters.mavlink_link.MavlinkLink`: the autopilot's clock seen from this computer
(:class:`LinkClock`), the link's counters (:class:`LinkStatus`), the MAVLink 2 signing key's reader and the
autopilot's STATUSTEXT log (:func:`add_status_text`)."""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from masonry.errors import InputError

if TYPE_CHECKING:
    import os


#: A received STATUSTEXT: (local time s, severity, text, MAVLink 2 ``id``: 0 for a text in one message).
StatusText = tuple[float, int, str, int]


def add_status_text(texts: list[StatusText] | None, msg: object, now_s: float, keep: int = 20) -> None:
    """Add STATUSTEXT ``msg`` to ``texts``, keeping the last ``keep``; a continuation of a longer text (the same
    non-zero ``id``, ``chunk_seq`` > 0: PX4 splits texts past 50 characters, "Arming denied: Resolve system health
    failures firs" + "t") is joined to the text it continues."""
    if texts is None:
        return
    text = str(getattr(msg, "text", "")).rstrip("\x00")
    text_id, chunk = int(getattr(msg, "id", 0) or 0), int(getattr(msg, "chunk_seq", 0) or 0)
    if text_id and chunk > 0 and texts and texts[-1][3] == text_id:
        t_s, severity, before, _ = texts[-1]
        texts[-1] = (t_s, severity, before + text, text_id)
        return
    texts.append((now_s, int(getattr(msg, "severity", 6)), text, text_id))
    del texts[:-keep]


def load_signing_key(path: str | os.PathLike[str]) -> bytes:
    """Read a MAVLink 2 signing key: 32 raw bytes, 64 hex digits, or a passphrase (SHA-256, as MAVProxy does).

    Raises:
        InputError: the file is missing or empty.
    """
    import hashlib

    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(f"{p}: cannot read signing key: {exc.strerror or exc}") from exc
    if len(raw) == 32:
        return raw
    text = raw.decode("utf-8", errors="replace").strip()
    if not text:
        raise InputError(f"{p}: signing key file is empty")
    if len(text) == 64 and all(ch in "0123456789abcdefABCDEF" for ch in text):
        return bytes.fromhex(text)
    return hashlib.sha256(text.encode("utf-8")).digest()


#: The farthest (s of the autopilot's clock) :meth:`LinkClock.now_s` extrapolates past the latest time-stamped
#: message, at the rate measured: 15 periods of the 30 Hz telemetry masonry asks for, two of a 4 Hz stream.
EXTRAPOLATION_HORIZON_S = 0.5
#: How long (s of this computer's clock) after the latest time-stamped message :meth:`LinkClock.now_s` holds
#: before it runs on this computer's clock: the MAVLink link watchdog's default ``heartbeat_timeout_s`` (the link
#: passes its own), so the clock holds while the watchdog holds the link alive.
HOLD_S = 1.0
#: How far back (s of this computer's clock) :attr:`LinkClock.rate` is measured: 60 messages of the 30 Hz
#: telemetry, so a SITL's new speed is the rate within 2 s (bench_link_clock.py).
RATE_WINDOW_S = 2.0
#: The least span (s of this computer's clock) :attr:`LinkClock.rate` is measured over: less, the rate before.
RATE_MIN_SPAN_S = 0.2
#: A silence of this long (s of this computer's clock; 9 periods of the 30 Hz telemetry) over which the
#: autopilot's clock moved less than half what the rate says is a stand-still (a SITL left unrun), not its speed.
#: Above a 4 Hz stream's period, so that a slow stream's next message measures the rate again.
STANDSTILL_GAP_S = 0.3


class LinkClock:
    """The autopilot's clock (``time_boot_ms``) seen from this computer: a Clock for the state machines.

    ``now_s`` extrapolates the last boot time received at the rate measured between the autopilot's and the
    local monotonic clock (1.0 for real hardware, the time-scale factor for a faster-than-real-time SITL), for at
    most ``horizon_s`` of the autopilot's time past it; then it holds (:attr:`stale`) until ``hold_s`` of this
    computer's time have passed since the message, and from then on runs at this computer's rate (1x) until the
    next message. ``sleep`` sleeps the wall time that corresponds to ``duration_s`` of autopilot time.

    The bound is issue 29's: unbounded, the extrapolation ran on as if the link were alive. A SITL that a loaded
    machine left unrun for 0.4-2.7 s of wall (its clock, heartbeats and vehicle stood still) read as that many
    seconds times its speed-up on the machines' timers, and the clock, never running backwards, then held until
    the SITL caught up. Holding is what a stand-still is; past ``hold_s`` the link watchdog has found the link
    lost (or the SITL stood still longer), the autopilot's time is not known, and the machines' own reaction to a
    lost link (the emergency's LAND retries, its give-up after ``link_lost_timeout_s``) runs on this computer's
    time: a clock held for good would stop it (the fly loop ticks the machine only when its time moves on).

    The rate is the recent one (issue 29): measured over the last ``window_s`` of this computer's clock, so a SITL
    whose speed changes (a loaded machine: asked for x5, it kept x3.45) is extrapolated, and slept for, at the
    speed it runs at now, not at its average since the link came up. A stand-still (:data:`STANDSTILL_GAP_S` or
    more of this computer's clock between two messages over which the autopilot's clock moved less than half
    what the rate says) is left out of it: the window starts again after it, at the rate measured before it.

    Args:
        monotonic: the local clock (s) the samples are stamped on (the link's: a test may inject one it holds).
        horizon_s: how far past the latest message (s of the autopilot's clock) ``now_s`` extrapolates at the rate.
        hold_s: how long after the latest message (s of the local clock) ``now_s`` holds before it runs at 1x.
        window_s: how far back (s of the local clock) the rate is measured.
    """

    def __init__(
        self,
        monotonic: Callable[[], float] = time.monotonic,
        *,
        horizon_s: float = EXTRAPOLATION_HORIZON_S,
        hold_s: float = HOLD_S,
        window_s: float = RATE_WINDOW_S,
    ) -> None:
        self._monotonic = monotonic
        self.horizon_s = horizon_s
        self.hold_s = hold_s
        self.window_s = window_s
        self._lock = threading.Lock()
        # (boot_s, monotonic_s): the window's samples and the newest one before it
        self._samples: deque[tuple[float, float]] = deque()
        # the rate until the window spans RATE_MIN_SPAN_S: 1x, or the one measured before a stand-still
        self._carried = 1.0
        self._returned = -math.inf
        self._created = self._monotonic()
        self.extrapolate = True  # False: now_s is the last boot time heard (a SITL in lock-step, lockstep.py)

    def observe(self, boot_s: float, monotonic_s: float) -> None:
        with self._lock:
            samples = self._samples
            if samples:
                last_boot_s, last_local_s = samples[-1]
                gap_s = monotonic_s - last_local_s
                if boot_s < last_boot_s - 1.0:  # autopilot rebooted: measure again from 1x
                    samples.clear()
                    self._carried = 1.0
                    self._returned = -math.inf
                elif gap_s >= STANDSTILL_GAP_S:
                    rate = self._rate_locked()
                    if boot_s - last_boot_s < 0.5 * gap_s * rate:  # a stand-still: not the speed
                        self._carried = rate  # (measured on from after it)
                        samples.clear()
            samples.append((boot_s, monotonic_s))
            # keep the newest sample at least window_s old, so the window spans window_s once it can
            while len(samples) > 2 and samples[1][1] <= monotonic_s - self.window_s:
                samples.popleft()

    def _rate_locked(self) -> float:
        samples = self._samples
        if len(samples) < 2:
            return self._carried
        (boot0_s, local0_s), (boot1_s, local1_s) = samples[0], samples[-1]
        if local1_s - local0_s < RATE_MIN_SPAN_S:
            return self._carried
        return max(1e-3, (boot1_s - boot0_s) / (local1_s - local0_s))

    @property
    def rate(self) -> float:
        """Autopilot seconds per local second over the last ``window_s`` (1.0 until 0.2 s of samples exist)."""
        with self._lock:
            return self._rate_locked()

    @property
    def _last(self) -> tuple[float, float] | None:
        return self._samples[-1] if self._samples else None

    def now_s(self) -> float:
        rate = self.rate
        with self._lock:
            if self._last is None:  # nothing heard yet: seconds since this clock was made
                return self._monotonic() - self._created
            if not self.extrapolate:
                return self._last[0]
            age_s = self._monotonic() - self._last[1]
            horizon_local_s = self.horizon_s / rate
            # at the rate up to the horizon, then held; silent past the hold, on at this computer's rate
            now = self._last[0] + min(age_s, horizon_local_s) * rate
            now += max(0.0, age_s - max(self.hold_s, horizon_local_s))
            self._returned = max(self._returned, now)  # never runs backwards
            return self._returned

    @property
    def age_s(self) -> float:
        """Seconds of the local clock since the latest time-stamped message (inf before one)."""
        with self._lock:
            return math.inf if self._last is None else self._monotonic() - self._last[1]

    @property
    def stale(self) -> bool:
        """Whether :meth:`now_s` is past its horizon (held, or on this computer's clock): no message for longer
        than ``horizon_s`` of the autopilot's time at the rate measured (or none yet)."""
        return self.age_s * self.rate > self.horizon_s

    @property
    def last_boot_s(self) -> float | None:
        """The autopilot's clock in the latest time-stamped message (s since its boot); None before one."""
        with self._lock:
            return None if self._last is None else self._last[0]

    @property
    def anchored(self) -> bool:
        """Whether a time-stamped message from the autopilot has been seen."""
        return self._last is not None

    def sleep(self, duration_s: float) -> None:
        if duration_s > 0.0:
            time.sleep(duration_s / self.rate)


@dataclass(frozen=True)
class LinkStatus:
    """What the link's threads have done and met so far (counters since construction)."""

    connected: bool
    autopilot: str | None
    setpoints_sent: int
    vision_sent: int
    handler_errors: int  # messages the receiver could not handle (missing or ill-typed fields)
    receive_errors: int  # failed reads from the connection
    send_errors: int  # failed sends of the background stream (heartbeat, setpoints)
    pose_errors: int  # failed pose reads or forwards (``pose_source``)
    last_error: str | None

    @property
    def errors(self) -> int:
        """All errors the threads met."""
        return self.handler_errors + self.receive_errors + self.send_errors + self.pose_errors
