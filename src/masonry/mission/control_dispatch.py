"""Mission control's side of dispatch: who may take off for a task, and the admission rule's facts.

:func:`may_take_off` is the dispatcher's ``may_start`` (a landed UAV takes a task only with its take-off column
reserved); :func:`admit` hands the dispatcher the wall's width at the conflict radius and which UAVs are on their
pads (:mod:`masonry.planner.dispatch_admission`, docs/dispatch.md "Admission").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from masonry.mission import table_dispatch, table_holds
from masonry.mission.airspace import ColumnClearance, Phase
from masonry.mission.dispatch_chain import ChainThrough
from masonry.mission.sites import work_point_m
from masonry.mission.swap_stagger import swap_due
from masonry.planner.dispatch_admission import Admission, site_width

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl


def admit(
    mc: MissionControl, column_radius_m: float, table: str = table_dispatch.DEFAULT_TABLE_DISPATCH
) -> None:
    """Give ``mc``'s dispatcher the admission rule, under either airspace; none with ``column_radius_m`` 0 (every
    column granted). Under ``--airspace table`` too (issue 27, branch ``table44``): without it every UAV of the
    pyramid's 8 + 4 took tasks, and the table grants a UAV the site gate does not hold back its whole hop down from
    its pad, a site interval as long as that flight (68 s) on a wall whose intervals run one at a time: 4,234.8 s
    against 1,671.3 s with the rule (docs/performance/fleet.md, "Why the table is slow on the pyramid").
    Under the table the dispatcher also chooses among the policy's top few by the table
    (:func:`masonry.mission.table_dispatch.install`, ``table``: its ``table_dispatch``)."""
    table_dispatch.install(mc, table)
    if column_radius_m <= 0:
        return
    points = [work_point_m(t)[:2] for t in mc.plan.tasks if not t.done]
    width = site_width(((p[0], p[1]) for p in points), column_radius_m)
    mc.dispatcher.admission = Admission(
        width,
        lambda name: mc.columns.phase(name) is Phase.LANDED,
        swap_sent=lambda name: mc.swaps.is_sent(mc, name),
    )
    if isinstance(mc.dispatcher, ChainThrough):
        mc.dispatcher.spares_rest = lambda role: mc.swaps.resting(mc, role)
        if isinstance(mc.columns, ColumnClearance) and column_radius_m < mc.columns.sep_xy_m:
            mc.dispatcher.apart_m = mc.columns.sep_xy_m  # (zones closer than r_c apart: docs/dispatch.md)


def may_take_off(mc: MissionControl, name: str) -> bool:
    """A UAV landed on its pad takes a task only with the column over its pad for its take-off (reserved
    here): take-offs from neighbouring pads go one after the other. Under the table a recall and a wind grounding
    are read from the table's holds (:func:`masonry.mission.table_holds.holding`), under the columns from the
    operator and the wind limit: the same answers (docs/safety.md, "The operator, the wind and the fence on the
    table")."""
    held = table_holds.holding(mc, name)
    recalled = name in mc.operator.held if held is None else "operator" in held
    if recalled or not mc.operator.under_limit(mc, name):
        return False  # recalled, or its role at the operator's fleet limit
    if swap_due(mc, name):
        return False  # it flies home for a fresh pack now, while few of its role are away for theirs
    if (mc.wind_limit is not None and not mc.wind_limit.allows(name)) if held is None else "wind" in held:
        return False  # above its max_wind_mps: it finishes its task and lands
    if mc.columns.phase(name) is Phase.LANDED and not mc.columns.take_off(name):
        mc._deferred_at = mc.columns.version
        return False
    # from now on a report that it is landed may predate the assignment (it lands, then reads it)
    mc.uavs[name].taking_off = True
    return True


__all__ = ["admit", "may_take_off"]
