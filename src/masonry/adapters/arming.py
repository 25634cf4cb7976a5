"""Arming through an autopilot's first seconds (issue 29): asked again while it says the refusal is temporary.

PX4 answers MAV_CMD_COMPONENT_ARM_DISARM with MAV_RESULT_TEMPORARILY_REJECTED whenever its arming checks fail,
and in its first seconds they do: PX4 v1.16 SITL (SIH, ../shared/px4) refused every arming for 3 s after its
first HEARTBEAT (2.1 s after start), then accepted it; a user who starts PX4 and flies at once got "arm
rejected: temporarily rejected". So :meth:`MavlinkFlightController.arm
<masonry.adapters.mavlink.MavlinkFlightController.arm>` asks again every :data:`ARM_RETRY_INTERVAL_S` while
the answer is that one, for at most ``arm_retry_s`` (:data:`ARM_RETRY_S` by default), then raises the last
refusal with how long it lasted. PX4 gives the same answer to a check that will not pass by itself (a
calibration missing): the bound ends that wait. Every other refusal (ArduPilot's FAILED with "PreArm: ...",
DENIED) is raised at once, as before.

A client starved under load (issue 29) can let its zero-setpoint burst go stale before PX4 looks at it: PX4 v1.16
then refuses the arming in OFFBOARD, or an armed switch to OFFBOARD, as TEMPORARILY_REJECTED, and the next asking
streams the burst again. A switch to OFFBOARD refused for want of setpoints with another result (FAILED, as the
project's SITL answered before issue 29) is asked again the same way: :func:`asked_again`.
"""

from __future__ import annotations

from collections.abc import Callable

from masonry.errors import CommandRejected

__all__ = ["ARM_RETRY_INTERVAL_S", "ARM_RETRY_S", "arm_retrying", "asked_again"]

#: How long (s) an arming refused as temporary is asked again before the refusal is raised.
ARM_RETRY_S = 30.0
#: Between two askings (s): PX4 runs its arming checks at about 10 Hz.
ARM_RETRY_INTERVAL_S = 0.5


def asked_again(exc: CommandRejected) -> bool:
    """Whether a refusal met while arming is asked again: temporary, or OFFBOARD refused for want of setpoints."""
    return exc.temporary or (exc.command == "set mode OFFBOARD" and "setpoints" in exc.reason)


def arm_retrying(
    arm: Callable[[], None],
    monotonic: Callable[[], float],
    wait: Callable[[float], bool],
    retry_s: float = ARM_RETRY_S,
) -> int:
    """Call ``arm`` until it is accepted, again after each temporary refusal, for at most ``retry_s``.

    Args:
        arm: sends the arm command and returns once accepted (raises :class:`CommandRejected` otherwise).
        monotonic: the clock (s) ``retry_s`` is measured on.
        wait: sleeps the given seconds; True if the wait was cut short (the link is closing: no more asking).
        retry_s: how long temporary refusals are asked through (s; 0: the first refusal is raised).

    Returns:
        How many temporary refusals came before the acceptance.

    Raises:
        CommandRejected: a refusal not :func:`asked_again` (at once), or the last temporary one once ``retry_s``
            has passed (its reason says how long the autopilot refused).
    """
    started_s = monotonic()
    refusals = 0
    while True:
        try:
            arm()
            return refusals
        except CommandRejected as exc:
            if not asked_again(exc):
                raise
            refusals += 1
            waited_s = monotonic() - started_s
            if waited_s + ARM_RETRY_INTERVAL_S > retry_s:
                raise CommandRejected(
                    exc.command,
                    f"{exc.reason} for {waited_s:.1f} s (asked {refusals} times, for at most {retry_s:g} s)",
                    temporary=exc.temporary,
                ) from exc
            if wait(ARM_RETRY_INTERVAL_S):
                raise
