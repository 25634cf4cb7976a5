"""The reservation model's invariants under random sequences of requests, clock steps, delays, silences and
losses (issue 27): no two granted reservations of different UAVs overlap in space and time; every granted plan ends
in an open-ended reservation (a place the UAV may stay); a UAV told to wait holds nothing new, and a wait with an
end is granted at that end; every UAV's flight home is granted at a finite time with the others where they are
(so no cycle of waits is a deadlock: docs/safety.md, "The reservation table's rules"); and every request is
granted, at a finite time, once the others have gone back to their pads (deadlock-freedom by construction).
Hypothesis is derandomised (tests/conftest.py); a failing sequence is printed."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from hypothesis import event, given, settings
from hypothesis import strategies as st

from masonry.errors import PlanningError
from masonry.reservation import Grant, Reservation, Table, Wait, Work, decide, layout_problems, pad
from reservation_scenario import LAYERS_M, Scenario, check_table

SITES = [(1.5 * i, y) for i in range(7) for y in (3.0, 4.5)]


@dataclass(frozen=True)
class Step:
    """One step of a random sequence: ``fly`` (to ``site``, working ``seconds``, then staying at ``then``), ``tick``
    (the clock moves ``seconds`` on), ``late`` (``seconds`` behind) or ``silent``."""

    kind: str
    uav: int = 0
    site: int = 0
    seconds: float = 0.0
    then: str = "pad"
    clearance_m: float = 0.0


fly = st.builds(
    Step,
    st.just("fly"),
    st.integers(0, 3),
    st.integers(0, len(SITES) - 1),
    st.floats(5.0, 60.0),
    st.sampled_from(["pad", "site", "site", "parking", "none"]),
    st.sampled_from([0.0, 1.5]),
)
tick = st.builds(Step, st.just("tick"), seconds=st.floats(1.0, 20.0))
late = st.builds(Step, st.just("late"), st.integers(0, 3), seconds=st.floats(1.0, 30.0))
silent = st.builds(Step, st.just("silent"), st.integers(0, 3))
lost = st.builds(Step, st.just("lost"), st.integers(0, 3))


def test_the_random_layout_meets_the_guarantees_condition() -> None:
    """The layout below keeps pads and parking spots out of every flight's way (the deadlock-freedom argument's
    condition, docs/safety.md): four pads 3 m apart, each UAV's parking spot 3 m behind its pad, sites 3 m ahead."""
    homes = {f"u{i}": (3.0 * i, 0.0) for i in range(4)}
    parking = {f"u{i}": (3.0 * i, -3.0) for i in range(4)}
    zones = [Work(xy, 1.0, 1.0).zone() for xy in SITES]
    assert layout_problems(homes, zones, LAYERS_M, parking=parking) == []


def _released(s: Scenario, uav: str) -> tuple[Reservation, ...]:
    """The table's reservations once every UAV but ``uav`` is back on its pad after all that is reserved now."""
    end_s = 1.0 + max((r.t1_s for r in s.table.reservations if not r.open_ended), default=s.now_s)
    table = s.table
    for other in table.uavs():
        if other != uav:
            x, y = s.pads[other]
            table = table.release(other, end_s).add(Reservation(other, pad((x, y)), end_s, math.inf, "stay"))
    return table.reservations


def _every_uav_can_go_home(s: Scenario) -> None:
    """Rule 12 (docs/safety.md): every UAV's flight home from where it stays is granted at a finite start, with the
    others where they are: so no cycle of waits is ever a deadlock (any UAV in it can leave it)."""
    airspace = replace(s.airspace, horizon_s=math.inf)
    for uav in s.table.uavs():
        if any(r.purpose == "lost" and r.open_ended for r in s.table.of(uav)):
            continue  # (it holds its last volume until it is accounted for)
        home = decide(s.table, s.request(uav, then="pad"), s.now_s, airspace)
        assert isinstance(home, Grant) and math.isfinite(home.plan.start_s), f"{uav} cannot go home: {home}"
        event("home: granted")


def _lost(s: Scenario, uav: str) -> None:
    """``uav`` is lost where it stays (or is to stay): plans not under way that need that space are withdrawn."""
    try:
        s.lost(uav, s.where[uav].volume())
        event(f"lost: {'withdrew plans' if s.moves else 'moved nobody'}")
    except PlanningError as exc:  # a plan under way needs that space: refused, the table as it was
        event("lost: refused")
        assert "neither can move" in str(exc), exc


