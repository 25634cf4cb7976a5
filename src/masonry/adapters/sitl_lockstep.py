"""Lock-step for the project's SITL (``masonry sitl --lockstep``): simulated time waits for the flying client.

Without it the SITL's clock runs at ``time_scale`` x the wall whatever its client does, so a client that a
loaded machine leaves unrun for 0.1 s of wall finds the vehicle 0.4 s of simulated flight further on (at x4),
having coasted on a stale setpoint (issue 29). With it the client paces the simulation (docs/sitl-lockstep.md):

1. On a ground station's first HEARTBEAT (and on one heard again after 3 s without) the SITL sends STATUSTEXT
   :data:`LOCKSTEP_TEXT`: it takes grants.
2. A grant: the client has dealt with everything up to now and next acts at ``T`` on the SITL's clock; it sends
   SYSTEM_TIME with ``time_boot_ms`` = ``T`` (``time_unix_usec``: its wall clock, as ground stations send it).
3. The SITL runs, at up to ``time_scale`` x the wall, to the latest grant and stops there. Having reached it,
   it sends ATTITUDE and LOCAL_POSITION_NED at ``T`` and then the reply, SYSTEM_TIME with ``time_boot_ms`` =
   ``T`` (its own time, if it had run free past ``T``): the client, waiting for the reply
   (:mod:`masonry.adapters.lockstep`), reads the state at ``T`` and its clock reads the reply's time.
4. A client that stops granting (it waits on its own wall clock for a take-off or an arming, or it is gone)
   cannot stall the SITL: held at a grant, the SITL waits for the next one at most ``wait_s`` of wall (its
   socket's next datagram ends the wait at once), then runs free at ``time_scale`` until a grant comes again.
   Heartbeats and streams keep their wall rates throughout, so the client's link watchdog never sees a
   silence that lock-step made. The wall time spent held is not made up.
"""

from __future__ import annotations

import math
import select
import time
from typing import TYPE_CHECKING

import numpy as np

from masonry.adapters.lockstep import LOCKSTEP_TEXT
from masonry.adapters.mavlink import MSG_ATTITUDE, MSG_LOCAL_POSITION_NED
from masonry.adapters.sitl_config import MAV_SEVERITY_INFO
from masonry.ports import Telemetry

if TYPE_CHECKING:
    from masonry.adapters.sitl import MavlinkSitl

__all__ = ["LOCKSTEP_TEXT", "SitlLockstep"]
#: A ground station heard again after this long (s of wall) without its heartbeat is told again (a new client).
GREET_AFTER_S = 3.0
#: The draws a vehicle's noise fetches at once (``masonry.sim.vehicle``'s blocks): the first of a seed, kept.
_BLOCK = 4096
#: How far below a grant (s) the simulated time counts as having reached it (time_boot_ms is whole ms).
_REACHED_S = 1e-6
#: A longer wall gap (s) between two of the SITL loop's turns (every 4 ms or so) is the SITL itself unrun (a
#: loaded machine), not counted as its client's silence: a client in the same process, or left unrun as long,
#: could not have granted meanwhile (at load average 9.7 a flight ran free once so and placed 8.7 mm, not 12.7).
UNRUN_S = 0.25


