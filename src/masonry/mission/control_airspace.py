"""Mission control's side of the airspace: requests answered, reports followed, layers raised, events told.

Part of :class:`~masonry.mission.control.MissionControl` (issue 27 §2): the airspace itself
(:class:`~masonry.mission.airspace.ColumnClearance` or :class:`~masonry.mission.reserved.TableClearance`) decides;
these functions feed it what the UAVs say, send its answers, and fail a task whose flight leaves the fence.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from masonry.errors import MissionError
from masonry.geofence import Site
from masonry.mission import plan_reading, table_holds
from masonry.mission.airspace import ON_PAD_Z_M, ColumnClearance, Grant, task_work_altitude_m
from masonry.mission.events import volume_list
from masonry.mission.messages import MISSION_CONTROL, Clearance, ClearanceRequest, Heartbeat, Progress
from masonry.mission.records import UavLink
from masonry.mission.reserved import AIRSPACES, TableClearance
from masonry.mission.sites import SiteGate
from masonry.mission.uav_facts import facts_from
from masonry.mission.volumes import Vec3
from masonry.ports import PlanProgress
from masonry.timing import DEFAULT_TIMING, TaskTiming

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Mapping

    from masonry.mission.control import MissionControl

__all__ = [
    "answer",
    "emit_clearance",
    "emit_uav",
    "fail_outside_fence",
    "grant_number",
    "grant_waiting",
    "make_airspace",
    "on_clearance_request",
    "raise_layers",
    "report",
    "sample",
]

log = logging.getLogger("masonry.mission.control")


def report(mc: MissionControl, link: UavLink, msg: Heartbeat | Progress, position_m: Vec3 | None) -> None:
    """A UAV's state, facts and position (heartbeat or progress): its flight shrinks behind it; on its pad, done
    flying, it holds only the pad."""
    link.state = msg.state
    link.facts = facts_from(msg)
    link.plan_progress = msg.plan_progress
    if position_m is None:
        return
    link.moved_to(position_m)
    name = link.spec.name
    airborne = position_m[2] - link.spec.home_m[2] > ON_PAD_Z_M
    mc.heard_separation.note(name, mc.now_s, position_m, airborne=airborne)  # (heard at this step's time)
    if airborne:
        link.taking_off = False  # it is in the air: whatever it reports from now on is after its take-off
    if isinstance(mc.columns, TableClearance):  # (the table reads where the UAV says it is along its plan)
        mc.columns.progress(name, position_m, msg.plan_progress)
    else:
        mc.columns.progress(name, position_m)
    if link.facts.on_pad and not link.taking_off and mc.dispatcher.task_of(name) is None:
        # (one landed with its task, for a fresh battery, takes off again on its own: it keeps its column)
        mc.columns.landed(name, position_m)


def on_clearance_request(mc: MissionControl, msg: ClearanceRequest, now_s: float) -> None:
    """A UAV asks for a flight (or says it left a column, or came down): the airspace answers."""
    if msg.release:
        mc.columns.release(msg.sender, msg.site_m)
        if mc.sites.released(msg.sender, msg.site_m, now_s):
            mc.columns.touch()
        return
    if msg.arrived:
        mc.columns.end_transit(msg.sender)
        return
    if msg.position_m is not None:
        mc.columns.progress(msg.sender, msg.position_m)
    if mc.sites.leaving(msg.sender, msg.site_m, now_s):
        mc.columns.touch()  # a site is free: who waits for it may go now
    mc.lingers.consider(mc, msg.sender, msg.site_m, msg.position_m, now_s)  # home, with a task due soon?
    g = mc.columns.request(msg.sender, msg.site_m, now_s, msg.position_m, msg.top_m, msg.to_m)
    mc.waits.answered(msg.sender, mc.dispatcher.task_of(msg.sender), g.site_m, g.granted)
    emit_clearance(mc, now_s, g)
    if g.refused is not None:
        fail_outside_fence(mc, msg.sender, g.refused, now_s)
    answer(mc, g, now_s)


def answer(mc: MissionControl, g: Grant, now_s: float) -> None:
    """Send the airspace's answer ``g`` to its UAV.

    A UAV sent to a hold point leaves the site it is at: its visit there ends (``SiteIntervals.left``). A sprayer
    that asked for its next segment 0.15 m on kept its finished segment's visit (a site within ``AT_SITE_M`` is
    the same stay) while it waited at a hold point, and held back a conflicting task's UAV whose hover it waited
    for in turn (``bench_layouts --large`` seed 3041: three attempts given up after 240 s). Ending the visit as
    soon as it asks for the next segment instead lets brick UAVs in between a sprayer's chained segments: the
    pyramid and the 12 m wall at 4 + 2 9-14 % slower.
    """
    if not g.granted and g.hold_m is not None and mc.sites.left(g.uav, now_s):
        mc.columns.touch()  # its site is free: who waits for it may go now
    radius_m = mc.columns.release_radius_m
    open_for_s = None if mc.glue is None or not g.granted else mc.glue.open_for_s(g.uav, g.site_m, now_s)
    answer = Clearance(
        MISSION_CONTROL,
        g.uav,
        g.site_m,
        radius_m,
        now_s,
        g.granted,
        g.hold_m,
        g.layer_m,
        g.gentle,
        open_for_s,
        grant_number(mc, g),
    )
    mc.out.send(g.uav, answer)


def grant_number(mc: MissionControl, g: Grant) -> int:
    """The number of the flight answer ``g`` sets its UAV flying (granted, or to a hold point), which its
    ``plan_progress`` will name: under the table its plan's (one per plan, :mod:`masonry.mission.plan_reading`),
    under the columns one more than the UAV's last; 0: the answer sets no flight (it waits where it is)."""
    if not g.granted and g.hold_m is None:
        return 0
    if isinstance(mc.columns, TableClearance):
        return plan_reading.grant_number(mc.columns.record(g.uav))
    links: Mapping[str, UavLink] = getattr(mc, "uavs", {})  # (a mission control of parts, as tests build one)
    link = links.get(g.uav)
    if link is None:
        return 0
    link.grants += 1
    return link.grants


