"""The battery swaps of a fleet (issue 27 section 4): when each UAV swaps, how long it is away, which overlap, and
what the mission would take without them; prints Markdown, asserts nothing.

Flies ``masonry.mission.SimulatedMission`` as ``bench_fleet.py`` flies ``simulate`` (``critical-path``,
``site``, ``columns``, geometric camera, the default vehicle and pack) with a tick hook that watches every UAV:

1. per swap: the UAV, why it went home (``stagger``: mission control's swap stagger sent it early,
   :mod:`masonry.mission.swap_stagger`; ``sent, under the reserve``: mission control gave it no task under the
   handler's reserve; ``reserve``: its handler held a task for the battery reserve or budget, the task in
   progress meanwhile; ``idle``: landed with nothing to do under the top-up line), when it was sent, set off
   home, landed (with its charge), had its fresh pack and took off again, and the time away (setting off home to
   the take-off); then per role the time away summed and the seconds with two or more of the role away at once;
2. with ``--no-swap``, the same wall and fleet flown with no battery drain (``Faults(battery_drain_per_s=0)``): no
   swap at all, an upper bound of what the swaps cost (not a product setting).

Usage: python benchmarks/bench_swaps.py [--walls 12m] [--fleets 4+2] [--seeds 1] [--no-swap]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, walls_and_fleets

from masonry.blueprint import Blueprint
from masonry.mission.report import MissionReport
from masonry.mission.simulate import SimulatedMission
from masonry.mission.swap_stagger import RESERVE
from masonry.sim import Faults


@dataclass
class Swap:
    """One swap of one UAV, as the hook saw it (times in simulated seconds; None: not seen)."""

    uav: str
    role: str
    why: str = ""
    sent_s: float | None = None  # mission control's swap stagger sent it home
    charge_sent: float | None = None  # the charge its heartbeats reported then
    home_s: float | None = None  # its machine set off home (its last task's end)
    landed_s: float | None = None
    charge_landed: float = float("nan")
    fresh_s: float | None = None  # the fresh pack in
    takeoff_s: float | None = None  # in the air again after it

    @property
    def away_s(self) -> float | None:
        """From setting off home to the take-off with the fresh pack."""
        if self.home_s is None or self.takeoff_s is None:
            return None
        return self.takeoff_s - self.home_s


@dataclass
class SwapWatch:
    """A tick hook: each UAV's landing, fresh pack and the stagger's sends."""

    mission: SimulatedMission
    swaps: list[Swap] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._open: dict[str, Swap] = {}
        self._home: dict[str, float] = {}  # when each UAV's machine last set off home
        self._flying: dict[str, Swap] = {}  # swapped, not in the air again yet
        self._ground: dict[str, bool] = {}
        self._charge: dict[str, float] = {}
        self._top_ups: dict[str, int] = {}
        self._role = {u.name: u.role for u in self.mission.fleet}

    def __call__(self, now_s: float) -> None:
        sent = self.mission.control.swaps.sent_s
        for name, h in self.mission.handlers.items():
            v = self.mission.world.uavs[name].vehicle
            on_ground = bool(v.on_ground)
            charge = float(v.battery_fraction)
            state = h.model.state if h.model is not None else ""
            if state == "home" and name not in self._home:
                self._home[name] = now_s
            elif state not in ("home", "land", "idle"):
                self._home.pop(name, None)
            if not on_ground and name in self._flying:
                self._flying.pop(name).takeoff_s = now_s
            swap = self._open.get(name)
            if name in sent and (swap is None or swap.sent_s is None):
                if swap is None:
                    swap = self._open[name] = Swap(name, self._role[name])
                swap.sent_s = sent[name]
                swap.charge_sent = self.mission.control.uavs[name].battery
            if on_ground and not self._ground.get(name, True):
                if swap is None:
                    swap = self._open[name] = Swap(name, self._role[name])
                swap.landed_s, swap.charge_landed = now_s, charge
                swap.home_s = self._home.get(name)
            if charge > self._charge.get(name, 1.0) + 0.02:
                swap = self._open.pop(name, None) or Swap(name, self._role[name])
                swap.fresh_s = now_s
                if swap.sent_s is not None:
                    under = swap.charge_sent is not None and swap.charge_sent < RESERVE
                    swap.why = "sent, under the reserve" if under else "stagger"
                elif h.top_ups > self._top_ups.get(name, 0):
                    swap.why = "idle"
                else:
                    swap.why = "reserve"
                self.swaps.append(swap)
                self._flying[name] = swap
            elif (
                on_ground is False and swap is not None and swap.sent_s is None and swap.landed_s is not None
            ):
                self._open.pop(name)  # landed and took off again without a swap (a mission's end, a put-back)
            self._ground[name] = on_ground
            self._charge[name] = charge
            self._top_ups[name] = h.top_ups


def _fmt(t: float | None) -> str:
    return "-" if t is None else f"{t:,.1f}"


def swap_rows(swaps: list[Swap]) -> list[str]:
    """One row per swap, in the order the fresh packs went in."""
    rows = []
    for s in sorted(swaps, key=lambda s: s.fresh_s or 0.0):
        home = None if s.home_s is None or s.landed_s is None else s.landed_s - s.home_s
        pad = None if s.landed_s is None or s.takeoff_s is None else s.takeoff_s - s.landed_s
        rows.append(
            f"| {s.uav} | {s.why} | {_fmt(s.sent_s)} | {_fmt(s.home_s)} | {_fmt(s.landed_s)} "
            f"({s.charge_landed:.0%}) | {_fmt(s.fresh_s)} | {_fmt(s.takeoff_s)} | {_fmt(home)} | {_fmt(pad)} "
            f"| {_fmt(s.away_s)} |"
        )
    return rows


def overlaps(swaps: list[Swap], makespan_s: float) -> list[str]:
    """Per role: the swaps, their time away summed, and the seconds with two or more of the role away at once
    (from setting off home to the take-off; a UAV not in the air again is away to the mission's end)."""
    away: dict[str, list[tuple[float, float]]] = {}
    for s in swaps:
        lo = s.home_s if s.home_s is not None else (s.landed_s or 0.0)
        hi = s.takeoff_s if s.takeoff_s is not None else makespan_s
        away.setdefault(s.role, []).append((lo, hi))
    out = []
    for role, spans in sorted(away.items()):
        points = sorted([(lo, 1) for lo, _ in spans] + [(hi, -1) for _, hi in spans])
        n, last, both = 0, 0.0, 0.0
        for t, d in points:
            if n >= 2:
                both += t - last
            n, last = n + d, t
        total = sum(hi - lo for lo, hi in spans)
        out.append(
            f"{role}: {len(spans)} swaps, {total:,.1f} s away in all, {both:,.1f} s with two or more away"
        )
    return out


def fly(
    blueprint: Blueprint, bricks: int, adhesion: int, seed: int, drain: float | None
) -> tuple[MissionReport, list[Swap]]:
    mission = SimulatedMission.from_blueprint(
        blueprint,
        brick_uavs=bricks,
        adhesion_uavs=adhesion,
        seed=seed,
        policy="critical-path",
        camera="geometric",
        reservation="site",
        airspace="columns",
        faults=None if drain is None else Faults(battery_drain_per_s=drain),
    )
    watch = SwapWatch(mission)
    mission.tick_hooks.append(watch)
    report = mission.run()
    return report, watch.swaps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2")
    ap.add_argument("--seeds", default="1")
    ap.add_argument("--no-swap", action="store_true", help="also fly with no battery drain (an upper bound)")
    args = ap.parse_args()
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        blueprint = WALLS[wall][1]()
        for seed in (int(s) for s in args.seeds.split(",")):
            report, swaps = fly(blueprint, bricks, adhesion, seed, None)
            print(
                f"\n## {WALLS[wall][0]}, {bricks} + {adhesion}, seed {seed}: {report.makespan_s:,.1f} s "
                f"({'complete' if report.completed else 'NOT complete'})\n"
            )
            print(
                "| UAV | why | sent | set off home | landed (charge) | fresh pack | took off | flight home s "
                "| on the pad s | away s |"
            )
            print("|---|---|---|---|---|---|---|---|---|---|")
            print("\n".join(swap_rows(swaps)))
            print()
            print("\n".join(f"- {line}" for line in overlaps(swaps, report.makespan_s)))
            if args.no_swap:
                bound, _ = fly(blueprint, bricks, adhesion, seed, 0.0)
                print(
                    f"- no battery drain (no swap, a bound): {bound.makespan_s:,.1f} s "
                    f"({bound.makespan_s - report.makespan_s:+,.1f} s)"
                )
            sys.stdout.flush()


if __name__ == "__main__":
    main()
