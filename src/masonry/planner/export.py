"""The plan as JSON (the shape `masonry plan --format json` prints), built fast enough for 100k-brick walls.

Shape::

    {"tasks": [{"id": "B1", "kind": "brick", "brick": 1, "done": false, "position": [x, y, z], "yaw": 0.0,
                "pickup": [x, y, z] | null},
               {"id": "A0", "kind": "adhesion", "below": 0, "above": 1, "start": [...], "end": [...],
                "length": 0.3}],
     "dependencies": [["B1", "A0"], ["A0", "B0"]],
     "conflicts": [["A3", "B7"]]}

With an ``adhesive`` in the blueprint, a fourth key lists its edges (:mod:`masonry.planner.deadlines`)::

     "deadlines": [{"kind": "open", "adhesion": "A0", "brick": "B1", "max_lag_s": 300.0},
                   {"kind": "cure", "adhesion": "A5", "brick": "B1", "min_lag_s": 120.0}]

Numbers are rounded to the nanometre (1e-9) so 0.1 + 0.2 prints as 0.3.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from masonry.planner.deadlines import Deadline, deadline_to_dict
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan, Task

if TYPE_CHECKING:
    from masonry.planner.graphs import PlanGraphs


def _r(value: float) -> float:
    return round(float(value), 9) + 0.0


def _v(values: Sequence[float] | None) -> list[float] | None:
    return None if values is None else [_r(v) for v in values]


def task_to_dict(task: Task) -> dict[str, Any]:
    """One task as its JSON object."""
    if isinstance(task, BrickTask):
        return {
            "id": task.id,
            "kind": "brick",
            "brick": task.brick,
            "done": task.done,
            "position": _v(task.position_m),
            "yaw": _r(task.yaw_rad),
            "pickup": _v(task.pickup_m),
        }
    assert isinstance(task, AdhesionTask)
    return {
        "id": task.id,
        "kind": "adhesion",
        "below": task.below,
        "above": task.above,
        "start": _v(task.start_m),
        "end": _v(task.end_m),
        "length": _r(task.length_m),
    }


def plan_to_dict(plan: Plan) -> dict[str, Any]:
    """The whole plan as plain JSON-ready data."""
    return {
        "tasks": [task_to_dict(t) for t in plan.tasks],
        "dependencies": [list(e) for e in plan.dependencies],
        "conflicts": [list(c) for c in plan.conflicts],
        **_deadlines(plan.deadlines),
    }


def _deadlines(deadlines: Sequence[Deadline]) -> dict[str, Any]:
    """``{"deadlines": [...]}`` when the plan has any (absent otherwise: the plan's JSON of old)."""
    return {"deadlines": [deadline_to_dict(d) for d in deadlines]} if deadlines else {}


def iter_plan_json(plan: Plan | PlanGraphs) -> Iterator[str]:
    """The plan's JSON text in pieces (one task per line; the pair lists in large chunks).

    Takes a :class:`Plan` or, for very large walls, the :class:`PlanGraphs` from ``plan_graphs()``.
    """
    yield '{"tasks": ['
    for k, task in enumerate(plan.tasks):
        yield ("\n  " if k == 0 else ",\n  ") + json.dumps(task_to_dict(task))
    yield "],\n"
    yield ' "dependencies": '
    yield from _pairs_json(plan, plan.dependencies, None)
    yield ",\n"
    yield ' "conflicts": '
    if isinstance(plan, Plan):
        yield from _pairs_json(plan, plan.conflicts, plan.conflict_indices)
    else:
        yield from _pairs_json(plan, None, plan.conflict_indices)
    if plan.deadlines:
        yield ',\n "deadlines": ['
        for k, d in enumerate(plan.deadlines):
            yield ("\n  " if k == 0 else ",\n  ") + json.dumps(deadline_to_dict(d))
        yield "]"
    yield "}\n"


def plan_json(plan: Plan | PlanGraphs) -> str:
    """The plan's whole JSON text."""
    return "".join(iter_plan_json(plan))


def _pairs_json(
    plan: Plan | PlanGraphs,
    pairs: Sequence[tuple[str, str]] | None,
    indices: tuple[np.ndarray, np.ndarray] | None,
    chunk: int = 1_000_000,
) -> Iterator[str]:
    if pairs is None:
        assert indices is not None, "the pairs or their indices"
        count = len(indices[0])
    else:
        count = len(pairs)
    if count == 0:
        yield "[]"
        return
    if pairs is not None and (indices is None or len(indices[0]) != len(pairs)):
        position = {t.id: k for k, t in enumerate(plan.tasks)}
        a = np.fromiter((position[p[0]] for p in pairs), dtype=np.int64, count=len(pairs))
        b = np.fromiter((position[p[1]] for p in pairs), dtype=np.int64, count=len(pairs))
    else:
        assert indices is not None  # pairs is None here, or indices match the pairs
        a, b = np.asarray(indices[0], dtype=np.int64), np.asarray(indices[1], dtype=np.int64)
    # Each id as its quoted JSON bytes, NUL-padded to a fixed width; a pair is then a fixed-width record whose
    # NULs are dropped at the end. Ids here are "B<int>" / "A<int>", so json.dumps adds no escapes.
    quoted = [json.dumps(t.id).encode() for t in plan.tasks]
    width = max(len(q) for q in quoted)
    table = np.array(quoted, dtype=f"S{width}")
    record = np.dtype(
        [("open", "S1"), ("a", f"S{width}"), ("sep", "S2"), ("b", f"S{width}"), ("close", "S3")]
    )
    yield "["
    for begin in range(0, len(a), chunk):
        sl = slice(begin, begin + chunk)
        rows = np.zeros(len(a[sl]), dtype=record)
        rows["open"] = b"["
        rows["a"] = table[a[sl]]
        rows["sep"] = b", "
        rows["b"] = table[b[sl]]
        rows["close"] = b"], "
        raw = rows.view(np.uint8)
        text = raw[raw != 0].tobytes().decode("ascii")
        if begin + chunk >= len(a):
            text = text[:-2]  # no separator after the last pair
        yield text
    yield "]"
