"""Chaining through a queued task: the sprayer keeps its run (issue 27; docs/dispatch.md, "Chaining through").

An adhesion UAV still at the end of the segment it has just sprayed takes the segment starting there when that
segment is available (:mod:`masonry.planner.dispatch_chaining`): it sprays it chained, a short descent instead of
the climb, the transit, the hover and the first descent. Under the ``site`` reservation a segment is *not*
available while a conflicting task is in progress, whatever its UAV is doing: a brick UAV that took a brick within
r_c of the sprayer (nothing else was available, or a brick to prefetch) makes the next segment of the run
unavailable while it flies to the pallet, picks its brick and holds, and the sprayer, given another segment,
climbs out and flies away; the run is broken and its rest sprayed later, unchained.

:class:`ChainThrough` gives the sprayer that next segment anyway when it is *ready* (its prerequisites done,
not done itself, not in progress): what keeps the two UAVs apart at the wall is mission control's site rule, not
the dispatcher (conflicting tasks never work at their sites at once; the one that asks first goes first, and the
sprayer, already there, asks at once). Nothing waits in a cycle: a ready segment waits on no brick's completion,
only on a site visit in progress, which ends. The sprayers are the role the 12 m wall waits on at 4 + 2 and
8 + 4 (the tasks waiting for a free sprayer, docs/performance/fleet.md "Chaining through a queued task").

Only while the fleet's core (:func:`masonry.mission.fleet.core_counts`) has no more UAVs than the wall has sites to
work at once (the admission rule's width at r_c, so only under the columns): past it the UAVs queue at the sites
already, and chaining through slowed the 12 m wall at 8 + 4 (12 UAVs, width 8). Used by mission control for the
reactive policies under ``site`` with no adhesive's open times (a plan with deadlines keeps the glue dispatcher,
which holds segments back on purpose); ``--policy schedule`` has its own ``chain`` rule.

**Spares past the core** (issue 27, 2026-12-06, branch ``grid38``; docs/dispatch.md, "Spares past the 2 : 1
core"). A UAV on its pad is not given a task while its role has as many UAVs busy as the fleet's core has of it
(two brick UAVs per sprayer, one sprayer per two brick UAVs): the 12 m wall's 8 + 2 flies as its 4 + 2 with four
spares on their pads, which take off only when a UAV of the core, sent home for a fresh pack with no task
(:mod:`masonry.mission.swap_stagger`), frees its place. The width rules here count the core, not the fleet. The
12 m wall at 5 + 2 to 8 + 2 and 4 + 3 / 4 + 4 was slower than at 4 + 2 (the extra UAVs in the core's way, on
both seeds flown); a fleet and its core fly the same mission up to the first swap.
While the role is not the wall's pace (its core would finish its work left before the other role's core,
:func:`masonry.mission.fleet.spares_rest`) its spares *rest*: a spare on its pad is given no task even with a core
UAV away for its swap, and the fleet flies its core's mission (the 12 m wall's 4 + 3 and 4 + 4 fly 4 + 2's).

**A spare brick UAV takes off for a brick it can start, or for the last brick** (issue 27, 2026-12-06, branch
``pyr39``; docs/dispatch.md, "Spares past the 2 : 1 core"). A brick UAV past the core in fleet order (its pad laid
past the core's) that stands on its pad is given, past the width (the core alone keeps every site the wall can work
busy), only a brick available now (no conflicting task in progress): not a brick to queue for nor one to fetch
ahead of its glue, which the core's brick UAVs, back from their swaps, take in time. Under the width it prefetches
as before (the 12 m wall's 8 + 2, seed 2, with the rule there too: +36 s). The pyramid's 3 + 1, seed 3: the spare,
let go while both core UAVs swapped, fetched B27 ahead of its glue, crossed the sprayer's flight and took the site
before the sprayer's chained A40 (+22 s over 2 + 1). The one exception is the wall's last brick (below). In a fleet
with spare brick UAVs each idle UAV is asked in turn (a core UAV with nothing to take does not stop the spare being
asked).

**The last brick for any brick UAV** (issue 27, 2026-12-06, branches ``pyr39``, ``last39``; docs/dispatch.md, "The
last brick"). The wall's last brick to give (every other brick done or in progress) goes to any brick UAV with no
task, on its pad or in the air, as soon as every segment under it is done, being sprayed or ready, where the prefetch
rule would give it only once the last of them is given: a pallet trip (~40 s) before the site is free, the
pyramid's last brick 25-28 s after its last segment. A UAV on its pad leaves it to one in the air with no task (no
take-off, often at the wall with its brick just placed; not one flying home for its swap), and while the last brick
is to give each idle UAV is asked in turn. The pyramid, seeds 1-5: 2 + 1 -19 to -21 s, 4 + 2 and 8 + 4 -16 to -20 s
on the seeds where the last segment waits for the brick before (else the prefetch gives the brick at the same
instant), 3 + 1 -4 to -7 s (now the core's UAVs take it, as at 2 + 1); the 12 m and 6 x 30 walls unchanged. Given
as soon as every other brick is given (a segment under it still waiting for the brick before) it came too soon
(pyramid 4 + 2 +23 / +21 s on seeds 1 / 3: its UAV at the wall beside the brick before, placed 24 s later).

**Apart from its own role past the width** (issue 27, 2026-12-06; docs/dispatch.md, "Sprayers apart past the width"
and "Brick UAVs apart past the width"). Past that width the other way round holds too: a UAV with nothing available
(every ready task of its role is within r_c of a task in progress) is given the policy's best ready task within r_c
of no task *of its own role* in progress (a brick UAV in the air with none ready: the best such brick to prefetch),
where there is one, and only then the dispatcher's choice (:meth:`ChainThrough._select_conflicting`). Two UAVs of
one role given tasks within r_c of each other queue for each other's site intervals (sprayers segment after segment
of their runs, brick UAVs at the pickups and at the wall); a task that conflicts only with the other role's waits
for one short visit. On the 6 x 30 wall at 6 + 3 (seed 1) the sprayers' site waits behind another sprayer fell from
1,616 to 400 task-seconds with the sprayers' half of the rule alone. A brick UAV's brick apart is looked for only
within :data:`APART_BRICK_REACH_M` of the brick the dispatcher would give it.

**Sprayers start apart** (issue 27, 2026-12-06, branches ``front38``, ``front39``; docs/dispatch.md, "Sprayers
start apart"). Up to the width, with two sprayers or more, each sprayer's first segment of the mission is the
available one starting nearest its spot (:func:`start_spots`: the middles of equal shares of the wall's segments
along it, the quarter points at two sprayers, the sprayers in the order of their homes along the wall), where the
policy ranks every segment available at the start alike (the 12 m wall: its 79 first segments one critical-path
step). There the policy's own picks start glue-2 six segments from the wall's end (+5.0 m): a short run, then a
jump out of it, unchained; from the quarter points each sprayer has a run of 20 segments or more before any jump,
and the brick UAVs behind the fronts hold less in the first 400 s (12 m wall, 4 + 2, seeds 1-7: 1,186.4 ->
1,148.0 s). Where the policy ranks part of the wall first (the 6 x 30 wall: its +x third
one step above the rest) the spots are not used: a sprayer sent to a spot of a lower step sprays one segment and
is sent back to the top step, into the other sprayer's run (both held ~50 s at the start; seeds 1-5 +2.1 %).

**A take-off does not cut ahead of the other role's next task** (issue 27 §4, 2026-12-07, branch ``more43``;
docs/dispatch.md). A UAV on its pad, while another of its role holds a task and the other role has one UAV, is
given the policy's best available task not within r_c of a task of the other role ready now or when a task in
progress ends (:func:`masonry.planner.dispatch_admission.cuts_ahead`), where there is one; else the task chosen
(never held on its pad: held there, the pyramid's 2 + 1 flew as 1 + 1). The compact layout of ``bench_layouts.py``
seed 7 at 2 + 1: 500.2 -> 428.7 s (1 + 1 459.2 s). Where the columns keep work zones farther apart than r_c
(:attr:`ChainThrough.apart_m`) "ahead" reaches that separation (:attr:`ChainThrough._beside`), whatever the other
role's count, and with no task apart the UAV stays on its pad until the next event (branch ``compact47``: the 30
compact layouts' slower larger fleets 4 -> 1, the worst +18.7 -> +2.3 s).

**A take-off does not wait in the air for the work beside it** (issue 27 §4, branch ``compact45``; docs/dispatch.md).
Where the columns keep work zones farther apart than r_c (:attr:`ChainThrough.apart_m`, the airspace's separation),
a UAV on its pad, while another of its role is out, is not given an available task within that separation of a
task in progress (its UAV would hold in the air for that zone): the policy's best available task clear of them, else
none until the next event (:meth:`ChainThrough._clear_of_work`). ``bench_layouts.py --compact --sub-fleets``: 7 -> 5
of 30 layouts with a larger fleet slower, the worst +38.9 -> +18.7 s.
Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from functools import cached_property

from masonry.blueprint import UavSpec
from masonry.mission.fleet import core_counts, core_of_role
from masonry.planner.dispatch import DEFAULT_POLICY, Dispatcher
from masonry.planner.dispatch_admission import cuts_ahead
from masonry.planner.dispatch_values import DONE, PENDING, RUNNING, STUCK
from masonry.planner.schedule_policy import SCHEDULE_POLICY, make_dispatcher
from masonry.planner.schedule_values import OfflineSchedule
from masonry.planner.tasks import Plan
from masonry.segments import point_segment_m

__all__ = ["APART_BRICK_REACH_M", "ChainThrough", "mission_dispatcher", "start_spots"]

#: Past the width, a brick UAV's brick away from the other brick UAVs is one within this (m, |dx| + |dy|) of the
#: brick the dispatcher would give it: a farther one sends it across the wall, through the other UAVs' legs (12 m
#: wall, 8 + 4, seed 3, no reach: the brick UAVs' airspace waits 1,830 -> 3,655 task-seconds, every sprayer home for
#: a pack, 1,030 -> 1,299 s; 3 m: 944 s). Measured at 3 and 5 m (docs/performance/fleet.md).
APART_BRICK_REACH_M = 3.0


class ChainThrough(Dispatcher):
    """The reactive dispatcher, with an adhesion UAV at the end of its segment given the next one of its run when
    that one is ready, even while a conflicting task is in progress; and each sprayer's first segment at its own
    spot along the wall where the policy ranks the first segments alike (see the module docstring)."""

    def __init__(
        self,
        plan: Plan,
        fleet: Sequence[UavSpec],
        policy: str = DEFAULT_POLICY,
        max_attempts: int = 3,
        durations_s: Mapping[str, float] | None = None,
        reservation: str = "task",
    ) -> None:
        super().__init__(plan, fleet, policy, max_attempts, durations_s, reservation)
        #: the sprayers given a segment already (only their first is at their spot)
        self._spraying: set[str] = set()
        first = self._available["adhesion"]
        alike = len({self._rank[i] for i in first}) <= 1
        segments = [self._start_m[i] for i, r in enumerate(self._role) if r == "adhesion"] if alike else []
        sprayers = [s for s in fleet if s.role == "adhesion"]
        # the core's sprayers only: the spares past it have no spot (4 + 4 starts as 4 + 2)
        core = core_counts(len(fleet) - len(sprayers), len(sprayers))[1]
        self._spot_axis, self._spots = start_spots(segments, sprayers[:core])

    #: the airspace's horizontal separation where it exceeds the conflict radius r_c (mission control sets it under
    #: the columns: :func:`masonry.mission.control_dispatch.admit`): a UAV on its pad is not sent to a task within
    #: it of a task in progress while another of its role is out (:meth:`_clear_of_work`); None: the rule is off
    apart_m: float | None = None

    #: whether a role's spares past the fleet's core rest on their pads, the core's swaps too (mission control's
    #: :meth:`masonry.mission.swap_stagger.SwapStagger.resting`; never, by default)
    spares_rest: Callable[[str], bool] = staticmethod(lambda _role: False)

    def _select(self, role: str, uav: str) -> int | None:
        i = self._spread_start(role, uav)
        if i is None:
            i = self._chained_through(role, uav)
        return super()._select(role, uav) if i is None else i

    def _start(self, i: int, uav: str) -> None:
        super()._start(i, uav)
        if self._role[i] == "adhesion":
            self._spraying.add(uav)

    def _spread_start(self, role: str, uav: str) -> int | None:
        """A sprayer's first segment of the mission, up to the width with two sprayers or more: the available one
        starting nearest its spot (:func:`start_spots`); None: not its first, no spots (the policy ranks the first
        segments apart), or the rule is off."""
        if role != "adhesion" or uav in self._spraying or self.admission is None or self._past_width():
            return None
        spot = self._spots.get(uav)
        available = self._available[role]
        if spot is None or self._live_count["adhesion"] < 2 or not available:
            return None
        axis, start = self._spot_axis, self._start_m
        return min(available, key=lambda k: (abs(start[k][axis] - spot), k))

    def _core(self, role: str) -> int:
        """How many UAVs of ``role`` the live fleet's core has (:func:`masonry.mission.fleet.core_counts`)."""
        return core_of_role(role, self._live_count)

    def _cap_counts(self, role: str) -> tuple[int, int]:
        """The admission cap shares the wall among the fleet's core, not its spares (the pyramid's 4 + 4 kept
        2 + 2 busy where its core 4 + 2 keeps 3 + 1)."""
        return self._core(role), self._core("brick") + self._core("adhesion")

    def _admitted(self, uav: str, role: str, i: int) -> int | None:
        """None for a spare (:meth:`_spare`), else the admission rule's answer, not cutting ahead
        (:meth:`_not_ahead`)."""
        if self._spare(uav, role):
            return None
        admitted = super()._admitted(uav, role, i)
        if admitted is None:
            return None
        ahead = self._not_ahead(uav, role, admitted)
        return None if ahead is None else self._clear_of_work(uav, role, ahead)

    def _clear_of_work(self, uav: str, role: str, i: int) -> int | None:
        """``i``, or for ``uav`` on its pad while another UAV of its role is out (holding a task, or in the air
        with none), when ``i`` is available (no conflicting task in progress: r_c apart) but within
        :attr:`apart_m` of a task in progress, where the airspace's work zones keep it waiting in the air, the
        policy's best available task of ``role`` clear of them all; None where there is none: it stays on its pad
        until the next event, and the UAV of its role out takes the task in turn (docs/dispatch.md, "A take-off
        does not wait in the air for the work beside it")."""
        rule, apart = self.admission, self.apart_m
        if apart is None or rule is None or not rule.landed(uav) or i not in self._available[role]:
            return i
        out = sum(1 for j in self._uav_task.values() if self._role[j] == role) + self._out_idle(role, rule)
        if out == 0 or not self._beside_work(i, apart):
            return i
        clear = [k for k in self._available[role] if not self._beside_work(k, apart)]
        return self._ranking.pick_among(clear, self._position[uav], self._after(uav)) if clear else None

    def _beside_work(self, i: int, apart_m: float) -> bool:
        """Task ``i``'s site lies within ``apart_m`` (horizontally) of a task's in progress (a brick's drop-off,
        a segment's whole line)."""
        return any(self._site_gap_m(i, j) < apart_m for j in self._uav_task.values() if j != i)

    def _site_gap_m(self, i: int, j: int) -> float:
        """The horizontal distance between tasks ``i`` and ``j``'s sites (a brick's drop-off: its end; a
        segment: its line from start to end)."""
        ai, bi = self._site_xy(i)
        aj, bj = self._site_xy(j)
        return min(
            point_segment_m(ai, aj, bj),
            point_segment_m(bi, aj, bj),
            point_segment_m(aj, ai, bi),
            point_segment_m(bj, ai, bi),
        )

    def _site_xy(self, i: int) -> tuple[tuple[float, float], tuple[float, float]]:
        end = (float(self._end_m[i][0]), float(self._end_m[i][1]))
        if self._role[i] == "brick":
            return end, end
        return (float(self._start_m[i][0]), float(self._start_m[i][1])), end

    def _not_ahead(self, uav: str, role: str, i: int) -> int | None:
        """``i``, or for ``uav`` on its pad while another UAV of its role holds a task, when ``i`` cuts ahead of the
        other role's next task (:func:`masonry.planner.dispatch_admission.cuts_ahead`), the policy's best available
        task of ``role`` that does not. Where the columns keep work zones farther apart than r_c
        (:attr:`apart_m`), "ahead" reaches that far, whatever the other role's count, and with no such task the UAV
        stays on its pad until the next event (None; docs/dispatch.md, "A take-off does not cut ahead of the other
        role's work beside it"). Elsewhere only where the other role has one UAV (its tasks are that UAV's one
        sequence), and ``i`` where there is none (held there, the pyramid's 2 + 1 flew as 1 + 1, 1,182.3 -> 1,274.9
        s on seed 1)."""
        rule, apart = self.admission, self.apart_m
        other = "adhesion" if role == "brick" else "brick"
        if rule is None or not rule.landed(uav) or (apart is None and self._live_count[other] != 1):
            return i  # several of the other role: one may take the task elsewhere (6 x 30 6 + 3: +154 s)
        if not self._cutting(i):
            return i
        if not any(self._role[j] == role for j in self._uav_task.values()):
            return i  # the first of its role out: the role's work is its
        free = [k for k in self._available[role] if not self._cutting(k)]
        if free:
            return self._ranking.pick_among(free, self._position[uav], self._after(uav))
        return None if apart is not None else i

    def _cutting(self, i: int) -> bool:
        """Task ``i`` cuts ahead of the other role's next task (:func:`cuts_ahead` on the dispatcher's state), within
        r_c, or within :attr:`apart_m` where it is set (:attr:`_beside`)."""
        st = self._status
        return cuts_ahead(
            i,
            self._role,
            lambda k: st[k] == RUNNING,
            lambda k: st[k] == DONE,
            self._neighbours if self.apart_m is None else self._beside,
            self._prerequisites,
        )

    @cached_property
    def _beside(self) -> list[list[int]]:
        """Per task, its conflicting tasks and the tasks of the other role whose sites lie within :attr:`apart_m`
        of its site (:meth:`_site_gap_m`, horizontally); found through a grid of cells wider than the separation
        plus the longest site twice, so the whole wall is never compared pair by pair."""
        apart = self.apart_m or 0.0
        sites = [self._site_xy(i) for i in range(len(self._role))]
        cell = apart + 2.0 * max((math.dist(a, b) for a, b in sites), default=0.0) + 1e-6
        grid: dict[tuple[int, int], list[int]] = {}
        for i, (a, _) in enumerate(sites):
            grid.setdefault((math.floor(a[0] / cell), math.floor(a[1] / cell)), []).append(i)
        out: list[list[int]] = []
        for i, (a, _) in enumerate(sites):
            cx, cy = math.floor(a[0] / cell), math.floor(a[1] / cell)
            near = set(self._neighbours[i])
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for j in grid.get((cx + dx, cy + dy), ()):
                        if self._role[j] != self._role[i] and self._site_gap_m(i, j) < apart:
                            near.add(j)
            out.append(sorted(near))
        return out

    def _spare(self, uav: str, role: str) -> bool:
        """``uav`` is on its pad (the admission rule says so) and its role has its core's count of UAVs busy, or
        its role's spares rest (:attr:`spares_rest`) and ``uav`` is not of the core (its first UAVs in fleet
        order)."""
        rule = self.admission
        if rule is None or not rule.landed(uav):
            return False
        core = self._core(role)
        if core >= self._live_count[role]:
            return False
        if self.spares_rest(role) and self._spare_uav(uav, role):
            return True
        return sum(1 for j in self._uav_task.values() if self._role[j] == role) >= core

    def _spare_uav(self, uav: str, role: str) -> bool:
        """``uav`` comes after its role's core among the live UAVs of ``role`` in fleet order (its pad laid past
        the core's: :func:`masonry.mission.fleet.fleet_for`)."""
        core = self._core(role)
        if core >= self._live_count[role]:
            return False
        names = [n for n, spec in self._fleet.items() if spec.role == role and n in self._live]
        return names.index(uav) >= core

    @property
    def _per_uav_choice(self) -> bool:  # type: ignore[override]
        """Each idle UAV is asked in turn while the fleet has spare brick UAVs, or while the wall's last brick is
        to be given (a UAV on its pad leaves it to one in the air: see the module docstring)."""
        if self._core("brick") < self._live_count["brick"]:
            return True
        return self.admission is not None and self._last_brick() is not None

    @cached_property
    def _brick_tasks(self) -> list[int]:
        """The indices of the plan's brick tasks."""
        return [i for i, role in enumerate(self._role) if role == "brick"]

    def _last_brick(self) -> int | None:
        """The wall's last brick to give (every other brick task done, in progress or given up), when every
        prerequisite of it is done, in progress or ready (none given up); None otherwise. Given to any brick UAV
        with no task (:meth:`_select_conflicting`)."""
        st, left = self._status, self._prereqs
        last = None
        for i in self._brick_tasks:
            if st[i] == PENDING:
                if last is not None:
                    return None
                last = i
        if last is None or any(
            st[p] == STUCK or (st[p] == PENDING and left[p]) for p in self._prerequisites[last]
        ):
            return None
        return last

    def _past_width(self) -> bool:
        """The fleet's core has more UAVs than the wall has sites to work at once (False without the admission
        rule)."""
        rule = self.admission
        return rule is not None and self._core("brick") + self._core("adhesion") > rule.width

    def _select_conflicting(self, role: str, uav: str) -> int | None:
        """Every brick UAV: the wall's last brick (:meth:`_last_brick`), but a UAV on its pad leaves it to one in
        the air with no task; else a spare brick UAV on its pad past the width nothing. Past the width, a UAV with
        nothing available is given the policy's best of :meth:`_apart`, where there is one; else the dispatcher's
        choice (a task next to another of its role, or a brick to prefetch)."""
        rule = self.admission
        if role == "brick" and rule is not None:
            last = self._last_brick()
            if last is not None:
                return None if rule.landed(uav) and self._out_idle(role, rule) else last
            if rule.landed(uav) and self._spare_uav(uav, role) and self._past_width():
                return None
        if self._past_width():
            apart = self._apart(role, uav)
            if apart and role == "brick":
                choice = super()._select_conflicting(role, uav)
                apart = self._near(apart, choice)
                if not apart:
                    return choice  # (asked once: none apart within reach of it)
            if apart:
                return self._ranking.pick_among(apart, self._position[uav], self._after(uav))
        return super()._select_conflicting(role, uav)

    def _near(self, apart: list[int], choice: int | None) -> list[int]:
        """The bricks of ``apart`` within :data:`APART_BRICK_REACH_M` (|dx| + |dy| of where they are laid) of the
        dispatcher's own ``choice`` (all of them when it has none)."""
        if choice is None:
            return apart
        end = self._end_m
        cx, cy = end[choice][0], end[choice][1]
        return [i for i in apart if abs(end[i][0] - cx) + abs(end[i][1] - cy) <= APART_BRICK_REACH_M]

    def _apart(self, role: str, uav: str) -> list[int]:
        """The ready tasks of ``role`` (for a brick UAV in the air with none ready: the bricks to prefetch) within
        r_c of no task of ``role`` in progress."""
        st, nb, roles = self._status, self._neighbours, self._role
        available = self._available[role]
        candidates = [i for i in self._ready[role] if i not in available]
        landed = self.admission is not None and self.admission.landed(uav)
        if not candidates and self.prefetch and role == "brick" and not landed:
            candidates = self._prefetchable(role)  # (a UAV on its pad prefetches only as the one coming)
        return [i for i in candidates if not any(st[k] == RUNNING and roles[k] == role for k in nb[i])]

    def _chained_through(self, role: str, uav: str) -> int | None:
        """The segment starting where ``uav`` has just sprayed (it is still there), ready but blocked by a
        conflicting task in progress; None: none (the policy's pick, which chains an available one itself), or
        the fleet's core has more UAVs than the wall has sites to work at once (the admission rule's width: only
        under the columns), where the UAVs queue at the sites already and one more queue-jumper costs more
        than the chain saves (12 m wall, 8 + 4: +59 s in the mean of seeds 1-3)."""
        if role != "adhesion" or self.admission is None or self._past_width():
            return None
        if self._live_count["brick"] < 2:
            return None  # the one brick UAV is the whole of its role: its wait at the wall is the wall's
        after = self._after(uav)
        if after is None:
            return None
        ready, available = self._ready[role], self._available[role]
        for s in self._successors[after]:
            if s in ready and s not in available and self._status[s] != RUNNING:
                return s
        return None


