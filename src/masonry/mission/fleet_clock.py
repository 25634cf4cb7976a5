"""Mission time that follows the UAVs' own clocks: the clock of ``masonry mission-control`` (issue 29).

Every UAV stamps its heartbeats with its own clock: its autopilot's when it flies one (``masonry fly --fc``:
wall time on a real vehicle, the SITL's own time on a bench), its simulated world's under ``--sim``. Mission
control's time used to be the wall clock times ``--time-scale``; an ArduCopter SITL asked for x5 on a loaded
2-core machine runs at x3.5 (measured), so mission time ran ahead of the UAVs' and its timeouts, glue open times
and reservations drifted away from what the vehicles did. :class:`FleetClock` advances mission time as the
slowest live UAV's clock advances, so a slowed SITL slows the mission equally:

- each UAV heard is anchored (its time and mission time at that moment); its *equivalent* mission time is the
  anchor plus how far its clock has moved since, extrapolated past its last heartbeat at ``time_scale`` for at
  most ``lead_s``;
- mission time is the least equivalent over the UAVs heard within ``hold_wall_s`` of wall time, and never runs
  backwards; with no UAV heard (before they join, or all silent) it runs at ``time_scale`` of the wall, so the
  heartbeat and start-up timeouts still fire for UAVs that fell silent;
- a UAV whose clock runs slower than ``time_scale`` (a SITL in lock-step, ``masonry sitl --lockstep``, goes only
  as fast as its loaded client: say x0.8 where x4 was asked) holds the clock for :data:`HOLD_HEARTBEATS` of its own
  heartbeat periods at the rate measured for it (at most :data:`MAX_HOLD_WALL_S`): with ``hold_wall_s`` alone it
  dropped out between two of its heartbeats, mission time ran on at the other UAVs' pace and anchored it anew
  ahead each time (a 45 s brick flight took 90 s of mission time);
- a UAV heard again after a silence, or whose clock went backwards (its autopilot rebooted), is anchored anew;
- a silence is counted only while the clock is read: mission control's own process left unrun for a while (a
  loaded machine) has the UAVs' heartbeats of that while waiting in its queue, not missing
  (:data:`UNLOOKED_S`).

On a real vehicle the autopilots' clocks run at the wall's rate, so with ``time_scale`` 1 this is the wall clock
(docs/hardware.md). The wall clock is read through ``monotonic`` (injected: tests hold it).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from masonry.errors import InputError

#: How far (mission seconds) a UAV's equivalent is extrapolated past its last heartbeat: a heartbeat period
#: (1 s) and its jitter, so that a UAV keeping pace does not hold the clock between two heartbeats.
LEAD_S = 1.5
#: A UAV not heard for this many of its heartbeat periods (mission seconds, at ``time_scale``) no longer holds
#: the clock; the wall-time guard against a hung UAV process (at least :data:`MIN_HOLD_WALL_S`).
HOLD_HEARTBEATS = 3.0
MIN_HOLD_WALL_S = 1.0
#: The longest a UAV slower than ``time_scale`` holds the clock (wall s) for its :data:`HOLD_HEARTBEATS`: a UAV
#: measured slower than 0.3 of the wall still releases it this long after its last heartbeat.
MAX_HOLD_WALL_S = 10.0
#: A gap (wall s) between two readings of the clock longer than this is the reading process left unrun (mission
#: control's loop reads it every tick, 50 ms): the UAVs' heartbeats of that while wait unread in its queue, so the
#: gap past this does not count as their silence (it let mission time jump at ``time_scale`` of the wall, and
#: anchored each UAV anew ahead of itself).
UNLOOKED_S = 0.5
#: Own seconds between two heartbeats of a UAV (``masonry fly``'s heartbeat period).
HEARTBEAT_PERIOD_S = 1.0


@dataclass
class _Track:
    """One UAV's clock as heard: its anchor and its latest heartbeat."""

    uav0_s: float  # the UAV's time at the anchor
    mission0_s: float  # mission time at the anchor
    uav_s: float  # the UAV's latest time heard
    wall_s: float  # when it was heard (local monotonic)
    wall0_s: float  # when it was anchored (local monotonic)
    wall_per_own_s: float = 0.0  # wall seconds per second of its clock over its last heartbeat (0: not known)


