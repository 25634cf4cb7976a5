"""Mission control's losses: a UAV silent too long or out of service leaves the mission; one heard again rejoins.

Part of :class:`~masonry.mission.control.MissionControl` (issue 27 §2): :mod:`masonry.mission.liveness` says who
is heard, silent, lost, rejoined or out of service; these functions carry out what that means for the airspace
(a silent UAV's way home stays reserved), the dispatcher (its task back to the pool), the spares (a brick lost
with it) and the journal.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from masonry.mission import control_airspace, control_results
from masonry.mission.liveness import Lapse, way_home_s
from masonry.mission.messages import Heartbeat, Message, Result
from masonry.mission.records import Liveness, UavLink
from masonry.mission.reducer import loss_reason, placed_before_loss, way_home_of
from masonry.mission.uav_facts import facts_from
from masonry.planner.tasks import BrickTask
from masonry.timing import DEFAULT_TIMING

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl

__all__ = ["check_heartbeats", "lose", "maybe_start", "readmit", "screened"]

log = logging.getLogger("masonry.mission.control")


def readmit(mc: MissionControl, link: UavLink, msg: Message, now_s: float) -> bool:
    """A UAV declared lost for its silence is heard again: back in the mission if its heartbeat says it holds
    no task and is in service (a radio that came back after its task was given away, a handler restarted),
    holding its pad, or the column where it hovers, in the airspace (``ColumnClearance.rejoined``);
    anything else it sends stays ignored (a late result of a task that went to another UAV)."""
    if link.liveness is not Liveness.LOST or not isinstance(msg, Heartbeat) or msg.task_id is not None:
        return False
    if msg.out_of_service or mc.ended_at_s is not None:
        return False
    name = link.spec.name
    way_home = way_home_of(facts_from(msg), link.way_via_m, mc.fallback_layers_m.get(name))
    if not mc.columns.rejoined(name, msg.position_m, way_home):
        return False
    if not mc.dispatcher.readmit_uav(name):
        return False
    log.warning("UAV %s heard again (%s, no task): back in the mission", name, msg.state or "-")
    mc.liveness.rejoin(link)
    mc.events.rejoined += 1
    control_airspace.emit_uav(mc, now_s, link)  # its status is "ok" again (a log, a live view)
    mc.wake()
    return True


def check_heartbeats(mc: MissionControl, now_s: float) -> None:
    """What the clock did (:meth:`~masonry.mission.liveness.LivenessTracker.sweep`): a way home's hold ran out,
    a UAV fell silent for too long."""
    for name, lapse in mc.liveness.sweep(now_s, lambda n: mc.dispatcher.task_of(n) is not None):
        if lapse is Lapse.AIRSPACE_EXPIRED:
            mc.columns.release(name)  # not heard again: it fell, or landed where it was
        elif mc.ended_at_s is not None and mc.uavs[name].facts.on_pad and mc.dispatcher.task_of(name) is None:
            # it left: on its pad after the mission's end, its `masonry fly --mission` over (mission control
            # answers on for the UAVs still flying home: MissionControl.may_leave), not lost
            continue
        else:
            quiet_s = now_s - (mc.uavs[name].last_heard_s or now_s)
            log.warning("UAV %s silent for %.1f s: lost", name, quiet_s)
            lose(mc, name, now_s)


def lose(mc: MissionControl, name: str, now_s: float, status: str = "lost") -> None:
    """Take a UAV out of the mission (silent, or out of service); its task goes back to the pool."""
    link = mc.uavs[name]
    mc.liveness.lose(link, now_s, out_of_service=status != "lost")
    task_id = mc.dispatcher.task_of(name)
    task = mc.spares.task(mc.tasks[task_id]) if task_id is not None else None
    # last heard with its brick on the magnet: it may have taken it down with it, or puts it back first
    carried = task if link.facts.carrying and isinstance(task, BrickTask) else None
    if status == "lost" and mc.columns.volumes(name):
        # silent: it may be cut off and hovering where it stopped, inside what it was granted (its rule when
        # mission control is silent), and fly home on its own after LAST_RESORT_S: both stay reserved until
        # it is heard again, or for as long as that flight takes
        link.airspace_until_s = now_s + mc.rejoin_timeout_s
        # (carrying, it puts the brick back on its pallet first: docs/state-machines.md, "Putting a brick back")
        link.way_via_m = carried.pickup_m if carried is not None else None
        # (last heard on its pad too: it may have been taking off, and hovers over the pad asking to land)
        if link.position_m is not None:
            layer_m = mc.fallback_layers_m.get(name)
            way_m = mc.columns.silent(name, link.position_m, layer_m, link.way_via_m)
            way_s = way_home_s(way_m, (mc.timing or DEFAULT_TIMING).vertical_speed_mps)
            link.airspace_until_s = now_s + max(mc.rejoin_timeout_s, way_s)
    else:
        mc.columns.release(name)  # retired (on the ground) or fell: its column is free
    if mc.sites.left(name, now_s):
        mc.columns.touch()
    if status == "lost" and placed_before_loss(link.facts, isinstance(task, BrickTask)):
        control_results.placed_by_lost(mc, name, link.state, now_s)  # (its brick on the wall: done)
    released = mc.dispatcher.remove_uav(name)
    att = None if released is None else mc.ledger.running.get(released)
    if released is not None and att is not None:
        brick = carried.brick if status == "lost" and carried is not None else None
        reason = loss_reason(None if status == "lost" else status, link.state, brick)
        mc.ledger.end(att, now_s, "failed", reason, result=False)
        if brick is not None:
            mc.spares.lost(released, reason, now_s)
        log.info("%s failed on %s (attempt %d): %s", released, name, att.attempt, reason)
    mc.ledger.journal_lost(now_s, name)
    mc.out.emit(now_s, "lost", name, released, status=status)
    mc.wake()


def screened(mc: MissionControl, link: UavLink, msg: Message, now_s: float) -> bool:
    """True when ``msg`` needs nothing more: a late completion taken, or anything else from a UAV declared lost
    (it stays lost until a heartbeat says it holds no task: :func:`readmit`; its task went to another)."""
    if isinstance(msg, Result) and (
        control_results.heard_again(mc, msg) or control_results.late_result(mc, msg, now_s)
    ):
        return True
    return link.lost and not readmit(mc, link, msg, now_s)


def maybe_start(mc: MissionControl, now_s: float) -> None:
    """Start once the whole fleet is heard, or ``startup_timeout_s`` after the first step without the rest."""
    missing = mc.liveness.never_heard()
    assert mc.first_step_s is not None
    if missing and now_s - mc.first_step_s < mc.startup_timeout_s:
        return
    for name in missing:
        log.warning("UAV %s never came online; starting without it", name)
        lose(mc, name, now_s)
    mc.started_at_s = now_s
    mc.wake()
    mc.out.emit(now_s, "start", fleet=[n for n, u in mc.uavs.items() if not u.lost])
