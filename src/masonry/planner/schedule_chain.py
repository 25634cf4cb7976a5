"""What a sprayer's segment costs after the one before it, chained or not (the offline schedule's ``chain`` term;
docs/schedule.md, "Chaining", issue 27).

A segment's minimum duration (:func:`~masonry.planner.bounds.min_durations_s`) is the chained one: a 1 s leg,
the hover, a ``chain_descent_s`` descent, the spray and the valve's close. The state machine flies that only for a
segment starting where the nozzle ended (within ``chain_distance_m``, :mod:`masonry.fsm.adhesion`): for any other
it first climbs out to the segment's transit altitude (after its last segment) and comes down over the new one's
start (its first descent, :func:`~masonry.timing.spray_descent_leg_s`). The model charges those two legs on every
arc of a sprayer's circuit that is not a chain (from its pad: the first descent), so CP-SAT has a reason to chain.
Both legs are minimum-jerk legs at ``vertical_speed_mps`` counted at their least (at least
:data:`~masonry.timing.MIN_LEG_S`), so the model stays a relaxation of what the machines fly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from masonry.planner.tasks import AdhesionTask, Task
from masonry.timing import TaskTiming, min_jerk_leg_s, spray_descent_leg_s

#: How near a segment's start must be to where the nozzle ended for the state machine to chain it
#: (``UavConfig.chain_distance_m``; tests/test_schedule_chain.py checks they agree).
CHAIN_DISTANCE_M = 0.05


@dataclass(frozen=True)
class ChainCosts:
    """Per task index (ticks): the climb out after it when the next segment is not chained, the first descent over
    its start less the chained one; and the pairs (i, j) where j starts where i ends."""

    climb: tuple[int, ...]
    descend: tuple[int, ...]
    follows: frozenset[tuple[int, int]]

    def extra(self, prev: int, j: int) -> int:
        """Ticks task ``j`` costs over its minimum duration and empty flight after task ``prev`` on the same UAV
        (-1: from its pad, or nothing known)."""
        if prev < 0:
            return self.descend[j]
        if (prev, j) in self.follows:
            return 0
        return self.climb[prev] + self.descend[j]

    def most(self, j: int) -> int:
        """The most :meth:`extra` can be for ``j`` (for a horizon)."""
        return max(self.climb, default=0) + self.descend[j]


def _transit_m(t: AdhesionTask, timing: TaskTiming, cruise_altitude_m: float) -> float:
    """The segment's transit altitude, as the state machine's (cruise, raised so the nozzle clears the surface)."""
    return max(cruise_altitude_m, timing.spray_altitude_m(max(t.start_m[2], t.end_m[2])))


def _spray_body_m(z_m: float, timing: TaskTiming) -> float:
    """The body's altitude spraying a point at ``z_m``."""
    return z_m + timing.spray_height_m - timing.nozzle_offset_m[2]


def chain_costs(
    tasks: Sequence[Task], timing: TaskTiming, cruise_altitude_m: float, tick_s: float
) -> ChainCosts:
    """The chain term of ``tasks`` (ticks, every leg rounded down so the model stays a relaxation)."""
    climb: list[int] = []
    descend: list[int] = []
    for t in tasks:
        if not isinstance(t, AdhesionTask):
            climb.append(0)
            descend.append(0)
            continue
        top = _transit_m(t, timing, cruise_altitude_m)
        up = min_jerk_leg_s(max(0.0, top - _spray_body_m(t.end_m[2], timing)), timing.vertical_speed_mps)
        drop = max(0.0, top - _spray_body_m(t.start_m[2], timing))
        down = spray_descent_leg_s(drop, timing.vertical_speed_mps, timing.spray_descent_s)
        climb.append(math.floor(up / tick_s))
        descend.append(
            math.floor(max(0.0, down - min(timing.spray_descent_s, timing.chain_descent_s)) / tick_s)
        )
    starts: dict[tuple[int, int, int], list[tuple[int, tuple[float, float, float]]]] = {}
    cell = CHAIN_DISTANCE_M
    for j, t in enumerate(tasks):
        if isinstance(t, AdhesionTask):
            key = (
                math.floor(t.start_m[0] / cell),
                math.floor(t.start_m[1] / cell),
                math.floor(t.start_m[2] / cell),
            )
            starts.setdefault(key, []).append((j, t.start_m))
    follows: set[tuple[int, int]] = set()
    for i, t in enumerate(tasks):
        if not isinstance(t, AdhesionTask):
            continue
        e = t.end_m
        kx, ky, kz = (math.floor(e[0] / cell), math.floor(e[1] / cell), math.floor(e[2] / cell))
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for j, s in starts.get((kx + dx, ky + dy, kz + dz), ()):
                        if (
                            j != i
                            and math.hypot(s[0] - e[0], s[1] - e[1]) <= cell
                            and abs(s[2] - e[2]) <= cell
                        ):
                            follows.add((i, j))
    return ChainCosts(tuple(climb), tuple(descend), frozenset(follows))


__all__ = ["CHAIN_DISTANCE_M", "ChainCosts", "chain_costs"]
