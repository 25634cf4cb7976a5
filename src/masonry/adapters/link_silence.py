"""How long the autopilot has been silent, as the MAVLink link watchdog counts it (issue 29).

The watchdog (:meth:`~masonry.adapters.mavlink_link.MavlinkLink._link_ok`) finds the link lost on either of two
silences, both counted here by pure functions from what the receiver thread recorded:

- **No message** for ``heartbeat_timeout_s``, on the local clock, up to when the receiver last listened
  (:func:`heard_until`): a process held up by a loaded machine leaves messages unread in its socket, which is not
  the autopilot's silence.
- **No HEARTBEAT** for :data:`~masonry.adapters.mavlink_protocol.HEARTBEAT_MISSING_S` while other messages come
  (:func:`beatless_s`), on the slower of two clocks: the local one and the autopilot's own (the ``time_boot_ms``
  of its telemetry). The autopilot beats once a second *of its clock*. ArduCopter's SITL can stand still: at a
  speed-up above 1 it stops its loop while more than 1 KiB it wrote to SERIAL0 is unacknowledged, and a loaded
  machine can leave it runnable but unrun for a second or more. Its clock, its heartbeats and its simulated
  vehicle then stop together: the wall clock counts a silence the autopilot never had. Seen under load at x5
  (docs/performance/autopilots.md): 2.7 s of wall without a message while a take-off was commanded, in which
  the autopilot's clock moved 0.13 s; the first message after it found the last HEARTBEAT 2.88 s (wall) old:
  link down, which in flight lands the UAV ("flight controller link lost"). On real hardware the two clocks run
  together and nothing changes; a stream that goes on without heartbeats advances both and is lost after 2.5 s
  of the slower. A total silence has no clock but the local one: a SITL left unrun for longer than
  ``heartbeat_timeout_s`` while the receiver listens is a lost link (:func:`watchdog_text` says afterwards how
  far the autopilot's clock moved meanwhile).
"""

from __future__ import annotations

import math
from typing import Protocol

#: A receiver that has read nothing for this long (wall seconds) is hung, or the link is gone: the link watchdog
#: then counts wall time (the guard against a hung process; see :func:`heard_until`).
RECEIVER_HUNG_S = 10.0


def heard_until(now_s: float, last_message_s: float, listened_s: float) -> float:
    """Up to when (local s) the receiver has read all that arrived: ``now_s``, or when it last listened if earlier.

    This process starved by a loaded machine (its receiver not run) leaves messages unread in the socket, which
    is not the autopilot's silence; a receiver that has not read for :data:`RECEIVER_HUNG_S` is hung, and then
    the wall clock counts.

    Args:
        now_s: the local clock now.
        last_message_s: when (local s) the last message from the autopilot was read.
        listened_s: when (local s) the receiver last began a read that found nothing.
    """
    if now_s - last_message_s > RECEIVER_HUNG_S:
        return now_s
    return min(now_s, max(listened_s, last_message_s))


def beatless_s(
    heard_s: float, last_heartbeat_s: float, boot_s: float | None, heartbeat_boot_s: float | None
) -> float:
    """Seconds without a HEARTBEAT: on the slower of the local clock and the autopilot's.

    Args:
        heard_s: up to when (local s) the receiver has read (:func:`heard_until`).
        last_heartbeat_s: when (local s) the last HEARTBEAT was read.
        boot_s: the autopilot's clock (s since its boot) in the latest time-stamped message read; None: none yet.
        heartbeat_boot_s: the autopilot's clock when the last HEARTBEAT was read (that of the time-stamped
            message before it, at most one telemetry period early); None: no clock then.

    Returns:
        The local seconds since the last HEARTBEAT, or the autopilot's if fewer. Without the autopilot's clock
        at both ends, or with it gone backwards (a reboot), the local seconds.
    """
    local_s = heard_s - last_heartbeat_s
    if boot_s is None or heartbeat_boot_s is None or not math.isfinite(local_s) or boot_s < heartbeat_boot_s:
        return local_s
    return min(local_s, boot_s - heartbeat_boot_s)


class Heard(Protocol):
    """What the receiver recorded (local seconds), as the watchdog's log line reads it."""

    last_message_s: float
    last_heartbeat_s: float
    listened_s: float
    heartbeat_boot_s: float | None


def watchdog_text(
    now_s: float,
    heard: Heard,
    beatless: float,
    boot_s: float | None,
    down_at: tuple[float, float | None] | None,
) -> str:
    """The watchdog's log line at a transition: down (``down_at`` None) or back, with what it read on both clocks.

    Back, it says how far each clock moved since the last message before the link went down (``down_at``: when,
    on the local clock, and the autopilot's clock then): the autopilot's about nothing for a SITL the machine
    left unrun (it stood still), as far as the local one for a real loss.
    """
    clock = "-" if boot_s is None else f"{boot_s:.2f}"
    at_beat = "-" if heard.heartbeat_boot_s is None else f"{heard.heartbeat_boot_s:.2f}"
    text = (
        f"link {'down' if down_at is None else 'back'} (now {now_s:.2f} s; last message "
        f"{now_s - heard.last_message_s:.2f} s ago, last HEARTBEAT {now_s - heard.last_heartbeat_s:.2f} s ago "
        f"({beatless:.2f} s counted), receiver last listened {now_s - heard.listened_s:.2f} s ago; autopilot clock "
        f"{clock} s, at the last HEARTBEAT {at_beat} s)"
    )
    if down_at is not None and down_at[1] is not None and boot_s is not None:
        text += (
            f"; since the last message before it went down {now_s - down_at[0]:.2f} s of this computer's clock, "
            f"{boot_s - down_at[1]:.2f} s of the autopilot's"
        )
    return text


__all__ = ["RECEIVER_HUNG_S", "Heard", "beatless_s", "heard_until", "watchdog_text"]
