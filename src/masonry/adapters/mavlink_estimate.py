"""The position estimate a flight controller over MAVLink waits for before it arms: :class:`EstimateLink`, the base
of :class:`~masonry.adapters.mavlink.MavlinkFlightController` (whether the EKF's estimate is usable, in words, and
the wait with its countdown)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from masonry.adapters.mavlink_link import MavlinkLink
from masonry.adapters.mavlink_protocol import (
    MAV_LANDED_STATE_ON_GROUND,
    describe_estimate_flags,
    estimate_usable,
)
from masonry.errors import CommandRejected

if TYPE_CHECKING:
    from collections.abc import Callable

    from masonry.adapters.mavlink_link import _State


class EstimateLink(MavlinkLink):
    """A :class:`~masonry.adapters.mavlink_link.MavlinkLink` that knows when the autopilot's estimate is usable."""

    estimate_timeout_s: float
    #: called during this adapter's waits (the estimate, arming through refusals) at least every
    #: :attr:`ARM_RETRY_INTERVAL_S <masonry.adapters.arming.ARM_RETRY_INTERVAL_S>`: the loop around the machine
    #: (``masonry fly --mission``: the UAV's heartbeat to mission control) goes on meanwhile (issue 29,
    #: :class:`masonry.ports.WaitsAlive`). None: nothing to keep alive.
    keep_alive: Callable[[], None] | None = None
    #: how those waits wait ``seconds`` of the autopilot's time; None: on this computer's clock. A SITL in
    #: lock-step (:class:`masonry.adapters.lockstep.LockstepClock` sets it) has its time granted instead: it is
    #: held while nothing is granted, so the pre-flight, too, is on its clock (docs/sitl-lockstep.md).
    wait_hook: Callable[[float], None] | None = None

    def _pause(self, seconds: float) -> bool:
        """Wait ``seconds`` (True if cut short: the link is closing), the loop around kept alive first."""
        if self.keep_alive is not None:
            self.keep_alive()
        if self.wait_hook is not None:
            self.wait_hook(seconds)
            return self._stop.is_set()
        return self._stop.wait(seconds)

    def estimate_status(self) -> str:
        """What the estimate lacks now, in words: no local position yet, or what the EKF flags miss."""
        now = self._heard_until(self._monotonic())
        with self._lock:
            st = self._state
            flags = st.estimate_flags
            streaming = st.position_ned is not None and now - st.position_time_s <= max(
                0.5, self.heartbeat_timeout_s
            )
            at_rest = self._at_rest(st)
        if flags is not None and not estimate_usable(flags, self.autopilot, on_ground=at_rest):
            return (
                "no local position yet, " if not streaming else "local position streaming, "
            ) + describe_estimate_flags(flags, self.autopilot, on_ground=at_rest)
        if not streaming:
            return "no local position yet (LOCAL_POSITION_NED not streaming)" + (
                ""
                if flags is None
                else f", {describe_estimate_flags(flags, self.autopilot, on_ground=at_rest)}"
            )
        return (
            "usable" if flags is None else describe_estimate_flags(flags, self.autopilot, on_ground=at_rest)
        )

    def wait_for_estimate(
        self,
        timeout_s: float | None = None,
        *,
        progress: Callable[[str], None] | None = None,
        report_every_s: float = 5.0,
    ) -> None:
        """Block until the autopilot reports a usable local position estimate.

        ArduCopter SITL streams LOCAL_POSITION_NED about 19 s after its first client connects and its EKF is
        usable at about 40 s (docs/hardware.md), so a pre-flight check waits that long with a countdown.

        Args:
            progress: called with one line (what is missing, the seconds left) when that changes and every
                ``report_every_s``; e.g. the pre-flight check's echo to stderr.

        Raises:
            CommandRejected: no usable estimate within ``timeout_s`` (default ``estimate_timeout_s``), naming
                what was missing at the end.
            LinkLost: the link went silent meanwhile.
        """
        timeout_s = self.estimate_timeout_s if timeout_s is None else timeout_s
        start = self._monotonic()
        deadline = start + timeout_s
        last_status, last_report = "", start
        while True:
            self._check_link("wait for position estimate")
            now = self._monotonic()
            if self._position_ok(self._heard_until(now)):
                return
            status = self.estimate_status()
            if now >= deadline:
                hint = (
                    "is motion capture feeding the EKF?"
                    if self.pose_source is not None
                    else "an ArduPilot SITL needs about 40 s after its first connection, a cold Pixhawk about as "
                    "long: give more with `estimate_timeout_s`; indoors, is the position source feeding the EKF?"
                )
                raise CommandRejected(
                    "arm",
                    f"no usable position estimate from the autopilot after {timeout_s:.1f} s: {status} ({hint})",
                    options=() if self.pose_source is not None else ("estimate_timeout_s",),
                )
            if progress is not None and (status != last_status or now - last_report >= report_every_s):
                progress(
                    f"waiting for the position estimate: {status} ({max(0.0, deadline - now):.0f} s left)"
                )
                last_status, last_report = status, now
            self._pause(0.02)

    def _position_ok(self, now: float) -> bool:
        st = self._state
        if st.position_ned is None or now - st.position_time_s > max(0.5, self.heartbeat_timeout_s):
            return False
        if (
            st.estimate_flags is None
        ):  # no estimator report (yet): a streaming LOCAL_POSITION_NED is the signal
            return True
        return estimate_usable(st.estimate_flags, self.autopilot, on_ground=self._at_rest(st))

    @staticmethod
    def _at_rest(st: _State) -> bool:
        """Disarmed, or landed by EXTENDED_SYS_STATE: PX4's constant-position flag then means "at rest"."""
        return not st.armed or st.landed_state == MAV_LANDED_STATE_ON_GROUND
