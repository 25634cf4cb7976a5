"""Mission control's side of the adhesive (issue 31; docs/dispatch.md, "Adhesive: just in time").

Pure: no I/O, no clock (times are passed in). :class:`GlueGate` knows when each bead was sprayed (an adhesion
task's completion) and each glued brick placed, and:

* is the airspace's :class:`~masonry.mission.sites.SiteGate` in front of the site intervals: a brick's flight
  down to its site is granted only when every bead under it is done and will still be open when the brick
  presses on it (its age, plus the flight from where the UAV is to the site, plus :attr:`margin_s`, the placing
  descent and release, within the open time);
* every tick (:meth:`step`): a bead whose brick is not at its site yet and that would no longer be open by then
  has *expired*: its done attempt is marked failed (reason :data:`EXPIRED_REASON`), the brick's UAV, if it has
  one, is recalled at the :data:`RECALL_AFTER_EXPIRIES`-th expiry in one attempt (until then it keeps its brick
  and waits, at a hold point clear of the beads it waits for) (its attempt fails with the same reason and
  counts, so a brick that can never come in time ends stuck instead of looping); the dispatcher sprays the
  bead again (``reopen``): never is a brick placed on expired glue, whatever delayed it (a fault, a lost UAV, a
  pause: paused time counts against the open time like any other);
* tells the dispatcher when a brick's glue has cured (``cured``), so beads on top of it may be laid;
* tells the operator: a ``glue`` event for each bead sprayed (or known from the journal after a resume), with
  when it expires (the live page and the mission log show each bead's age and time left).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from masonry.errors import InputError, PlanningError
from masonry.mission.sites import AT_SITE_M, SiteIntervals, work_point_m
from masonry.planner.dispatch import Dispatcher
from masonry.planner.dispatch_glue import JustInTime
from masonry.planner.tasks import Plan
from masonry.timing import TaskTiming

if TYPE_CHECKING:  # (mission control builds the gate: no import cycle at run time)
    from masonry.mission.control import MissionControl

Vec3 = tuple[float, float, float]
#: The reason of a bead's attempt whose glue expired before its brick came (its re-spray explains itself).
EXPIRED_REASON = "open time expired"
#: Slack added to the placing descent and release when judging whether a bead will still be open (s).
MARGIN_SLACK_S = 12.0
#: Expiries of a brick's beads while one attempt of it is carried before its UAV is recalled (the attempt fails
#: and counts: a brick that can never come in time ends stuck instead of looping). Measured (docs/dispatch.md,
#: "Adhesive: just in time"): 3 let the 12 m wall at 4+2 complete at 120 s of open time, but the pyramid at 4+2
#: and 60 s then sprayed 495 beads again and ran out of time, where 1 ends it blocked, saying why, at 698 s.
RECALL_AFTER_EXPIRIES = 1


@dataclass
class GlueGate:
    """The beads' ages for one mission (see the module docstring)."""

    plan: Plan
    dispatcher: JustInTime
    sites: SiteIntervals
    margin_s: float
    #: the flight down to a site from where its UAV is: horizontally at this speed (m/s) ...
    cruise_speed_mps: float = 1.0
    #: ... and vertically at this one (m/s)
    vertical_speed_mps: float = 0.4
    #: bead (adhesion task id) -> when it was sprayed (its completion, s)
    sprayed_at_s: dict[str, float] = field(default_factory=dict)
    #: brick task id -> when its glue has cured (s)
    cures_at_s: dict[str, float] = field(default_factory=dict)
    #: re-sprays ordered: (time, bead, brick)
    expiries: list[tuple[float, str, str]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._open: dict[str, list[tuple[str, float]]] = {}  # brick -> its beads and their open time
        self._bead: dict[str, tuple[str, float]] = {}  # bead -> its brick and open time
        self._cure_s: dict[str, float] = {}  # glued brick -> cure time
        for d in self.plan.deadlines:
            if d.kind == "open":
                self._open.setdefault(d.brick, []).append((d.adhesion, d.lag_s))
                self._bead[d.adhesion] = (d.brick, d.lag_s)
            else:
                self._cure_s[d.brick] = d.lag_s
        self._work = {t.id: work_point_m(t) for t in self.plan.tasks}
        self.now_s = 0.0
        self._changed = False  # a bead was sprayed: the site gate's answers changed
        self._expired_in: dict[tuple[str, int], int] = {}  # (brick, attempt) -> its beads' expiries meanwhile
        self._untold: list[str] = []  # beads sprayed whose ``glue`` event is not emitted yet
        self._where: dict[str, Vec3] = {}  # UAV -> where it was at the last tick
        self._open_until_s: list[float] = []  # the open beads' ends at the last step (known_ends_s)

    # -- the site gate ---------------------------------------------------------------------------------------
    def may_enter(self, uav: str, site_m: Vec3) -> bool:
        """The site intervals' rule, and for a brick coming down to its site: every bead under it open then."""
        if not self.sites.may_enter(uav, site_m):
            return False
        tid = self.dispatcher.task_of(uav)
        if tid is None or tid not in self._open:
            return True
        w = self._work[tid]
        if math.hypot(site_m[0] - w[0], site_m[1] - w[1]) >= AT_SITE_M:
            return True  # a flight elsewhere (the pallet)
        lead = self._lead_s(uav, site_m)
        return all(self._fresh(a, lag, lead) for a, lag in self._open[tid])

    def open_for_s(self, uav: str, site_m: Vec3, now_s: float) -> float | None:
        """For ``uav`` granted ``site_m``: when it is its brick's drop-off with glue under it, the seconds from
        ``now_s`` the glue stays open (the bead sprayed longest ago; a re-seat presses the brick again only within it,
        :mod:`masonry.fsm.reseat`); None otherwise."""
        tid = self.dispatcher.task_of(uav)
        if tid is None or tid not in self._open:
            return None
        w = self._work[tid]
        if math.hypot(site_m[0] - w[0], site_m[1] - w[1]) >= AT_SITE_M:
            return None
        closes = [self.sprayed_at_s[a] + lag for a, lag in self._open[tid] if a in self.sprayed_at_s]
        return min(closes) - now_s if closes else 0.0

    def _lead_s(self, uav: str, site_m: Vec3) -> float:
        """The flight from where ``uav`` is (at the last tick) to ``site_m``, before its placing descent: a UAV
        granted from a hold point presses its brick that much later (0 s: its position is not known)."""
        p = self._where.get(uav)
        if p is None:
            return 0.0
        across_m = math.hypot(site_m[0] - p[0], site_m[1] - p[1])
        return across_m / self.cruise_speed_mps + abs(site_m[2] - p[2]) / self.vertical_speed_mps

    def entered(self, uav: str, site_m: Vec3, now_s: float) -> None:
        self.sites.entered(uav, site_m, now_s)

    def left(self, uav: str, now_s: float) -> bool:
        return self.sites.left(uav, now_s)

    def waited_on(self, uav: str) -> tuple[tuple[tuple[float, float], tuple[float, float]], ...]:
        """The site intervals' answer: a bead sprayed again is a not-done prerequisite of its brick again."""
        return self.sites.waited_on(uav)

    def _fresh(self, bead: str, open_time_s: float, lead_s: float = 0.0) -> bool:
        """Done, and still open when a brick that leaves in ``lead_s`` presses on it."""
        sprayed = self.sprayed_at_s.get(bead)
        done = bead in self.dispatcher.done
        return done and sprayed is not None and self.now_s - sprayed + self.margin_s + lead_s <= open_time_s

    # -- mission control's events ------------------------------------------------------------------------------
    def completed(self, task_id: str, now_s: float) -> None:
        """A task was reported done at ``now_s``: a bead's spraying ended, or a glued brick was placed."""
        if task_id in self._cure_s:
            self.cures_at_s[task_id] = now_s + self._cure_s[task_id]
        else:
            self.sprayed_at_s[task_id] = now_s
            self._changed = True
            self._untold.append(task_id)

    def restore(self, completions: Iterable[tuple[str, float]]) -> None:
        """A resumed mission: each journaled completion (task id, time s) as if heard now, in time order (a bead
        sprayed before the stop is as old as the journal says; a re-spray's last completion wins)."""
        for task_id, time_s in sorted(completions, key=lambda c: c[1]):
            self.completed(task_id, time_s)

    def step(self, mc: MissionControl, now_s: float) -> bool:
        """Cures that ended, beads that expired (sprayed again); True when the dispatcher has news."""
        self.now_s = now_s
        self._where = {n: link.position_m for n, link in mc.uavs.items() if link.position_m is not None}
        news = False
        for brick, at in list(self.cures_at_s.items()):
            if now_s >= at:
                del self.cures_at_s[brick]
                self.dispatcher.cured(brick)
                news = True
        done = self.dispatcher.done
        stuck = self.dispatcher.stuck
        self._open_until_s.clear()
        for brick, beads in self._open.items():
            if brick in done or brick in self.sites.on_site or brick in stuck:
                continue  # (a stuck brick never comes: its glue is not sprayed again and again)
            for bead, lag in beads:
                if bead in done and bead in self.sprayed_at_s:
                    if not self._fresh(bead, lag):
                        self._expire(mc, bead, brick, now_s)
                        news = True
                    else:
                        self._open_until_s.append(self.sprayed_at_s[bead] + lag)
        self._tell(mc)
        if news or self._changed:
            self._changed = False
            mc.columns.touch()  # the gate's answers changed: the waiting requests are looked at again
        return news

    def known_ends_s(self) -> list[float]:
        """When the adhesive's clocks run out (the stall watchdog's known waits): each curing brick's cure, each
        sprayed bead's open time while its brick is still to come (it expires by then; as of the last :meth:`step`)."""
        return [*self.cures_at_s.values(), *self._open_until_s]

    def _tell(self, mc: MissionControl) -> None:
        """A ``glue`` event for each bead sprayed since the last tick (with an open time, still open)."""
        for bead in self._untold:
            sprayed = self.sprayed_at_s.get(bead)
            brick, lag = self._bead.get(bead, ("", 0.0))
            if brick and sprayed is not None and brick not in self.dispatcher.done:
                # (a resumed mission's restored beads under bricks placed before the stop are not waiting)
                mc.emit_event(
                    self.now_s, "glue", None, bead, brick=brick, sprayed_s=sprayed, open_until_s=sprayed + lag
                )
        self._untold.clear()

    def _expire(self, mc: MissionControl, bead: str, brick: str, now_s: float) -> None:
        del self.sprayed_at_s[bead]
        self.expiries.append((now_s, bead, brick))
        carrier = self.dispatcher.in_progress.get(brick)
        attempt = mc.ledger.number_of(brick)
        if carrier is not None:
            # at the RECALL_AFTER_EXPIRIES-th expiry in one attempt its UAV puts the brick back and comes again
            # (an attempt: a brick never in time ends stuck, not looping); before, it keeps the brick and waits
            n = self._expired_in[brick, attempt] = self._expired_in.get((brick, attempt), 0) + 1
            if n == RECALL_AFTER_EXPIRIES:
                mc.recall(carrier, now_s, EXPIRED_REASON, brick, attempt)
        self.dispatcher.reopen(bead)
        for att in reversed(mc.history):
            if att.task_id == bead and att.status == "done":
                att.status, att.reason = "failed", EXPIRED_REASON
                if mc.journal is not None:
                    mc.journal.record_failure(now_s, bead, att.uav, EXPIRED_REASON, attempt=att.attempt)
                mc.emit_event(now_s, "failed", att.uav, bead, attempt=att.attempt, reason=EXPIRED_REASON)
                break


def glue_gate(
    plan: Plan, dispatcher: Dispatcher, sites: SiteIntervals, timing: TaskTiming
) -> GlueGate | None:
    """Mission control's glue gate (None: the plan has no deadlines).

    Raises:
        InputError: an open time no brick can meet (shorter than its placing descent and release).
    """
    if not plan.deadlines:
        return None
    margin = timing.descent_duration_s + timing.release_dwell_s + MARGIN_SLACK_S
    for d in plan.deadlines:
        if d.kind == "open" and d.lag_s <= margin:
            raise InputError(
                f"adhesive.open_time_s: {d.lag_s:g} s is not above a brick's placing descent and release "
                f"({margin:g} s with {MARGIN_SLACK_S:g} s of slack): no brick could be placed on open glue"
            )
    if not isinstance(
        dispatcher, JustInTime
    ):  # (make_dispatcher mixes it in whenever the plan has deadlines)
        raise PlanningError(
            f"a plan with deadlines needs a just-in-time dispatcher, not {type(dispatcher).__name__}"
        )
    return GlueGate(plan, dispatcher, sites, margin, timing.cruise_speed_mps, timing.vertical_speed_mps)


__all__ = ["EXPIRED_REASON", "MARGIN_SLACK_S", "RECALL_AFTER_EXPIRIES", "GlueGate", "glue_gate"]
