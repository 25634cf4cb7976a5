"""What the airspace's reservations cost a fleet (issue 27): the same mission flown with classes of reserved
volumes that no longer conflict, as bounds; prints a Markdown table, asserts nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``, geometric
camera) once per mode, each in a fresh state, and prints the makespan, the minimum separation (measured by the
world) and completion per wall, fleet, seed and mode. The modes other than ``main`` are **unsafe measurements, not
ways to fly**: mission control's airspace (:class:`masonry.mission.airspace.ColumnClearance`) is patched here so
that two volumes of the class named never conflict (the UAVs then fly into each other: the separation printed
says so), and the difference to ``main`` is what those reservations cost the makespan, the rest held as it is:

- ``main``: nothing patched;
- ``all``: no two volumes conflict (the layers, the site gate, first come first served and the hold points stay);
- ``flights``: no pair with a climb or a lateral leg in it (zones, hovers and pads still keep apart);
- ``crossings``: no pair of two climbs or lateral legs (flight against flight: what perfectly timed climbs and
  legs could at most let pass; a flight against a zone, a hover or a pad still conflicts);
- ``pallet`` / ``wall``: no pair of volumes both over the pallet (between the first and last pickup row, with
  ``SEPARATION_XY_M`` around) / both over the wall's footprint (the same margin);
- ``hover``: no pair with a hold hover in it;
- ``flight-zone`` / ``flight-hover`` / ``flight-pad``: no pair of a climb or a lateral leg with a zone (a UAV
  working at a site, or the column a flight comes down into) / a hold hover / a landed UAV's pad: one kind of
  what *stays* at a time, against flights (``flights`` is all three and ``crossings`` together);
- ``flight-flight`` / ``flight-stay`` / ``flight-column``: told apart by whose volume it is (mission control's
  :meth:`~masonry.mission.airspace.ColumnClearance.free` patched, not the pair test): no climb or leg conflicts
  with another *flight* (its climb, its leg, or the column it comes down into; two columns down still keep apart)
  / with what *stays* (a zone of a UAV not flying, a hold hover, a pad) / with a flight's column down only;
- ``lane-hover``: no pair with a hold hover in the lane between the pallet and the wall (the hover's y between
  the pickup row nearest the wall and the wall);
- ``no-swaps``: every volume reserved as in ``main``, the packs drain 1/100 as fast (no battery swap);
- ``no-separation``: ``simulate(separation=False)``: no layers, no columns (the site rule only).

Usage: python benchmarks/bench_airspace_cost.py [--walls 12m] [--fleets 4+2,8+4] [--seeds 1,2,3]
       [--modes main,all,flights,crossings,pallet,wall,hover,no-swaps,no-separation]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, simulate_fleet

import masonry.mission.airspace as airspace_mod
import masonry.mission.airspace_queries as queries_mod
import masonry.mission.airspace_requests as requests_mod
import masonry.mission.linger as linger_mod
from masonry.blueprint import Blueprint
from masonry.mission.airspace import ColumnClearance
from masonry.mission.report import MissionReport
from masonry.mission.volumes import Volume, volumes_clear, volumes_conflict
from masonry.separation import SEPARATION_XY_M
from masonry.sim.faults import Faults

MODES = (
    "main",
    "all",
    "flights",
    "crossings",
    "pallet",
    "wall",
    "hover",
    "flight-zone",
    "flight-hover",
    "flight-pad",
    "lane-hover",
    "flight-flight",
    "flight-stay",
    "flight-column",
    "no-swaps",
    "no-separation",
)

#: the volumes of a flight (what moves), against what stays (a zone, a hold hover, a pad)
FLIGHT = frozenset({"climb", "leg"})

#: the pack's drain with ``no-swaps``: 1/100 of the simulated vehicles' 1/1200 per second
NO_SWAP_DRAIN_PER_S = 1.0 / 120000.0

Ignore = Callable[[Volume, Volume], bool]


def bands(blueprint: Blueprint) -> tuple[tuple[float, float], tuple[float, float]]:
    """The y ranges (m) of the pallet and of the wall's footprint, each widened by ``SEPARATION_XY_M``."""
    pick = [b.pickup_m[1] for b in blueprint.bricks if b.pickup_m is not None]
    wall = [b.position_m[1] for b in blueprint.bricks]
    m = SEPARATION_XY_M
    return (min(pick) - m, max(pick) + m), (min(wall) - m, max(wall) + m)


def ignore_for(mode: str, blueprint: Blueprint) -> Ignore | None:
    """Which pairs of volumes the mode lets overlap (None: every pair is checked, as in ``main``)."""
    pallet, wall = bands(blueprint)

    m = SEPARATION_XY_M
    lo, hi = sorted(((pallet[0] + m, pallet[1] - m), (wall[0] + m, wall[1] - m)))
    lane = (lo[1], hi[0])  # between the pickup rows nearest the wall and the wall

    def inside(v: Volume, band: tuple[float, float]) -> bool:
        return all(band[0] < y < band[1] for y in (v.a[1], v.b[1]))

    def against(v: Volume, q: Volume, stay: str) -> bool:
        return (v.kind in FLIGHT and q.kind == stay) or (q.kind in FLIGHT and v.kind == stay)

    rules: dict[str, Ignore] = {
        "all": lambda v, q: True,
        "flights": lambda v, q: bool({v.kind, q.kind} & {"climb", "leg"}),
        "crossings": lambda v, q: {v.kind, q.kind} <= {"climb", "leg"},
        "pallet": lambda v, q: inside(v, pallet) and inside(q, pallet),
        "wall": lambda v, q: inside(v, wall) and inside(q, wall),
        "hover": lambda v, q: "hover" in (v.kind, q.kind),
        "flight-zone": lambda v, q: against(v, q, "zone"),
        "flight-hover": lambda v, q: against(v, q, "hover"),
        "flight-pad": lambda v, q: against(v, q, "pad"),
        "lane-hover": lambda v, q: any(x.kind == "hover" and lane[0] < x.a[1] < lane[1] for x in (v, q)),
    }
    return rules.get(mode)


