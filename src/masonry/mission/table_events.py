"""The reservation table's changes as mission events, for the log, ``masonry replay --at`` and the live page (issue
27, "Explain every wait"; docs/logging.md, "The reservation table"). Pure: no I/O, no clock.

With ``--airspace table`` mission control grants flights from a space-time reservation table
(:class:`~masonry.mission.reserved.TableClearance`). :class:`TableWatch` is that table's ``on_change``: after
every change it compares the table with the one it saw last and hands the mission's event sink one
``reservation`` event per reservation

- ``made``: new in the table;
- ``moved``: the same UAV, volume, purpose and task with another window (shifted, extended for a late UAV, or
  shortened: a stay that ends when its UAV sets off), or the same window with its volume cut to what lies ahead
  of its UAV (a leg under way); ``was`` is the window before;
- ``released``: dropped before its window ended, or its window cut to end now (a flight's legs once the UAV is
  down at its site, everything of a UAV out of the mission).

A window that runs to its end is not released: the table drops it then, and so does a reader (its ``t1_s`` says
when). Each reservation has an ``id``, from 1 in the order made, that its later events repeat.

The table's holds on take-offs (:class:`~masonry.reservation.Hold`: the operator's pause and recall, the wind
limit's groundings, :mod:`masonry.mission.table_holds`) are reported the same way, one ``hold`` event per hold
``made`` or ``released`` (lifted: its window cut to end now), with its own ``id`` (from 1 among holds), its ``cause``,
``uavs`` (empty: every UAV) and window. Under the default ``columns`` airspace there is no table, and no such event.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from masonry.mission.events import EventSink, MissionEvent

if TYPE_CHECKING:  # (at run time this module needs only the events: the CLI imports it before any mission)
    from masonry.mission.control import MissionControl
    from masonry.reservation import Hold, Reservation, Table

#: The changes a ``reservation`` event reports (its ``change`` field).
CHANGES = ("made", "moved", "released")


def _key(r: Reservation) -> tuple[object, ...]:
    """What stays the same when a reservation moves: its UAV, volume, purpose and task."""
    return (r.uav, r.volume, r.purpose, r.task)


def _arrival(arrived: dict[tuple[object, ...], list[Reservation]], r: Reservation) -> Reservation | None:
    """What ``r`` became, taken out of ``arrived``: the same UAV, volume, purpose and task (moved), else the same
    UAV, purpose, task and window with another volume (a leg under way cut to what lies ahead of its UAV,
    :func:`masonry.mission.reserved_parts.ahead_of`); None: neither (released, or ended)."""
    same = arrived.get(_key(r))
    if same:
        return same.pop(0)
    for rs in arrived.values():
        for i, q in enumerate(rs):
            if (q.uav, q.purpose, q.task, q.t0_s, q.t1_s) == (r.uav, r.purpose, r.task, r.t0_s, r.t1_s):
                return rs.pop(i)
    return None


def _end(t1_s: float) -> float | None:
    return None if math.isinf(t1_s) else t1_s


def hold_fields(h: Hold) -> dict[str, object]:
    """A hold as an event's JSON fields: ``cause``, ``uavs`` (sorted; empty: every UAV), ``t0_s`` and ``t1_s``
    (null: until lifted)."""
    return {"cause": h.cause, "uavs": sorted(h.uavs), "t0_s": h.t0_s, "t1_s": _end(h.t1_s)}


def reservation_fields(r: Reservation) -> dict[str, object]:
    """A reservation as an event's JSON fields: ``purpose``, ``t0_s``, ``t1_s`` (null: open-ended), ``volume``
    (``[ax, ay, bx, by, z0, z1, radius]``, metres) and ``space`` (the volume's kind: air, ground or site)."""
    v = r.volume
    return {
        "purpose": r.purpose,
        "t0_s": r.t0_s,
        "t1_s": _end(r.t1_s),
        "volume": [v.a[0], v.a[1], v.b[0], v.b[1], v.z0_m, v.z1_m, v.radius_m],
        "space": v.kind,
    }


class TableWatch:
    """Turns each change of a reservation table into ``reservation`` events (see the module docstring).

    Args:
        sink: returns the event sink to hand them to (None: nobody watches now; the next change with a sink
            reports everything since).
        task_of: the task a UAV has in hand (its reservations serve it; None: none), for a reservation that
            names no task itself.
    """

    def __init__(
        self, sink: Callable[[], EventSink | None], task_of: Callable[[str], str | None] = lambda uav: None
    ) -> None:
        self.sink = sink
        self.task_of = task_of
        self._seen: tuple[Reservation, ...] = ()
        self._ids: dict[Reservation, list[int]] = {}  # each reservation in the table seen last -> its ids
        self._next_id = 1
        self._tasks: dict[int, str | None] = {}  # id -> the task its UAV had in hand when it was made
        self._holds: dict[tuple[str, frozenset[str], float], tuple[int, Hold]] = {}  # held seen last, by key
        self._next_hold = 1
        self._seen_holds: tuple[Hold, ...] = ()

    def __call__(self, table: Table, now_s: float) -> None:
        """The table changed at ``now_s``: hand the sink what changed."""
        same = table.reservations is self._seen or table.reservations == self._seen
        if same and (table.holds is self._seen_holds or table.holds == self._seen_holds):
            return
        sink = self.sink()
        if sink is None:
            return
        for event in self.changes(table, now_s):
            sink.emit(event)

    def changes(self, table: Table, now_s: float) -> list[MissionEvent]:
        """The events between the table seen last and ``table`` (which becomes the one seen last)."""
        old, new = Counter(self._seen), Counter(table.reservations)
        gone, came = old - new, new - old
        self._seen = table.reservations
        arrived: dict[tuple[object, ...], list[Reservation]] = {}
        for r in sorted(came.elements(), key=lambda r: (r.t0_s, r.t1_s)):
            arrived.setdefault(_key(r), []).append(r)
        out: list[MissionEvent] = []
        for r in sorted(gone.elements(), key=lambda r: (r.uav, r.t0_s, r.t1_s)):
            rid = self._take_id(r)
            after = _arrival(arrived, r)
            if after is not None:
                self._ids.setdefault(after, []).append(rid)
                change = "released" if after.t1_s <= now_s < r.t1_s else "moved"
                out.append(self._event(now_s, change, rid, after, was=[r.t0_s, _end(r.t1_s)]))
            else:  # (one whose window ran to its end is not released: it ended)
                if r.t1_s > now_s:
                    out.append(self._event(now_s, "released", rid, r.until(max(r.t0_s, now_s))))
                self._tasks.pop(rid, None)
        for r in (r for rs in arrived.values() for r in rs):
            rid, self._next_id = self._next_id, self._next_id + 1
            self._ids.setdefault(r, []).append(rid)
            out.append(self._event(now_s, "made", rid, r))
        out.sort(key=lambda e: int(e.fields["id"]))
        return [*out, *self.hold_changes(table.holds, now_s)]

    def hold_changes(self, holds: tuple[Hold, ...], now_s: float) -> list[MissionEvent]:
        """The ``hold`` events between the holds seen last and ``holds`` (which become the ones seen last): one
        gone before its end (lifted) is ``released``, its window cut to end now (one that ran to its end: nothing);
        one whose end changed ``moved`` (``released`` if it ends by now); a new one ``made``."""
        self._seen_holds = holds
        now = {(h.cause, h.uavs, h.t0_s): h for h in holds}
        out: list[MissionEvent] = []
        for key, (hid, h) in sorted(self._holds.items(), key=lambda kv: kv[1][0]):
            after = now.get(key)
            if after == h:
                continue
            del self._holds[key]
            if after is None or after.t1_s <= now_s:
                if h.t1_s > now_s:  # (lifted before its end)
                    out.append(self._hold_event(now_s, "released", hid, h.until(now_s)))
                now.pop(key, None)
                continue
            self._holds[key] = (hid, after)
            out.append(self._hold_event(now_s, "moved", hid, after))
        for key, h in now.items():
            if key not in self._holds:
                hid, self._next_hold = self._next_hold, self._next_hold + 1
                self._holds[key] = (hid, h)
                out.append(self._hold_event(now_s, "made", hid, h))
        return out

    @staticmethod
    def _hold_event(now_s: float, change: str, hid: int, h: Hold) -> MissionEvent:
        uav = next(iter(h.uavs)) if len(h.uavs) == 1 else None
        return MissionEvent(now_s, "hold", uav, None, {"change": change, "id": hid, **hold_fields(h)})

    def _take_id(self, r: Reservation) -> int:
        ids = self._ids.get(r)
        if not ids:  # (not seen made: a table watched from the middle)
            rid, self._next_id = self._next_id, self._next_id + 1
            return rid
        rid = ids.pop(0)
        if not ids:
            del self._ids[r]
        return rid

    def _event(
        self, now_s: float, change: str, rid: int, r: Reservation, was: list[float | None] | None = None
    ) -> MissionEvent:
        fields: dict[str, object] = {"change": change, "id": rid, **reservation_fields(r)}
        if was is not None:
            fields["was"] = was
        task = r.task or self._tasks.get(rid)
        if task is None and change == "made":
            task = self._tasks[rid] = self.task_of(r.uav)
        return MissionEvent(now_s, "reservation", r.uav, task, fields)


@runtime_checkable
class WatchedTable(Protocol):
    """An airspace with a reservation table it reports changes of (:class:`~masonry.mission.reserved.TableClearance`)."""

    table: Table
    now_s: float
    on_change: Callable[[Table, float], object]


def watch_table(control: MissionControl) -> TableWatch | None:
    """Hand ``control``'s event sink the changes of its reservation table (``--airspace table``), starting with
    what the table holds now (each UAV's pad, as ``made``); None under the ``columns`` airspace (no table)."""
    columns = control.columns
    if not isinstance(columns, WatchedTable):
        return None
    watch = TableWatch(lambda: control.sink, control.dispatcher.task_of)
    columns.on_change = watch
    watch(columns.table, columns.now_s)
    return watch


__all__ = ["CHANGES", "TableWatch", "WatchedTable", "hold_fields", "reservation_fields", "watch_table"]
