"""Test doubles and random steps for driving a :class:`ColumnClearance` by hand (shared by the airspace tests)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from masonry.mission.airspace import ColumnClearance, Phase
from masonry.mission.reserved import TableClearance

Vec3 = tuple[float, float, float]


class HeldGate:
    """A site gate that holds back the UAVs in ``held`` (their site is busy, or their task's prerequisites are not
    done yet) and lets every other UAV in."""

    def __init__(self, *held: str) -> None:
        self.held = set(held)

    def may_enter(self, uav: str, site_m: Vec3) -> bool:
        return uav not in self.held

    def entered(self, uav: str, site_m: Vec3, now_s: float) -> None:
        pass

    def waited_on(self, uav: str) -> tuple[str, ...]:
        return ()

    def left(self, uav: str, now_s: float) -> bool:
        return False


def apply_step(
    c: ColumnClearance,
    uav: str,
    op: str,
    site: Sequence[float],
    pos: Sequence[float],
    top: float,
    t: float,
    *,
    homes: Mapping[str, Vec3] | None = None,
    gate: HeldGate | None = None,
) -> None:
    """One random step of a UAV: ask for ``site`` from ``pos`` (``req``), end its transit (``end``), leave what it
    holds (``away``), move along its layer (``move``), reach its hold point (``hold``), go silent (``lost``), take
    off, land on its home pad, or be held back / let in by the gate (``gate``)."""
    if op == "req":
        c.request(uav, (*site, 1.2), t, (*pos, 1.2), top_m=top)
    elif op == "end":
        c.end_transit(uav)
    elif op == "away":
        for h in c.held.get(uav, ()):
            c.release(uav, h)
    elif op == "move":
        layer = c.layer_m(uav)
        if layer is not None:
            c.progress(uav, (*pos, layer))
    elif op == "hold":
        hover = [v for v in c.volumes(uav) if v.kind == "hover"]
        layer = c.layer_m(uav)
        if c.phase(uav) is Phase.TO_HOLD and hover and layer is not None:
            c.progress(uav, (*hover[-1].a, layer))
    elif op == "lost":
        c.release(uav)
    elif op == "takeoff":
        c.take_off(uav)
    elif op == "land" and homes is not None and uav in homes:
        c.landed(uav, homes[uav])
    elif op == "gate" and gate is not None:
        gate.held ^= {uav}
        c.touch()


def table_pair() -> TableClearance:
    """The table of two UAVs, a and b, with pads 3 m apart 5 m south of the wall (r_c 0.8 m)."""
    homes = {"a": (0.0, -5.0, 0.0), "b": (3.0, -5.0, 0.0)}
    return TableClearance(0.8, 2.0, homes=homes, start_base_m=1.2)


def table_pair_waiting_for_each_others_site() -> TableClearance:
    """:func:`table_pair` with a at its site (0, 0), b at its site (3, 0), each refused the other's site at 30 s:
    a cycle of stays the parking rule breaks (lift spots off: one of them would break it first, the latest request's
    UAV climbing to its lift spot, ``tests/test_table_lift.py``)."""
    air = table_pair()
    air.lifting = False
    s1, s2 = (0.0, 0.0, 1.2), (3.0, 0.0, 1.2)
    for uav, site in (("a", s1), ("b", s2)):
        air.take_off(uav)
        assert air.request(uav, site, 0.0, (site[0], -5.0, 1.2)).granted
    for t in range(1, 30):
        air.grant(float(t))
    for uav, site in (("a", s1), ("b", s2)):
        air.end_transit(uav)
        air.progress(uav, site)
    assert not air.request("a", s2, 30.0, s1).granted
    assert not air.request("b", s1, 30.5, s2).granted
    return air
