"""Battery swaps one after another, not as one wave: which UAV mission control gives no task, to swap early.

Every UAV of a fleet flies from t = 0 without landing, so, left alone, every pack runs low together and the
handlers hold the UAVs' next tasks for their swaps at once: on the 12 m wall at 8 + 4 every UAV swapped between
720 and 980 s, three to five tasks waiting at a time (issue 27, docs/performance/fleet.md). Mission control hears
every UAV's battery, so it spreads the swaps (:func:`swap_due`): a UAV reporting less than :data:`SWAP_EARLY`
is given no task while fewer than one in :data:`SWAP_SHARE` of the UAVs of its role (at least one) are away for
theirs, and while another UAV of its role is there to work. Given nothing, it flies home and lands, and its
handler has the ground crew swap the pack while it is idle on its pad
(:attr:`masonry.mission.handler.UavHandler.top_up_fraction`); with the fresh pack it is dispatched again.
A UAV alone in its role is never held back (the swap would cost the wall as much now as later, and sooner means
more swaps). Nothing here relaxes the battery reserve: a UAV given a task its battery does not cover still has
it held for a swap by its handler (docs/state-machines.md, "Battery budget").

Pure bookkeeping over mission control's state: no I/O, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl

__all__ = ["SWAP_EARLY", "SWAP_SHARE", "swap_due"]

#: A UAV reporting less charge than this may be sent home for its swap early (above the handler's reserve, 0.4).
SWAP_EARLY = 0.5
#: At most one in this many UAVs of a role (at least one) are held back for their swap at a time.
SWAP_SHARE = 4


def _away(mc: MissionControl, name: str) -> bool:
    """``name`` is given no task for its swap: under :data:`SWAP_EARLY`, with no task, in the mission."""
    link = mc.uavs[name]
    return (
        not link.lost
        and link.battery is not None
        and link.battery < SWAP_EARLY
        and mc.dispatcher.task_of(name) is None
    )


def swap_due(mc: MissionControl, name: str) -> bool:
    """``name`` should be given no task now but fly home for a fresh pack (see the module docstring)."""
    link = mc.uavs[name]
    if link.lost or link.battery is None or link.battery >= SWAP_EARLY:
        return False
    role = [n for n, u in mc.uavs.items() if u.spec.role == link.spec.role and n != name and not u.lost]
    away = sum(1 for n in role if _away(mc, n))
    if away >= max(1, (len(role) + 1) // SWAP_SHARE):
        return False
    return away < len(role)  # another of its role is there to work
