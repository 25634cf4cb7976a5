"""Just-in-time glue for the dispatcher (issue 31; docs/dispatch.md, "Adhesive: just in time").

Pure, like :mod:`masonry.planner.dispatch`. With the adhesive's deadlines in the plan
(:mod:`masonry.planner.deadlines`), :func:`with_glue` gives a dispatcher class (any policy's) that *holds* an
adhesion task out of the available set while:

* ``cure``: a brick under it has glue that has not cured yet (mission control says when: :meth:`cured`);
* ``open``: its brick cannot follow it soon: another bead under that brick still waits for the brick below it
  (or for a cure): this one would be laid now and the brick come only after that brick is placed; or the bead
  expired once already waiting for its brick, which has not started since, and no brick UAV is free to bring it
  (else a brick that waits long for a UAV has its glue sprayed again and again).

Other rules were measured and left out, on the 12 m wall with 4+2 UAVs, 300 s of open time, seed 1
(``masonry blueprint running-bond --courses 3 --bricks-per-course 40 --placed-courses 1 --brick-uavs 4
--adhesion-uavs 2``, then ``masonry sim --seed 1``: 1,416.5 s without an adhesive): holding beads while as many
glued bricks as live brick UAVs are not placed yet (glue only for a brick a UAV is free to bring): 2,872 s
(2,045 s with twice the UAVs); holding a bead within r_c of a brick whose glue is all laid (so the sprayer does
not keep that brick off its site): 1,873 s; neither: 1,574 s. In ``bench_open_time.py`` (its own fleet homes,
1,513.1 s without an adhesive), holding beads while as many bricks as brick UAVs had all their glue and waited,
with the oldest glue's brick taken first: 1,971.7 s and a brick stuck. Re-sprays are cheaper than idle sprayers,
and the gate keeps every brick off expired glue either way. The first two rules helped a single brick UAV at
short open times (the case study at 30 s: without them its brick B0 ends stuck after three recalls).

A bead whose brick is in progress (a re-spray: its glue expired while the brick came) is never held. When
nothing is in progress and nothing is available, the open holds are let go (no dead-lock on a hold): the glue
may then wait, and mission control sprays it again if it expires (:meth:`reopen`). :attr:`blocked` is False while
a task is held (time releases a cure; the next :meth:`assign` the other holds).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TypeVar, cast

from masonry.planner.dispatch import _DONE, _PENDING, Dispatcher
from masonry.planner.dispatch_values import Assignment
from masonry.planner.tasks import Plan


class JustInTime(Dispatcher):
    """The hold rules, mixed in before a :class:`~masonry.planner.dispatch.Dispatcher` class (see the module):
    :func:`with_glue` puts it first in the policy's class, so its ``super()`` calls reach the policy's methods."""

    _glue_on = False

    def _setup_glue(self, plan: Plan) -> None:
        index = self._index
        self._glue_brick: dict[int, int] = {}
        self._cure_under: dict[int, list[int]] = {}
        self._uncured: set[int] = set()
        for d in plan.deadlines:
            a, b = index[d.adhesion], index[d.brick]
            if d.kind == "open":
                self._glue_brick[a] = b
            else:
                self._cure_under.setdefault(a, []).append(b)
                if self._status[b] != _DONE:
                    self._uncured.add(b)
        self._held: set[int] = set()
        self._expired: set[int] = set()  # beads sprayed again (``reopen``) whose brick has not started since
        self._glue_on = True
        self._rehold()

    # -- the rules ---------------------------------------------------------------------------------------
    def _cure_holds(self, i: int) -> bool:
        return any(b in self._uncured for b in self._cure_under.get(i, ()))

    def _holds(self, i: int) -> bool:
        if self._role[i] != "adhesion":
            return False
        if self._cure_holds(i):
            return True
        b = self._glue_brick.get(i)
        if b is None or self._status[b] != _PENDING:
            return False  # no open time, or its brick is on its way already (a re-spray)
        status, prereqs = self._status, self._prereqs
        if any(
            a != i and status[a] == _PENDING and (prereqs[a] or self._cure_holds(a))
            for a in self._prerequisites[b]
        ):
            return True  # another bead under the brick cannot be laid yet: this one would wait for it
        # a bead that expired once waiting for its brick is laid again only when a brick UAV is free to bring it
        return i in self._expired and not self._idle_brick_uav()

    def _idle_brick_uav(self) -> bool:
        return any(
            spec.role == "brick" and n in self._live and n not in self._uav_task
            for n, spec in self._fleet.items()
        )

    def _start(self, i: int, uav: str) -> None:
        if self._glue_on and self._role[i] == "brick":
            self._expired.difference_update(self._prerequisites[i])
        super()._start(i, uav)

    def _rehold(self) -> None:
        """Hold the available beads the rules now hold; let go the held ones they no longer hold."""
        for i in list(self._ready["adhesion"]):
            if self._holds(i):
                self._unavailable(i)
                self._ready["adhesion"].pop(i, None)  # nor given as a conflicting ready task (``site``)
                self._held.add(i)
        for i in sorted(self._held):
            if self._status[i] != _PENDING or self._prereqs[i]:
                self._held.discard(i)
            elif not self._holds(i):
                self._held.discard(i)
                Dispatcher._maybe_available(self, i)

    # -- the dispatcher's hooks ----------------------------------------------------------------------------
    def _maybe_available(self, i: int) -> None:
        if self._glue_on and self._status[i] == _PENDING and not self._prereqs[i] and self._holds(i):
            self._held.add(i)
            return
        super()._maybe_available(i)

    def assign(
        self,
        uav_positions_m: Mapping[str, Sequence[float]] | None = None,
        may_start: Callable[[str], bool] | None = None,
    ) -> list[Assignment]:
        self._rehold()
        idle = not self._in_progress and not any(self._available.values())
        if idle and self._held:
            for i in sorted(self._held):
                if not self._cure_holds(
                    i
                ):  # nothing else can run: lay it (mission control re-sprays it if need be)
                    self._held.discard(i)
                    Dispatcher._maybe_available(self, i)
        return super().assign(uav_positions_m, may_start)

    @property
    def blocked(self) -> bool:
        if self._held:
            return False  # a cure ends with time; the next assign() lets the other holds go when all is idle
        return super().blocked

    # -- mission control's events --------------------------------------------------------------------------
    def cured(self, brick_task_id: str) -> None:
        """The glue under ``brick_task_id`` has cured: beads on top of it may be laid."""
        self._uncured.discard(self._lookup(brick_task_id, "cured"))

    def held(self) -> tuple[str, ...]:
        """Ids of the adhesion tasks held back now, in plan order."""
        return tuple(self._ids[i] for i in sorted(self._held))

    def reopen(self, task_id: str) -> None:
        """A done bead expired before its brick came: it is to be sprayed again (no attempt is counted).

        Raises:
            PlanningError: the task is unknown or not done.
        """
        from masonry.errors import PlanningError

        i = self._lookup(task_id, "reopen")
        if self._status[i] != _DONE or self._role[i] != "adhesion":
            raise PlanningError(
                f"cannot reopen task {task_id}: only a done adhesion task can be sprayed again"
            )
        self._events += 1
        self._status[i] = _PENDING
        self._done.discard(task_id)
        self._expired.add(i)
        for d in self._dependents[i]:
            self._prereqs[d] += 1
            if self._status[d] == _PENDING:
                self._unavailable(d)
                self._ready[self._role[d]].pop(d, None)
        self._maybe_available(i)


D = TypeVar("D", bound=Dispatcher)


def with_glue(cls: type[D]) -> type[D]:
    """``cls`` with :class:`JustInTime` mixed in (call ``_setup_glue(plan)`` on the instance after building it)."""
    return cast("type[D]", type(f"JustInTime{cls.__name__}", (JustInTime, cls), {}))


__all__ = ["JustInTime", "with_glue"]
