"""The client's side of a SITL's lock-step (:mod:`masonry.adapters.sitl_lockstep`, docs/sitl-lockstep.md).

``masonry fly`` on an autopilot's clock waits between its steps with the clock's ``sleep``. Against a SITL that
announced lock-step (its STATUSTEXT :data:`LOCKSTEP_TEXT`) that wait is a grant
instead: SYSTEM_TIME with the time the loop next acts at, then a wait for the SITL's reply, which comes once its
simulated time has got there. Against any other autopilot (a real one, ArduCopter's SITL) it sleeps as before and
sends nothing.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from masonry.adapters.mavlink import MavlinkFlightController

#: What a SITL in lock-step says (STATUSTEXT, at most 50 characters) on a ground station's first HEARTBEAT.
LOCKSTEP_TEXT = "Lockstep: SYSTEM_TIME grants pace the simulation"
#: The longest wall time (s) a step waits for the SITL's reply to its grant before it goes on without it (a SITL
#: the machine leaves unrun for that long; the next step's grant picks the lock-step up again).
REPLY_WAIT_S = 2.0
#: How long (wall s) after a grant's reply the flight controller's own thread leaves the setpoint stream to the
#: grants (each grant sends it once, so the SITL gets it at a defined simulated time; while a grant waits for its
#: reply the thread streams nothing); a client that stops granting (its waits on the wall: arming, commands) has
#: its thread stream again after this, to a SITL held at its last grant.
PACED_STREAM_S = 0.5
#: How often (wall s) a client in its pre-flight tells a SITL held at its last grant to stay there (the grant
#: again): the SITL counts a client silent for its ``wait_s`` (1 s) as gone and runs free, and a pre-flight's
#: steps on this computer (the checks, the report, the machines' start) can take that long on a loaded machine.
HOLD_EVERY_S = 0.25
#: In flight the hold goes on at most this long (wall s) after a grant's reply: a fly loop the machine leaves
#: unrun for more than the SITL's ``wait_s`` keeps the SITL at its grant (issue 29: under load such a flight ran
#: free, PX4's offboard check fired and the same flight ended otherwise); a client that stops granting on purpose
#: (its waits on the wall: a test's take-off, the end of the flight) lets it run free this much later.
HOLD_IN_FLIGHT_S = 5.0
#: After this many grants in a row not answered within :data:`REPLY_WAIT_S` (so at least 6 s of wall without a
#: reply: longer than :data:`HOLD_IN_FLIGHT_S`, the longest stall of a loaded machine the lock-step rides out) the
#: SITL counts as gone (issue 29): :meth:`LockstepClock.now_s` runs on from the time last heard at this computer's
#: rate (1x, as ``LinkClock`` past its hold), so that the fly loop ticks, the machine sees the link lost and its
#: own reaction runs; held at the last time heard, ``masonry fly`` waited 2 s a step for ever. A process left unrun
#: as a whole counts one late reply, not three: its next grant is answered.
GONE_AFTER_LATE_REPLIES = 3


class LockstepClock:
    """The autopilot's clock (``fc.clock``) whose ``sleep`` keeps in lock-step with a SITL that asks for it.

    Make it before ``fc.connect()``: the SITL announces lock-step when it first hears the ground station.

    The SITL holds its time at 0 until its client first grants (:mod:`masonry.adapters.sitl_lockstep`): from the
    announcement on, the flight controller's own waits (the position estimate, the arming's, ``fc._pause``) grant
    too, and a thread tells the SITL every :data:`HOLD_EVERY_S` to stay at the last grant: until the fly loop's
    first :meth:`sleep` (the pre-flight's waits on this computer's clock: commands, the checks), then for at most
    :data:`HOLD_IN_FLIGHT_S` after each grant's reply (a loop left unrun by a loaded machine). The whole flight,
    pre-flight included, is then on the SITL's clock: the same seed, the same flight (docs/sitl-lockstep.md).

    A SITL that stops answering (:data:`GONE_AFTER_LATE_REPLIES` grants in a row) is gone: the clock runs on at
    1x of this computer's clock from the time last heard, each step waits its own duration of wall for the reply
    (not :data:`REPLY_WAIT_S`), and a reply (a SITL that comes back) puts it in lock-step again.

    Args:
        fc: the MAVLink flight controller, not yet connected.
        reply_wait_s: how long (wall s) a step waits for the SITL's reply (None: :data:`REPLY_WAIT_S`).
        monotonic: this computer's clock (s) the clock runs on once the SITL is gone (a test may inject one).
    """

    def __init__(
        self,
        fc: MavlinkFlightController,
        *,
        reply_wait_s: float | None = None,
        monotonic: Callable[[], float] = time.monotonic,
    ) -> None:
        self._fc = fc
        self.reply_wait_s = REPLY_WAIT_S if reply_wait_s is None else reply_wait_s
        self._monotonic = monotonic
        self._texts = fc.listen(("STATUSTEXT",))
        self._replies: queue.Queue[object] | None = None
        self._now_s = -math.inf  # in lock-step: the SITL's time as last heard, never extrapolated
        self.grants = 0
        self.late_replies = 0  # grants not answered within REPLY_WAIT_S
        self.late_in_row = 0  # ... since the last reply
        self.gone_at: tuple[float, float] | None = None  # the SITL gone: (its time, this computer's) then
        self._held_ms: int | None = None  # the latest grant (or the time heard at the announcement)
        self._preflight = True  # until the fly loop's first sleep: the SITL is held between grants
        self._replied_wall_s = -math.inf  # when (wall) the last grant was answered (or given up on)

    @property
    def lockstep(self) -> bool:
        """Whether the autopilot announced lock-step (so far)."""
        return self._replies is not None

    def now_s(self) -> float:
        """The autopilot's time (s); in lock-step the time its telemetry and replies last gave, not extrapolated:
        a client the machine left unrun for a while does not grant that while on top of its step."""
        # the announcement is read here too: the loop's first tick is then on the SITL's time as heard
        if not self.lockstep and not self._announced():
            return self._fc.clock.now_s()
        heard_s = self._fc.clock.last_boot_s
        self._now_s = max(self._now_s, heard_s if heard_s is not None else -math.inf)
        if (gone_at := self.gone_at) is not None:  # the SITL gone: on at 1x from when it was found so
            self._now_s = max(self._now_s, gone_at[0] + self._monotonic() - gone_at[1])
        return self._now_s

    @property
    def gone(self) -> bool:
        """Whether the SITL has stopped answering (:data:`GONE_AFTER_LATE_REPLIES` grants in a row) and not come
        back: :meth:`now_s` runs at this computer's rate."""
        return self.gone_at is not None

    def sleep(self, duration_s: float) -> None:
        """Wait ``duration_s`` of the autopilot's time: a grant and its reply in lock-step, else a sleep. The fly
        loop's: its first ends the pre-flight's hold (the loop grants from here on)."""
        if not self.lockstep and not self._announced():
            self._fc.clock.sleep(duration_s)
            return
        if duration_s > 0.0:
            self._preflight = False
        self._grant(duration_s)

    def _pause(self, duration_s: float) -> None:
        """The flight controller's own waits (``fc.wait_hook``), in lock-step: a grant, the pre-flight held."""
        self._grant(duration_s)

    def _hold(self) -> None:
        """The hold: the latest grant again every :data:`HOLD_EVERY_S` of wall (the SITL takes a grant at or below
        its latest as "stay where you are"), in the pre-flight until the fly loop grants, in flight for at most
        :data:`HOLD_IN_FLIGHT_S` after a grant's reply; until the link closes."""
        fc = self._fc
        while not fc._stop.wait(HOLD_EVERY_S):
            held_ms = self._held_ms
            if held_ms is None:
                continue
            if self._preflight or time.monotonic() - self._replied_wall_s < HOLD_IN_FLIGHT_S:
                self._send_hold(held_ms)

    def _send_hold(self, held_ms: int) -> None:
        self._fc.send_message(lambda mav: mav.system_time_send(time.time_ns() // 1000, held_ms))

    def _grant(self, duration_s: float) -> None:
        if duration_s <= 0.0:
            return
        grant_ms = round((self.now_s() + duration_s) * 1000.0)
        # the setpoint stream at the grant, not at the sender thread's wall times (the SITL applies it in order);
        # none from that thread while the SITL runs to the grant: every setpoint reaches it held at a grant
        fc = self._fc
        fc.stream_paced_until_s = math.inf
        fc._stream_setpoint(fc.stream_clock())
        self._fc.send_message(lambda mav: mav.system_time_send(time.time_ns() // 1000, grant_ms))
        self._held_ms = grant_ms  # (set after the grant: a hold never comes before the setpoint above)
        self.grants += 1
        try:
            self._await_reply(
                grant_ms, min(self.reply_wait_s, duration_s) if self.gone else self.reply_wait_s
            )
        finally:
            fc.stream_paced_until_s = fc._monotonic() + PACED_STREAM_S
            self._replied_wall_s = time.monotonic()

    def _await_reply(self, grant_ms: int, wait_s: float) -> None:
        """Wait (at most ``wait_s`` of wall) for the SITL's reply to the grant ``grant_ms``: a late one counted
        (its wait the whole :attr:`reply_wait_s`), the SITL gone after :data:`GONE_AFTER_LATE_REPLIES` in a row."""
        assert self._replies is not None
        deadline_s = time.monotonic() + wait_s
        while (left_s := deadline_s - time.monotonic()) > 0.0:
            try:
                reply = self._replies.get(timeout=left_s)
            except queue.Empty:
                break
            reply_ms = int(getattr(reply, "time_boot_ms", -1))
            if reply_ms >= grant_ms:  # the SITL's time: the grant, or later if it ran free past it
                self._now_s = max(self._now_s, reply_ms / 1000.0)
                self.late_in_row, self.gone_at = 0, None  # (back in lock-step, if it had gone)
                return
        if self.gone:
            return  # a step of the clock's own, not a late reply
        self.late_replies += 1
        self.late_in_row += 1
        if self.late_in_row >= GONE_AFTER_LATE_REPLIES:
            self.gone_at = (self.now_s(), self._monotonic())

    def _position_age_s(self) -> float:
        """How old the position the velocity loop closes on is, on the autopilot's time as heard (not the wall's:
        at a grant's reply it is the state at the grant, however long the machine then leaves this client unrun)."""
        loop = self._fc.velocity_loop
        observed_s = loop.observed_s if loop is not None else None
        return math.inf if observed_s is None else self._fc.clock.now_s() - observed_s

    def _announced(self) -> bool:
        while True:
            try:
                text = str(getattr(self._texts.get_nowait(), "text", ""))
            except queue.Empty:
                return False
            if text.rstrip("\x00").startswith(LOCKSTEP_TEXT):
                self._fc.unlisten(self._texts)
                self._fc.clock.extrapolate = False  # its time: as last heard (the state the client has)
                self._fc.stream_clock = self.now_s
                self._fc.position_age_s = self._position_age_s
                self._now_s = self._fc.clock.now_s()  # on from where the loop's clock read last
                self._replies = self._fc.listen(("SYSTEM_TIME",))
                self._held_ms = round(self._now_s * 1000.0)
                self._fc.wait_hook = self._pause
                threading.Thread(target=self._hold, name="lockstep-hold", daemon=True).start()
                return True