class SitlLockstep:
    """The SITL's side of lock-step: how far its simulated time may advance, and when to reply.

    Args:
        sitl: the SITL it paces (its simulated time, its connection).
        wait_s: the longest wall time (s) the SITL, held at a grant, waits for the next before it runs free.
    """

    def __init__(self, sitl: MavlinkSitl, wait_s: float = 1.0) -> None:
        if not wait_s > 0.0:
            raise ValueError(f"the lock-step wait must be positive, got {wait_s!r} s")
        self._sitl = sitl
        self.wait_s = wait_s
        self.grant_ms: int | None = None  # the latest grant (the client's time_boot_ms)
        self.engaged = False  # a grant came and the client has not been silent for wait_s since
        self.grants = 0
        self.free_runs = 0  # times the SITL gave up waiting for a grant and ran free
        self._replied_ms: int | None = None
        self._held_since_s: float | None = None
        self._owed_s = 0.0  # simulated time owed (less than a physics step), run free
        self.epoch_s = 0.0  # the simulated time the first grant was reached at (the flight's own time starts)
        self._waited_free = False  # held before the first grant for wait_s without one: not again
        self._armed_once = False  # the vehicle has been armed: its noise is drawn afresh each step from then
        self.client_since_s: float | None = None  # wall time of the first datagram from a client
        self._last_wall_s: float | None = None  # the wall time of the last step_s (the SITL loop's last turn)
        self._last_setpoint: tuple[float, ...] = ()
        #: the telemetry drawn at the last physics step (sample): what LOCAL_POSITION_NED sends until the next step
        self.sampled: Telemetry | None = None
        self._first: tuple[np.random.Generator, list[float]] | None = (
            None  # the seed's generator, its first block
        )

    def greet(self, last_heartbeat_s: float | None, now_s: float) -> None:
        """A ground station's HEARTBEAT (wall s): announce lock-step to one first heard, or heard again after a
        silence (a second ``masonry fly`` against the same SITL)."""
        if last_heartbeat_s is None or now_s - last_heartbeat_s > GREET_AFTER_S:
            self._sitl._text(MAV_SEVERITY_INFO, LOCKSTEP_TEXT)

    def heard(self, wall_s: float) -> None:
        """A datagram from a client (wall s): the first starts the count of its silence before its first grant."""
        if self.client_since_s is None:
            self.client_since_s = wall_s

    def grant(self, time_boot_ms: int) -> None:
        """A client's SYSTEM_TIME: it next acts at ``time_boot_ms`` of the SITL's clock. One below the latest
        (the client's hold during its pre-flight, :mod:`masonry.adapters.lockstep`) keeps the SITL held where it
        is: simulated time never goes back, and a grant is never taken back."""
        if self.grant_ms is not None and time_boot_ms <= self.grant_ms:  # a hold (not counted)
            if self.engaged:  # the client is there: still held (once run free, only a grant engages again)
                self._held_since_s = None
            return
        self.grant_ms = int(time_boot_ms)
        self.grants += 1
        self.engaged = True
        self._held_since_s = None

    def run(self, free_step_s: float, wall_s: float) -> None:
        """Advance the SITL in whole physics steps only, as far as :meth:`step_s` allows of the wall's
        ``free_step_s`` (what is left of a step is owed to the next call); engaged, to the first whole step at or
        past the grant: the steps, and so the noise drawn at each, are the grants' and not the wall's."""
        sitl = self._sitl
        dt_s = sitl.physics_dt_s
        room_s = self.step_s(free_step_s, wall_s)
        if room_s <= 0.0:  # held: the wall spent is not made up
            self._owed_s = 0.0
            return
        self._owed_s += room_s
        steps = int(self._owed_s / dt_s + _REACHED_S)
        if self.engaged and self.grant_ms is not None:
            to_grant_s = self.grant_ms / 1000.0 - sitl.sim_time_s
            to_grant = math.ceil(to_grant_s / dt_s - _REACHED_S)
            steps = to_grant if room_s >= to_grant_s - _REACHED_S else min(steps, to_grant)
        self._owed_s = max(0.0, self._owed_s - steps * dt_s)
        for _ in range(steps):
            sitl._advance(dt_s)

    def same_setpoint(self, msg: object) -> bool:
        """Whether SET_POSITION_TARGET_LOCAL_NED ``msg`` repeats the last (the client's stream resending it at its
        wall rate): in lock-step a repeat refreshes the setpoint, it does not apply it anew at whatever step."""
        fields = tuple(
            getattr(msg, k) for k in ("type_mask", "vx", "vy", "vz", "afx", "afy", "afz", "yaw_rate")
        )
        same, self._last_setpoint = fields == self._last_setpoint, fields
        return same and self.engaged

    def step_s(self, free_step_s: float, wall_s: float) -> float:
        """How far to advance simulated time now: ``free_step_s`` (``time_scale`` x the wall since the last
        step) running free; engaged, that cut at the grant; 0 once there (held), until ``wait_s`` of wall without
        a grant has passed. Before the first grant it is held too: at its start until a client is heard (nothing
        flies), then at most ``wait_s`` of wall (a client that does not grant: it runs free then). The whole
        flight, its pre-flight included, is then on the grants' time: a lock-step client's pre-flight grants its
        waits (the estimate's convergence, the arming) from simulated time 0 (docs/sitl-lockstep.md)."""
        last_s, self._last_wall_s = self._last_wall_s, wall_s
        if last_s is not None and wall_s - last_s > UNRUN_S and self._held_since_s is not None:
            self._held_since_s += wall_s - last_s  # the SITL was not run: its client's silence is not counted
        if self.grant_ms is None and not self._waited_free:
            if self.client_since_s is None:
                return 0.0  # no client yet: the simulated time starts with one
            if self._held_since_s is None:
                self._held_since_s = self.client_since_s  # its silence counts from when it was first heard
            return self._held(free_step_s, wall_s)
        if not self.engaged or self.grant_ms is None:
            return free_step_s
        room_s = self.grant_ms / 1000.0 - self._sitl.sim_time_s
        if room_s > _REACHED_S:  # below it: on to it (the whole step at or just past it)
            self._held_since_s = None
            return min(free_step_s, room_s)
        return self._held(free_step_s, wall_s)

    def _held(self, free_step_s: float, wall_s: float) -> float:
        if self._held_since_s is None:
            self._held_since_s = wall_s
        elif (
            wall_s - self._held_since_s > self.wait_s
        ):  # the client is silent: run free until it grants again
            self.engaged = False
            self._waited_free = True
            self._held_since_s = None
            self.free_runs += 1
            return free_step_s
        return 0.0

    def sample(self) -> None:
        """After each physics step: the telemetry's noise sample for it (drawn per step, not per message sent).
        Until the first arming (the pre-flight, standing) every step draws the same sample, so what the client
        measures standing (its ground height) is the same whichever of its messages it read.
        The streams send this sample until the next step: a command between steps (an arming, a take-off) clears
        the vehicle's own, and a message sent after it at a wall-chosen moment would draw the next step's noise."""
        vehicle = self._sitl.vehicle
        self._armed_once = self._armed_once or bool(getattr(vehicle, "armed", False))
        if not self._armed_once and hasattr(vehicle, "reseed"):
            # the seed's first block drawn once, not per step: a new generator and 4096 draws a step (0.3 ms) kept
            # a free-running SITL at x50 (x4 at load average 19) catching up for seconds, its streams silent
            if self._first is None:
                rng = np.random.default_rng(self._sitl.seed)
                self._first = (rng, rng.standard_normal(_BLOCK).tolist())
            vehicle.reseed(*self._first)
        self.sampled = vehicle.telemetry()

    def telemetry(self) -> Telemetry:
        """The vehicle's telemetry as the last physics step drew it (the vehicle's own before the first step)."""
        return self.sampled if self.sampled is not None else self._sitl.vehicle.telemetry()

    def at_grant(self) -> bool:
        """Whether the SITL may send its streams: running free, or held at the grant (within a step below it);
        on its way there it sends none (the client sees the state at the grants only, whatever the wall)."""
        grant_ms, sitl = self.grant_ms, self._sitl
        if not self.engaged or grant_ms is None:
            return True
        return sitl.sim_time_s >= grant_ms / 1000.0 - _REACHED_S

    def reply(self) -> None:
        """Once simulated time has reached the latest grant: the state at it, then the reply (step 3 above)."""
        sitl = self._sitl
        if self.grant_ms is None or self.grant_ms == self._replied_ms:
            return
        if not self.at_grant():
            return
        if self._replied_ms is None:  # the first grant (a lock-step client: at 0 s), the flight time starts
            self.epoch_s = sitl.sim_time_s
        self._replied_ms = self.grant_ms
        sitl._send_heartbeat()  # the whole state at the grant, the latest of each message when the reply comes
        for msg_id, rate_hz in sitl._rates_hz.items():
            if rate_hz > 0.0 or msg_id in (MSG_ATTITUDE, MSG_LOCAL_POSITION_NED):
                sitl._send_stream(msg_id)  # (no LOCAL_POSITION_NED before the EKF has converged)
        # the time it is at: the grant, or later where it ran free past it (the client's clock goes on from there)
        now_ms = max(self.grant_ms, round(sitl.sim_time_s * 1000.0))
        sitl._conn.mav.system_time_send(time.time_ns() // 1000, now_ms)

    def summary(self) -> str:
        """One line on how the lock-step went (``masonry sitl`` prints it when it stops): the grants taken, the
        times the client fell silent for ``wait_s`` (the SITL ran free), and the simulated time reached."""
        return (
            f"lock-step: {self.grants} grants, ran free {self.free_runs} times (its client silent for "
            f"{self.wait_s:g} s of wall), at {self._sitl.sim_time_s:.2f} s simulated"
        )

    def wait(self, timeout_s: float) -> None:
        """Wait up to ``timeout_s`` of wall for the next datagram from the client (a grant ends a hold at once)."""
        sock = getattr(self._sitl._conn, "port", None)  # pymavlink's udpout socket
        if sock is None:
            self._sitl._stop.wait(timeout_s)
            return
        try:
            select.select([sock], [], [], timeout_s)
        except (OSError, ValueError):  # closed under us (stop): the loop sees the stop event
            return
