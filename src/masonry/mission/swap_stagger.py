"""Battery swaps one after another, not as one wave: which UAV mission control gives no task, to swap early.

Every UAV of a fleet flies from t = 0 without landing, so, left alone, every pack runs low together and the
handlers hold the UAVs' next tasks for their swaps at once: on the 12 m wall at 8 + 4 every UAV swapped between
720 and 980 s, three to five tasks waiting at a time (issue 27, docs/performance/fleet.md). Mission control hears
every UAV's battery, so it spreads the swaps (:func:`swap_due`): a UAV reporting less than :data:`SWAP_EARLY` is
sent home (given no task) while fewer than one in :data:`SWAP_SHARE` of the UAVs of its role are sent, and
while another UAV of its role is there to work. Given nothing, it flies home and lands, and its handler has the
ground crew swap the pack while it is idle on its pad
(:attr:`masonry.mission.handler.UavHandler.top_up_fraction`); with the fresh pack it is dispatched again.

A UAV once sent stays sent until a heartbeat reports its fresh pack (:class:`SwapStagger`): counting as "away"
every UAV of the role under the line that happened to be between two tasks let a UAV landing for its swap take a
task again as soon as another finished one, and the next be sent instead (12 m wall, 6 + 3, seed 3: three brick
UAVs flew home and back without a swap, +125 s). Never sent: a UAV whose heartbeats do not say a ground crew
swaps its pack (``swaps_batteries``: it would sit on its pad, never swapped), a UAV of a role of fewer than
:data:`SWAP_SHARE` (alone, the swap costs the wall as much now as later; two or three swap with little overlap
anyway, and a pack swapped early flies less: 12 m wall, 2 + 1, +80 s), a UAV while another of its role waits on
its pad with a good pack and no task (:meth:`SwapStagger.spare`), and a UAV whose pack, above the handler's
reserve at the drain its heartbeats show, covers its share of the work of its role left (the mission ends before
it runs low).

A UAV reporting less than the handler's reserve (:data:`RESERVE`) is sent in a role of any size and whoever else
of its role is sent: its handler would hold any task it is given for the swap, through the flight home, the
landing, the crew's 60 s and the take-off (78-115 s on the 12 m wall), while mission control sees the task in
progress and gives it to no one else. Sent with nothing, it is swapped on its pad as an idle UAV, and the task
goes to a UAV that can start it (12 m wall, means of seeds 1-6: 4 + 2 -1.8 %, 8 + 4 -3.0 %). Not while a spare
waits on its pad (:meth:`SwapStagger.spare`): sent then, the task went to a spare from a pad farther out (the
pyramid at 8 + 4, +4.2 %; docs/performance/fleet.md, "The brick UAVs' battery swaps"), except where the admission
rule keeps its role to one busy UAV (:meth:`~masonry.planner.dispatch.Dispatcher.capped_alone`, the pyramid's
sprayers from 4 + 2 up): held, its task stopped every site visit for the swap; the spare takes it ("The pyramid
past 2 + 1").

A role with spares past the fleet's core (:func:`masonry.mission.fleet.core_counts`: the 12 m wall's 8 + 2 has four
brick UAVs past its 4 + 2) has them on its pads by design (:mod:`masonry.mission.dispatch_chain`, "Spares past the
core"), not because the wall cannot use more: there a spare waiting does not keep a low UAV at work. It is sent as
in a role without one, and the spare takes its place (with the spare rule, the handlers held the core's tasks for
their swaps while the spares sat: 12 m wall 8 + 2 seed 1, 1,183 s against 4 + 2's 1,157 s; without it 1,127 s).
While the role is not the wall's pace its spares rest (:meth:`SwapStagger.resting`,
:func:`masonry.mission.fleet.spares_rest`): the role is its core here too (:func:`core_of`), so a core of two is
never sent early, as at 4 + 2 (the 12 m wall's 4 + 4 sent its fourth sprayer home at 50 %, in the middle of its run,
and flew a spare in its place: +7 to +72 s over 4 + 2 on four of five seeds).

Nothing here relaxes the battery reserve: a UAV given a task its battery does not cover still has it held for a
swap by its handler (docs/state-machines.md, "Battery budget"). Pure bookkeeping over mission control's state:
no I/O, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from masonry.battery_drain import flight_left_s
from masonry.mission.fleet import core_of_role, spares_rest
from masonry.planner.bounds import estimate_durations_s
from masonry.timing import DEFAULT_TIMING

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl

__all__ = [
    "RESERVE",
    "SWAP_EARLY",
    "SWAP_SHARE",
    "SwapStagger",
    "core_of",
    "live_counts",
    "past_core",
    "swap_due",
]

#: A UAV reporting less charge than this may be sent home for its swap early (above the handler's reserve).
SWAP_EARLY = 0.5
#: At most one in this many UAVs of a role are sent home for their swap at a time (a role of fewer: none).
SWAP_SHARE = 4
#: The handler's battery reserve (``UavHandler(reserve_fraction=0.4)``): the pack's flight left is counted to it.
RESERVE = 0.4


class SwapStagger:
    """Which UAVs mission control sent home for an early swap (since when, s): one of them is sent until a
    heartbeat reports a pack at or above :data:`SWAP_EARLY`, or it leaves the mission."""

    def __init__(self) -> None:
        self.sent_s: dict[str, float] = {}
        self._expected_s: dict[str, float] | None = None  # each task's expected duration (planner.bounds)
        self._left_s: dict[tuple[str, int], float] = {}  # (role, tasks done) -> its expected seconds left

    def is_sent(self, mc: MissionControl, name: str) -> bool:
        """``name`` was sent home for its swap and has not reported a fresh pack yet."""
        if name not in self.sent_s:
            return False
        link = mc.uavs[name]
        if link.lost or link.battery is None or link.battery >= SWAP_EARLY:
            del self.sent_s[name]
            return False
        return True

    def spare(self, mc: MissionControl, name: str) -> bool:
        """``name`` waits on its pad with no task and a pack over :data:`SWAP_EARLY`: a fleet with such a UAV
        in the role has more of it than the wall can use, and the swaps cost the wall nothing there."""
        link = mc.uavs[name]
        return (
            not link.lost
            and link.facts.on_pad
            and link.battery is not None
            and link.battery >= SWAP_EARLY
            and mc.dispatcher.task_of(name) is None
        )

    def left_s(self, mc: MissionControl, role: str) -> float:
        """The expected seconds of the tasks of ``role`` not done yet (summed once per task done)."""
        if self._expected_s is None:
            self._expected_s = estimate_durations_s(mc.plan, mc.fleet, timing=mc.timing or DEFAULT_TIMING)
        done = mc.dispatcher.done
        key = (role, len(done))
        left = self._left_s.get(key)
        if left is None:
            left = sum(
                self._expected_s.get(t.id, 0.0) for t in mc.plan.tasks if t.kind == role and t.id not in done
            )
            self._left_s = {k: v for k, v in self._left_s.items() if k[1] == len(done)}
            self._left_s[key] = left
        return left

    def share_left_s(self, mc: MissionControl, role: str) -> float:
        """The expected seconds of the tasks of ``role`` not done yet, per UAV of the role in the mission."""
        working = sum(1 for u in mc.uavs.values() if u.spec.role == role and not u.lost)
        return self.left_s(mc, role) / max(1, working)

    def resting(self, mc: MissionControl, role: str) -> bool:
        """``role``'s spares past the fleet's core stay on their pads (:func:`masonry.mission.fleet.spares_rest`:
        its core would finish before the other role's)."""
        live = live_counts(mc)
        return spares_rest(role, {r: self.left_s(mc, r) for r in live}, live)

    def covers(self, mc: MissionControl, name: str) -> bool:
        """``name``'s pack, above :data:`RESERVE` at the drain its heartbeats show, covers its share of the work
        of its role left (False while no drain is measured)."""
        link = mc.uavs[name]
        meter = mc.lingers.drains.get(name)
        drain = None if meter is None else meter.drain_per_s
        if drain is None or link.battery is None:
            return False
        return flight_left_s(link.battery, RESERVE, drain) >= self.share_left_s(mc, link.spec.role)


def swap_due(mc: MissionControl, name: str) -> bool:
    """``name`` should be given no task now but fly home for a fresh pack (see the module docstring)."""
    book = mc.swaps
    link = mc.uavs[name]
    if book.is_sent(mc, name):
        return True
    if link.lost or not link.swaps_batteries or link.battery is None or link.battery >= SWAP_EARLY:
        return False
    role = [n for n, u in mc.uavs.items() if u.spec.role == link.spec.role and n != name and not u.lost]
    if book.resting(mc, link.spec.role):
        # its spares rest on their pads: the role is its core (a core of two is never sent early, as at 4 + 2)
        role = [n for n in core_of(mc, link.spec.role) if n != name]
    # a spare on its pad takes the task (not one past the fleet's core: it waits there by design), unless the
    # admission rule keeps its role to this one busy UAV: then the handler's hold would stop the role's work for the
    # whole swap (the pyramid's sprayer at 4 + 2 to 8 + 4)
    spare = not past_core(mc, link.spec.role) and any(book.spare(mc, n) for n in role)
    if link.battery < RESERVE and (not spare or mc.dispatcher.capped_alone(link.spec.role)):
        book.sent_s[name] = mc.now_s  # its handler would hold any task through the swap: it is given none
        return True
    if len(role) + 1 < SWAP_SHARE:
        return False  # a few of a role: their swaps barely overlap, and sent early each pack flies less
    sent = sum(1 for n in role if book.is_sent(mc, n))
    if sent >= max(1, (len(role) + 1) // SWAP_SHARE) or sent >= len(role):
        return False  # enough of its role away for theirs, or none other there to work
    if spare or book.covers(mc, name):
        return False
    book.sent_s[name] = mc.now_s
    return True


def past_core(mc: MissionControl, role: str) -> bool:
    """``role`` has more UAVs in the mission than the fleet's core has of it
    (:func:`masonry.mission.fleet.core_counts`)."""
    live = live_counts(mc)
    return live[role] > core_of_role(role, live)


def core_of(mc: MissionControl, role: str) -> list[str]:
    """The live UAVs of ``role`` in the fleet's core: its first ones in fleet order
    (:func:`masonry.mission.fleet.core_counts`; the spares' pads are laid past the core's,
    :func:`masonry.mission.fleet.fleet_for`)."""
    names = [n for n, u in mc.uavs.items() if u.spec.role == role and not u.lost]
    return names[: core_of_role(role, live_counts(mc))]


def live_counts(mc: MissionControl) -> dict[str, int]:
    """How many UAVs of each role are in the mission (not lost)."""
    live = {"brick": 0, "adhesion": 0}
    for u in mc.uavs.values():
        if not u.lost:
            live[u.spec.role] += 1
    return live
