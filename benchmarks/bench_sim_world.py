"""Cost of the simulated world: step, ports, camera, coverage, on a 1,000-brick wall with 6 UAVs.

Run: ``python benchmarks/bench_sim_world.py`` (prints its figures; nothing is asserted).
The mission simulator steps the world every 0.05 s of simulated time, so the per-step figures set the
real-time factor of ``masonry sim`` before the state machines and mission control are counted.
"""

from __future__ import annotations

import math
import platform
import statistics
import time
from collections.abc import Callable

from masonry.blueprint_gen import running_bond
from masonry.planner.tasks import AdhesionTask
from masonry.sim import World

DT_S = 0.05


def timed(fn: Callable[[], object], repeat: int, rounds: int = 5) -> float:
    """Median over ``rounds`` of the mean time of one call, seconds."""
    samples = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        samples.append((time.perf_counter() - t0) / repeat)
    return statistics.median(samples)


def main() -> None:
    print(f"# masonry.sim world benchmark ({platform.python_implementation()} {platform.python_version()})")
    bp = running_bond(courses=20, bricks_per_course=50, brick_uavs=4, adhesion_uavs=2, placed_courses=2)
    t_build = timed(lambda: World(bp, seed=0).add_fleet(), 1, rounds=3)
    print(f"world with {len(bp.bricks)} bricks and {len(bp.fleet)} UAVs built in {t_build * 1e3:.1f} ms")

    w = World(bp, seed=0)
    uavs = w.add_fleet()
    parked = timed(lambda: w.step(DT_S), 2000)
    print(f"step, 6 UAVs parked:                    {parked * 1e6:7.1f} us")
    for u in uavs:
        u.fc.arm()
        u.fc.takeoff(1.2)
    for _ in range(200):
        w.step(DT_S)
    hovering = timed(lambda: w.step(DT_S), 2000)
    print(f"step, 6 UAVs hovering (no setpoints):   {hovering * 1e6:7.1f} us")

    tick = [0]

    def flying_step() -> None:
        i = tick[0] = tick[0] + 1
        for k, u in enumerate(uavs):
            u.fc.telemetry()
            u.fc.send_velocity((0.6 * math.sin(i / 40 + k), 0.6 * math.cos(i / 40 + k), 0.0), 0.1)
        w.step(DT_S)

    flying = timed(flying_step, 2000)
    print(f"step + telemetry + setpoint x 6 UAVs:   {flying * 1e6:7.1f} us")
    sim_hours = 5.0
    steps = sim_hours * 3600 / DT_S
    print(
        f"  -> {sim_hours:g} h of simulated time at dt {DT_S} s: {steps * flying:.1f} s wall "
        f"(real-time factor {DT_S / flying:,.0f}x), world and ports only"
    )

    # Camera over the pallet (neighbouring bricks in view) and over the wall.
    brick_uav = uavs[0]
    pickup = next(b for b in bp.bricks if b.pickup_m is not None).pickup_m
    assert pickup is not None
    for target, label in (
        (pickup, "over the pallet"),
        (bp.bricks[len(bp.bricks) // 2].position_m, "over the wall"),
    ):
        brick_uav.vehicle._x, brick_uav.vehicle._y = target[0], target[1]  # teleport: placement only
        frame = brick_uav.camera.read()
        n = len(frame.tags or ()) if frame is not None else 0
        t_cam = timed(brick_uav.camera.read, 300)
        print(f"camera.read geometric {label:16s} {t_cam * 1e6:7.1f} us ({n} markers seen)")
    w_render = World(bp, seed=0, camera="render")
    ru = w_render.add_fleet()[0]
    ru.vehicle._x, ru.vehicle._y, ru.vehicle._z = pickup[0], pickup[1], 1.2
    t_render = timed(ru.camera.read, 10, rounds=3)
    print(f"camera.read render over the pallet      {t_render * 1e3:7.2f} ms")

    # Adhesive coverage query on a segment with a bead deposited along it (plus 10,000 other beads).
    for i in range(10_000):
        x = (i % 100) * 0.3
        w.adhesive.add((x, 5.0 + (i // 100) * 0.2, 0.1), (x + 0.3, 5.0 + (i // 100) * 0.2, 0.1))
    task = AdhesionTask("A0", 0, 1, (0.0, 0.0, 0.1), (0.15, 0.0, 0.1), 0.15)
    for i in range(60):
        w.adhesive.add((i * 0.0025, 0.0, 0.1), ((i + 1) * 0.0025, 0.0, 0.1))
    t_cov = timed(lambda: w.coverage(task), 200)
    print(f"coverage of a 15 cm segment              {t_cov * 1e6:7.1f} us (coverage {w.coverage(task):.2f})")


if __name__ == "__main__":
    main()
