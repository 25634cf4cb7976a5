"""The pure mission planner (paper Section III): tasks, dependency graph G^d, conflict graph G^c.

``plan(blueprint) -> Plan`` is a plain function with no I/O; :mod:`masonry.planner.tasks` holds the values.
"""

from __future__ import annotations

from masonry.planner.graphs import adhesion_segments, plan
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan, Task

__all__ = ["AdhesionTask", "BrickTask", "Plan", "Task", "adhesion_segments", "plan"]

# After the plan values: the bounds and the dispatcher, which build on them.
from masonry.planner.bounds import estimate_durations_s, lower_bound_s, min_cycles_s, min_durations_s
from masonry.planner.dispatch import DEFAULT_RESERVATION, POLICIES, RESERVATIONS, Assignment, Dispatcher

__all__ += [
    "DEFAULT_RESERVATION",
    "POLICIES",
    "RESERVATIONS",
    "Assignment",
    "Dispatcher",
    "estimate_durations_s",
    "lower_bound_s",
    "min_cycles_s",
    "min_durations_s",
]
