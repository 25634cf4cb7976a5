"""The simulated adhesive's age: how old the glue under each brick was when it was placed, and the open-time and
cure-time violations, measured by the world (issue 31; docs/simulator.md, "Adhesive open and cure times").

The world stamps every bead segment with the time it was laid (:class:`masonry.sim.adhesive.AdhesiveDeposit`).
When a brick is released within :data:`AT_PLACE_M` of its blueprint position, the glue under it is looked up on
each of its adhesion lines (the plan's segments, their ends trimmed by the bead radius, so a neighbour's bead
over the joint does not count): per sample the freshest bead over it, per line the oldest of those (a re-sprayed
line is fresh again), per brick the oldest line: its ``glue_age_s``. Older than the open time is an open-time
violation. A bead laid on top of a brick that has glue under it sooner than the cure time after that brick was
placed is a cure-time violation (counted once per brick). Mission control plays no part in either count.

A stop of mission control rebuilds the world: the glue laid and the bricks placed before it would be unknown to
the new one, and so would the violations counted. :meth:`GlueWatch.snapshot` is journaled with every record (the
simulator's ``measured``, :class:`masonry.mission.measured.MeasuredJournal`), and :meth:`GlueWatch.restore` lays
the journaled beads again in the rebuilt world, at the time the first world laid them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from masonry.adhesive import Adhesive
from masonry.blueprint import Blueprint
from masonry.sim.adhesive import AdhesiveDeposit
from masonry.sim.bricks import BrickField, point_in_rect

Vec3 = tuple[float, float, float]
#: A release within this of the brick's blueprint position (horizontally) is its placement (not a put-back).
AT_PLACE_M = 0.15


class GlueWatch:
    """The glue ages and violations of a world (inert, ``enabled`` False, without an ``adhesive``)."""

    def __init__(self, blueprint: Blueprint, deposit: AdhesiveDeposit) -> None:
        from masonry.planner import plan

        self.adhesive: Adhesive = blueprint.adhesive or Adhesive()
        self.enabled = blueprint.adhesive is not None
        self._deposit = deposit
        self._blueprint = {b.id: b for b in blueprint.bricks}
        self._lines: dict[int, list[tuple[Vec3, Vec3]]] = {}
        trim = deposit.bead_radius_m
        for t in plan(blueprint).tasks if self.enabled else ():
            if t.kind == "adhesion":
                self._lines.setdefault(t.above, []).append(_trimmed(t.start_m, t.end_m, trim))  # type: ignore[union-attr]
        #: a bead's line (start, end; its task's, not trimmed) -> when its glue was laid, noted when it was done
        self.bead_laid_at_s: dict[tuple[Vec3, Vec3], float] = {}
        #: brick id -> age of the oldest glue under it when it was placed (s)
        self.glue_age_s: dict[int, float] = {}
        self.placed_at_s: dict[int, float] = {}
        self.open_violations: list[int] = []
        self.cure_violations: set[int] = set()

    def placed(self, brick_id: int, position_m: Vec3, now_s: float) -> None:
        """Brick ``brick_id`` was released at ``position_m``: at its place, its glue's age is measured."""
        if not self.enabled:
            return
        target = self._blueprint[brick_id].position_m
        if math.hypot(position_m[0] - target[0], position_m[1] - target[1]) > AT_PLACE_M:
            return
        if brick_id in self._lines:  # (glue under it: its cure counts from now)
            self.placed_at_s[brick_id] = now_s
        laid = [self._deposit.laid_at_s(a, b) for a, b in self._lines.get(brick_id, ())]
        times = [t for t in laid if t is not None]
        if not times:
            return
        age = now_s - min(times)
        self.glue_age_s[brick_id] = age
        if self.adhesive.open_time_s is not None and age > self.adhesive.open_time_s:
            self.open_violations.append(brick_id)

    def sprayed_at(self, field: BrickField, point_m: Vec3, now_s: float) -> None:
        """Glue was laid at ``point_m`` (on a surface) at ``now_s``: on top of which brick, if any."""
        if not self.enabled:
            return
        x, y, z = point_m
        for b in field.near(x, y, 0.0):
            # (not within a bead's radius of its edge: a bead ending at a joint is not on the brick beside it)
            if abs(b.top_z_m - z) < 1e-6 and point_in_rect(x, y, *b.rect(self._deposit.bead_radius_m)):
                self.sprayed_on(b.id, now_s)

    def sprayed_on(self, brick_id: int, now_s: float) -> None:
        """Glue was laid on top of brick ``brick_id`` at ``now_s``."""
        placed = self.placed_at_s.get(brick_id)
        if placed is None:
            return  # a pre-placed brick, or one on the ground: no glue under it to cure
        if now_s - placed < self.adhesive.cure_time_s:
            self.cure_violations.add(brick_id)

    def note_bead(self, start_m: Vec3, end_m: Vec3) -> None:
        """A bead on the line ``start_m`` -> ``end_m`` (its task's) was reported done: note when it was laid.

        Lines, not task ids: a rebuilt world's plan (its bricks placed before the stop) numbers its tasks anew."""
        if not self.enabled:
            return
        laid = self._deposit.laid_at_s(*_trimmed(start_m, end_m, self._deposit.bead_radius_m))
        if laid is not None:
            self.bead_laid_at_s[(tuple(start_m), tuple(end_m))] = laid  # type: ignore[index]

    def snapshot(self) -> dict[str, object]:
        """What a rebuilt world needs to go on measuring (JSON-able; see the module docstring)."""
        return {
            "beads": [[*a, *b, t] for (a, b), t in self.bead_laid_at_s.items()],
            "placed_s": {str(b): t for b, t in self.placed_at_s.items()},
            "ages_s": {str(b): a for b, a in self.glue_age_s.items()},
            "open": list(self.open_violations),
            "cure": sorted(self.cure_violations),
        }

    def restore(self, snapshot: object) -> None:
        """A rebuilt world after a stop: the journaled :meth:`snapshot`'s beads laid again at their times, its
        placements, ages and violations kept (anything unreadable in it is ignored)."""
        if not self.enabled or not isinstance(snapshot, Mapping):
            return
        beads = snapshot.get("beads")
        for bead in beads if isinstance(beads, list) else ():
            if isinstance(bead, list) and len(bead) == 7 and all(isinstance(v, (int, float)) for v in bead):
                a, b, t = (bead[0], bead[1], bead[2]), (bead[3], bead[4], bead[5]), float(bead[6])
                self._deposit.add(a, b, t)
                self.bead_laid_at_s[(a, b)] = t
        ids = {str(b): b for b in self._blueprint}
        self.placed_at_s.update(
            {ids[k]: t for k, t in _numbers(snapshot.get("placed_s")).items() if k in ids}
        )
        self.glue_age_s.update({ids[k]: a for k, a in _numbers(snapshot.get("ages_s")).items() if k in ids})
        self.open_violations.extend(b for b in _ints(snapshot.get("open")) if b in self._blueprint)
        self.cure_violations.update(b for b in _ints(snapshot.get("cure")) if b in self._blueprint)

    def report_fields(self, task_ids: Mapping[int, str]) -> dict[str, object]:
        """What the mission report carries: ``glue_age_s`` per brick task id, and both violation counts."""
        return {
            "glue_age_s": {task_ids[b]: age for b, age in self.glue_age_s.items() if b in task_ids},
            "open_time_violations": len(self.open_violations),
            "cure_time_violations": len(self.cure_violations),
            "open_time_s": self.adhesive.open_time_s,
        }


def _numbers(value: object) -> dict[str, float]:
    items = value.items() if isinstance(value, Mapping) else ()
    return {str(k): float(v) for k, v in items if isinstance(v, (int, float)) and math.isfinite(v)}


def _ints(value: object) -> list[int]:
    return [int(v) for v in value if isinstance(v, int)] if isinstance(value, list) else []


def _trimmed(start_m: Vec3, end_m: Vec3, trim_m: float) -> tuple[Vec3, Vec3]:
    length = math.dist(start_m[:2], end_m[:2])
    if length <= 2.0 * trim_m:
        mid = tuple((a + b) / 2.0 for a, b in zip(start_m, end_m))
        return mid, mid  # type: ignore[return-value]
    f = trim_m / length
    a = tuple(s + f * (e - s) for s, e in zip(start_m, end_m))
    b = tuple(e - f * (e - s) for s, e in zip(start_m, end_m))
    return a, b  # type: ignore[return-value]


__all__ = ["AT_PLACE_M", "GlueWatch"]