def _late(s: Scenario, uav: str, late_s: float) -> None:
    try:
        s.late(uav, late_s)
        event(f"late: {'moved others' if {m.uav for m in s.moves} - {uav} else 'moved nobody'}")
    except PlanningError as exc:  # a plan under way in the way: refused, the table as it was
        event("late: refused")
        assert "neither can move" in str(exc) or "cannot wait" in str(exc), exc


def _silent(s: Scenario, uav: str) -> None:
    try:
        s.silent(uav)
        event(f"way home: {'moved others' if s.moves else 'moved nobody'}")
    except PlanningError as exc:
        event("way home: refused")
        assert "neither can move" in str(exc) or "cannot wait" in str(exc) or "no layer" in str(exc), exc


def _fly(s: Scenario, uav: str, step: Step) -> None:
    """``uav`` asks for ``step``'s flight: a grant ends open-ended; a wait is honest, reserves nothing, and the
    request is granted at a finite time once the others are back on their pads."""
    x, _y = s.pads[uav]
    stay: str | tuple[float, float] = (x, -3.0) if step.then == "parking" else step.then
    if stay == "none":
        stay = "pad"
    to = None if step.then == "none" else SITES[step.site]
    request = s.request(uav, to, work_s=step.seconds, then=stay, clearance_m=step.clearance_m)
    s.fly(uav, to, work_s=step.seconds, then=stay, clearance_m=step.clearance_m)
    if isinstance(s.last, Grant):
        plan = s.last.plan
        assert s.now_s <= plan.start_s <= s.now_s + s.horizon_s
        event(f"grant: {'now' if plan.start_s == s.now_s else 'later'}, layer {LAYERS_M.index(plan.layer_m)}")
        assert plan.reservations[-1].open_ended and all(not r.open_ended for r in plan.reservations[:-1])
        return
    assert isinstance(s.last, Wait)
    wait = s.last
    event(f"wait: {'until they leave' if math.isinf(wait.until_s) else 'beyond the horizon'}")
    if math.isinf(wait.until_s):
        assert wait.blocked_by and all(r.open_ended and r.uav != uav for r in wait.blocked_by), (
            wait.describe()
        )
    else:
        assert wait.until_s > s.now_s + s.horizon_s
        # an honest wait: asked again then, with nothing newer in the way, it is granted then
        again = decide(s.table, request, wait.until_s, s.airspace)
        assert isinstance(again, Grant) and math.isclose(again.plan.start_s, wait.until_s), again
    # once the others are back on their pads, the request is granted at a finite time
    released = Table(_released(s, uav), s.table.separation)
    check_table(released)
    airspace = replace(s.airspace, horizon_s=math.inf)
    granted = decide(released, request, s.now_s, airspace)
    assert isinstance(granted, Grant), granted
    assert math.isfinite(granted.plan.start_s)
    check_table(granted.table)


@settings(max_examples=80, deadline=None)
@given(
    n=st.integers(2, 4),
    steps=st.lists(st.one_of(fly, fly, tick, late, silent, lost), min_size=6, max_size=30),
    first_arrival=st.booleans(),
)
def test_random_sequences_keep_the_table_sound_and_every_request_is_eventually_granted(
    n: int, steps: list[Step], first_arrival: bool
) -> None:
    uavs = [f"u{i}" for i in range(n)]
    s = Scenario({u: (3.0 * i, 0.0) for i, u in enumerate(uavs)}, first_arrival=first_arrival)
    for step in steps:
        if step.kind == "tick":
            s.at(s.now_s + step.seconds)
            continue
        uav = uavs[step.uav % n]
        gone = any(r.purpose == "lost" and r.open_ended for r in s.table.of(uav))
        if step.kind == "lost" and not gone:
            _lost(s, uav)
        elif step.kind == "late" and not gone:
            _late(s, uav, step.seconds)
        elif step.kind == "silent" and not gone:
            _silent(s, uav)
        elif step.kind == "fly":
            if gone:
                s.found(uav)  # accounted for, back on its pad, before it flies again
            _every_uav_can_go_home(s)
            _fly(s, uav, step)