class FleetClock:
    """Mission time paced by the UAVs' own clocks (see the module docstring).

    Args:
        time_scale: mission seconds per wall second while no UAV is heard (``--time-scale``), and the rate a
            UAV's time is extrapolated at between its heartbeats.
        start_s: mission time now (a resumed mission's last time).
        lead_s: how far past its last heartbeat a UAV's time is extrapolated (mission seconds).
        hold_wall_s: a UAV silent for longer (wall seconds) stops holding the clock (None: from
            :data:`HOLD_HEARTBEATS` and ``time_scale``).
        unlooked_s: a longer gap (wall s) between two readings is the reader left unrun: not counted as the
            UAVs' silence (:data:`UNLOOKED_S`; more for a reader that reads less often).
        monotonic: the wall clock (s).
    """

    def __init__(
        self,
        time_scale: float = 1.0,
        *,
        start_s: float = 0.0,
        lead_s: float = LEAD_S,
        hold_wall_s: float | None = None,
        unlooked_s: float = UNLOOKED_S,
        monotonic: Callable[[], float] = time.monotonic,
    ) -> None:
        if not time_scale > 0.0:
            raise InputError(f"time_scale must be > 0, not {time_scale}", options=("time_scale",))
        self.time_scale = time_scale
        self.lead_s = lead_s
        self.hold_wall_s = (
            max(MIN_HOLD_WALL_S, HOLD_HEARTBEATS / time_scale) if hold_wall_s is None else hold_wall_s
        )
        self.unlooked_s = unlooked_s
        self._monotonic = monotonic
        self._tracks: dict[str, _Track] = {}
        self._now = start_s
        self._wall = monotonic()

    def heard(self, uav: str, uav_time_s: float) -> None:
        """``uav``'s heartbeat stamped ``uav_time_s`` on its own clock has just arrived."""
        wall = self._monotonic()
        track = self._tracks.get(uav)
        # its rate over this heartbeat, kept across an anchoring anew (one that its slowness made, too)
        rate_s = track.wall_per_own_s if track is not None else 0.0
        if track is not None and uav_time_s > track.uav_s:
            rate_s = (wall - track.wall_s) / (uav_time_s - track.uav_s)
        if track is None or uav_time_s < track.uav_s or wall - track.wall_s > self._hold_s(track):
            self._tracks[uav] = _Track(uav_time_s, self.now_s(), uav_time_s, wall, wall, rate_s)
        else:
            track.uav_s, track.wall_s, track.wall_per_own_s = uav_time_s, wall, rate_s

    def _hold_s(self, track: _Track) -> float:
        """How long (wall s) ``track``'s UAV holds the clock after its last heartbeat: ``hold_wall_s``, or
        :data:`HOLD_HEARTBEATS` of its heartbeat periods at its measured rate where it runs slower (the slower of
        its rate since its anchor and over its last heartbeat), at most :data:`MAX_HOLD_WALL_S`."""
        moved_s = track.uav_s - track.uav0_s
        mean_s = (track.wall_s - track.wall0_s) / moved_s if moved_s > 0.0 else 0.0
        own_hold_s = HOLD_HEARTBEATS * HEARTBEAT_PERIOD_S * max(mean_s, track.wall_per_own_s)
        return max(self.hold_wall_s, min(own_hold_s, MAX_HOLD_WALL_S))

    def now_s(self) -> float:
        """Mission time now (s): the slowest live UAV's, or ``time_scale`` of the wall with none live."""
        wall = self._monotonic()
        unlooked_s = wall - self._wall - self.unlooked_s
        if unlooked_s > 0.0:  # this process was not run (a loaded machine): not a silence of the UAVs
            for t in self._tracks.values():
                t.wall_s += unlooked_s
                t.wall0_s += unlooked_s
        bound = math.inf
        for t in self._tracks.values():
            since_s = wall - t.wall_s
            if since_s <= self._hold_s(t):
                ahead_s = min(max(0.0, since_s) * self.time_scale, self.lead_s)
                bound = min(bound, t.mission0_s + (t.uav_s - t.uav0_s) + ahead_s)
        if math.isinf(bound):
            bound = self._now + max(0.0, wall - self._wall) * self.time_scale
        self._now, self._wall = max(self._now, bound), wall
        return self._now
