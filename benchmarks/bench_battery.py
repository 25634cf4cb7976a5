"""Short battery packs (issue 18): missions flown with packs of a few minutes, every UAV's battery watched.

    python benchmarks/bench_battery.py [--vehicle arducopter|ideal] [--seeds 0,1,2] [--quick]

Each scenario is a wall, a fleet and a drain (``Faults(battery_drain_per_s=...)``: 0.0033/s is a pack of about
five minutes airborne). Printed per run: completed, makespan, battery swaps by the ground crew, tasks given up
for the battery (attempts not counted) and bricks put back among them, UAVs out of service, the lowest battery
of a UAV in the air and the longest single wait for clearance (ask or hold) of a task.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from typing import Any

from masonry.blueprint import Blueprint
from masonry.blueprint_gen import pyramid, running_bond, towers
from masonry.fsm import UavConfig
from masonry.fsm.tuning import uav_settings
from masonry.mission.simulate import SimulatedMission
from masonry.ports import BATTERY_LOW_REASON
from masonry.sim import Faults


@dataclass(frozen=True)
class Scenario:
    name: str
    blueprint: Blueprint
    drain_per_s: float


def scenarios(quick: bool) -> list[Scenario]:
    out = [
        Scenario(
            "running_bond(3,10) 4+2 @0.0033", running_bond(3, 10, brick_uavs=4, adhesion_uavs=2), 0.0033
        ),
        Scenario("running_bond(3,10) 4+2 @0.005", running_bond(3, 10, brick_uavs=4, adhesion_uavs=2), 0.005),
        Scenario("running_bond(2,12) 3+1 @0.004", running_bond(2, 12, brick_uavs=3, adhesion_uavs=1), 0.004),
        Scenario("pyramid(5) 2+2 @0.002", pyramid(5, brick_uavs=2, adhesion_uavs=2), 0.002),
        Scenario("towers(3,4) 3+2 @0.005", towers(3, 4, brick_uavs=3, adhesion_uavs=2), 0.005),
    ]
    return out[:2] if quick else out


@dataclass
class Watch:
    """What a tick hook sees of the fleet: the lowest battery in the air, the longest clearance wait."""

    mission: Any
    min_airborne: float = 1.0
    min_airborne_uav: str = ""
    longest_wait_s: float = 0.0
    longest_wait_uav: str = ""

    def __post_init__(self) -> None:
        self._wait_since: dict[str, float] = {}

    def __call__(self, now_s: float) -> None:
        for name, h in self.mission.handlers.items():
            v = self.mission.world.uavs[name].vehicle
            m = h.model
            airborne = not v.on_ground if hasattr(v, "on_ground") else True
            if airborne and v.battery_fraction < self.min_airborne:
                self.min_airborne, self.min_airborne_uav = v.battery_fraction, name
            waiting = m is not None and m.task is not None and m.transit.state in ("ask", "hold")
            if waiting:
                since = self._wait_since.setdefault(name, now_s)
                if now_s - since > self.longest_wait_s:
                    self.longest_wait_s, self.longest_wait_uav = now_s - since, name
            else:
                self._wait_since.pop(name, None)


def fly(s: Scenario, seed: int, vehicle: str, budget: dict[str, float]) -> dict[str, Any]:
    uav_config = None
    if budget:
        settings = uav_settings(vehicle) if vehicle != "ideal" else {}
        uav_config = UavConfig("template", "brick", (0.0, 0.0, 0.0), **settings, **budget)  # type: ignore[arg-type]
    mission = SimulatedMission.from_blueprint(
        s.blueprint,
        seed=seed,
        faults=Faults(battery_drain_per_s=s.drain_per_s),
        vehicle=vehicle,
        uav_config=uav_config,
    )
    watch = Watch(mission)
    mission.tick_hooks.append(watch)
    t0 = time.perf_counter()
    r = mission.run()
    battery = [a for a in r.attempts if (a.reason or "").startswith(BATTERY_LOW_REASON)]
    return {
        "completed": r.completed,
        "makespan_s": r.makespan_s,
        "swaps": sum(h.battery_swaps for h in mission.handlers.values()),
        "battery_aborts": len(battery),
        "put_back": sum("put back" in (a.reason or "") for a in battery),
        "out_of_service": [u.name for u in r.uavs if u.status != "ok"],
        "min_airborne": watch.min_airborne,
        "min_airborne_uav": watch.min_airborne_uav,
        "longest_wait_s": watch.longest_wait_s,
        "longest_wait_uav": watch.longest_wait_uav,
        "stall": r.stall,
        "stuck": list(r.stuck),
        "wall_s": time.perf_counter() - t0,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vehicle", default="arducopter")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--quick", action="store_true", help="the first two scenarios only")
    ap.add_argument("--only", default="", help="scenarios whose name contains this")
    ap.add_argument("--wait-budget", type=float, default=None, help="UavConfig.battery_wait_budget_s")
    ap.add_argument("--return-wait", type=float, default=None, help="UavConfig.battery_return_wait_s")
    args = ap.parse_args()
    budget = {}
    if args.wait_budget is not None:
        budget["battery_wait_budget_s"] = args.wait_budget
    if args.return_wait is not None:
        budget["battery_return_wait_s"] = args.return_wait
    seeds = [int(x) for x in args.seeds.split(",")]
    print(f"vehicle {args.vehicle}, seeds {seeds}")
    print(
        "scenario | seed | completed | makespan s | swaps | battery aborts (put back) | out of service | "
        "min battery airborne | longest wait s"
    )
    totals = {"runs": 0, "completed": 0, "makespan_s": 0.0, "swaps": 0, "put_back": 0, "out_of_service": 0}
    for s in scenarios(args.quick):
        if args.only not in s.name:
            continue
        for seed in seeds:
            o = fly(s, seed, args.vehicle, budget)
            totals["runs"] += 1
            totals["completed"] += bool(o["completed"])
            totals["makespan_s"] += o["makespan_s"]
            totals["swaps"] += o["swaps"]
            totals["put_back"] += o["put_back"]
            totals["out_of_service"] += len(o["out_of_service"])
            oos = ",".join(o["out_of_service"]) or "-"
            print(
                f"{s.name} | {seed} | {'yes' if o['completed'] else 'NO'} | {o['makespan_s']:.0f} | {o['swaps']} | "
                f"{o['battery_aborts']} ({o['put_back']}) | {oos} | {o['min_airborne']:.0%} {o['min_airborne_uav']} | "
                f"{o['longest_wait_s']:.0f} {o['longest_wait_uav']}"
                + ("" if o["completed"] else f" | stuck {o['stuck']} stall {o['stall']}"),
                flush=True,
            )
    print(
        f"all: {totals['completed']}/{totals['runs']} completed, makespan sum {totals['makespan_s']:.0f} s, "
        f"{totals['swaps']} swaps, {totals['put_back']} bricks put back, {totals['out_of_service']} UAVs out of service"
    )


if __name__ == "__main__":
    main()
