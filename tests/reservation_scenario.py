"""A small scenario language over the pure reservation model (issue 27): UAVs on pads, clock steps, requests and
the grants, waits and moves expected of them. Every step re-checks the table's invariants.

    s = Scenario({"a": (0, 0), "b": (10, 0)})
    s.at(0).fly("a", to=(10, 4), work_s=20).granted(start_s=0, layer=0)
    s.fly("b", to=(10.5, 4), work_s=20).waits(for_uavs=("a",))
    s.at(30).late("a", 15).moved("b")

``fly`` asks for a flight from where the UAV stays now to ``to`` (its work there lasts ``work_s``), then to stay
``then``: ``"pad"`` (default), ``"site"`` or a parking spot ``(x, y)``; without ``to`` it flies straight there.

The same scenario reads as a table (:func:`play`), one step a row: the clock, the UAV, what happens, what is
expected::

    s = play({"a": (0, 0), "b": (10, 0)}, '''
        t_s | uav | does                      | expect
        0   | a   | fly to (5, 5) work 30     | granted now layer 0
        0   | b   | fly to (5.5, 5) work 20   | granted later
        40  | a   | late 25                   | moves b
    ''')

``does``: ``fly to (x, y) [z Z] [work S] [rc R] [task T] [then pad|site|(x, y)]`` (``z``: the work altitude, 1 m
by default), ``home`` (straight to its pad), ``park (x, y)`` (straight to a parking spot there), ``late S``,
``silent``, ``lost [(x, y)]`` (its last volume: the column up to 3 m there, or where it stays), ``found`` (accounted
for: back on its pad from now), ``hold operator|wind`` and ``lift operator|wind`` (a hold on the UAV's take-offs
from now, until lifted; the UAV ``*``: every UAV).
``expect``: ``granted [now|later|at T] [layer K]``, ``waits [for u,v] [until T|until they leave] [held CAUSE]``,
``waits outside the fence``,
``moves u,v`` or ``moves nobody``, ``refused [words of the reason]``, or ``-``. Times are to 0.05 s.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import pytest

from masonry.errors import PlanningError
from masonry.reservation import (
    Airspace,
    Decision,
    Fence,
    FlightPlan,
    Grant,
    Move,
    Place,
    Request,
    Reservation,
    Table,
    Wait,
    Work,
    column,
    decide,
    extend,
    lose,
    start_table,
    violations,
    way_home,
    with_holds,
)
from masonry.reservation.space import Volume

XY = tuple[float, float]

#: Layers over work zones up to 1.2 m (the vertical separation 1.1 m above them and apart)
LAYERS_M = (2.5, 3.6, 4.7, 5.8)


def check_table(table: Table) -> None:
    """The invariants of a table after any step: no two UAVs' reservations clash; every UAV holds exactly one
    open-ended reservation, and it is its last (a place it may stay)."""
    bad = violations(table)
    assert not bad, "clash: " + "; ".join(f"{p.describe()} / {q.describe()}" for p, q in bad)
    for uav in table.uavs():
        mine = table.of(uav)
        open_ended = [r for r in mine if r.open_ended]
        assert len(open_ended) == 1, f"{uav} holds {len(open_ended)} open-ended reservations"
        assert max(r.t0_s for r in mine) == open_ended[0].t0_s, (
            f"{uav}'s open-ended reservation is not its last"
        )


@dataclass
class Scenario:
    """A fleet on its pads, a clock, and the table their requests build."""

    pads: dict[str, XY]
    layers_m: tuple[float, ...] = LAYERS_M
    margin_s: float = 2.0
    horizon_s: float = 60.0
    now_s: float = 0.0
    #: plan each flight at the layer that arrives first (``Airspace.first_arrival``, as mission control's table)
    first_arrival: bool = False
    #: the site's fence every flown leg keeps inside (``Airspace.fence``; None: none)
    fence: Fence | None = None
    table: Table = field(init=False)
    where: dict[str, Place] = field(init=False)
    last: Decision | None = field(init=False, default=None)
    moves: tuple[Move, ...] = field(init=False, default=())
    #: the UAV the last change (late, silent, lost) was about
    about: str = field(init=False, default="")
    plans: dict[str, FlightPlan] = field(init=False, default_factory=dict)
    #: the places UAVs left from, by UAV and the volume they held there (a withdrawn plan leaves its UAV there)
    left_from: dict[tuple[str, Volume], Place] = field(init=False, default_factory=dict)

    def __post_init__(self) -> None:
        self.table = start_table({u: (float(x), float(y)) for u, (x, y) in self.pads.items()}, self.now_s)
        self.where = {u: Place((float(x), float(y))) for u, (x, y) in self.pads.items()}
        check_table(self.table)

    @property
    def airspace(self) -> Airspace:
        return Airspace(
            self.layers_m,
            margin_s=self.margin_s,
            horizon_s=self.horizon_s,
            first_arrival=self.first_arrival,
            fence=self.fence,
        )

    def at(self, t_s: float) -> Scenario:
        """The clock moves on to ``t_s``."""
        assert t_s >= self.now_s, f"the clock goes forward: {t_s} < {self.now_s}"
        self.now_s = t_s
        return self

    def request(
        self,
        uav: str,
        to: XY | None = None,
        *,
        work_s: float = 10.0,
        z_m: float = 1.0,
        along_to: XY | None = None,
        clearance_m: float = 0.0,
        then: str | XY = "pad",
        task: str = "",
    ) -> Request:
        """The request ``fly`` makes."""
        if then == "site":
            stay = None
        elif then == "pad":
            x, y = self.pads[uav]
            stay = Place((float(x), float(y)))
        else:
            assert not isinstance(then, str), f"then: pad, site or (x, y), got {then!r}"
            stay = Place((float(then[0]), float(then[1])), kind="parking")
        work = None
        if to is not None:
            work = Work(
                (float(to[0]), float(to[1])), z_m, work_s, along_to, clearance_m=clearance_m, task=task
            )
        return Request(uav, self.where[uav], work, stay)

    def fly(self, uav: str, to: XY | None = None, **kw: object) -> Scenario:
        """``uav`` asks to fly (see :meth:`request`); a grant updates the table and where it will stay."""
        request = self.request(uav, to, **kw)  # type: ignore[arg-type]
        before = self.table
        self.last = decide(self.table, request, self.now_s, self.airspace)
        if isinstance(self.last, Grant):
            self.table = self.last.table
            self.plans[uav] = self.last.plan
            assert self.last.plan.stay.open_ended, "a granted plan ends where the UAV may stay"
            self.left_from[(uav, request.start.volume())] = request.start
            self.where[uav] = request.stay if request.stay is not None else request.work.end_place()  # type: ignore[union-attr]
        else:
            assert self.table == before, "a wait changes nothing: the UAV keeps only its stay"
        check_table(self.table)
        return self

    def granted(self, *, start_s: float | None = None, layer: int | None = None) -> Scenario:
        """The last request was granted (starting at ``start_s``, on layer index ``layer``)."""
        assert isinstance(self.last, Grant), f"expected a grant, got: {self._said()}"
        if start_s is not None:
            assert math.isclose(self.last.plan.start_s, start_s, abs_tol=1e-6), self.last.plan.start_s
        if layer is not None:
            assert self.last.plan.layer_m == self.layers_m[layer], self.last.plan.layer_m
        return self

    def waits(self, *, for_uavs: tuple[str, ...] | None = None, until_s: float | None = None) -> Scenario:
        """The last request was told to wait (for ``for_uavs``' reservations, until ``until_s``)."""
        assert isinstance(self.last, Wait), f"expected a wait, got: {self._said()}"
        if for_uavs is not None:
            assert self.last.blocking_uavs == for_uavs, self.last.describe()
        if until_s is not None:
            assert math.isclose(self.last.until_s, until_s, abs_tol=1e-6), self.last.describe()
        return self

    def late(self, uav: str, late_s: float) -> Scenario:
        """``uav`` is ``late_s`` behind its plan: its windows extend, others' plans move."""
        self.table, self.moves = extend(self.table, uav, self.now_s, late_s)
        self.about = uav
        check_table(self.table)
        return self

    def silent(self, uav: str, where: Place | None = None) -> Scenario:
        """``uav`` fell silent at ``where`` (default: where it stays now): its way home is reserved from now."""
        x, y = self.pads[uav]
        at = self.where[uav] if where is None else where
        self.table, plan, self.moves = way_home(
            self.table, uav, self.now_s, at, Place((float(x), float(y))), self.airspace
        )
        self.plans[uav] = plan
        self.about = uav
        self.where[uav] = Place((float(x), float(y)))
        check_table(self.table)
        return self

    def lost(self, uav: str, last: Volume) -> Scenario:
        """``uav`` is lost: its last volume stays reserved; plans withdrawn leave their UAVs where they were."""
        places = {(u, p.volume()): p for u, p in self.where.items()}
        places |= {
            (u, Place((float(x), float(y))).volume()): Place((float(x), float(y)))
            for u, (x, y) in self.pads.items()
        }
        places |= self.left_from
        self.table, self.moves = lose(self.table, uav, self.now_s, last)
        self.about = uav
        for m in self.moves:
            if (
                m.after.open_ended and not m.before.open_ended
            ):  # withdrawn: it stays where it was to leave from
                self.where[m.uav] = places[(m.uav, m.after.volume)]
        check_table(self.table)
        return self

    def found(self, uav: str) -> Scenario:
        """``uav`` (lost) is accounted for: back on its pad from now."""
        x, y = self.pads[uav]
        home = Place((float(x), float(y)))
        self.table = self.table.release(uav, self.now_s).add(
            Reservation(uav, home.volume(), self.now_s, math.inf, "stay")
        )
        self.where[uav] = home
        check_table(self.table)
        return self

    def hold(self, uav: str, cause: str, *, lift: bool = False) -> Scenario:
        """``cause`` holds ``uav`` (``*``: every UAV) on the ground from now until lifted (``lift``: lifted now)."""
        key = (cause, frozenset() if uav == "*" else frozenset({uav}))
        wanted = {(h.cause, h.uavs) for h in self.table.holds if math.isinf(h.t1_s)}
        self.table = with_holds(self.table, wanted - {key} if lift else wanted | {key}, self.now_s)
        check_table(self.table)
        return self

    def moved(self, *uavs: str) -> Scenario:
        """The last change moved exactly these UAVs' reservations (besides the one it was about)."""
        got = tuple(sorted({m.uav for m in self.moves} - {self.about}))
        assert got == tuple(sorted(uavs)), f"moved {got}, expected {uavs}: " + "; ".join(
            m.describe() for m in self.moves
        )
        return self

    def _said(self) -> str:
        if isinstance(self.last, Wait):
            return self.last.describe()
        if isinstance(self.last, Grant):
            return f"a grant from {self.last.plan.start_s:.1f} s at {self.last.plan.layer_m} m"
        return "nothing yet"


# ---- the scenario as a table

_TOKEN = re.compile(r"\(\s*-?[\d.]+\s*,\s*-?[\d.]+\s*\)|[^\s]+")
TIME_TOL_S = 0.05


def _xy(token: str) -> XY:
    x, y = token.strip("()").split(",")
    return (float(x), float(y))


def _options(words: list[str], row: str) -> dict[str, str]:
    """``key value`` pairs (``to (1, 2) work 20``) as a dict; a key with no value is an error naming the row."""
    if len(words) % 2:
        raise AssertionError(f"{row!r}: expected `key value` pairs, got {' '.join(words)!r}")
    return dict(zip(words[::2], words[1::2], strict=True))


def _do(s: Scenario, uav: str, does: list[str], row: str) -> None:
    verb, rest = does[0], does[1:]
    if verb == "fly":
        opts = _options(rest, row)
        then_word = opts.pop("then", "pad")
        then: str | XY = then_word if then_word in ("pad", "site") else _xy(then_word)
        kw: dict[str, object] = {"then": then}
        if "work" in opts:
            kw["work_s"] = float(opts.pop("work"))
        if "rc" in opts:
            kw["clearance_m"] = float(opts.pop("rc"))
        if "task" in opts:
            kw["task"] = opts.pop("task")
        if "z" in opts:
            kw["z_m"] = float(opts.pop("z"))
        to = _xy(opts.pop("to")) if "to" in opts else None
        assert not opts, f"{row!r}: unknown options {sorted(opts)}"
        s.fly(uav, to, **kw)
    elif verb == "home":
        s.fly(uav, then="pad")
    elif verb == "park":
        s.fly(uav, then=_xy(rest[0]))
    elif verb == "late":
        s.late(uav, float(rest[0]))
    elif verb == "silent":
        s.silent(uav)
    elif verb == "lost":
        last = column(_xy(rest[0]), 0.0, 3.0) if rest else s.where[uav].volume()
        s.lost(uav, last)
    elif verb == "found":
        s.found(uav)
    elif verb in ("hold", "lift"):
        s.hold(uav, rest[0], lift=verb == "lift")
    else:
        raise AssertionError(f"{row!r}: unknown step {verb!r}")


def _expect(s: Scenario, words: list[str]) -> None:
    if not words or words == ["-"]:
        return
    kind, rest = words[0], words[1:]
    if kind == "granted":
        assert isinstance(s.last, Grant), f"expected a grant, got: {s._said()}"
        start_s = s.last.plan.start_s
        while rest:
            word = rest.pop(0)
            if word == "now":
                assert math.isclose(start_s, s.now_s, abs_tol=1e-9), f"granted from {start_s:.2f} s, not now"
            elif word == "later":
                assert start_s > s.now_s + 1e-9, f"granted now ({start_s:.2f} s), not later"
            elif word == "at":
                want = float(rest.pop(0))
                assert abs(start_s - want) <= TIME_TOL_S, f"granted from {start_s:.2f} s, not {want} s"
            elif word == "layer":
                s.granted(layer=int(rest.pop(0)))
            else:
                raise AssertionError(f"granted: unknown word {word!r}")
    elif kind == "waits":
        _expect_wait(s, rest)
    elif kind == "moves":
        s.moved(*(() if rest == ["nobody"] else tuple(rest[0].split(","))))
    else:
        raise AssertionError(f"unknown expectation {kind!r}")


def _expect_wait(s: Scenario, rest: list[str]) -> None:
    """``waits ...``: the last request was told to wait, as the words say."""
    s.waits()
    assert isinstance(s.last, Wait)
    while rest:
        word = rest.pop(0)
        if word == "for":
            s.waits(for_uavs=tuple(sorted(rest.pop(0).split(","))))
        elif word == "until" and rest[:2] == ["they", "leave"]:
            del rest[:2]
            assert math.isinf(s.last.until_s), s.last.describe()
        elif word == "until":
            want = float(rest.pop(0))
            assert abs(s.last.until_s - want) <= TIME_TOL_S, s.last.describe()
        elif word == "held":
            cause = rest.pop(0)
            assert s.last.held_by and s.last.cause == cause, s.last.describe()
        elif word == "outside" and rest[:2] == ["the", "fence"]:
            del rest[:2]
            assert s.last.outside_fence and math.isinf(s.last.until_s), s.last.describe()
        else:
            raise AssertionError(f"waits: unknown word {word!r}")


def play(pads: dict[str, XY], script: str, **scenario: object) -> Scenario:
    """Play ``script``, a table of steps (the module's docstring), from a fleet on ``pads``; every row's
    expectation is checked (a failure names the row) and the table's invariants after every step. Returns the
    scenario, for the test to look closer."""
    s = Scenario(pads, **scenario)  # type: ignore[arg-type]
    rows = [line.strip() for line in script.strip().splitlines() if line.strip()]
    header = [c.strip() for c in rows[0].split("|")]
    assert header == ["t_s", "uav", "does", "expect"], (
        f"the header is t_s | uav | does | expect, got {rows[0]!r}"
    )
    for row in rows[1:]:
        cells = [c.strip() for c in row.split("|")]
        assert len(cells) == 4, f"{row!r}: four cells, got {len(cells)}"
        t_s, uav, does, expect = cells
        words = _TOKEN.findall(expect)
        try:
            s.at(float(t_s))
            table = s.table
            if words and words[0] == "refused":
                with pytest.raises(PlanningError) as refusal:
                    _do(s, uav, _TOKEN.findall(does), row)
                reason = " ".join(words[1:])
                assert reason in str(refusal.value), f"refused with {refusal.value}, not {reason!r}"
                assert s.table == table, "a refused change leaves the table as it was"
                continue
            _do(s, uav, _TOKEN.findall(does), row)
            _expect(s, words)
        except AssertionError as exc:
            raise AssertionError(f"row {row!r}: {exc}") from exc
    return s