@contextmanager
def patched(ignore: Ignore | None) -> Iterator[None]:
    """The airspace's conflict tests with ``ignore``'s pairs left out, for the ``with`` block."""
    if ignore is None:
        yield
        return

    def conflict(p: Volume, q: Volume, sep_xy_m: float, sep_z_m: float) -> bool:
        return not ignore(p, q) and volumes_conflict(p, q, sep_xy_m, sep_z_m)

    def clear(vols: Sequence[Volume], others: Sequence[Volume], sep_xy_m: float, sep_z_m: float) -> bool:
        return all(ignore(v, q) or volumes_clear([v], [q], sep_xy_m, sep_z_m) for v in vols for q in others)

    saved = [
        (airspace_mod, "volumes_clear", airspace_mod.volumes_clear),
        (airspace_mod, "volumes_conflict", airspace_mod.volumes_conflict),
        (requests_mod, "volumes_clear", requests_mod.volumes_clear),
        (linger_mod, "volumes_clear", linger_mod.volumes_clear),
        (queries_mod, "volumes_conflict", queries_mod.volumes_conflict),
    ]
    for mod, name, _f in saved:
        setattr(mod, name, clear if name == "volumes_clear" else conflict)
    try:
        yield
    finally:
        for mod, name, f in saved:
            setattr(mod, name, f)


#: the owner-aware modes: which (my volume, its volume) pairs ``ColumnClearance.free`` lets pass, given whether
#: each is a climb or leg (``move``) or a flight's column down (``column``)
OWNER_MODES: dict[str, Callable[[bool, bool, bool, bool], bool]] = {
    "flight-flight": lambda vm, vc, qm, qc: (vm and (qm or qc)) or (qm and vc),
    "flight-stay": lambda vm, vc, qm, qc: (vm and not (qm or qc)) or (qm and not (vm or vc)),
    "flight-column": lambda vm, vc, qm, qc: (vm and qc) or (qm and vc),
}


@contextmanager
def owner_patched(mode: str) -> Iterator[None]:
    """``ColumnClearance.free`` letting ``OWNER_MODES[mode]``'s pairs pass, for the ``with`` block."""
    passes = OWNER_MODES[mode]
    saved = ColumnClearance.free

    def free(self: ColumnClearance, uav: str, vols: list[Volume]) -> bool:
        mine = vols[-1] if vols and vols[-1].kind == "zone" else None
        for other, u in self.records.items():
            if other == uav:
                continue
            theirs = (
                u.volumes[-1] if u.flight is not None and u.volumes and u.volumes[-1].kind == "zone" else None
            )
            for q in u.volumes:
                for v in vols:
                    if not volumes_conflict(v, q, self.sep_xy_m, self.spacing_m - 1e-9):
                        continue
                    if not passes(v.kind in FLIGHT, v is mine, q.kind in FLIGHT, q is theirs):
                        return False
        return True

    ColumnClearance.free = free  # type: ignore[method-assign]
    try:
        yield
    finally:
        ColumnClearance.free = saved  # type: ignore[method-assign]


def fly(blueprint: Blueprint, bricks: int, adhesion: int, seed: int, mode: str) -> MissionReport:
    """One mission in ``mode``."""
    extra: dict[str, object] = {}
    if mode == "no-swaps":
        extra["faults"] = Faults(battery_drain_per_s=NO_SWAP_DRAIN_PER_S)
    if mode == "no-separation":
        extra["separation"] = False
    if mode in OWNER_MODES:
        with owner_patched(mode):
            return simulate_fleet(blueprint, bricks, adhesion, seed, **extra)
    with patched(ignore_for(mode, blueprint)):
        return simulate_fleet(blueprint, bricks, adhesion, seed, **extra)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2,8+4")
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--modes", default=",".join(MODES))
    args = ap.parse_args()
    modes = args.modes.split(",")
    for m in modes:
        if m not in MODES:
            ap.error(f"--modes: unknown mode {m!r} (one of {', '.join(MODES)})")
    seeds = [int(s) for s in args.seeds.split(",")]
    for wall in args.walls.split(","):
        blueprint = WALLS[wall][1]()
        for fleet in args.fleets.split(","):
            bricks, adhesion = (int(x) for x in fleet.split("+"))
            print(f"\n## {WALLS[wall][0]}, {bricks} + {adhesion}\n")
            print("| mode | makespan per seed | mean | against main | min separation | complete |")
            print("|---|---|---|---|---|---|")
            base: float | None = None
            for mode in modes:
                t0 = time.perf_counter()
                runs = [fly(blueprint, bricks, adhesion, s, mode) for s in seeds]
                spans = [r.makespan_s for r in runs]
                mean = statistics.fmean(spans)
                if mode == "main":
                    base = mean
                vs = "" if base is None or mode == "main" else f"{100.0 * (mean / base - 1.0):+.1f} %"
                seps = [r.min_separation_m for r in runs if r.min_separation_m is not None]
                sep = f"{min(seps):.3f} m" if seps else "n/a"
                done = sum(1 for r in runs if r.completed)
                per = " / ".join(f"{s:,.1f}" for s in spans)
                print(
                    f"| {mode} | {per} | **{mean:,.1f}** | {vs} | {sep} | {done} of {len(runs)} |"
                    f"  <!-- {time.perf_counter() - t0:.0f} s wall -->",
                    flush=True,
                )


if __name__ == "__main__":
    main()