def fail_outside_fence(mc: MissionControl, uav: str, reason: str, now_s: float) -> None:
    """``uav``'s flight can only be flown outside the site's fence: its task fails with the reason (once per
    task in hand; the attempt counts, so a task no UAV can reach inside the fence ends stuck, saying why)."""
    task_id = mc.dispatcher.task_of(uav)
    if task_id is None:
        return
    key = (uav, task_id, mc.ledger.number_of(task_id))
    if key in mc.fence_failed:
        return
    mc.fence_failed.add(key)
    mc.recall(uav, now_s, reason, task_id, key[2])


def emit_clearance(mc: MissionControl, now_s: float, g: Grant) -> None:
    if mc.sink is not None:
        mc.out.emit(
            now_s,
            "clearance",
            g.uav,
            mc.dispatcher.task_of(g.uav),
            site_m=list(g.site_m),
            granted=g.granted,
            hold_m=None if g.hold_m is None else list(g.hold_m),
            layer_m=g.layer_m,
            volumes=volume_list(mc.columns.volumes(g.uav)),
        )


def raise_layers(mc: MissionControl, task_ids: Iterable[str]) -> None:
    """These tasks' bricks may be on the wall now: transit layers granted from now on clear them."""
    if mc.layer_floor_m is None:
        return
    top = max(
        (task_work_altitude_m(mc.tasks[tid], mc.layer_floor_m, timing=mc.timing) for tid in task_ids),
        default=None,
    )
    if top is not None:
        mc.columns.raise_base(top)


