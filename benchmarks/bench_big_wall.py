"""A big wall that flies (issue 30): a 5,000-brick running bond with reused marker numbers, 4 brick + 2 adhesion UAVs.

Generates the wall (``masonry blueprint`` numbers it: marker numbers reused where no camera sees two alike),
validates it for flight, and flies it in the simulator with the ``mixed`` camera: the geometric camera model
everywhere, drawn images decoded by ArUco over every 100th pickup. Prints: the generation and validation times,
the marker numbers used, completion, the picks, those identified (the brick taken was the task's), confusions
(another brick taken), the picks made on drawn images, the simulated and wall-clock times and the real-time factor.

Usage: python benchmarks/bench_big_wall.py [--courses 20] [--per-course 250] [--camera mixed] [--seed 0]
       [--max-time S] [--profile FILE]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from pathlib import Path

from masonry.blueprint import format_blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.marker_reuse import covisible_distance_m
from masonry.mission.pick_audit import audit_picks
from masonry.mission.simulate import SimulatedMission


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--courses", type=int, default=20)
    parser.add_argument("--per-course", type=int, default=250)
    parser.add_argument("--camera", default="mixed")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-time", type=float, default=None, help="stop after this many simulated seconds")
    parser.add_argument(
        "--profile", default=None, help="write a cProfile of the flight here and print its top"
    )
    args = parser.parse_args()

    t0 = time.perf_counter()
    bp = running_bond(args.courses, args.per_course, placed_courses=0, brick_uavs=4, adhesion_uavs=2)
    t1 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big-wall.yaml"
        path.write_text(format_blueprint(bp))
        reloaded = load_blueprint(path)  # validates for flight: marker ids, reuse out of every camera's view
    t2 = time.perf_counter()
    numbers = {b.marker_number for b in bp.bricks}
    print(
        f"wall: {len(bp.bricks)} bricks ({args.courses} x {args.per_course}), {bp.markers.dictionary}, "
        f"{len(numbers)} marker numbers reused (co-visible span {covisible_distance_m(bp.markers):.2f} m)"
    )
    print(f"generate + number: {t1 - t0:.2f} s; write, read and validate for flight: {t2 - t1:.2f} s")
    assert len(reloaded.bricks) == len(bp.bricks)

    profiler = cProfile.Profile() if args.profile else None
    cpu0, wall0 = time.process_time(), time.perf_counter()
    with SimulatedMission.from_blueprint(
        bp, camera=args.camera, seed=args.seed, max_time_s=args.max_time
    ) as mission:
        if profiler is not None:
            profiler.enable()
        report = mission.run()
        if profiler is not None:
            profiler.disable()
        world = mission.world
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    audit = audit_picks(world.picks, report.attempts, world.drawn_pickups)
    done = sum(1 for t in report.tasks if t.kind == "brick" and t.status == "done")
    todo = sum(1 for b in bp.bricks if not b.placed)
    print(f"completed: {report.completed}; bricks placed {done} / {todo}; stuck {len(report.stuck)}")
    print(
        f"picks: {audit.picks}; identified {audit.identified}; confusions {len(audit.confusions)}"
        + (f" {list(audit.confusions)[:5]}" if audit.confusions else "")
    )
    print(
        f"picks on drawn images (ArUco): {audit.sampled}, identified {audit.sampled_identified}; "
        f"frames drawn {world.rendered_frames}"
    )
    print(
        f"simulated {report.sim_time_s:.0f} s (makespan {report.makespan_s:.0f} s) in {wall:.1f} s wall, "
        f"{cpu:.1f} s CPU: real-time factor x{report.sim_time_s / wall:.0f} (wall), "
        f"x{report.sim_time_s / cpu:.0f} (CPU); {1000 * cpu / max(report.sim_time_s, 1e-9):.2f} ms CPU per "
        "simulated second"
    )
    if profiler is not None:
        profiler.dump_stats(args.profile)
        pstats.Stats(profiler).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    main()
