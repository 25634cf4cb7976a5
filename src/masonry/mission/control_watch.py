"""Mission control's watches: the progress watchdog (a stall stops the mission) and the wind limit's changes.

Part of :class:`~masonry.mission.control.MissionControl` (issue 27 §2).
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

from masonry.mission import table_holds
from masonry.mission.stall import stall_of

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl

__all__ = ["known_until_s", "on_wind", "watch_progress"]

log = logging.getLogger("masonry.mission.control")


def watch_progress(mc: MissionControl, now_s: float) -> None:
    """The watchdog: progress is a task done or failed, a flight or hold flight granted, a UAV's state
    changed or a UAV lost; none for ``stall_timeout_s`` stops the mission with the wait-for graph. A wait whose
    end mission control knows (:func:`known_until_s`) is no stall: the timeout counts from its end."""
    if mc.operator.paused or mc.operator.held or mc.operator.aborting:
        return  # waiting for the operator is no stall
    wind = mc.wind_limit
    if wind is not None and wind.grounded:
        mc.watch.observe(now_s, ("wind", wind.version))
        return  # waiting for the wind to drop is no stall either
    signature = (
        mc.operator.version,
        mc.ledger.results,
        mc.columns.granted_count,
        mc.columns.held_back,
        tuple((link.state, link.lost) for link in mc.uavs.values()),
    )
    if not mc.watch.observe(now_s, signature, known_until_s(mc, now_s)) or mc.finished:
        return
    assert mc.watch.since_s is not None and mc.watch.timeout_s is not None
    live = [(name, link.state) for name, link in mc.uavs.items() if not link.lost]
    mc.stall = stall_of(now_s, mc.watch.since_s, mc.watch.timeout_s, live, mc.dispatcher, mc.columns)
    log.warning("%s", mc.stall.line())
    mc.out.emit(now_s, "stall", line=mc.stall.line())


def known_until_s(mc: MissionControl, now_s: float) -> float | None:
    """The latest end of a wait mission control knows the end of (None: none): a role's last UAV lost within
    the rejoin window, a lost UAV's way home holding its airspace, a UAV cut off while finishing its work
    (:meth:`~masonry.mission.liveness.LivenessTracker.known_ends_s`), an adhesive curing or open
    (:meth:`~masonry.mission.glue.GlueGate.known_ends_s`). Not the lingering UAVs' waits: a linger ends by the
    model's expected release, which the model may move (docs/safety.md, "Never stuck, never silent")."""
    ends = mc.liveness.known_ends_s(now_s)
    if mc.glue is not None:
        ends += mc.glue.known_ends_s()
    return max(ends, default=None)


def on_wind(mc: MissionControl, now_s: float) -> None:
    """The wind grounded or freed UAVs: say so, and dispatch again."""
    wind = mc.wind_limit
    assert wind is not None
    mc.wake()
    table_holds.sync(mc, now_s)  # (under the table: a grounded UAV's take-off held from now)
    speed = wind.speed_mps if wind.speed_mps is not None else math.nan
    grounded = sorted(wind.grounded)
    if grounded:
        log.warning("wind %.1f m/s: no tasks for %s (above max_wind_mps)", speed, ", ".join(grounded))
    else:
        log.info("wind %.1f m/s: every UAV within its max_wind_mps, dispatching again", speed)
    mc.out.emit(now_s, "wind", speed_mps=None if math.isnan(speed) else float(speed), grounded=grounded)