def emit_uav(
    mc: MissionControl,
    now_s: float,
    link: UavLink,
    position_m: Vec3 | None = None,
    battery: float | None = None,
) -> None:
    """A UAV's state, position, task and airspace as mission control knows them (its position and battery
    as measured elsewhere, if given)."""
    name = link.spec.name
    p = link.position_m if position_m is None else position_m
    mc.out.emit(
        now_s,
        "uav",
        name,
        mc.dispatcher.task_of(name),
        state=link.state,
        position_m=None if p is None else list(p),
        battery=link.battery if battery is None else battery,
        status=link.status,
        volumes=volume_list(mc.columns.volumes(name)),
        plan_progress=plan_progress_dict(link.plan_progress),
    )


def plan_progress_dict(pp: PlanProgress | None) -> dict[str, object] | None:
    """A UAV's ``plan_progress`` in an event (as on the wire, its leg named too; None: none)."""
    if pp is None:
        return None
    return {
        "grant": pp.grant,
        "leg": pp.leg,
        "leg_name": pp.leg_name,
        "leg_fraction": round(pp.leg_fraction, 4),
    }


def make_airspace(
    kind: str,
    radius_m: float,
    layers_m: tuple[float | None, float, float | None],
    homes: Mapping[str, Vec3],
    gate: SiteGate,
    fence: Site | None,
    timing: TaskTiming | None,
    work_site: Callable[[str, Vec3], bool] | None = None,
    roles: Mapping[str, str] | None = None,
) -> ColumnClearance | TableClearance:
    """Mission control's airspace of ``kind`` (``columns`` or ``table``: :data:`masonry.mission.reserved.AIRSPACES`).

    Args:
        layers_m: the transit layers' base, their spacing and the floor layer 0 rises from (``MissionControl``'s
            ``layer_base_m``, ``layer_spacing_m`` and ``layer_floor_m``).
        work_site: is a site a UAV's task's (the table sends a UAV far from it to its approach spot first,
            :mod:`masonry.mission.reserved_approach`; None: no approach spots).
        roles: each UAV's role: under the columns a hold point may lie by the pad of a landed UAV of the holder's
            role (:func:`masonry.mission.airspace_requests.landed_alike`; None: by no pad).
    """
    if kind not in AIRSPACES:
        raise MissionError(f"airspace must be one of {', '.join(AIRSPACES)}, got {kind!r}")
    base_m, spacing_m, floor_m = layers_m
    made = (TableClearance if kind == "table" else ColumnClearance)(
        radius_m, base_m, spacing_m, homes=homes, start_base_m=floor_m, gate=gate, fence=fence
    )
    if isinstance(made, TableClearance):
        made.use_timing(timing or DEFAULT_TIMING)  # the legs' windows: the UAVs' own speeds
        made.work_site = work_site
    elif roles is not None:
        made.roles = dict(roles)
    return made


def grant_waiting(mc: MissionControl, now_s: float) -> None:
    """The airspace looks at the waiting requests again; each answer is sent, noted and told."""
    mc.lingers.review(mc, now_s)  # (a UAV that stops waiting near the wall asks to fly home)
    table_holds.sync(mc, now_s)  # (under the table: the operator's and the wind's holds on take-offs)
    if not mc.columns.waiting:
        return
    for g in mc.columns.grant(now_s):
        answer(mc, g, now_s)
        mc.waits.answered(g.uav, mc.dispatcher.task_of(g.uav), g.site_m, g.granted)
        emit_clearance(mc, now_s, g)
        how = "granted" if g.granted else "held"
        log.debug("flight to (%.2f, %.2f) %s to %s", *g.site_m[:2], how, g.uav)


def sample(
    mc: MissionControl, now_s: float, positions_m: Mapping[str, Vec3], batteries: Mapping[str, float]
) -> None:
    """Hand the sink a ``uav`` event per live UAV, its position and battery measured outside mission control."""
    if mc.sink is None:
        return
    for name, link in mc.uavs.items():
        if name in positions_m and not link.lost:
            emit_uav(mc, now_s, link, positions_m[name], batteries.get(name))
