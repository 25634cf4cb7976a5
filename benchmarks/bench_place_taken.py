"""The tests' px4 pyramid over seeds (issue 30, "place taken"): completed, releases refused onto a taken place,
bricks against their neighbours.

The wall of tests/test_wall_align.py and tests/test_course_check.py (pyramid(3), turned 30 degrees, r_c 1 m), one
UAV per role, the default ``px4`` vehicle and preset (``SimulatedMission.from_blueprint(..., vehicle="px4")``).
A brick's error against its neighbours is the horizontal distance of its offset from the design to the mean offset
of the placed bricks it touches in its course or stands on (the simulator's truth), as the tests measure it.

    PYTHONPATH=src python benchmarks/bench_place_taken.py --seeds 20
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from masonry.blueprint_gen import pyramid
from masonry.mission.built_truth import neighbour_errors_m
from masonry.mission.simulate import SimulatedMission


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--seed0", type=int, default=0)
    args = parser.parse_args()
    completed, taken, errors = 0, [], []
    for seed in range(args.seed0, args.seed0 + args.seeds):
        wall = pyramid(3, yaw_rad=math.radians(30.0), clearance_m=1.0)
        mission = SimulatedMission.from_blueprint(wall, seed=seed, vehicle="px4")
        report = mission.run()
        completed += report.completed
        refused = [
            a.task_id
            for a in mission.control.history
            if a.status == "failed" and (a.reason or "").startswith("place taken")
        ]
        taken += [f"{seed}:{t}" for t in refused]
        errors += neighbour_errors_m(mission)
        stuck = ",".join(report.stuck) or "-"
        print(f"seed {seed:3d}  completed {report.completed!s:5}  stuck {stuck}", flush=True)
    over = sum(e > 0.02 for e in errors)
    print(
        f"completed {completed}/{args.seeds}; place taken {' '.join(taken) or 'none'}; neighbours mean / max "
        f"{np.mean(errors) * 1000:.1f} / {max(errors) * 1000:.1f} mm, over 2 cm {over}/{len(errors)}"
    )


if __name__ == "__main__":
    main()