def start_spots(
    segments_m: Sequence[tuple[float, float, float]], sprayers: Sequence[UavSpec]
) -> tuple[int, dict[str, float]]:
    """Where each sprayer's first segment is (issue 27; docs/dispatch.md, "Sprayers start apart").

    The segments' starts span ``[lo, hi]`` along their longer horizontal axis; the sprayers, ordered by their homes
    along it (then fleet order), take the middles of ``n`` equal shares of the span: at 2 sprayers the quarter
    points. Returns (the axis, 0 for x and 1 for y; the spot along it per sprayer); no spots without segments.
    """
    if not segments_m or not sprayers:
        return 0, {}
    xs, ys = [p[0] for p in segments_m], [p[1] for p in segments_m]
    axis = 0 if max(xs) - min(xs) >= max(ys) - min(ys) else 1
    lo, hi = (min(xs), max(xs)) if axis == 0 else (min(ys), max(ys))
    ordered = sorted(range(len(sprayers)), key=lambda k: (sprayers[k].home_m[axis], k))
    n = len(sprayers)
    return axis, {sprayers[k].name: lo + (j + 0.5) * (hi - lo) / n for j, k in enumerate(ordered)}


def mission_dispatcher(
    plan: Plan,
    fleet: Sequence[UavSpec],
    policy: str,
    *,
    schedule: OfflineSchedule | None = None,
    max_attempts: int = 3,
    durations_s: Mapping[str, float] | None = None,
    reservation: str = "task",
) -> Dispatcher:
    """Mission control's dispatcher: :class:`ChainThrough` for a reactive policy under ``site`` on a plan without
    the adhesive's deadlines, else :func:`masonry.planner.schedule_policy.make_dispatcher`'s.

    Raises:
        PlanningError: as :func:`~masonry.planner.schedule_policy.make_dispatcher`.
    """
    if policy == SCHEDULE_POLICY or reservation != "site" or plan.deadlines:
        return make_dispatcher(
            plan,
            fleet,
            policy,
            schedule=schedule,
            max_attempts=max_attempts,
            durations_s=durations_s,
            reservation=reservation,
        )
    return ChainThrough(plan, fleet, policy, max_attempts, durations_s, reservation)
