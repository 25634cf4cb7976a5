"""Admission (issue 27 §4): a UAV on its pad is not sent out, on a wall too compact for the fleet, past the UAVs it
can keep busy or where the fleet already queues.

On a compact wall (the bundled pyramid: 2.1 m wide, r_c 1.5 m) only one or two site intervals can be open at once;
under the ``site`` reservation the dispatcher still gives every idle UAV a task, conflicting or to prefetch, and
the extra UAVs fly out and hold near the wall and over the pallet, where their holds block the UAVs that could
work (the pyramid took 1,349 s at 2 + 1 and 2,092 s at 8 + 4). The rule (docs/dispatch.md, "Admission"):

- the *width* of a wall is how many of its tasks' work points can be worked at once, r_c apart (a greedy count,
  :func:`site_width`); the rule applies only when the fleet has more UAVs than twice the width (one at each site
  that can be worked, one coming to it): on the 12 m wall (width 8) it never does up to 8 + 4;
- a task in progress is *queued* when a conflicting task is in progress too (one of them waits for the other's
  site interval);
- a task is *crowded* when a queued task lies within two conflict hops of it (conflicts with it, or with a task
  it conflicts with) and does not wait for it (a prerequisite is never held back by its dependent);
- a UAV on its pad takes off only while fewer UAVs of its role are busy (hold a task, or are in the air with
  none: they take the next one; not one flying home for its battery swap) than the role's *cap*: its
  share of :data:`UAVS_PER_SITE` busy UAVs per site the wall can work at once, in proportion to the live fleet,
  rounded, one at least (:meth:`Admission.cap`; the pyramid: 3 brick + 1 adhesion UAVs at 4 + 2 to 8 + 4). Every
  role keeps a UAV it may fly, so the mission goes on as a smaller fleet's would;
- on every wall, a UAV on its pad is sent to fetch a brick early (prefetch) only where it would be the one UAV
  coming to its site (:func:`coming_alone`: at most one conflicting task runs, and that one waits for no other;
  the 12 m wall's 6 + 3 and 8 + 4: docs/dispatch.md); a ready conflicting task is given as before;
- a task *cuts ahead* (:func:`cuts_ahead`) of a task of the other role within r_c that is ready, or becomes ready
  when a task in progress ends: mission control's dispatcher gives a UAV on its pad, with another of its role at
  work, an available task that does not where there is one (:mod:`masonry.mission.dispatch_chain`);
- a UAV on its pad whose chosen task is crowded is given the policy's best uncrowded task of its role instead,
  available first, else ready and conflicting; with none it stays on its pad until the next event.

A UAV in the air is never held back, by the cap or the crowd: it is out already. Holding it back (it flies home
idle) was tried and not kept: on a random compact layout an idle adhesion UAV that had sprayed up to the start of a
queued segment then hovered on that segment's site, refused its way home by the hold of the UAV waiting for that
site (they were 1.1 m apart, under the 1.2 m separation), and five tasks were given up for hold patience
(docs/performance/fleet.md, "Admission"). With the cap the crowd does not form in the first place: the UAVs past
it never take off.

Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

#: a fleet larger than this many UAVs per site that can be worked at once is admitted by :class:`Admission`
UAVS_PER_SITE = 2


def site_width(points_xy: Iterable[tuple[float, float]], radius_m: float) -> int:
    """How many of ``points_xy`` can be worked at once, at least ``radius_m`` apart horizontally (greedy, in
    the given order: a lower bound of the largest such set; 1 at least for a non-empty wall)."""
    kept: list[tuple[float, float]] = []
    for x, y in points_xy:
        if all(math.hypot(x - a, y - b) >= radius_m for a, b in kept):
            kept.append((x, y))
    return len(kept)


def queued(
    running: Iterable[int], is_running: Callable[[int], bool], waits_on: Callable[[int], Iterable[int]]
) -> list[int]:
    """The tasks of ``running`` of which a task they wait on (``waits_on``: the conflicting ones) runs too."""
    return [j for j in running if any(is_running(k) for k in waits_on(j))]


def crowded(
    task: int,
    queued_tasks: Sequence[int],
    neighbours: Sequence[Sequence[int]],
    prerequisites: Sequence[Sequence[int]],
) -> bool:
    """A task of ``queued_tasks`` conflicts with ``task`` or with one of its conflicting tasks (two hops), and
    does not wait for ``task`` itself (a brick fetched early whose glue is still to spray: holding the glue's UAV
    back would make the brick's UAV wait until its hold patience gives the brick up)."""
    if not queued_tasks:
        return False
    near = set(neighbours[task])
    return any(
        (j in near or not near.isdisjoint(neighbours[j])) and task not in prerequisites[j]
        for j in queued_tasks
    )


def coming_alone(task: int, is_running: Callable[[int], bool], neighbours: Sequence[Sequence[int]]) -> bool:
    """At most one task conflicting with ``task`` runs, and that one waits for no other running task: ``task``'s
    UAV would be the one coming to a site interval (one working, one coming), not a second in its queue."""
    running = [j for j in neighbours[task] if is_running(j)]
    if len(running) > 1:
        return False
    return all(not any(is_running(k) for k in neighbours[j] if k != task) for j in running)


def cuts_ahead(
    task: int,
    roles: Sequence[str],
    running: Callable[[int], bool],
    done: Callable[[int], bool],
    neighbours: Sequence[Sequence[int]],
    prerequisites: Sequence[Sequence[int]],
) -> bool:
    """A task of the other role than ``task``'s conflicts with it, is neither done nor in progress, and has every
    prerequisite done or in progress: it is ready, or becomes ready when a task in progress ends, for a UAV of its
    role already at work (docs/dispatch.md, "A take-off does not cut ahead of the other role's next task")."""
    role = roles[task]
    return any(
        roles[j] != role
        and not running(j)
        and not done(j)
        and all(running(p) or done(p) for p in prerequisites[j])
        for j in neighbours[task]
    )


@dataclass(frozen=True)
class Admission:
    """The rule's facts about a mission: the wall's width and which UAVs stand on their pads.

    Args:
        width: :func:`site_width` of the wall's tasks at the conflict radius.
        landed: whether a UAV is on its pad (mission control's airspace).
        swap_sent: whether a UAV flies home for its battery swap (:mod:`masonry.mission.swap_stagger`).
    """

    width: int
    landed: Callable[[str], bool]
    #: whether a UAV was sent home for its battery swap (mission control's stagger): not out to take a task
    swap_sent: Callable[[str], bool] = lambda _name: False

    def applies(self, live_uavs: int) -> bool:
        """The fleet has more UAVs than :data:`UAVS_PER_SITE` per site the wall can work at once."""
        return live_uavs > UAVS_PER_SITE * max(self.width, 1)

    def cap(self, role_uavs: int, live_uavs: int) -> int:
        """How many UAVs of a role with ``role_uavs`` of the ``live_uavs`` may be busy before another takes off:
        its share (rounded half up, one at least) of :data:`UAVS_PER_SITE` per site the wall can work at once
        (rounded down, the pyramid's 4 + 2 kept 2 + 1 UAVs busy and a 3 x 10 running bond at 4 + 2 took 941 s, not
        777 s)."""
        share_x2 = 2 * UAVS_PER_SITE * max(self.width, 1) * role_uavs // max(live_uavs, 1)  # twice the share
        return max(1, (share_x2 + 1) // 2)


__all__ = ["UAVS_PER_SITE", "Admission", "coming_alone", "crowded", "cuts_ahead", "queued", "site_width"]
