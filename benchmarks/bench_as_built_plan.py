"""Work planned on what was built (issue 30): placement error per course on a tall wall, with and without.

On a tall wall (a 10-brick tower and an 8-course running bond of 3 bricks a course, turned 30 degrees, r_c 1.0 m,
one UAV per role) it flies the mission in ``masonry sim`` (``SimulatedMission``) twice per seed: as designed, and
with the blueprint's ``plan_on_as_built`` (the default ``as_built_pullback_m``, 5 mm per course, and
``placement_tolerance_m``, 2 cm, as the cap). Per course it prints, from the simulator's truth, over the bricks
placed (mean and max, millimetres, horizontal):

- **design**: the brick's distance from its design;
- **supports**: its offset from the design less the mean offset of the bricks it stands on (how far it is off
  its designed offset to what it stands on: the joint the glue must take); not for the first course.

and, on the first row of each wall, the missions completed. The default run (arducopter, calm and 4 m/s wind
with light turbulence, seeds 0-2) takes a few minutes::

    .venv/bin/python benchmarks/bench_as_built_plan.py

(``--vehicles``, ``--walls``, ``--wind``, ``--seeds``, ``--pullback`` select.)
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from masonry.blueprint import Blueprint
from masonry.blueprint_gen import running_bond, towers
from masonry.mission.simulate import SimulatedMission
from masonry.placement_check import PlacementCheck
from masonry.planner.as_built_plan import supports_of
from masonry.planner.graphs import plan
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

SITE = {"yaw_rad": math.radians(30.0), "clearance_m": 1.0, "brick_uavs": 1, "adhesion_uavs": 1}
WALLS: dict[str, Callable[[], Blueprint]] = {
    "tower-10": lambda: towers(1, 10, name="tower-10", **SITE),
    "bond-8x3": lambda: running_bond(8, 3, name="bond-8x3", **SITE),
}


def _course_of(bp: Blueprint) -> dict[int, int]:
    zs = sorted({round(b.position_m[2], 4) for b in bp.bricks})
    return {b.id: zs.index(round(b.position_m[2], 4)) for b in bp.bricks}


def run_one(
    bp: Blueprint, vehicle: str, seed: int, wind_mps: float
) -> tuple[bool, dict[int, list[float]], dict[int, list[float]]]:
    """One mission: completed, and per course the bricks' horizontal error from the design and from their
    supports (m)."""
    faults = Faults(wind=WindConfig(speed_mps=wind_mps, turbulence="light")) if wind_mps > 0 else None
    mission = SimulatedMission.from_blueprint(bp, seed=seed, vehicle=vehicle, faults=faults)
    report = mission.run()
    offsets: dict[int, np.ndarray] = {}
    for b in bp.bricks:
        sim = mission.world.bricks[b.id]
        if b.placed or not sim.released or sim.state != "placed":
            continue
        offsets[b.id] = (np.asarray(sim.position_m) - np.asarray(b.position_m))[:2]
    course = _course_of(bp)
    supports = supports_of(plan(bp).tasks)
    design: dict[int, list[float]] = {}
    relative: dict[int, list[float]] = {}
    for bid, off in offsets.items():
        c = course[bid]
        design.setdefault(c, []).append(float(np.linalg.norm(off)))
        under = [offsets[s] for s in supports.get(bid, ()) if s in offsets]
        if under:
            relative.setdefault(c, []).append(float(np.linalg.norm(off - np.mean(under, axis=0))))
    return bool(report.completed), design, relative


def _mm(values: Sequence[float]) -> str:
    if not values:
        return "     -      -"
    return f"{np.mean(values) * 1000:6.1f} {max(values) * 1000:6.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--seed0", type=int, default=0)
    parser.add_argument("--wind", default="calm,4", help="comma-separated: calm and/or mean speeds in m/s")
    parser.add_argument("--walls", default=",".join(WALLS))
    parser.add_argument("--vehicles", default="arducopter")
    parser.add_argument(
        "--pullback", type=float, default=None, help="as_built_pullback_m (default the blueprint's)"
    )
    args = parser.parse_args()
    winds = [0.0 if w == "calm" else float(w) for w in args.wind.split(",")]
    for vehicle in args.vehicles.split(","):
        for wall in args.walls.split(","):
            designed = WALLS[wall]()
            check = PlacementCheck(plan_on_as_built=True)
            if args.pullback is not None:
                check = dataclasses.replace(check, pullback_m=args.pullback)
            as_built = dataclasses.replace(designed, placement=check)
            for wind in winds:
                label = "calm" if wind == 0 else f"{wind:g} m/s"
                start = time.perf_counter()
                runs = {"design": (designed, [0, 0, {}, {}]), "as-built": (as_built, [0, 0, {}, {}])}
                for seed in range(args.seed0, args.seed0 + args.seeds):
                    for bp, tally in runs.values():
                        done, design, relative = run_one(bp, vehicle, seed, wind)
                        tally[0] += 1
                        tally[1] += int(done)
                        for c, v in design.items():
                            tally[2].setdefault(c, []).extend(v)
                        for c, v in relative.items():
                            tally[3].setdefault(c, []).extend(v)
                (_, d), (_, a) = runs["design"], runs["as-built"]
                print(
                    f"\n{vehicle} {wall} {label}: completed as designed {d[1]}/{d[0]}, planned on as-built "
                    f"{a[1]}/{a[0]} ({time.perf_counter() - start:.0f} s); error mean/max mm"
                )
                print(
                    f"{'course':>6}  {'design: as designed':>19}  {'as-built plan':>13}  "
                    f"{'supports: as designed':>21}  {'as-built plan':>13}"
                )
                for c in sorted(d[2]):
                    print(
                        f"{c:>6}  {_mm(d[2].get(c, [])):>19}  {_mm(a[2].get(c, [])):>13}  "
                        f"{_mm(d[3].get(c, [])):>21}  {_mm(a[3].get(c, [])):>13}",
                        flush=True,
                    )
                for name, t in (("as designed", d), ("as-built plan", a)):
                    top = max(t[2]) if t[2] else 0
                    print(
                        f"  all courses, {name}: design {_mm([x for v in t[2].values() for x in v])}, supports "
                        f"{_mm([x for v in t[3].values() for x in v])}; top course design {_mm(t[2].get(top, []))}"
                    )


if __name__ == "__main__":
    main()
