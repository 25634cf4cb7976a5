"""The adhesive's deadlines as edges of the plan (issue 31; docs/planner.md, "Adhesive deadlines").

Pure. An adhesive with an open time and a cure time (:class:`masonry.adhesive.Adhesive`) adds two kinds of
edges between an adhesion task and a brick task, each with a lag in seconds:

* ``open`` (adhesion A, brick B above it, ``max_lag_s``): B's site visit (its flight down onto the bead) starts
  at most ``max_lag_s`` after A ends: the bead is still open when the brick is pressed on it;
* ``cure`` (adhesion A' on top of brick B, B, ``min_lag_s``): A' starts at least ``min_lag_s`` after B ends
  (B is pressed on its glue at the end of its placement): nothing is sprayed onto, so nothing placed on, B
  before the glue under it has cured. Only bricks that have glue under them (an adhesion task of the plan)
  get cure edges, and only with a cure time > 0.

The reference point of the cure time is the end of the brick's placement, not the end of the spraying under
it: the joint exists only once the brick is pressed into the bead (a skinned bead that was never pressed does
not cure into a joint), and the later point is the safer one. docs/schedule.md says how the schedule uses them.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from masonry.adhesive import Adhesive
from masonry.planner.tasks import AdhesionTask, Task

DeadlineKind = Literal["open", "cure"]


@dataclass(frozen=True)
class Deadline:
    """One adhesive edge: ``open`` (brick site start - adhesion end <= lag) or ``cure`` (adhesion start - brick
    end >= lag), in seconds."""

    kind: DeadlineKind
    adhesion: str
    brick: str
    lag_s: float


def adhesive_deadlines(tasks: Iterable[Task], adhesive: Adhesive | None) -> tuple[Deadline, ...]:
    """The open edges (one per adhesion task), then the cure edges (one per adhesion task on a glued brick).

    Empty without an adhesive. Adhesion tasks in plan order within each kind.
    """
    if adhesive is None:
        return ()
    adhesion = [t for t in tasks if isinstance(t, AdhesionTask)]
    out: list[Deadline] = []
    if adhesive.open_time_s is not None:
        out.extend(Deadline("open", a.id, f"B{a.above}", adhesive.open_time_s) for a in adhesion)
    if adhesive.cure_time_s > 0.0:
        glued = {a.above for a in adhesion}
        out.extend(
            Deadline("cure", a.id, f"B{a.below}", adhesive.cure_time_s) for a in adhesion if a.below in glued
        )
    return tuple(out)


def deadline_to_dict(deadline: Deadline) -> dict[str, object]:
    """The JSON object of a deadline in ``masonry plan --format json``."""
    lag = "max_lag_s" if deadline.kind == "open" else "min_lag_s"
    return {
        "kind": deadline.kind,
        "adhesion": deadline.adhesion,
        "brick": deadline.brick,
        lag: round(deadline.lag_s, 9) + 0.0,
    }


def open_deadlines_of(deadlines: Iterable[Deadline]) -> dict[str, list[Deadline]]:
    """Per brick task, its open edges (the beads under it)."""
    out: dict[str, list[Deadline]] = {}
    for d in deadlines:
        if d.kind == "open":
            out.setdefault(d.brick, []).append(d)
    return out


def cure_deadlines_of(deadlines: Iterable[Deadline]) -> dict[str, list[Deadline]]:
    """Per adhesion task, its cure edges (the glued brick it is sprayed onto)."""
    out: dict[str, list[Deadline]] = {}
    for d in deadlines:
        if d.kind == "cure":
            out.setdefault(d.adhesion, []).append(d)
    return out
