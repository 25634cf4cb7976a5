"""The ``visit`` physical term of the offline schedule (``masonry schedule --physical visit``; docs/schedule.md,
"The physical model", issue 27): the site part a task holds at run time, at its floor.

The plain model keeps apart each task's least site part (:func:`~masonry.planner.bounds.min_site_s`: a brick's
placing descent, release and verify; a segment's chained descent, spray and close). At run time a site interval
(``site_start_s`` to ``site_end_s`` in a simulated report: from the grant of the flight down to the site to the
request to leave it) holds more, and every part of it is in the task's minimum duration already:

* a brick: the flight in from where the flight down is granted, at least r_c (the blueprint's ``clearance``) from
  the site (the conflict zone's radius: the airspace grants the flight down from outside it), less the arrive
  slack, as one minimum-jerk leg at ``cruise_speed_mps``; the align over the drop-off (one minimum leg); the least
  site part; and the climb out (the brick task's last part);
* a segment: its whole minimum duration (the leg over its start, the hover, the chained descent, the spray, the
  close): the site is granted before the sprayer's leg over the segment's start.

Measured floors (docs/performance/fleet.md, "The site visit at its floor"): every runtime visit of the pyramid
and the 12 m wall at 1 + 1, 4 + 2, 8 + 4 was at least this (by 3.2 s at the least for a brick before the flight
in was counted, 0.7 s after; 0.7 s for a segment). The visit never outgrows the task (the least of the two), so the
term keeps each UAV's sequence and only keeps more of each task apart from its conflicting ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from masonry.planner.bounds import flight_slack_m
from masonry.planner.tasks import BrickTask, Task
from masonry.timing import MIN_LEG_S, TaskTiming, min_jerk_leg_s


def visit_before_ticks(timing: TaskTiming, clearance_m: float, tick_s: float) -> int:
    """What a brick's visit holds before its least site part (ticks, rounded down): the flight in from r_c and
    the align."""
    approach_s = min_jerk_leg_s(max(0.0, clearance_m - flight_slack_m(timing)), timing.cruise_speed_mps)
    return math.floor((approach_s + MIN_LEG_S) / tick_s)


def visit_site(
    tasks: Sequence[Task],
    dur: Sequence[int],
    site: Sequence[int],
    post: Sequence[int],
    timing: TaskTiming,
    clearance_m: float,
    tick_s: float,
) -> list[int]:
    """Per task its visit (ticks): a brick's flight in, align, least site part (``site``) and climb out
    (``post``), a segment's whole minimum duration; never more than the task's minimum duration ``dur``."""
    before = visit_before_ticks(timing, clearance_m, tick_s)
    return [
        min(dur[i], before + site[i] + post[i]) if isinstance(t, BrickTask) else dur[i]
        for i, t in enumerate(tasks)
    ]


__all__ = ["visit_before_ticks", "visit_site"]
